//! The rig description: what a rig's owner can know and write down about their rig (geometry
//! and stroke, sample rate, each sensor's datasheet and the IMU's mounting, gains, limits,
//! excitation, estimator settings, run phases, the link, the calibrations applied), read from
//! TOML with refusals that name the file, line and key. It never holds the simulated world's
//! truth: a scenario's `[world]` table is left to the simulator (docs/architecture.md).
//!
//! - [`config`]: the schema, one struct per table, units in the key names.
//! - [`bounded`]: a file a user names read with a cap on its size.
//! - [`load`]: reading a file laid over the embedded default, with FILE:LINE refusals.
//! - [`validate`]: range checks, each problem as (dotted key, what is wrong).
//! - [`link`]: the `[rig]` table and the rig address syntax.
//! - [`calibration`]: the dated calibration files a description applies.
//! - [`derived`]: what follows from it: the platform's geometry, the accelerometer's position.
//! - [`digest`]: the SHA-256 a report gives of the description and its calibrations.
//! - [`sources`]: a real rig's error sources, named once; [`quantities`]: the ten reported
//!   quantities; [`calendar`]: the UTC date of a Unix time, for stamps.
#![warn(missing_docs)]

pub mod bounded;
pub mod calendar;
pub mod calibration;
pub mod config;
pub mod derived;
pub mod digest;
pub mod link;
pub mod load;
pub mod quantities;
pub mod range;
pub mod sources;
pub mod validate;

pub use config::Config;
pub use load::{ConfigError, ConfigIssue, LoadedConfig};
