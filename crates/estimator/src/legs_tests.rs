//! The legs' model against physics written another way: the lever rule at rest, and the leg's
//! angular momentum about its base joint differentiated numerically along a moving plate.

use super::*;
use crate::testkit::test_geometry;
use nalgebra::Rotation3;
use stewart_types::GRAVITY_B_M_S2;

fn legs() -> LegModel {
    LegModel {
        cell_end: CellEnd::Plate,
        cylinder_mass_kg: 28.0,
        cylinder_com_from_base_m: 0.45,
        cylinder_inertia_kg_m2: 2.8,
        rod_mass_kg: 12.0,
        rod_com_from_plate_m: 0.55,
        rod_inertia_kg_m2: 1.0,
        joint_coulomb_torque_nm: 0.0,
        joint_viscous_nm_s_per_rad: 0.0,
    }
}

/// A plate pose moving on sines in all six axes (several frequencies, ±3 cm, ±3°).
fn pose_at(geometry: &Geometry, t: f64) -> Pose {
    let home = geometry.home_pose().position_m;
    let s = |a: f64, f: f64, ph: f64| a * libm::sin(2.0 * core::f64::consts::PI * f * t + ph);
    Pose {
        position_m: home + Vector3::new(s(0.03, 0.7, 0.1), s(0.025, 1.1, 0.7), s(0.02, 1.6, 1.3)),
        rotation: Rotation3::from_euler_angles(
            s(0.05, 0.9, 0.4),
            s(0.04, 1.3, 2.0),
            s(0.06, 0.5, 0.9),
        ),
    }
}

/// v, a, ω and ω̇ of [`pose_at`] by central differences of step `h`.
fn motion_at(geometry: &Geometry, t: f64, h: f64) -> PlateMotion {
    let p = |t| pose_at(geometry, t).position_m;
    let omega_p = |t: f64| {
        // Ṙ Rᵀ = [ω_B]×, ω_P = Rᵀ ω_B.
        let r = pose_at(geometry, t).rotation;
        let rd = (pose_at(geometry, t + h).rotation.matrix()
            - pose_at(geometry, t - h).rotation.matrix())
            / (2.0 * h);
        let s = rd * r.matrix().transpose();
        let w_b = Vector3::new(s[(2, 1)], s[(0, 2)], s[(1, 0)]);
        r.inverse() * w_b
    };
    PlateMotion {
        pose: pose_at(geometry, t),
        velocity_m_s: (p(t + h) - p(t - h)) / (2.0 * h),
        acceleration_m_s2: (p(t + h) - p(t) * 2.0 + p(t - h)) / (h * h),
        angular_velocity_rad_s: omega_p(t),
        angular_acceleration_rad_s2: (omega_p(t + h) - omega_p(t - h)) / (2.0 * h),
    }
}

#[test]
fn massless_frictionless_legs_miss_nothing() {
    let g = test_geometry();
    let m = motion_at(&g, 0.3, 1e-4);
    let u = unseen(&g, &LegModel::default(), &m, &GRAVITY_B_M_S2);
    assert_eq!(u.total().force_n.norm() + u.total().torque_nm.norm(), 0.0);
    assert!(u.transverse_n.iter().flatten().all(|v| *v == 0.0));
}

/// At rest each leg's weight splits between its two joints by the lever rule along the leg;
/// the plate joint's share across the leg is what a plate-end cell misses. Summed over the
/// legs, the missing vertical force is −Σ (m₁c₁ + m₂(L − c₂))/L · g₀ · sin²φ, φ the leg's angle
/// to the vertical.
#[test]
fn at_rest_the_plate_joint_carries_the_lever_rules_share() {
    let g = test_geometry();
    let pose = g.home_pose();
    let rest = PlateMotion {
        pose,
        velocity_m_s: Vector3::zeros(),
        acceleration_m_s2: Vector3::zeros(),
        angular_velocity_rad_s: Vector3::zeros(),
        angular_acceleration_rad_s2: Vector3::zeros(),
    };
    let l = legs();
    let u = unseen(&g, &l, &rest, &GRAVITY_B_M_S2);
    let mut expected = 0.0;
    for leg in 0..LEG_COUNT {
        let d = pose.position_m + pose.rotation * g.plate_joints_m()[leg] - g.base_joints_m()[leg];
        let len = d.norm();
        let cos = d.z / len;
        let share = (l.cylinder_mass_kg * l.cylinder_com_from_base_m
            + l.rod_mass_kg * (len - l.rod_com_from_plate_m))
            / len;
        expected -= share * stewart_types::STANDARD_GRAVITY_M_S2 * (1.0 - cos * cos);
    }
    let fz = (pose.rotation * u.dynamics.force_n).z;
    assert!(
        (fz - expected).abs() < 1e-9 * expected.abs(),
        "{fz} vs {expected}"
    );
    assert_eq!(u.friction.force_n.norm(), 0.0);
    // At the base end the cells miss the legs' whole weight along the legs as well.
    let base = unseen(
        &g,
        &LegModel {
            cell_end: CellEnd::Base,
            ..l
        },
        &rest,
        &GRAVITY_B_M_S2,
    );
    let fz_base = (pose.rotation * base.dynamics.force_n).z;
    let mut axial = 0.0;
    for leg in 0..LEG_COUNT {
        let d = pose.position_m + pose.rotation * g.plate_joints_m()[leg] - g.base_joints_m()[leg];
        let cos = d.z / d.norm();
        axial -=
            (l.cylinder_mass_kg + l.rod_mass_kg) * stewart_types::STANDARD_GRAVITY_M_S2 * cos * cos;
    }
    assert!((fz_base - (expected + axial)).abs() < 1e-9 * axial.abs());
}

