//! The static observations: the accelerometer's mean at rest at a set of poses (gravity's
//! direction in P against the kinematics' tilt) and the load cells' means there, with the
//! fixture alone and with the reference weight on (the forces the drawing predicts for the
//! weight at the pose forward kinematics gives, against those the built legs carry).

use kinematics::{Geometry, Pose};
use nalgebra::{DVector, Matrix6, Rotation3, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

use crate::observe::*;

/// Static poses of the empty plate: home, each axis at ± its amplitude, the four roll–pitch
/// corners; those the legs' stroke does not reach are left out.
pub fn static_poses(g: &Geometry, metres: f64, degrees: f64) -> Vec<Pose> {
    let home = g.home_pose();
    let a = degrees.to_radians();
    let mut out = vec![home];
    for axis in 0..6 {
        for s in [-1.0, 1.0] {
            let mut t = [0.0; 6];
            t[axis] = s * if axis < 3 { metres } else { a };
            out.push(Pose::from_rpy(
                home.position_m + Vector3::new(t[0], t[1], t[2]),
                t[3],
                t[4],
                t[5],
            ));
        }
    }
    for (r, p) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        out.push(Pose::from_rpy(home.position_m, r * a, p * a, 0.0));
    }
    let stroke = g.stroke();
    out.retain(|p| {
        g.leg_lengths(p)
            .iter()
            .all(|l| *l > stroke.min_length_m + 0.01 && *l < stroke.max_length_m - 0.01)
    });
    out
}

/// The accelerometer's mean over `hold_s` at each static pose: gravity's direction in P
/// against the kinematics' tilt.
pub fn add_tilts(
    info: &mut Information,
    g: &Geometry,
    built: &[Geometry],
    poses: &[Pose],
    hold_s: f64,
    d: &Datasheet,
) {
    let sigma = d.accel_density / hold_s.sqrt();
    let up = -GRAVITY_B_M_S2;
    for pose in poses {
        let changes = pose_change(g, built, pose);
        let rt = pose.rotation.inverse();
        let f = rt * up;
        for axis in 0..3 {
            let mut r = DVector::zeros(N);
            for k in 0..JOINTS {
                let phi: Vector3<f64> = changes[k].fixed_rows::<3>(3).into();
                r[k] = (rt * (skew(&up) * phi))[axis];
            }
            let s = skew(&f);
            for c in 0..3 {
                r[PSI + c] = s[(axis, c)];
            }
            r[ACCEL_SCALE + axis] = f[axis];
            r[ACCEL_BIAS + axis] = 1.0;
            info.row(&r, sigma);
        }
    }
}

/// The leg-force → wrench map (P axes, about the P origin) of `g` at `pose`.
fn leg_map(g: &Geometry, pose: &Pose) -> Matrix6<f64> {
    let columns: [Vector6<f64>; 6] = core::array::from_fn(|j| {
        estimator::wrench::to_vector(&g.wrench_in_platform(pose, &Vector6::ith(j, 1.0)))
    });
    Matrix6::from_columns(&columns)
}

/// The wrench that holds `mass_kg` at `com` (in P) at rest at `pose`, P axes.
fn weight(pose: &Pose, mass_kg: f64, com: &Vector3<f64>) -> Vector6<f64> {
    let f = pose.rotation.inverse() * (-GRAVITY_B_M_S2) * mass_kg;
    let t = com.cross(&f);
    Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
}

/// The cells' means over `hold_s` at each static pose, the fixture alone and then with the
/// reference weight on (its mass known to its certificate, its centre of mass not), the
/// poses `move_s` apart: gains, offsets and drift of each series beside the joints.
#[allow(clippy::too_many_arguments)]
pub fn add_static_wrench(
    info: &mut Information,
    g: &Geometry,
    built: &[Geometry],
    poses: &[Pose],
    hold_s: f64,
    move_s: f64,
    fixture_com: Vector3<f64>,
    d: &Datasheet,
) {
    let sigma = ((d.cell_noise_n.powi(2) / (hold_s * d.rate_hz)) + d.cell_floor_n.powi(2)).sqrt();
    let reference_com = fixture_com + Vector3::new(0.0, 0.0, 0.25);
    for series in 0..2 {
        for (i, pose) in poses.iter().enumerate() {
            let minutes = (i as f64) * (hold_s + move_s) / 60.0;
            let changes = pose_change(g, built, pose);
            let mut w = weight(pose, d.fixture_kg, &fixture_com);
            if series == 1 {
                w += weight(pose, d.reference_kg, &reference_com);
            }
            let map = leg_map(g, pose);
            let lu = map.lu();
            let f = lu.solve(&w).expect("a regular pose");
            // Per joint: the forces the built legs carry minus those the drawing predicts at
            // the pose forward kinematics gives.
            let joint: Vec<Vector6<f64>> = (0..JOINTS)
                .map(|k| {
                    let carried = leg_map(&built[k], pose).lu().solve(&w).expect("regular");
                    let x = changes[k] * H;
                    let seen = Pose::new(
                        pose.position_m + Vector3::new(x[0], x[1], x[2]),
                        Rotation3::new(Vector3::new(x[3], x[4], x[5])) * pose.rotation,
                    );
                    // The drawing's prediction takes gravity's direction from the pose it
                    // believes.
                    let mut ws = weight(&seen, d.fixture_kg, &fixture_com);
                    if series == 1 {
                        ws += weight(&seen, d.reference_kg, &reference_com);
                    }
                    let predicted = leg_map(g, &seen).lu().solve(&ws).expect("regular");
                    (carried - predicted) / H
                })
                .collect();
            // The body's parameters through the drawing's map: ∂f/∂θ = −M⁻¹ ∂W/∂θ.
            let body =
                |mass: f64, com: &Vector3<f64>, mi: usize, ci: usize, r: &mut [f64], leg: usize| {
                    let dm = lu.solve(&weight(pose, 1.0, com)).expect("regular");
                    r[mi] = -dm[leg];
                    for c in 0..3 {
                        let mut e = Vector3::zeros();
                        e[c] = 1.0;
                        let fz = pose.rotation.inverse() * (-GRAVITY_B_M_S2) * mass;
                        let dt = e.cross(&fz);
                        let dw = Vector6::new(0.0, 0.0, 0.0, dt.x, dt.y, dt.z);
                        r[ci + c] = -lu.solve(&dw).expect("regular")[leg];
                    }
                };
            for leg in 0..6 {
                let mut r = DVector::zeros(N);
                for k in 0..JOINTS {
                    r[k] = joint[k][leg];
                }
                r[GAIN + leg] = f[leg];
                r[OFFSET[series] + leg] = 1.0;
                r[DRIFT[series] + leg] = minutes;
                body(
                    d.fixture_kg,
                    &fixture_com,
                    FIXTURE_MASS,
                    FIXTURE_COM,
                    r.as_mut_slice(),
                    leg,
                );
                if series == 1 {
                    body(
                        d.reference_kg,
                        &reference_com,
                        REFERENCE_MASS,
                        REFERENCE_COM,
                        r.as_mut_slice(),
                        leg,
                    );
                }
                info.row(&r, sigma);
            }
        }
    }
}
