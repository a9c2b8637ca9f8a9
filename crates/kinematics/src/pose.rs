//! Pose of the platform frame P in the base frame B.

use crate::real::{self, Real};
use nalgebra::{Rotation3, Vector3};

/// Position of the P origin in B and rotation R that maps P-vectors into B.
#[derive(Clone, Copy, Debug)]
pub struct Pose<T = f64> {
    /// Position of the P origin, in B, metres.
    pub position_m: Vector3<T>,
    /// Rotation mapping vectors in P axes into B axes.
    pub rotation: Rotation3<T>,
}

// Written out: the derive would ask only `T: PartialEq`, and nalgebra's rotations compare for a
// `Scalar`.
impl<T: Real> PartialEq for Pose<T> {
    fn eq(&self, other: &Self) -> bool {
        self.position_m == other.position_m && self.rotation == other.rotation
    }
}

impl<T: Real> Default for Pose<T> {
    fn default() -> Self {
        Self::identity()
    }
}

impl<T: Real> Pose<T> {
    /// A pose from its parts.
    pub fn new(position_m: Vector3<T>, rotation: Rotation3<T>) -> Self {
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
    pub fn from_rpy(position_m: Vector3<T>, roll_rad: T, pitch_rad: T, yaw_rad: T) -> Self {
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), roll_rad);
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), pitch_rad);
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw_rad);
        Self::new(position_m, rx * ry * rz)
    }

    /// Roll, pitch, yaw (rad) such that [`Pose::from_rpy`] gives this rotation back; pitch in
    /// [−π/2, π/2]. From R = Rx·Ry·Rz: R₀₂ = sin β, R₁₂ = −sin α cos β, R₂₂ = cos α cos β,
    /// R₀₁ = −cos β sin γ, R₀₀ = cos β cos γ.
    pub fn rpy(&self) -> (T, T, T) {
        let r = self.rotation.matrix();
        let (m00, m01, m02) = (r.m11, r.m12, r.m13);
        let (m12, m22) = (r.m23, r.m33);
        let pitch = real::asin(m02.clamp(-T::one(), T::one()));
        let roll = real::atan2(-m12, m22);
        let yaw = real::atan2(-m01, m00);
        (roll, pitch, yaw)
    }

    /// A point given in P, expressed in B.
    pub fn transform_point(&self, point_in_p_m: &Vector3<T>) -> Vector3<T> {
        self.position_m + self.rotation * point_in_p_m
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.position_m.iter().all(|v| v.is_finite())
            && self.rotation.matrix().iter().all(|v| v.is_finite())
    }

    /// Translation distance (m) and rotation angle (rad) from `other` to `self`.
    pub fn distance_to(&self, other: &Pose<T>) -> (T, T) {
        let dp = (self.position_m - other.position_m).norm();
        (
            dp,
            rotation_angle(&(self.rotation * other.rotation.transpose())),
        )
    }
}

/// Angle of a rotation, rad, accurate near 0 and π (acos of the trace alone loses half the
/// digits near 0 and returns NaN when rounding pushes its argument past 1).
fn rotation_angle<T: Real>(r: &Rotation3<T>) -> T {
    let m = r.matrix();
    let twice_sin = Vector3::new(m.m32 - m.m23, m.m13 - m.m31, m.m21 - m.m12).norm();
    let half = T::lit(0.5);
    real::atan2(half * twice_sin, half * (m.trace() - T::one()))
}

impl<T: Real> Pose<T> {
    /// The same pose in another precision (each entry rounded to nearest; the rotation matrix
    /// is taken as it is, orthonormal to the target precision's rounding).
    pub fn cast<U: Real>(&self) -> Pose<U> {
        let convert = |v: T| U::lit(v.to_f64());
        Pose::new(
            self.position_m.map(convert),
            Rotation3::from_matrix_unchecked(self.rotation.matrix().map(convert)),
        )
    }
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