/// The leg's angular momentum about its fixed base joint, H = Σ mₖ (rₖ − b) × ṙₖ + (I₁ + I₂) ω_l,
/// with the bodies' positions taken from the pose alone and every rate by central
/// differences: L u × F = Σ (rₖ − b) × mₖ g − dH/dt gives the force across the leg that the
/// model derives in closed form from v, a, ω and ω̇.
#[test]
fn unseen_force_balances_the_legs_angular_momentum() {
    let g = test_geometry();
    let l = legs();
    let h = 1e-3;
    for leg in 0..LEG_COUNT {
        let b = g.base_joints_m()[leg];
        let pj = g.plate_joints_m()[leg];
        let q = |t: f64| {
            let p = pose_at(&g, t);
            p.position_m + p.rotation * pj
        };
        let u = |t: f64| (q(t) - b).normalize();
        let r1 = |t: f64| b + u(t) * l.cylinder_com_from_base_m;
        let r2 = |t: f64| q(t) - u(t) * l.rod_com_from_plate_m;
        let rate = |f: &dyn Fn(f64) -> Vector3<f64>, t: f64| (f(t + h) - f(t - h)) / (2.0 * h);
        let momentum = |t: f64| {
            let w_leg = u(t).cross(&rate(&u, t));
            (r1(t) - b).cross(&rate(&r1, t)) * l.cylinder_mass_kg
                + (r2(t) - b).cross(&rate(&r2, t)) * l.rod_mass_kg
                + w_leg * (l.cylinder_inertia_kg_m2 + l.rod_inertia_kg_m2)
        };
        for t in [0.13, 0.77, 1.41] {
            let hd = (momentum(t + h) - momentum(t - h)) / (2.0 * h);
            let gravity = (r1(t) - b).cross(&(GRAVITY_B_M_S2 * l.cylinder_mass_kg))
                + (r2(t) - b).cross(&(GRAVITY_B_M_S2 * l.rod_mass_kg));
            let m = gravity - hd;
            let (ut, len) = (u(t), (q(t) - b).norm());
            let expected = (m - ut * m.dot(&ut)).cross(&ut) / len;
            let motion = motion_at(&g, t, 1e-4);
            let got = motion.pose.rotation
                * unseen_of_leg(&g, leg, &l, &motion, &GRAVITY_B_M_S2)
                    .dynamics
                    .force_n;
            let scale = expected.norm().max(1.0);
            assert!(
                (got - expected).norm() < 2e-4 * scale,
                "leg {leg} t {t}: {got:?} vs {expected:?}"
            );
        }
    }
}

/// The unseen wrench is the sum of the legs' own, and a seventh leg adds nothing.
#[test]
fn unseen_sums_the_legs() {
    let g = test_geometry();
    let l = LegModel {
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..legs()
    };
    let m = motion_at(&g, 0.5, 1e-4);
    let all = unseen(&g, &l, &m, &GRAVITY_B_M_S2).total();
    let mut sum = Vector3::zeros();
    for leg in 0..LEG_COUNT {
        sum += unseen_of_leg(&g, leg, &l, &m, &GRAVITY_B_M_S2)
            .total()
            .torque_nm;
    }
    assert!((all.torque_nm - sum).norm() < 1e-9 * sum.norm());
    assert!(all.torque_nm.norm() > 0.0);
    let none = unseen_of_leg(&g, LEG_COUNT, &l, &m, &GRAVITY_B_M_S2).total();
    assert_eq!(none.force_n.norm() + none.torque_nm.norm(), 0.0);
}

/// The estimator's per-sample compensation, [`unseen_total`], is [`unseen`]'s total bit for
/// bit, with the cells at either end and friction on, at several instants of a moving plate.
#[test]
fn the_total_alone_is_the_full_sums_total_bit_for_bit() {
    let g = test_geometry();
    for cell_end in [CellEnd::Plate, CellEnd::Base] {
        let l = LegModel {
            cell_end,
            joint_coulomb_torque_nm: 1.0,
            joint_viscous_nm_s_per_rad: 5.0,
            ..legs()
        };
        for t in [0.1, 0.5, 1.7, 3.2] {
            let m = motion_at(&g, t, 1e-4);
            let full = unseen(&g, &l, &m, &GRAVITY_B_M_S2).total();
            let total = unseen_total(&g, &l, &m, &GRAVITY_B_M_S2);
            assert_eq!(total.force_n, full.force_n, "{cell_end:?} at {t} s");
            assert_eq!(total.torque_nm, full.torque_nm, "{cell_end:?} at {t} s");
            assert!(total.force_n.norm() > 0.0);
        }
    }
}
