//! The run log: every measurement streamed to an MCAP file that opens in Foxglove and that
//! `stewart estimate` re-reads.
//!
//! - [`schema`]: the JSON-schema builder and checker of the log's JSON messages, and the schemas
//!   of measure's saved records ([`schema::tare`]); crate `record-schema`, re-exported.
//! - [`messages`]: the channel catalogue and the `stewart.*` message types with their JSON
//!   schemas; [`metadata`] the run's metadata, estimator settings and (simulation) truth;
//!   [`link`] the rig link's records.
//! - [`proto`]: the protobuf encoding of the 1 kHz channels and its descriptor.
//! - [`foxglove`]: the 3D scene and transforms in Foxglove's well-known schemas.
//! - [`mcap_log`] (the MCAP writer on its own thread) and [`run_log`] (topics and time);
//!   [`observer`]: the [`measure::Observer`] that writes a measurement into it.
//! - [`tap`]: a second reader of every message the log writes, on the writer thread, and the
//!   pace the log keeps for it (the live view, crate `live`, is one).
//! - [`read`]: a log read back, tolerant of a file cut short (`stewart estimate` re-estimates
//!   its measurements with the operations library's `ops::estimate`).
//!
//! docs/log-schema.md documents every channel.
#![warn(missing_docs)]

pub mod channel;
pub mod clock;
pub mod compact;
pub mod foxglove;
pub mod mcap_log;
pub mod messages;
pub mod metadata;
pub mod observer;
pub mod proto;
pub mod read;
pub mod rig_record;
pub mod run_log;
pub use record_schema as schema;
pub mod tap;

pub use observer::LogObserver;
pub use read::LogContents;
pub use run_log::RunLog;
pub use tap::{Pace, Tap};
