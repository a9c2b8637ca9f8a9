//! The information the rig's own data carry about the 36 joint coordinates, linearised at the
//! drawing by finite differences through the kinematics, beside the nuisance parameters each
//! observation shares with them.
//!
//! A joint coordinate k off by δ_k gives, for the leg lengths of the true pose x, the pose
//! forward kinematics on the drawing returns: x̂ = x + J⁻¹ (l_built(x) − l_drawn(x)) (one
//! Newton step, first order in δ). Each observation's residual then changes:
//!
//! - gyro: ω̂ − ω = Rᵀ d(δφ)/dt (δφ the small rotation of x̂ in B, R x's rotation);
//! - accelerometer: f̂ − f = −Rᵀ (δφ × (a − g)) + Rᵀ d²(δp)/dt²;
//! - load cells at rest: the forces the drawing predicts at x̂ for the known weight against
//!   those the built legs carry at x, f = M_built(x)⁻¹ W.
//!
//! Every parameter is whitened by its prior sigma; the information is Λ = I + Σ h hᵀ / σ²
//! over rows h (whitened), the posterior covariance Λ⁻¹.

use kinematics::{Geometry, Pose};
use measure::record::Entry;
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Rotation3, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

/// Joint coordinates: base legs 0..6 × xyz, then plate legs 0..6 × xyz (the budget's order).
pub const JOINTS: usize = 36;
/// The IMU's rotation against P (gyro and accelerometer alike).
const PSI: usize = 36;
/// The gyro's symmetric matrix error (scales, non-orthogonality): xx yy zz xy xz yz.
const GYRO_SYM: usize = 39;
const GYRO_BIAS: usize = 45;
const ACCEL_BIAS: usize = 48;
const ACCEL_SCALE: usize = 51;
const LEVER: usize = 54;
const DELAY: usize = 57;
const GAIN: usize = 58;
/// Zero offsets of the cells, one set per static series (fixture alone, with the reference).
const OFFSET: [usize; 2] = [64, 70];
/// Zero drift of the cells, one set per static series.
const DRIFT: [usize; 2] = [76, 82];
const FIXTURE_MASS: usize = 88;
const FIXTURE_COM: usize = 89;
const REFERENCE_MASS: usize = 92;
const REFERENCE_COM: usize = 93;
/// Every parameter.
pub const N: usize = 96;

/// The figures the rows and priors read.
#[derive(Clone, Copy, Debug)]
pub struct Datasheet {
    pub joint_m: f64,
    pub rate_hz: f64,
    pub gyro_density: f64,
    pub accel_density: f64,
    pub accel_scale: f64,
    pub gain: f64,
    pub cell_noise_n: f64,
    pub cell_offset_n: f64,
    pub drift_n_per_min: f64,
    /// What a cell's static mean carries besides its noise (crosstalk, the legs' weight
    /// against their described figures), N.
    pub cell_floor_n: f64,
    pub reference_kg: f64,
    pub reference_tolerance_kg: f64,
    pub fixture_kg: f64,
    pub misalignment_rad: f64,
    pub gyro_scale: f64,
    pub gyro_bias: f64,
    pub accel_bias: f64,
    pub imu_position_m: f64,
    pub imu_skew_s: f64,
    /// The prior of what the calibrations fit freely, in datasheet figures.
    pub free: f64,
}

