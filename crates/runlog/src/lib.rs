//! The run log: every measurement streamed to an MCAP file that opens in Foxglove and that
//! `stewart estimate` re-reads.
//!
//! - [`messages`]: the channel catalogue and the `stewart.*` message types with their JSON
//!   schemas; [`metadata`] the run's metadata, estimator settings and (simulation) truth;
//!   [`link`] the rig link's records.
//! - [`proto`]: the protobuf encoding of the 1 kHz channels and its descriptor.
//! - [`foxglove`]: the 3D scene and transforms in Foxglove's well-known schemas.
//! - [`mcap_log`] (the MCAP writer on its own thread) and [`run_log`] (topics and time);
//!   [`observer`]: the [`measure::Observer`] that writes a measurement into it.
//! - [`live`] (feature `live`, on by default): the same channels served over the Foxglove
//!   WebSocket protocol while the log is written (`--live`).
//! - [`read`]: a log read back, tolerant of a file cut short (`stewart estimate` re-estimates
//!   its measurements with the operations library's `ops::estimate`).
//!
//! docs/log-schema.md documents every channel.
#![warn(missing_docs)]

pub mod channel;
pub mod clock;
pub mod compact;
pub mod foxglove;
pub mod link;
#[cfg(feature = "live")]
pub mod live;
pub mod mcap_log;
pub mod messages;
pub mod metadata;
pub mod observer;
pub mod proto;
pub mod read;
pub mod run_log;

pub use observer::LogObserver;
pub use read::LogContents;
pub use run_log::RunLog;
