//! The origin-form Newton–Euler of [`load_wrench`] against the centre-of-mass form evaluated
//! independently: the momenta m·v_C and L_C = J_C,B ω of the body along a trajectory,
//! differentiated numerically, give F = d(m v_C)/dt + m g₀ ẑ and τ_O = dL_C/dt + c_B × F.

use super::*;
use crate::trajectory::{Axis, SineComponent, Trajectory};
use kinematics::{Matrix3, Pose, StrokeLimits};

fn geometry() -> Geometry {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).unwrap()
}

/// Every axis moving at once, at frequencies with no common short period.
fn trajectory() -> Trajectory {
    let axes = [
        (Axis::X, 0.012, 0.7),
        (Axis::Y, 0.009, 1.1),
        (Axis::Z, 0.006, 1.3),
        (Axis::Roll, 0.03, 0.9),
        (Axis::Pitch, 0.025, 1.7),
        (Axis::Yaw, 0.035, 0.5),
    ];
    let components: [SineComponent; 6] =
        axes.map(|(axis, amplitude, frequency_hz)| SineComponent {
            axis,
            amplitude,
            frequency_hz,
            phase_rad: 0.4,
        });
    Trajectory::new(geometry().home_pose(), &components, 10.0, 1.0, 1.0).unwrap()
}

fn car() -> (f64, Vector3<f64>, Matrix3<f64>) {
    let inertia = Matrix3::new(
        600.0, -25.0, 60.0, //
        -25.0, 2500.0, -15.0, //
        60.0, -15.0, 2700.0,
    );
    (1500.0, Vector3::new(0.15, -0.08, 0.5), inertia)
}

/// The centre-of-mass form: momenta at `t`, for the numerical derivative.
fn momenta(t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (m, c, j_c) = car();
    let s = trajectory().sample(t);
    let r = s.pose.rotation.matrix();
    let c_b = r * c;
    let v_c = s.velocity_m_s + s.angular_velocity_rad_s.cross(&c_b);
    let l_c = r * j_c * r.transpose() * s.angular_velocity_rad_s;
    (v_c * m, l_c)
}

#[test]
fn the_origin_form_matches_the_centre_of_mass_form_along_a_motion() {
    let (m, c, j_c) = car();
    let load = InertialParameters::from_com(m, c, j_c);
    let h = 1e-5;
    let mut largest_torque_nm: f64 = 0.0;
    for t in [1.3, 2.71, 4.05, 6.6, 8.2] {
        let (p1, l1) = momenta(t + h);
        let (p0, l0) = momenta(t - h);
        let s = trajectory().sample(t);
        let force = (p1 - p0) / (2.0 * h) + Vector3::new(0.0, 0.0, m * GRAVITY_M_S2);
        let c_b = s.pose.rotation.matrix() * c;
        let torque = (l1 - l0) / (2.0 * h) + c_b.cross(&force);
        let w = load_wrench(&load, &s);
        let (f, tau) = (w.fixed_rows::<3>(0), w.fixed_rows::<3>(3));
        assert!(
            (f - force).norm() < 1e-4,
            "t {t}: force {f} against {force}"
        );
        assert!(
            (tau - torque).norm() < 1e-3,
            "t {t}: torque {tau} against {torque}"
        );
        largest_torque_nm = largest_torque_nm.max((torque - c_b.cross(&force)).norm());
    }
    // The motion's own torque is far above the tolerance: the check sees the dynamics.
    assert!(largest_torque_nm > 100.0, "{largest_torque_nm}");
}

#[test]
fn the_leg_forces_apply_the_wrench() {
    let g = geometry();
    let (m, c, j_c) = car();
    let load = InertialParameters::from_com(m, c, j_c);
    let s = trajectory().sample(3.3);
    let f = load_leg_forces(&g, &load, &s).unwrap();
    let applied = g.wrench_in_base(&s.pose, &Vector6::from(f));
    let wanted = load_wrench(&load, &s);
    assert!((applied.force_n - wanted.fixed_rows::<3>(0)).norm() < 1e-7);
    assert!((applied.torque_nm - wanted.fixed_rows::<3>(3)).norm() < 1e-7);
}

#[test]
fn at_rest_the_wrench_is_the_weight() {
    let (m, c, j_c) = car();
    let load = InertialParameters::from_com(m, c, j_c);
    let pose = Pose::from_rpy(geometry().home_pose().position_m, 0.02, -0.01, 0.3);
    let zero = Vector6::zeros();
    let s = TrajectorySample::from_coordinates(&pose, &zero, &zero, &zero);
    let w = load_wrench(&load, &s);
    let weight_up = Vector3::new(0.0, 0.0, m * GRAVITY_M_S2);
    assert!((w.fixed_rows::<3>(0) - weight_up).norm() < 1e-9);
    let arm = pose.rotation * c;
    assert!((w.fixed_rows::<3>(3) - arm.cross(&weight_up)).norm() < 1e-9);
}

#[test]
fn non_finite_input_is_an_error_not_a_force() {
    let g = geometry();
    let s = trajectory().sample(2.0);
    let mut load = InertialParameters::point_mass(100.0, Vector3::zeros());
    load.mass_kg = f64::NAN;
    assert!(load_leg_forces(&g, &load, &s).is_err());
    let wrench = Vector6::new(0.0, 0.0, f64::INFINITY, 0.0, 0.0, 0.0);
    assert!(leg_forces_for(&g, &s.pose, &g.jacobian(&s.pose), &wrench).is_err());
}
