//! The measured wrench: six axial leg forces and the forward-kinematics pose give the force and
//! the torque the legs apply to the plate, about the P origin in P axes.

use kinematics::{Geometry, Pose, Wrench};
use nalgebra::Vector6;

/// F = Σ fᵢ uᵢ and τ_O = Σ (R pᵢ) × fᵢ uᵢ (= Jᵀ f, `kinematics`), rotated into P axes.
/// A positive leg force pushes the plate away from the base.
pub fn measured(geometry: &Geometry, pose: &Pose, leg_forces_n: &Vector6<f64>) -> Wrench {
    geometry.wrench_in_platform(pose, leg_forces_n)
}

/// [Fx, Fy, Fz, τx, τy, τz] in the regressor's row order.
pub fn to_vector(wrench: &Wrench) -> Vector6<f64> {
    let (f, t) = (&wrench.force_n, &wrench.torque_nm);
    Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit::test_geometry;
    use nalgebra::Vector3;

    /// Independent sum over the legs, from the joint positions alone.
    #[test]
    fn equals_the_sum_of_leg_forces_in_platform_axes() {
        let g = test_geometry();
        let pose = Pose::from_rpy(
            g.home_pose().position_m + Vector3::new(0.02, -0.03, 0.05),
            0.1,
            -0.05,
            0.2,
        );
        let forces = Vector6::new(900.0, 1100.0, 950.0, 1020.0, 980.0, 1005.0);
        let w = measured(&g, &pose, &forces);
        let r = pose.rotation;
        let mut f_p = Vector3::zeros();
        let mut t_p = Vector3::zeros();
        for i in 0..6 {
            let top_b = pose.position_m + r * g.plate_joints_m()[i];
            let u_b = (top_b - g.base_joints_m()[i]).normalize();
            let u_p = r.inverse() * u_b;
            f_p += u_p * forces[i];
            t_p += g.plate_joints_m()[i].cross(&(u_p * forces[i]));
        }
        assert!((w.force_n - f_p).norm() < 1e-9 * f_p.norm());
        assert!((w.torque_nm - t_p).norm() < 1e-9 * f_p.norm());
        let v = to_vector(&w);
        assert_eq!(v[2], w.force_n.z);
        assert_eq!(v[5], w.torque_nm.z);
    }
}
