//! Inverse dynamics of the plate's load: the wrench the legs must apply to move a rigid body of
//! known inertial parameters along a set-point, and the leg forces that apply it.
//!
//! Newton–Euler about the P origin O (not the centre of mass, so the equations stay linear in
//! the parameters θ = [m, h, J_O] of [`InertialParameters`]), everything in B axes:
//!
//! ```text
//! F   = m (a_O − g⃗) + α × h_B + ω × (ω × h_B)
//! τ_O = h_B × (a_O − g⃗) + J_B α + ω × (J_B ω)
//! ```
//!
//! with h_B = R h and J_B = R J_O Rᵀ (R the plate's rotation, P axes into B), g⃗ = (0, 0, −g₀),
//! a_O, ω, α the set-point's acceleration of O, angular velocity and angular acceleration. The
//! legs' forces f apply Jᵀ f = [F; τ_O] ([`kinematics::Geometry::wrench_in_base`]), so
//! f = J⁻ᵀ [F; τ_O]. These are the estimator's rigid-body equations read the other way round
//! (docs/architecture.md, "Frames"): there the wrench is measured and θ fitted, here θ is the
//! owner's prior and the wrench is what the leg loops should not have to find by error.

use kinematics::{Geometry, KinematicsError, Matrix6, Pose, Vector3, Vector6};
use stewart_types::InertialParameters;

use crate::error::ControlError;
use crate::io::LEG_COUNT;
use crate::trajectory::TrajectorySample;
use stewart_types::STANDARD_GRAVITY_M_S2 as GRAVITY_M_S2;

/// The wrench `[F; τ_O]` (N, N·m; in B axes, the torque about the P origin) that moves a rigid
/// body of parameters `load` (about the P origin, P axes) along `sample` against gravity: the
/// Newton–Euler equations of the [module docs](self). At rest it is the weight's wrench
/// `[m g₀ ẑ; h_B × g₀ ẑ]`.
pub fn load_wrench(load: &InertialParameters, sample: &TrajectorySample) -> Vector6<f64> {
    let rotation = sample.pose.rotation.matrix();
    let h = rotation * load.first_moment_kg_m;
    let j = rotation * load.inertia_origin_kg_m2 * rotation.transpose();
    let w = sample.angular_velocity_rad_s;
    let alpha = sample.angular_acceleration_rad_s2;
    // a_O − g⃗ with g⃗ = (0, 0, −g₀).
    let specific = sample.acceleration_m_s2 + Vector3::new(0.0, 0.0, GRAVITY_M_S2);
    let force = specific * load.mass_kg + alpha.cross(&h) + w.cross(&w.cross(&h));
    let torque = h.cross(&specific) + j * alpha + w.cross(&(j * w));
    Vector6::new(force.x, force.y, force.z, torque.x, torque.y, torque.z)
}

/// The leg forces f that apply `wrench` to the plate at `pose`: the solution of
/// `Jᵀ f = wrench`, `jacobian` being [`Geometry::jacobian`] at `pose` (a caller that has it for
/// the leg speeds passes it rather than building it twice). A singular pose, or a wrench that
/// is not finite, is an error.
pub fn leg_forces_for(
    geometry: &Geometry,
    pose: &Pose,
    jacobian: &Matrix6<f64>,
    wrench: &Vector6<f64>,
) -> Result<[f64; LEG_COUNT], ControlError> {
    if !wrench.iter().all(|v| v.is_finite()) || !pose.is_finite() {
        return Err(ControlError::NonFinite {
            what: "inverse-dynamics wrench",
            index: 0,
        });
    }
    let singular = || {
        ControlError::Kinematics(KinematicsError::SingularPose {
            inverse_condition: geometry.inverse_condition_number(pose),
        })
    };
    let forces = jacobian
        .transpose()
        .lu()
        .solve(wrench)
        .ok_or_else(singular)?;
    if !forces.iter().all(|f| f.is_finite()) {
        return Err(singular());
    }
    Ok(forces.into())
}

/// The leg forces that move `load` along `sample`: [`leg_forces_for`] of [`load_wrench`] with
/// the Jacobian at `sample`'s pose.
pub fn load_leg_forces(
    geometry: &Geometry,
    load: &InertialParameters,
    sample: &TrajectorySample,
) -> Result<[f64; LEG_COUNT], ControlError> {
    load_leg_forces_with(geometry, &geometry.jacobian(&sample.pose), load, sample)
}

/// [`load_leg_forces`] with the Jacobian at `sample`'s pose already at hand.
pub fn load_leg_forces_with(
    geometry: &Geometry,
    jacobian: &Matrix6<f64>,
    load: &InertialParameters,
    sample: &TrajectorySample,
) -> Result<[f64; LEG_COUNT], ControlError> {
    if !load.is_finite() {
        return Err(ControlError::NonFinite {
            what: "inverse-dynamics load",
            index: 0,
        });
    }
    leg_forces_for(geometry, &sample.pose, jacobian, &load_wrench(load, sample))
}

#[cfg(test)]
mod tests;