/// Prior sigma of every parameter: the joints' tolerance; the datasheet's figure for what no
/// calibration fits (accelerometer scales, gains, drift, the reference's certificate);
/// `free` datasheet figures (the IMU's axes, scales, biases, position and delay, the cells'
/// zero offsets) or a loose bound (the bodies) for what the fits take freely.
pub fn priors(d: &Datasheet) -> DVector<f64> {
    let mut p = DVector::zeros(N);
    let mut set = |from: usize, n: usize, v: f64| {
        for k in from..from + n {
            p[k] = v;
        }
    };
    set(0, JOINTS, d.joint_m);
    set(PSI, 3, d.free * d.misalignment_rad);
    set(GYRO_SYM, 6, d.free * d.gyro_scale);
    set(GYRO_BIAS, 3, d.free * d.gyro_bias);
    set(ACCEL_BIAS, 3, d.free * d.accel_bias);
    set(ACCEL_SCALE, 3, d.accel_scale);
    set(LEVER, 3, d.free * d.imu_position_m);
    set(DELAY, 1, d.free * d.imu_skew_s);
    set(GAIN, 6, d.gain);
    set(OFFSET[0], 12, d.free * d.cell_offset_n);
    set(DRIFT[0], 12, d.drift_n_per_min);
    set(FIXTURE_MASS, 1, 100.0);
    set(FIXTURE_COM, 3, 0.1);
    set(REFERENCE_MASS, 1, d.reference_tolerance_kg);
    set(REFERENCE_COM, 3, 0.1);
    p
}

/// The drawing with joint `k` moved by `h`.
pub fn moved(g: &Geometry, k: usize, h: f64) -> Geometry {
    let (mut b, mut p) = (*g.base_joints_m(), *g.plate_joints_m());
    let (leg, c) = ((k % 18) / 3, k % 3);
    if k >= 18 {
        p[leg][c] += h;
    } else {
        b[leg][c] += h;
    }
    Geometry::from_points(b, p, g.stroke()).expect("a joint 0.2 mm off stays a valid platform")
}

/// The step of finite differences, m.
const H: f64 = 1e-5;

/// d x̂ / dδ_k at `pose` for every joint: column k = [δp; δφ] per metre.
fn pose_change(g: &Geometry, built: &[Geometry], pose: &Pose) -> [Vector6<f64>; JOINTS] {
    let lu = g.jacobian(pose).lu();
    let l0 = g.leg_lengths(pose);
    core::array::from_fn(|k| {
        let dl = (built[k].leg_lengths(pose) - l0) / H;
        lu.solve(&dl).expect("a regular pose")
    })
}

/// The drawing with each joint moved by the finite-difference step.
pub fn built_all(g: &Geometry) -> Vec<Geometry> {
    (0..JOINTS).map(|k| moved(g, k, H)).collect()
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// Information accumulated in whitened parameters.
pub struct Information {
    prior: DVector<f64>,
    pub lambda: DMatrix<f64>,
}

impl Information {
    pub fn new(prior: DVector<f64>) -> Self {
        Self {
            prior,
            lambda: DMatrix::identity(N, N),
        }
    }

    /// One row h (unwhitened: residual per unit parameter) with noise sigma.
    fn row(&mut self, h: &DVector<f64>, sigma: f64) {
        let w = h.component_mul(&self.prior) / sigma;
        self.lambda.ger(1.0, &w, &w, 1.0);
    }

    /// The joints' posterior covariance, m² (Λ⁻¹'s joint block, unwhitened).
    pub fn joint_covariance(&self) -> DMatrix<f64> {
        let inv = self
            .lambda
            .clone()
            .cholesky()
            .expect("Λ = I + HᵀH is positive definite")
            .inverse();
        let mut p = inv.view((0, 0), (JOINTS, JOINTS)).into_owned();
        for i in 0..JOINTS {
            for j in 0..JOINTS {
                p[(i, j)] *= self.prior[i] * self.prior[j];
            }
        }
        p
    }
}

/// Central differences of a uniformly sampled series (interior points; the ends copy).
fn derivative<const D: usize>(
    x: &[nalgebra::SVector<f64, D>],
    h: f64,
) -> Vec<nalgebra::SVector<f64, D>> {
    let n = x.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (x[b] - x[a]) / ((b - a) as f64 * h)
        })
        .collect()
}

/// Three centred moving averages of five entries (50 ms at 100 Hz; the window shrinks at the
/// ends): far above the excitation's frequencies.
fn smooth<const D: usize>(x: &[nalgebra::SVector<f64, D>]) -> Vec<nalgebra::SVector<f64, D>> {
    let n = x.len();
    let mut y = x.to_vec();
    for _ in 0..3 {
        let z = y.clone();
        for (i, v) in y.iter_mut().enumerate() {
            let (a, b) = (i.saturating_sub(2), (i + 2).min(n - 1));
            *v = z[a..=b].iter().sum::<nalgebra::SVector<f64, D>>() / (b - a + 1) as f64;
        }
    }
    y
}

