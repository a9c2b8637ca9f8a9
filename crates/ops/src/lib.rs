//! Every `stewart` command's work as a library call, as cargo's `ops` are to its commands:
//! `ops::x::run(&XOptions, observer…) -> Result<XOutcome, …>` with plain option structs (no
//! clap, serde-friendly), so a program, a test or a benchmark runs a measurement, a campaign, a
//! calibration or a rig measurement without the binary. The `stewart` binary turns flags into these
//! options, calls, and prints.
#![warn(missing_docs)]

pub mod bench;
pub mod calibration;
pub mod campaign;
pub mod emulate;
pub mod estimate;
pub mod exit;
pub mod export;
pub mod import;
pub mod key;
pub mod measurement;
pub mod plan;
pub mod report;
pub mod rig;
pub mod simulate;
