use kinematics::{Matrix6, Pose, Vector3, Vector6};

use super::*;
use crate::testkit::geometry;

/// The figures of the default rig description.
fn figures() -> Figures {
    let loaded = rig_description::load::load(None).expect("default rig");
    Figures::of(&loaded.config)
}

/// The leg forces that hold a body of mass `m` with its centre of mass at `c` (P) at rest at
/// `pose`: F = −m g_P, τ = c × F (independent of the weighing's formulas), solved through the
/// legs' unit wrenches.
fn holding_forces(pose: &Pose, m: f64, c: &Vector3<f64>) -> Vector6<f64> {
    let g = geometry();
    let gravity_p = pose.rotation.inverse() * Vector3::new(0.0, 0.0, -STANDARD_GRAVITY_M_S2);
    let f = -gravity_p * m;
    let t = c.cross(&f);
    let w = Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z);
    let map = Matrix6::from_fn(|r, i| {
        let mut e = Vector6::zeros();
        e[i] = 1.0;
        to_vector(&g.wrench_in_platform(pose, &e))[r]
    });
    map.lu().solve(&w).expect("regular pose")
}

fn tilted() -> Pose {
    let g = geometry();
    Pose::from_rpy(
        g.home_pose().position_m + Vector3::new(0.03, -0.02, 0.05),
        4f64.to_radians(),
        -3f64.to_radians(),
        10f64.to_radians(),
    )
}

fn weigh(pose: &Pose, forces: &Vector6<f64>, noise: f64) -> StaticWeighing {
    weigh_swinging(pose, forces, noise, 0.0)
}

