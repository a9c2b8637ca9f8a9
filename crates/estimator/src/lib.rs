//! Online estimation of a payload's ten inertial parameters — mass, centre of mass and full
//! inertia tensor — on a Stewart platform, with honest uncertainty.
//!
//! Data flow of one sample (`OnlineEstimator::update`):
//! leg forces + pose → [`wrench::measured`] → with the gyro and accelerometer →
//! [`conditioning`] (filtered derivative, one low-pass for everything, lever arm) → plus what
//! the cells do not see of the legs' mass and the joints' friction ([`legs`], when described) →
//! [`regressor`] (Newton–Euler about the P origin, linear in θ) → rows weighted by their noise →
//! [`rls`] (U-D factorised recursive least squares; the gyro's error, measured against the
//! kinematic rate of the pose, taken out at the run's ends: [`gyro_error`]) → [`score`] (the
//! residuals' sandwich covariance over overlapping windows, scored at the estimate without the
//! gyro's measured error, [`gyro_error`]) → [`uncertainty`] (propagated to c and J_C) → [`Estimate`]. An estimate that is not physically
//! consistent is projected onto the consistent set by [`projection::nearest_consistent`] (the
//! nearest point in the metric of its covariance).
//!
//! θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] about the P origin in P axes, with
//! h = m·c and J_O = ∫(‖r‖²𝟙 − r rᵀ) dm (tensor entries, so the off-diagonal ones are minus the
//! products of inertia; the layout `docs/CONTRACTS.md` fixes for logs). The paper's six-parameter
//! form (tensor about a known centre of mass, torque rows only) is available as
//! [`ParameterSet::InertiaAboutKnownCom`].
//!
//! `no_std`, no allocation, no panics on any input: every sample is checked before it touches
//! any state, and a bad one is rejected with an [`EstimatorError`] and counted.
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

pub mod conditioning;
pub mod dof;
pub mod drift;
mod error;
mod estimate;
pub mod filter;
pub mod gyro_error;
pub mod hold;
pub mod legs;
mod online;
pub mod projection;
pub mod regressor;
pub mod rls;
pub mod score;
pub mod timebase;
pub mod uncertainty;
pub mod window;
pub mod wrench;

#[cfg(test)]
mod testkit;
#[cfg(test)]
mod tests;

pub use conditioning::{Conditioner, ConditioningConfig};
pub use drift::LoadCellDrift;
pub use error::{ErrorKind, EstimatorError};
pub use estimate::{ConvergenceTolerances, Counts, Estimate, ParameterCovariance};
pub use hold::AccelerometerOffset;
pub use legs::{CellEnd, LegModel};
pub use online::{
    EstimatorConfig, OnlineEstimator, Outcome, ParameterSet, Sample, DEFAULT_MAX_RATE_ERROR,
    ONLINE_ESTIMATOR_MAX_BYTES,
};
pub use projection::{nearest_consistent, Projection};
pub use rls::Rls;
/// The inertial parameters and their θ layout, defined once in `stewart-types`.
pub use stewart_types::{
    principal_of, Consistency, Inconsistency, InertialParameters, ParameterVector, Principal,
    PARAMETER_COUNT,
};
pub use timebase::Timing;
