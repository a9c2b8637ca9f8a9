//! Inverse kinematics: leg vectors, lengths and directions for a pose.

use crate::real::Real;
use crate::{Geometry, KinematicsError, Pose, LEG_COUNT};
use nalgebra::{Vector3, Vector6};

/// The six legs at one pose, all in B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Legs<T = f64> {
    /// lᵢ = p + R pᵢ − bᵢ, from base joint to plate joint, m.
    pub vectors_m: [Vector3<T>; LEG_COUNT],
    /// ‖lᵢ‖, m.
    pub lengths_m: Vector6<T>,
    /// uᵢ = lᵢ/‖lᵢ‖; a positive leg force pushes the plate along uᵢ.
    pub units: [Vector3<T>; LEG_COUNT],
}

impl<T: Real> Geometry<T> {
    /// Inverse kinematics (corrected Eq. 5): leg vectors, lengths and unit vectors for `pose`.
    ///
    /// A zero-length leg (joints coincide) gets a zero unit vector rather than NaN; the stroke
    /// check refuses such a pose because the minimum length is positive.
    pub fn legs(&self, pose: &Pose<T>) -> Legs<T> {
        let mut vectors_m = [Vector3::zeros(); LEG_COUNT];
        for ((v, plate_joint), base_joint) in vectors_m
            .iter_mut()
            .zip(self.plate_joints_m())
            .zip(self.base_joints_m())
        {
            *v = pose.transform_point(plate_joint) - base_joint;
        }
        let lengths_m = vectors_m.map(|v| v.norm());
        let mut units = [Vector3::zeros(); LEG_COUNT];
        for ((u, v), &length) in units.iter_mut().zip(&vectors_m).zip(&lengths_m) {
            if length > T::zero() {
                *u = v / length;
            }
        }
        Legs {
            vectors_m,
            lengths_m: Vector6::from(lengths_m),
            units,
        }
    }

    /// Leg lengths for `pose`, m.
    pub fn leg_lengths(&self, pose: &Pose<T>) -> Vector6<T> {
        self.legs(pose).lengths_m
    }

    /// Inverse kinematics with the stroke check: the legs, or an error naming the first leg
    /// out of stroke and by how much.
    pub fn check_reachable(&self, pose: &Pose<T>) -> Result<Legs<T>, KinematicsError> {
        if !pose.is_finite() {
            return Err(KinematicsError::NonFinite { what: "pose" });
        }
        let legs = self.legs(pose);
        let stroke = self.stroke();
        for (leg, &length_m) in legs.lengths_m.iter().enumerate() {
            if length_m < stroke.min_length_m {
                return Err(KinematicsError::LegTooShort {
                    leg,
                    length_m: length_m.to_f64(),
                    min_length_m: stroke.min_length_m.to_f64(),
                });
            }
            if length_m > stroke.max_length_m {
                return Err(KinematicsError::LegTooLong {
                    leg,
                    length_m: length_m.to_f64(),
                    max_length_m: stroke.max_length_m.to_f64(),
                });
            }
        }
        Ok(legs)
    }
}

#[cfg(test)]
mod tests {
    use crate::{Geometry, KinematicsError, Pose, StrokeLimits};
    use nalgebra::Vector3;

    #[test]
    fn leg_lengths_match_a_hand_computation() {
        // Base radius 2 with pairs 60° apart: base joints at ±30° about 0°, 120°, 240°, so leg 2
        // (index 1) starts at (2cos30°, 2sin30°, 0) = (√3, 1, 0). Plate radius 1 with pairs 30°
        // apart about 60°, 180°, 300°: leg 2 ends at the plate joint at 60° − 15° = 45°,
        // (a, a, 0) in P with a = √2/2.
        let stroke = StrokeLimits {
            min_length_m: 0.5,
            max_length_m: 3.0,
        };
        let (pi, s3, a) = (
            core::f64::consts::PI,
            3f64.sqrt(),
            core::f64::consts::FRAC_1_SQRT_2,
        );
        let g = Geometry::from_radii(2.0, 1.0, pi / 3.0, pi / 6.0, stroke).unwrap();
        let hand = |x: f64, y: f64, z: f64| (x * x + y * y + z * z).sqrt();
        // Pure translation (0.1, −0.2, 1.5).
        let pose = Pose::from_rpy(Vector3::new(0.1, -0.2, 1.5), 0.0, 0.0, 0.0);
        let by_hand = hand(a + 0.1 - s3, a - 0.2 - 1.0, 1.5);
        assert!((g.leg_lengths(&pose)[1] - by_hand).abs() < 1e-14);
        // Yaw by 90° at height 1: the plate joint moves from 45° to 135°, (−a, a, 1).
        let pose = Pose::from_rpy(Vector3::new(0.0, 0.0, 1.0), 0.0, 0.0, pi / 2.0);
        let by_hand = hand(-a - s3, a - 1.0, 1.0);
        assert!((g.leg_lengths(&pose)[1] - by_hand).abs() < 1e-14);
        // Roll by 0.3 rad at height 1.2: (a, a, 0) → (a, a cos0.3, a sin0.3).
        let pose = Pose::from_rpy(Vector3::new(0.0, 0.0, 1.2), 0.3, 0.0, 0.0);
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let by_hand = hand(a - s3, a * c - 1.0, 1.2 + a * s);
        assert!((g.leg_lengths(&pose)[1] - by_hand).abs() < 1e-14);
    }

    #[test]
    fn stroke_check_names_the_leg() {
        let stroke = StrokeLimits {
            min_length_m: 1.5,
            max_length_m: 2.3,
        };
        let g = Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).unwrap();
        let mut high = g.home_pose();
        high.position_m.z += 1.0;
        assert!(matches!(
            g.check_reachable(&high),
            Err(KinematicsError::LegTooLong { leg: 0, .. })
        ));
        let mut low = g.home_pose();
        low.position_m.z -= 1.0;
        assert!(matches!(
            g.check_reachable(&low),
            Err(KinematicsError::LegTooShort { leg: 0, .. })
        ));
        // Tilting about x lifts one side: the first leg out is on the +y side, not leg 1.
        let tilted = Pose::from_rpy(g.home_pose().position_m, 0.6, 0.0, 0.0);
        match g.check_reachable(&tilted) {
            Err(KinematicsError::LegTooLong { leg, .. })
            | Err(KinematicsError::LegTooShort { leg, .. }) => {
                let l = g.leg_lengths(&tilted)[leg];
                assert!(!(1.5..=2.3).contains(&l));
            }
            other => panic!("expected a stroke error, got {other:?}"),
        }
        assert!(g.check_reachable(&g.home_pose()).is_ok());
        let mut nan = g.home_pose();
        nan.position_m.x = f64::NAN;
        assert!(matches!(
            g.check_reachable(&nan),
            Err(KinematicsError::NonFinite { .. })
        ));
    }
}
