//! The Jacobian, the leg-force → wrench map and the conditioning measure.

use crate::real::{self, Real};
use crate::{Geometry, Legs, Pose, LEG_COUNT};
use nalgebra::{Matrix6, Vector3, Vector6};

/// A force and a torque acting on the plate. Which point and which axes is said by the
/// function that returns it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wrench<T = f64> {
    /// Force, N.
    pub force_n: Vector3<T>,
    /// Torque, N·m.
    pub torque_nm: Vector3<T>,
}

impl<T: Real> Default for Wrench<T> {
    fn default() -> Self {
        Self {
            force_n: Vector3::zeros(),
            torque_nm: Vector3::zeros(),
        }
    }
}

impl<T: Real> Geometry<T> {
    /// The 6×6 Jacobian J with row i = [uᵢᵀ, ((R pᵢ) × uᵢ)ᵀ], so that the leg rates are
    /// l̇ = J·[v; ω] with v the velocity of the P origin and ω the angular velocity, both in B.
    ///
    /// By virtual work the same matrix maps leg forces to the plate wrench: w = Jᵀ f.
    pub fn jacobian(&self, pose: &Pose<T>) -> Matrix6<T> {
        self.jacobian_of_legs(pose, &self.legs(pose))
    }

    /// [`Geometry::jacobian`] from `legs`, the legs of `pose` ([`Geometry::legs`]) already at
    /// hand: forward kinematics has them from its residual, and computing them again would
    /// cost as much as the Jacobian's own rows.
    pub fn jacobian_of_legs(&self, pose: &Pose<T>, legs: &Legs<T>) -> Matrix6<T> {
        let mut rows = [[T::zero(); 6]; LEG_COUNT];
        for ((row, plate_joint), u) in rows.iter_mut().zip(self.plate_joints_m()).zip(&legs.units) {
            let m = (pose.rotation * plate_joint).cross(u);
            *row = [u.x, u.y, u.z, m.x, m.y, m.z];
        }
        // From<[[T; 6]; 6]> reads each inner array as a column, so it builds Jᵀ.
        Matrix6::from(rows).transpose()
    }

    /// Wrench of six axial leg forces on the plate: force in B and torque about the P origin
    /// in B axes, F = Σ fᵢ uᵢ, τ = Σ (R pᵢ) × fᵢ uᵢ (= Jᵀ f).
    pub fn wrench_in_base(&self, pose: &Pose<T>, leg_forces_n: &Vector6<T>) -> Wrench<T> {
        let w = self.jacobian(pose).transpose() * leg_forces_n;
        let [fx, fy, fz, tx, ty, tz]: [T; 6] = w.into();
        Wrench {
            force_n: Vector3::new(fx, fy, fz),
            torque_nm: Vector3::new(tx, ty, tz),
        }
    }

    /// The same wrench as [`Geometry::wrench_in_base`] (torque about the P origin), in P axes.
    pub fn wrench_in_platform(&self, pose: &Pose<T>, leg_forces_n: &Vector6<T>) -> Wrench<T> {
        let w = self.wrench_in_base(pose, leg_forces_n);
        let to_p = pose.rotation.inverse();
        Wrench {
            force_n: to_p * w.force_n,
            torque_nm: to_p * w.torque_nm,
        }
    }

