//! The run's log: the MCAP writer with every channel of [`crate::messages`] registered, a
//! time base (Unix nanoseconds, monotonic across runs), and the decimation of the derived
//! channels.

use std::path::Path;

use anyhow::Result;
use serde::Serialize;

use crate::mcap_log::{Delivery, McapLog};
use crate::messages::channels;

/// Rates of the decimated channels, Hz (sensors and commands are logged at every sample).
pub mod rates {
    /// `/pose`, `/legs`, `/control/pid`.
    pub const DERIVED_HZ: f64 = 100.0;
    /// `/estimate` and `/tf`.
    pub const ESTIMATE_HZ: f64 = 50.0;
    /// `/scene`.
    pub const SCENE_HZ: f64 = 10.0;
    /// `/supervisor` (besides every change).
    pub const SUPERVISOR_HZ: f64 = 10.0;
}

/// An open run log.
pub struct RunLog {
    log: McapLog,
    start_unix_ns: u64,
    first_time_s: Option<f64>,
    last_ns: u64,
}

impl RunLog {
    /// Creates the file with every channel. `start_unix_ns` is the wall-clock time that the
    /// first sample's time maps to.
    pub fn create(path: &Path, start_unix_ns: u64) -> Result<Self> {
        Self::create_with(path, start_unix_ns, Delivery::Lossless)
    }

    /// [`Self::create`] with the given behaviour when the log's writer thread falls behind
    /// (`stewart rig`: drop and count, never stall the control loop).
    pub fn create_with(path: &Path, start_unix_ns: u64, delivery: Delivery) -> Result<Self> {
        Ok(Self {
            log: McapLog::create_with(path, &channels(), delivery)?,
            start_unix_ns,
            first_time_s: None,
            last_ns: start_unix_ns,
        })
    }

    /// Serves every message written from here on live as well ([`crate::live`]); `None`
    /// leaves the log as it is.
    #[cfg(feature = "live")]
    pub fn with_live(mut self, live: Option<crate::live::LiveServer>) -> Self {
        if let Some(live) = live {
            self.log.serve_live(live);
        }
        self
    }

    /// The address of the live view, when one is served.
    #[cfg(feature = "live")]
    pub fn live_addr(&self) -> Option<std::net::SocketAddr> {
        self.log.live().map(crate::live::LiveServer::addr)
    }

    /// Messages dropped because the writer fell behind ([`Delivery::DropWhenFull`]).
    pub fn dropped(&self) -> u64 {
        self.log.dropped()
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        self.log.path()
    }

    /// Wall-clock time the first sample maps to, ns since the Unix epoch.
    pub fn start_unix_ns(&self) -> u64 {
        self.start_unix_ns
    }

    /// Log time of backend time `time_s`: the start plus the time since the first sample, never
    /// going backwards (a backend clock that restarts does not reorder the log).
    pub fn time_ns(&mut self, time_s: f64) -> u64 {
        let t0 = *self.first_time_s.get_or_insert(time_s);
        let dt = time_s - t0;
        let ns = if dt.is_finite() && dt > 0.0 {
            self.start_unix_ns.saturating_add((dt * 1e9).round() as u64)
        } else {
            self.start_unix_ns
        };
        self.last_ns = self.last_ns.max(ns);
        self.last_ns
    }

    /// The latest log time used, ns.
    pub fn last_ns(&self) -> u64 {
        self.last_ns
    }

    /// Writes `message` on `topic` at backend time `time_s`.
    pub fn write<T: Serialize>(&mut self, topic: &str, time_s: f64, message: &T) -> Result<()> {
        let ns = self.time_ns(time_s);
        self.log.write(topic, ns, message)
    }

    /// Writes `message` in protobuf on `topic` at backend time `time_s`.
    pub fn write_proto<T: crate::proto::Encode>(
        &mut self,
        topic: &str,
        time_s: f64,
        message: &T,
    ) -> Result<()> {
        let ns = self.time_ns(time_s);
        self.log.write_proto(topic, ns, message)
    }

    /// Writes `message`, a well-known Foxglove message, on `topic` at backend time `time_s`.
    pub fn write_foxglove<T: foxglove::Encode>(
        &mut self,
        topic: &str,
        time_s: f64,
        message: &T,
    ) -> Result<()>
    where
        T::Error: Send + Sync + 'static,
    {
        let ns = self.time_ns(time_s);
        self.log.write_foxglove(topic, ns, message)
    }

    /// Writes `message` on `topic` at the latest log time (for run-level records).
    pub fn write_now<T: Serialize>(&mut self, topic: &str, message: &T) -> Result<()> {
        let ns = self.last_ns;
        self.log.write(topic, ns, message)
    }

    /// Flushes the current chunk to the file.
    pub fn flush(&mut self) -> Result<()> {
        self.log.flush()
    }

    /// Writes the summary and footer.
    pub fn finish(&mut self) -> Result<()> {
        self.log.finish()
    }
}

pub use crate::clock::unix_now_ns;
