//! Pose of the platform frame P in the base frame B.

use nalgebra::{Rotation3, Vector3};

/// Position of the P origin in B and rotation R that maps P-vectors into B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Position of the P origin, in B, metres.
    pub position_m: Vector3<f64>,
    /// Rotation mapping vectors in P axes into B axes.
    pub rotation: Rotation3<f64>,
}

impl Default for Pose {
    fn default() -> Self {
        Self::identity()
    }
}

impl Pose {
    /// A pose from its parts.
    pub fn new(position_m: Vector3<f64>, rotation: Rotation3<f64>) -> Self {
        Self {
            position_m,
            rotation,
        }
    }

    /// P coincident with B.
    pub fn identity() -> Self {
        Self::new(Vector3::zeros(), Rotation3::identity())
    }

    /// From position and roll α, pitch β, yaw γ with R = Rx(α)·Ry(β)·Rz(γ), the paper's Eq. 7
    /// order, each factor the right-handed rotation about its axis; in particular
    /// Ry(β) = [[cos β, 0, sin β], [0, 1, 0], [−sin β, 0, cos β]] (the paper's Eq. 6 misprints
    /// R_β).
    pub fn from_rpy(position_m: Vector3<f64>, roll_rad: f64, pitch_rad: f64, yaw_rad: f64) -> Self {
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), roll_rad);
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), pitch_rad);
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_rad);
        Self::new(position_m, rx * ry * rz)
    }

    /// Roll, pitch, yaw (rad) such that [`Pose::from_rpy`] gives this rotation back; pitch in
    /// [−π/2, π/2]. From R = Rx·Ry·Rz: R₀₂ = sin β, R₁₂ = −sin α cos β, R₂₂ = cos α cos β,
    /// R₀₁ = −cos β sin γ, R₀₀ = cos β cos γ.
    pub fn rpy(&self) -> (f64, f64, f64) {
        let r = self.rotation.matrix();
        let pitch = libm::asin(r[(0, 2)].clamp(-1.0, 1.0));
        let roll = libm::atan2(-r[(1, 2)], r[(2, 2)]);
        let yaw = libm::atan2(-r[(0, 1)], r[(0, 0)]);
        (roll, pitch, yaw)
    }

    /// A point given in P, expressed in B.
    pub fn transform_point(&self, point_in_p_m: &Vector3<f64>) -> Vector3<f64> {
        self.position_m + self.rotation * point_in_p_m
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.position_m.iter().all(|v| v.is_finite())
            && self.rotation.matrix().iter().all(|v| v.is_finite())
    }

    /// Translation distance (m) and rotation angle (rad) from `other` to `self`.
    pub fn distance_to(&self, other: &Pose) -> (f64, f64) {
        let dp = (self.position_m - other.position_m).norm();
        (
            dp,
            rotation_angle(&(self.rotation * other.rotation.transpose())),
        )
    }
}

/// Angle of a rotation, rad, accurate near 0 and π (acos of the trace alone loses half the
/// digits near 0 and returns NaN when rounding pushes its argument past 1).
fn rotation_angle(r: &Rotation3<f64>) -> f64 {
    let m = r.matrix();
    let twice_sin = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
    .norm();
    libm::atan2(0.5 * twice_sin, 0.5 * (m.trace() - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_matches_hand_built_matrices() {
        let (a, b, g) = (0.1_f64, -0.2_f64, 0.3_f64);
        // The right-handed elementary rotations (Eq. 6 with R_β corrected), written out by hand.
        let rx =
            nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, a.cos(), -a.sin(), 0.0, a.sin(), a.cos());
        let ry =
            nalgebra::Matrix3::new(b.cos(), 0.0, b.sin(), 0.0, 1.0, 0.0, -b.sin(), 0.0, b.cos());
        let rz =
            nalgebra::Matrix3::new(g.cos(), -g.sin(), 0.0, g.sin(), g.cos(), 0.0, 0.0, 0.0, 1.0);
        let pose = Pose::from_rpy(Vector3::zeros(), a, b, g);
        assert!((pose.rotation.matrix() - rx * ry * rz).norm() < 1e-15);
        let (a2, b2, g2) = pose.rpy();
        assert!((a - a2).abs() < 1e-14 && (b - b2).abs() < 1e-14 && (g - g2).abs() < 1e-14);
    }
}
