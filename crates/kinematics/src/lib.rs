//! Kinematics of a 6-6 Stewart platform: geometry, poses, inverse and forward kinematics, the
//! Jacobian, the map from six axial leg forces to the wrench on the plate, and stroke and
//! singularity checks.
//!
//! `no_std`, no allocation, no panics: every function that can meet bad input returns a
//! [`KinematicsError`].
//!
//! Every type is generic over the scalar [`Real`] (`f64` or `f32`), `f64` by default: the
//! [`real`] module says why and how, docs/firmware.md what f32 costs in accuracy.
//!
//! Conventions: base frame B fixed to the ground with z up; platform frame P fixed to the plate;
//! a pose (p, R) holds the position p of the P origin in B and the rotation R that maps
//! P-vectors into B. With bᵢ the base joints in B and pᵢ the plate joints in P, leg i's vector is
//! lᵢ = p + R pᵢ − bᵢ, its length ‖lᵢ‖ and its unit vector uᵢ = lᵢ/‖lᵢ‖ (the paper's Eq. 5
//! gives the unit vector, not the length).
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

mod error;
#[cfg(test)]
mod f32_tests;
mod fk;
mod geometry;
mod jacobian;
mod legs;
mod pose;
pub mod real;

pub use error::{ErrorKind, KinematicsError};
pub use fk::{FkOptions, FkSolution};
pub use geometry::{Geometry, StrokeLimits};
pub use jacobian::Wrench;
pub use legs::Legs;
pub use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};
pub use pose::Pose;
pub use real::Real;
/// Number of legs (and of joints on each plate), defined in `stewart-types`.
pub use stewart_types::LEG_COUNT;

/// Below this inverse condition number (σmin/σmax of the length-scaled Jacobian) a pose or a
/// design is treated as singular: leg forces would grow without bound for some wrenches.
pub const SINGULARITY_THRESHOLD: f64 = 1e-3;
