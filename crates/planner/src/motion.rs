//! A planned trajectory as the rig will see it, before it moves: the plate's motion in P at
//! every sample, the regressor the estimator will form from it, and the leg forces it will
//! take for a given body on the plate.
//!
//! With R the rotation of P in B, the trajectory's ω, ω̇ (B) and the origin's acceleration a
//! (B) give the estimator's signals in P: ω_P = Rᵀω, ω̇_P = Rᵀω̇, f = Rᵀ(a − g). The legs'
//! forces follow from the Newton–Euler equations of everything on the plate, `Φ θ`
//! ([`estimator::regressor`]), less what the legs' own mass and friction take
//! ([`estimator::legs::unseen`]), mapped back through the leg-force → wrench map:
//! `f = G(pose)⁻¹ (Φθ − unseen)`.

use control::trajectory::Trajectory;
use estimator::legs::PlateMotion;
use estimator::regressor::{from_signals, Regressor, RegressorSignals};
use estimator::{LegModel, ParameterVector};
use kinematics::{Geometry, Pose};
use nalgebra::{Matrix6, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

/// The plate's motion at one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionPoint {
    /// Trajectory time, s.
    pub time_s: f64,
    /// The plate's motion (pose, v, a in B; ω, ω̇ in P).
    pub plate: PlateMotion,
    /// ω̇, ωᵢωⱼ and the specific force of the P origin, in P.
    pub signals: RegressorSignals,
}

impl MotionPoint {
    /// The point of `trajectory` at `time_s`.
    pub fn of(trajectory: &Trajectory, time_s: f64) -> Self {
        let s = trajectory.sample(time_s);
        let to_p = s.pose.rotation.inverse();
        let omega = to_p * s.angular_velocity_rad_s;
        let omega_dot = to_p * s.angular_acceleration_rad_s2;
        let specific_force = to_p * (s.acceleration_m_s2 - GRAVITY_B_M_S2);
        Self {
            time_s,
            plate: PlateMotion {
                pose: s.pose,
                velocity_m_s: s.velocity_m_s,
                acceleration_m_s2: s.acceleration_m_s2,
                angular_velocity_rad_s: omega,
                angular_acceleration_rad_s2: omega_dot,
            },
            signals: RegressorSignals::new(&omega, &omega_dot, &specific_force),
        }
    }

    /// The 6×10 regressor at this point.
    pub fn regressor(&self) -> Regressor {
        from_signals(&self.signals)
    }

    /// The pose of P in B.
    pub fn pose(&self) -> &Pose {
        &self.plate.pose
    }
}

/// `trajectory` sampled every `period_s` over its whole duration (ends included).
pub fn sample(trajectory: &Trajectory, period_s: f64) -> Vec<MotionPoint> {
    if !(period_s.is_finite() && period_s > 0.0) {
        return Vec::new();
    }
    let n = (trajectory.duration_s() / period_s).floor() as usize;
    (0..=n)
        .map(|k| MotionPoint::of(trajectory, k as f64 * period_s))
        .collect()
}

/// The leg-force → wrench map G at `pose`: column i is the wrench (about the P origin, P axes)
/// of a unit force in leg i.
pub fn leg_map(geometry: &Geometry, pose: &Pose) -> Matrix6<f64> {
    let mut g = Matrix6::zeros();
    for leg in 0..6 {
        let mut f = Vector6::zeros();
        f[leg] = 1.0;
        let w = geometry.wrench_in_platform(pose, &f);
        g.set_column(leg, &estimator::wrench::to_vector(&w));
    }
    g
}

/// The axial leg forces that move `theta` (everything on the plate) along `point`, with the
/// legs of `legs` (`None`: massless and frictionless); `None` at a singular pose.
pub fn leg_forces(
    geometry: &Geometry,
    legs: Option<&LegModel>,
    theta: &ParameterVector,
    point: &MotionPoint,
) -> Option<Vector6<f64>> {
    let mut wrench = point.regressor() * theta;
    if let Some(model) = legs {
        let unseen = estimator::legs::unseen(geometry, model, &point.plate, &GRAVITY_B_M_S2);
        wrench -= estimator::wrench::to_vector(&unseen.total());
    }
    leg_map(geometry, point.pose()).lu().solve(&wrench)
}

/// Acceleration of the point `com_m` (in P) of the plate, in B, m/s²:
/// a + R(ω̇ × c + ω × (ω × c)) with ω, ω̇ in P.
pub fn acceleration_at(point: &MotionPoint, com_m: &Vector3<f64>) -> Vector3<f64> {
    let p = &point.plate;
    let (w, wd) = (p.angular_velocity_rad_s, p.angular_acceleration_rad_s2);
    p.acceleration_m_s2 + p.pose.rotation * (wd.cross(com_m) + w.cross(&w.cross(com_m)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use control::trajectory::{Axis, SineComponent};
    use estimator::InertialParameters;
    use nalgebra::Matrix3;

    fn geometry() -> Geometry {
        measure::setup::geometry(&rig_description::load::load(None).expect("default loads"))
            .expect("default geometry")
    }

    #[test]
    fn at_rest_the_legs_carry_the_weight() {
        let g = geometry();
        let traj = Trajectory::new(g.home_pose(), &[], 4.0, 1.0, 1.0).expect("trajectory");
        let body = InertialParameters::from_com(
            1000.0,
            Vector3::new(0.0, 0.0, 0.3),
            Matrix3::identity() * 100.0,
        );
        let point = MotionPoint::of(&traj, 1.0);
        let f = leg_forces(&g, None, &body.to_vector(), &point).expect("regular pose");
        // The vertical components of the six axial forces add up to the weight.
        let lengths = g.legs(point.pose());
        let vertical: f64 = (0..6).map(|i| f[i] * lengths.units[i].z).sum();
        assert!(
            (vertical - 1000.0 * 9.80665).abs() < 1e-6,
            "vertical {vertical}"
        );
    }

    #[test]
    fn a_heave_sine_accelerates_as_its_second_derivative() {
        let g = geometry();
        let (amp, f_hz) = (0.01, 1.0);
        let traj = Trajectory::new(
            g.home_pose(),
            &[SineComponent {
                axis: Axis::Z,
                amplitude: amp,
                frequency_hz: f_hz,
                phase_rad: 0.0,
            }],
            10.0,
            1.0,
            1.0,
        )
        .expect("trajectory");
        let t = 5.1;
        let point = MotionPoint::of(&traj, t);
        let w = 2.0 * core::f64::consts::PI * f_hz;
        let expected = -amp * w * w * (w * t).sin() + 9.80665;
        let got = point.signals.specific_force_m_s2.z;
        assert!((got - expected).abs() < 1e-9, "{got} against {expected}");
        // No rotation: the point acceleration is the origin's.
        let a = acceleration_at(&point, &Vector3::new(0.3, 0.1, 0.5));
        assert!((a.z - (expected - 9.80665)).abs() < 1e-9);
    }
}