/// Which of the IMU's readings of the motion enter.
#[derive(Clone, Copy, Debug)]
pub struct Dynamic {
    pub gyro: bool,
    pub accel: bool,
}

/// The IMU's readings during a motion of the empty plate (the record's entries), against the
/// kinematics' rate and acceleration, with the IMU calibration's parameters beside the joints.
pub fn add_motion(
    info: &mut Information,
    g: &Geometry,
    built: &[Geometry],
    entries: &[Entry],
    d: &Datasheet,
    which: Dynamic,
) {
    let n = entries.len();
    if n < 5 {
        return;
    }
    let h = (entries[n - 1].time_s - entries[0].time_s) / (n - 1) as f64;
    let poses: Vec<Pose> = entries.iter().map(|e| e.pose()).collect();
    let changes: Vec<[Vector6<f64>; JOINTS]> =
        poses.iter().map(|p| pose_change(g, built, p)).collect();
    // The motion's rate, acceleration and specific force from the kinematics, smoothed alike
    // with the joints' changes: the regressors of the nuisances then carry neither the IMU's
    // noise nor the encoders' (a noisy regressor would look independent of a smooth one and
    // fake information).
    let rot: Vec<Matrix3<f64>> = poses.iter().map(|p| *p.rotation.matrix()).collect();
    let gyro = smooth(
        &(0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let s = rot[i].transpose() * (rot[b] - rot[a]) / ((b - a) as f64 * h);
                Vector3::new(
                    s[(2, 1)] - s[(1, 2)],
                    s[(0, 2)] - s[(2, 0)],
                    s[(1, 0)] - s[(0, 1)],
                ) * 0.5
            })
            .collect::<Vec<_>>(),
    );
    let position: Vec<Vector3<f64>> = poses.iter().map(|p| p.position_m).collect();
    let acc = smooth(&derivative(&derivative(&smooth(&position), h), h));
    let accel: Vec<Vector3<f64>> = (0..n)
        .map(|i| rot[i].transpose() * (acc[i] - GRAVITY_B_M_S2))
        .collect();
    // The IMU's rotation and the accelerometer's position act as a rotation and a
    // translation of the plate's frame: their columns go through the same differences and
    // smoothing as the joints' (an IMU turned by ψ reads Rᵀ d(Rψ)/dt = ω × ψ; one moved by
    // r, Rᵀ d²(R r)/dt² = (ω̇× + ω×ω×) r).
    let mut turn = vec![Matrix3::zeros(); n];
    let mut lever = vec![Matrix3::zeros(); n];
    for c in 0..3 {
        let e: Vec<Vector3<f64>> = rot.iter().map(|r| r.column(c).into()).collect();
        let rate = smooth(&derivative(&e, h));
        let acc = smooth(&derivative(&derivative(&smooth(&e), h), h));
        for i in 0..n {
            turn[i].set_column(c, &(rot[i].transpose() * rate[i]));
            lever[i].set_column(c, &(rot[i].transpose() * acc[i]));
        }
    }
    let gyro_dot = derivative(&gyro, h);
    let accel_dot = derivative(&accel, h);
    // Per joint: δφ's rate and δp's acceleration along the record.
    let mut phi_rate = vec![[Vector3::zeros(); JOINTS]; n];
    let mut p_acc = vec![[Vector3::zeros(); JOINTS]; n];
    for k in 0..JOINTS {
        let phi: Vec<Vector3<f64>> = changes
            .iter()
            .map(|c| c[k].fixed_rows::<3>(3).into())
            .collect();
        let p: Vec<Vector3<f64>> = changes
            .iter()
            .map(|c| c[k].fixed_rows::<3>(0).into())
            .collect();
        let rate = smooth(&derivative(&phi, h));
        let acc = smooth(&derivative(&derivative(&smooth(&p), h), h));
        for i in 0..n {
            phi_rate[i][k] = rate[i];
            p_acc[i][k] = acc[i];
        }
    }
    for i in 8..n - 8 {
        let e = &entries[i];
        let rt = poses[i].rotation.inverse();
        let samples = f64::from(e.samples.max(1));
        let (w, wd, f, fd) = (gyro[i], gyro_dot[i], accel[i], accel_dot[i]);
        let sg = d.gyro_density * (d.rate_hz / samples).sqrt();
        let sa = d.accel_density * (d.rate_hz / samples).sqrt();
        let a_minus_g = poses[i].rotation * f;
        for axis in 0..3 {
            if which.gyro {
                let mut r = DVector::zeros(N);
                for k in 0..JOINTS {
                    r[k] = (rt * phi_rate[i][k])[axis];
                }
                for c in 0..3 {
                    r[PSI + c] = turn[i][(axis, c)];
                }
                let sym = [
                    [w.x, 0.0, 0.0, w.y, w.z, 0.0],
                    [0.0, w.y, 0.0, w.x, 0.0, w.z],
                    [0.0, 0.0, w.z, 0.0, w.x, w.y],
                ];
                for c in 0..6 {
                    r[GYRO_SYM + c] = sym[axis][c];
                }
                r[GYRO_BIAS + axis] = 1.0;
                r[DELAY] = wd[axis];
                info.row(&r, sg);
            }
            if which.accel {
                let mut r = DVector::zeros(N);
                for k in 0..JOINTS {
                    let phi: Vector3<f64> = changes[i][k].fixed_rows::<3>(3).into();
                    r[k] = (rt * (skew(&a_minus_g) * phi + p_acc[i][k]))[axis];
                }
                let s = skew(&f);
                for c in 0..3 {
                    r[PSI + c] = s[(axis, c)];
                    r[LEVER + c] = lever[i][(axis, c)];
                }
                r[ACCEL_SCALE + axis] = f[axis];
                r[ACCEL_BIAS + axis] = 1.0;
                r[DELAY] = fd[axis];
                info.row(&r, sa);
            }
        }
    }
}

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

