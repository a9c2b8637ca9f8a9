//! The inertia measurement as a library: what a rig's owner writes down about their rig, the
//! cores (kinematics, control, estimator) set up from it, and the whole procedure — brake hold,
//! settle, excitation, park; tare, payload change, loaded run; report with its uncertainty —
//! on any [`control::io::Backend`], reporting to an [`Observer`] as it goes.
//!
//! Layers (docs/architecture.md): the `no_std` cores below, this crate in the middle, and
//! above it the log (`runlog`: MCAP, Foxglove), the simulator (`sim`), the rig link (`rig`) and
//! the `stewart` command line. Nothing here depends on a terminal, a log format, a plotting
//! library or a physics engine.
//!
//! - [`config`], [`load`], [`validate`], [`link`]: the rig description (crate
//!   `rig_description`, re-exported), read from TOML with refusals that name the file, line
//!   and key.
//! - [`setup`]: geometry, trajectory, controller and estimator settings from it, every check
//!   that can refuse a run made before anything moves.
//! - [`feed`] and [`tick`]: the one rule from sensor frame to estimator sample, and the one
//!   per-sample tick the product runs.
//! - [`run`] (one tare or loaded run), [`sequence`] (tare, payload change, loaded run) and
//!   [`observer`] (where they report).
//! - [`tare`], [`systematic`], [`budget`], [`report`]: the tare file, the estimator's exact
//!   accelerometer-bias and load-cell-offset effects, the error budget (every source's share of
//!   sigma, from the rig description's figures and each run's own data), the report.
//! - [`sources`]: the real rig's error sources, named once for the simulated world's switches
//!   and the report's error budget.
//! - [`replay`]: the estimator re-run on recorded frames; [`accuracy`]: error statistics of
//!   a campaign against a known truth.
#![warn(missing_docs)]

pub mod accuracy;
pub mod budget;
pub mod feed;
pub mod observer;
pub mod quality;
pub mod record;
pub mod reorder;
pub mod replay;
pub mod report;
pub mod run;
pub mod sequence;
pub mod setup;
pub mod systematic;
pub mod tare;
#[cfg(any(test, feature = "testkit"))]
pub mod testkit;
pub mod tick;
/// The vehicle-frame results (crate `vehicle-frame`).
pub use vehicle_frame as vehicle;
pub mod weigh;

pub use observer::{Observer, TickEvent};
pub use report::Report;
pub use run::{measure, End, MeasureOutcome, MeasureSetup};
pub use sequence::{Station, TarePlan};
pub use setup::Measurement;
pub use tare::TareFile;

/// A tare as the estimator subtracts it: the fixture's parameters and their covariance.
pub type TareEstimate = (
    estimator::InertialParameters,
    estimator::ParameterCovariance,
);
