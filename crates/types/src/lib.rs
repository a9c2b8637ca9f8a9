//! Types and constants that every layer of the Stewart-platform inertia rig shares, each defined
//! here once: the leg count, standard gravity, the sensor and command frames with the backend
//! status bits, the [`Backend`] trait that the simulator and the rig implement, and the ten
//! inertial parameters of a rigid body.
//!
//! Frames and conventions: the base frame B is fixed to the ground with z up; the platform frame
//! P is fixed to the moving plate. A pose (p, R) maps a P-vector v to B as p + R v. Gravity in B
//! is g = (0, 0, −g₀) with g₀ = [`STANDARD_GRAVITY_M_S2`]. Units are SI throughout.
//!
//! `no_std`, no allocation, no panics.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

mod inertial;
mod io;

use nalgebra::Vector3;

pub use inertial::{
    parallel_axis, principal_of, Consistency, Inconsistency, InertialParameters, ParameterVector,
    Principal, RigidBody, PARAMETER_COUNT, TENSOR_ENTRIES,
};
pub use io::{Backend, CommandFrame, SensorFrame, Status};

/// Number of legs of a 6-6 Stewart platform, and of joints on each of its two plates.
pub const LEG_COUNT: usize = 6;

/// Standard gravity g₀ = 9.80665 m/s² (the conventional value, exact by definition).
pub const STANDARD_GRAVITY_M_S2: f64 = 9.80665;

/// Gravity in the base frame B (z up): g = (0, 0, −g₀) m/s², g₀ = [`STANDARD_GRAVITY_M_S2`].
/// An accelerometer at rest reads the specific force a − g = (0, 0, +g₀) in B.
pub const GRAVITY_B_M_S2: Vector3<f64> = Vector3::new(0.0, 0.0, -STANDARD_GRAVITY_M_S2);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_points_down_in_b_with_the_standard_magnitude() {
        assert_eq!(GRAVITY_B_M_S2.z, -STANDARD_GRAVITY_M_S2);
        assert_eq!(GRAVITY_B_M_S2.norm(), STANDARD_GRAVITY_M_S2);
    }
}