    /// σmin/σmax of the Jacobian with its angular columns divided by the characteristic length
    /// ([`Geometry::characteristic_length_m`]: the rig's size), so that the measure does not depend on units. 1 is perfectly
    /// isotropic, 0 singular; NaN only if the pose itself is not finite.
    pub fn inverse_condition_number(&self, pose: &Pose<T>) -> T {
        let mut j = self.jacobian(pose);
        let scale = T::one() / self.characteristic_length_m();
        for mut angular_column in j.column_iter_mut().skip(3) {
            angular_column *= scale;
        }
        if !j.iter().all(|v| v.is_finite()) {
            return T::lit(f64::NAN);
        }
        // Eigenvalues of JᵀJ are the squared singular values; the symmetric eigensolver is
        // robust and allocation-free for fixed-size matrices.
        let jtj = j.transpose() * j;
        match nalgebra::SymmetricEigen::try_new(jtj, T::EIGEN_TOLERANCE, 1000) {
            Some(eig) => {
                let max = eig.eigenvalues.max();
                let min = eig.eigenvalues.min().max(T::zero());
                if max > T::zero() {
                    real::sqrt(min / max)
                } else {
                    T::zero()
                }
            }
            None => T::zero(),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use crate::{Geometry, Pose, StrokeLimits};
    use nalgebra::{Vector3, Vector6};

    fn geometry() -> Geometry {
        let stroke = StrokeLimits {
            min_length_m: 1.5,
            max_length_m: 2.3,
        };
        Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).unwrap()
    }

    /// Column `k` of the Jacobian by central differences of IK with step `h` along twist
    /// component k (an angular velocity in B acts as a left multiplication by exp(dφ)).
    pub(crate) fn numeric_column(g: &Geometry, pose: &Pose, k: usize, h: f64) -> Vector6<f64> {
        let step = |sign: f64| {
            let mut twist = Vector6::zeros();
            twist[k] = h * sign;
            let dp = Vector3::new(twist[0], twist[1], twist[2]);
            let dphi = Vector3::new(twist[3], twist[4], twist[5]);
            Pose::new(
                pose.position_m + dp,
                nalgebra::Rotation3::new(dphi) * pose.rotation,
            )
        };
        (g.leg_lengths(&step(1.0)) - g.leg_lengths(&step(-1.0))) / (2.0 * h)
    }

    #[test]
    fn jacobian_matches_finite_differences_of_ik() {
        let g = geometry();
        let pose = Pose::from_rpy(
            g.home_pose().position_m + Vector3::new(0.05, -0.03, 0.02),
            0.05,
            -0.08,
            0.1,
        );
        let j = g.jacobian(&pose);
        for k in 0..6 {
            let numeric = numeric_column(&g, &pose, k, 1e-6);
            for i in 0..6 {
                assert!(
                    (numeric[i] - j[(i, k)]).abs() < 1e-8,
                    "J[{i},{k}]: {} vs {}",
                    numeric[i],
                    j[(i, k)]
                );
            }
        }
    }

    #[test]
    fn legs_balance_an_off_centre_weight() {
        // A 1200 kg body with its centre of gravity at c (in P) on a tilted plate. Static
        // balance: the legs' wrench about the P origin must equal −(m g) and −(R c) × m g in B.
        let g = geometry();
        let pose = Pose::from_rpy(
            g.home_pose().position_m + Vector3::new(0.02, 0.01, -0.05),
            0.04,
            -0.03,
            0.2,
        );
        let mass_kg = 1200.0;
        let c = Vector3::new(0.3, -0.2, 0.5);
        let weight = stewart_types::GRAVITY_B_M_S2 * mass_kg;
        let arm = pose.rotation * c;
        let mut needed = Vector6::zeros();
        needed.fixed_rows_mut::<3>(0).copy_from(&-weight);
        needed
            .fixed_rows_mut::<3>(3)
            .copy_from(&-arm.cross(&weight));
        let forces = g.jacobian(&pose).transpose().lu().solve(&needed).unwrap();
        let w = g.wrench_in_base(&pose, &forces);
        assert!((w.force_n + weight).norm() < 1e-8 * mass_kg);
        assert!((w.torque_nm + arm.cross(&weight)).norm() < 1e-8 * mass_kg);
        // Independent check, leg by leg: Σ fᵢ uᵢ and Σ (R pᵢ) × fᵢ uᵢ.
        let legs = g.legs(&pose);
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        for i in 0..6 {
            force += legs.units[i] * forces[i];
            torque += (pose.rotation * g.plate_joints_m()[i]).cross(&(legs.units[i] * forces[i]));
        }
        assert!((force + weight).norm() < 1e-8 * mass_kg);
        assert!((torque + arm.cross(&weight)).norm() < 1e-8 * mass_kg);
        // In P axes it is the same wrench rotated.
        let wp = g.wrench_in_platform(&pose, &forces);
        assert!((pose.rotation * wp.force_n - w.force_n).norm() < 1e-9 * mass_kg);
        assert!((pose.rotation * wp.torque_nm - w.torque_nm).norm() < 1e-9 * mass_kg);
        // Every leg pushes: a platform holding a weight has legs in compression.
        assert!(forces.iter().all(|f| *f > 0.0));
    }

    #[test]
    fn conditioning_is_healthy_at_home_and_drops_towards_a_singularity() {
        let g = geometry();
        let home = g.inverse_condition_number(&g.home_pose());
        assert!(home > 0.05 && home <= 1.0, "{home}");
        // Yaw by a large angle aligns legs with the plate's tangent: conditioning falls.
        let twisted = Pose::from_rpy(g.home_pose().position_m, 0.0, 0.0, 1.2);
        assert!(g.inverse_condition_number(&twisted) < home);
    }
}