/// Orthonormal basis (columns) of the frames' own freedoms in joint space: all base joints
/// moved by one small rigid motion (t + ψ × b_i), and all plate joints likewise.
pub fn gauge(g: &Geometry) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(JOINTS, 12);
    for (frame, joints) in [g.base_joints_m(), g.plate_joints_m()]
        .into_iter()
        .enumerate()
    {
        for dof in 0..6 {
            let col = frame * 6 + dof;
            for (leg, j) in joints.iter().enumerate() {
                let v = if dof < 3 {
                    Vector3::ith(dof, 1.0)
                } else {
                    Vector3::ith(dof - 3, 1.0).cross(j)
                };
                for c in 0..3 {
                    m[(frame * 18 + leg * 3 + c, col)] = v[c];
                }
            }
        }
    }
    m.qr().q()
}

/// The largest difference, over `poses` and every joint moved by `sigma`, between the pose
/// full forward kinematics on the drawing gives for the built rig's leg lengths and the
/// first-order step the information uses, relative to the step's size: a check of the
/// linearisation against an independent solver.
pub fn linearisation_error(g: &Geometry, built: &[Geometry], poses: &[Pose], sigma: f64) -> f64 {
    let options = kinematics::FkOptions {
        tolerance_m: 1e-13,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    for pose in poses {
        let changes = pose_change(g, built, pose);
        for (k, change) in changes.iter().enumerate() {
            let lengths = moved(g, k, sigma).leg_lengths(pose);
            let Ok(fk) = g.forward_kinematics(&lengths, pose, &options) else {
                return f64::INFINITY;
            };
            let dp = fk.pose.position_m - pose.position_m;
            let dr = fk.pose.rotation * pose.rotation.inverse();
            let v = dr.scaled_axis();
            let exact = Vector6::new(dp.x, dp.y, dp.z, v.x, v.y, v.z);
            let step = change * sigma;
            worst = worst.max((exact - step).norm() / step.norm().max(1e-12));
        }
    }
    worst
}
