//! The principal frame of J_C for `--principal-axes`: J_C = R·diag(I₁, I₂, I₃)·Rᵀ, the columns
//! of R the principal axes in P, R a proper rotation (det R = +1), given as the roll-pitch-yaw
//! of URDF and SDF and as the quaternion of MJCF.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

/// |RᵀR − 𝟙| and |det R − 1| tolerated of the eigen-solver's axes.
const ROTATION_TOLERANCE: f64 = 1e-9;

/// cos(pitch) below which roll-pitch-yaw is near its gimbal lock (pitch within 6° of ±90°),
/// where roll and yaw lose digits in proportion to 1/cos(pitch).
const GIMBAL_COS: f64 = 0.1;

/// A principal frame of J_C.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipalFrame {
    /// The moments about the frame's x, y and z axes, kg·m²: ascending, or ascending rotated
    /// cyclically when the smallest moment's axis is near P's z (see [`PrincipalFrame::of`]).
    pub moments: [f64; 3],
    /// R: column k is the unit axis (in P) of `moments[k]`; J_C = R·diag(moments)·Rᵀ.
    pub rotation: Matrix3<f64>,
    /// [roll, pitch, yaw], rad, of URDF's `rpy` and SDF's `pose`: R = Rz(yaw)·Ry(pitch)·Rx(roll)
    /// (fixed axes x, y, z in that order).
    pub rpy: [f64; 3],
    /// [w, x, y, z], MJCF's `quat`: the unit quaternion of R, w ≥ 0.
    pub quat_wxyz: [f64; 4],
}

impl PrincipalFrame {
    /// The principal frame of the symmetric `j` ([`stewart_types::principal_of`]:
    /// moments ascending, axes right-handed). When the first axis is within 6° of P's z (the
    /// roll-pitch-yaw gimbal lock), the axes and moments are rotated cyclically, (1 2 3) →
    /// (2 3 1) or (3 1 2), to the order whose first axis is farthest from z: still a proper
    /// rotation, and the angles keep every digit. `None` if the eigen-solver fails or its axes
    /// are not a rotation with det +1.
    pub fn of(j: &Matrix3<f64>) -> Option<PrincipalFrame> {
        let p = stewart_types::principal_of(j)?;
        let z0 = p.axes[(2, 0)];
        let shift = if 1.0 - z0 * z0 >= GIMBAL_COS * GIMBAL_COS {
            0
        } else {
            // The cyclic order whose first axis has the smallest z component: of three
            // orthonormal vectors one has |z| ≤ 1/√3, so cos(pitch) ≥ √(2/3).
            (0..3)
                .min_by(|&a, &b| p.axes[(2, a)].abs().total_cmp(&p.axes[(2, b)].abs()))
                .unwrap_or(0)
        };
        let order = [shift, (shift + 1) % 3, (shift + 2) % 3];
        let rotation = Matrix3::from_fn(|r, c| p.axes[(r, order[c])]);
        let moments = order.map(|k| p.moments_kg_m2[k]);
        let orthonormal = (rotation.transpose() * rotation - Matrix3::identity()).amax();
        if !(orthonormal <= ROTATION_TOLERANCE
            && (rotation.determinant() - 1.0).abs() <= ROTATION_TOLERANCE)
        {
            return None;
        }
        let rot = Rotation3::from_matrix_unchecked(rotation);
        let q = UnitQuaternion::from_rotation_matrix(&rot);
        let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
        Some(PrincipalFrame {
            moments,
            rotation,
            rpy: rpy_of(&rotation),
            quat_wxyz: [q.w * sign, q.i * sign, q.j * sign, q.k * sign],
        })
    }
}

/// Roll, pitch, yaw of R = Rz(yaw)·Ry(pitch)·Rx(roll):
/// R₂₀ = −sin p, R₂₁ = cos p·sin r, R₂₂ = cos p·cos r, R₁₀ = cos p·sin y, R₀₀ = cos p·cos y.
/// Away from cos p = 0 (which [`PrincipalFrame::of`] avoids) each angle is exact to rounding.
fn rpy_of(r: &Matrix3<f64>) -> [f64; 3] {
    let cos_pitch = r[(0, 0)].hypot(r[(1, 0)]);
    [
        r[(2, 1)].atan2(r[(2, 2)]),
        (-r[(2, 0)]).atan2(cos_pitch),
        r[(1, 0)].atan2(r[(0, 0)]),
    ]
}
