//! Kinematics of a 6-6 Stewart platform: geometry, poses, inverse and forward kinematics, the
//! Jacobian, the map from six axial leg forces to the wrench on the plate, and stroke and
//! singularity checks.
//!
//! `no_std`, no allocation, no panics: every function that can meet bad input returns a
//! [`KinematicsError`]. Conventions follow `DESIGN.md`: base frame B fixed with z up, platform
//! frame P on the plate, pose (p, R) with R mapping P-vectors into B, leg vector
//! lᵢ = p + R pᵢ − bᵢ (ERRATA: the paper's Eq. 5 gives the unit vector, not the length).
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]

mod error;
mod fk;
mod geometry;
mod jacobian;
mod legs;
mod pose;

pub use error::{ErrorKind, KinematicsError};
pub use fk::{FkOptions, FkSolution};
pub use geometry::{Geometry, StrokeLimits};
pub use jacobian::Wrench;
pub use legs::Legs;
pub use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};
pub use pose::Pose;

/// Number of legs (and of joints on each plate).
pub const LEG_COUNT: usize = 6;

/// Below this inverse condition number (σmin/σmax of the length-scaled Jacobian) a pose or a
/// design is treated as singular: leg forces would grow without bound for some wrenches.
pub const SINGULARITY_THRESHOLD: f64 = 1e-3;