/// As [`weigh`], the legs also pushing `swing` N more and less over one period of the hold
/// (a plate that settles and comes back to rest: no momentum change over the hold).
fn weigh_swinging(pose: &Pose, forces: &Vector6<f64>, noise: f64, swing: f64) -> StaticWeighing {
    let mut w = Weigher::new(geometry(), None, STANDARD_GRAVITY_M_S2);
    let mut state = 12345u64;
    for k in 0..400 {
        let phase = (2.0 * std::f64::consts::PI * k as f64 / 400.0).sin();
        let f = forces.map(|f| {
            let f = f + swing * phase;
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            f + noise * (((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5) * 12f64.sqrt()
        });
        w.push(k as f64 * 1e-3, pose, &f);
    }
    w.finish(&figures()).expect("a weighing")
}

/// On a tilted pose, the wrench of a known body gives back its mass and its c_x, c_y once its
/// height is given; the height's slope is the tilt.
#[test]
fn a_tilted_pose_gives_back_mass_and_horizontal_centre() {
    let pose = tilted();
    let (m, c) = (1234.5, Vector3::new(0.07, -0.04, 0.6));
    let s = weigh(&pose, &holding_forces(&pose, m, &c), 0.0);
    let r = s.weighed(c.z);
    assert!((r.mass_kg - m).abs() < 1e-9 * m, "{r:?}");
    assert!((r.com_xy_m[0] - c.x).abs() < 1e-9, "{r:?}");
    assert!((r.com_xy_m[1] - c.y).abs() < 1e-9, "{r:?}");
    // Assuming the centre at the P origin's height is off by the tilt times the height.
    let flat = s.weighed(0.0);
    let up = pose.rotation.inverse() * Vector3::z();
    assert!((flat.com_xy_m[0] - (c.x - c.z * up.x / up.z)).abs() < 1e-9);
    assert!((flat.com_xy_m[1] - (c.y - c.z * up.y / up.z)).abs() < 1e-9);
    assert!(up.x.abs() > 0.01, "the pose is tilted");
}

/// The payload is the loaded run's less the tare's: two bodies on the plate weigh as one of
/// their summed mass and combined centre; the payload comes back alone.
#[test]
fn the_tare_subtracted_leaves_the_payload() {
    let pose = tilted();
    let (mt, ct) = (300.0, Vector3::new(-0.01, 0.02, 0.1));
    let (mp, cp) = (900.0, Vector3::new(0.05, -0.06, 0.5));
    let total_m = mt + mp;
    let total_c = (ct * mt + cp * mp) / total_m;
    let tare = weigh(&pose, &holding_forces(&pose, mt, &ct), 0.0);
    let loaded = weigh(&pose, &holding_forces(&pose, total_m, &total_c), 0.0);
    let p = payload(&loaded, total_c.z, &tare, ct.z);
    assert!((p.mass_kg - mp).abs() < 1e-9 * mp, "{p:?}");
    assert!((p.com_xy_m[0] - cp.x).abs() < 1e-9, "{p:?}");
    assert!((p.com_xy_m[1] - cp.y).abs() < 1e-9, "{p:?}");
    assert!((p.com_z_used_m - cp.z).abs() < 1e-9, "{p:?}");
}

/// The noise's sigma of the mean: white noise of σ per cell over n samples gives the mass the
/// variance Var m = σ²/n Σᵢ (Lᵢ·(û, 0)/g)² (Lᵢ's force part along up, over g).
#[test]
fn the_noise_sigma_matches_white_noise() {
    let pose = geometry().home_pose();
    let forces = holding_forces(&pose, 1500.0, &Vector3::new(0.0, 0.0, 0.3));
    let s = weigh(&pose, &forces, 40.0);
    let up = Vector3::z();
    let expected: f64 = (0..6)
        .map(|i| {
            let mut e = Vector6::zeros();
            e[i] = 1.0;
            let l = to_vector(&geometry().wrench_in_platform(&pose, &e));
            (Vector3::new(l[0], l[1], l[2]).dot(&up) / STANDARD_GRAVITY_M_S2).powi(2)
        })
        .sum::<f64>()
        * 40.0f64.powi(2)
        / 400.0;
    let got = s.noise_covariance[0][0];
    // 398 second differences: the variance's own relative sigma is about 0.1.
    assert!(
        got > 0.7 * expected && got < 1.4 * expected,
        "{got} vs {expected}"
    );
    // Without noise, none.
    let quiet = weigh(&pose, &forces, 0.0);
    assert!(quiet.noise_covariance[0][0] < 1e-20);
    // A slow swing of the load over the hold leaves the mean and hardly touches the sigma.
    let swung = weigh_swinging(&pose, &forces, 40.0, 500.0);
    assert!((swung.values[0] - s.values[0]).abs() < 1e-6, "{swung:?}");
    let ratio = swung.noise_covariance[0][0] / got;
    assert!(ratio > 0.99 && ratio < 1.05, "{ratio}");
}

/// A rig's shared error cancels in the payload as far as the two runs' loads agree: the
/// load-cell offsets' share of the payload's mass is far below one run's.
#[test]
fn shared_offsets_cancel_in_the_payload() {
    let pose = geometry().home_pose();
    let c = Vector3::new(0.0, 0.0, 0.2);
    let tare = weigh(&pose, &holding_forces(&pose, 400.0, &c), 0.0);
    let loaded = weigh(&pose, &holding_forces(&pose, 1900.0, &c), 0.0);
    let alone = loaded.weighed(0.2);
    let p = payload(&loaded, 0.2, &tare, 0.2);
    assert!(alone.sigma_mass_kg > 0.0);
    // The payload keeps the gains' share (scaled by its load) but loses the offsets'.
    let offsets = |s: &StaticWeighing| {
        s.effects
            .iter()
            .find(|e| e.source == "load_cell_offset")
            .map(|e| e.effects.iter().map(|d| d[0] * d[0]).sum::<f64>().sqrt())
            .unwrap_or(0.0)
    };
    assert!(offsets(&loaded) > 0.0);
    assert!(p.sigma_mass_kg < alone.sigma_mass_kg, "{p:?} vs {alone:?}");
}
