//! The run's log: the MCAP writer with every channel of [`crate::messages`] registered, a
//! time base (Unix nanoseconds, monotonic across runs), and the decimation of the derived
//! channels.

use std::path::Path;

use anyhow::Result;
use serde::Serialize;

use crate::compact::{CommandBlock, CommandCounts, SensorBlock, SensorCounts, BLOCK_FRAMES};
use crate::mcap_log::{Delivery, McapLog};
use crate::messages::{self as topics, channels};
use crate::tap::Tap;

/// Rates of the decimated channels, Hz (sensors and commands are logged at every sample).
pub mod rates {
    /// `/pose`, `/legs`, `/control/pid`.
    pub const DERIVED_HZ: f64 = 100.0;
    /// `/estimate` (JSON, about 1.7 kB a message: at 50 Hz it would be a sixth of the log) and
    /// `/tf/payload`; `stewart estimate`'s trace of the replay.
    pub const ESTIMATE_HZ: f64 = 10.0;
    /// `/tf`: the plate moves smoothly in the 3D view.
    pub const TF_HZ: f64 = 50.0;
    /// `/scene`.
    pub const SCENE_HZ: f64 = 10.0;
    /// `/supervisor` (besides every change).
    pub const SUPERVISOR_HZ: f64 = 10.0;
}

/// Copies of `/run/metadata` a log holds, each in a chunk of its own ([`RunLog::write_metadata`]).
pub const METADATA_COPIES: usize = 2;

/// Backend time between the copies of a measurement's `/run/estimator` settings, s
/// ([`RunLog::write_settings`]): several chunks apart (a chunk holds about a second of a
/// 1 kHz run), and well within the two minutes of frames `stewart estimate` holds while it
/// waits for a measurement's settings.
pub const SETTINGS_REPEAT_S: f64 = 5.0;

/// An open run log.
pub struct RunLog {
    log: McapLog,
    start_unix_ns: u64,
    first_time_s: Option<f64>,
    last_ns: u64,
    sensors: Block<SensorBlock, SensorCounts>,
    commands: Block<CommandBlock, CommandCounts>,
    settings: Option<Repeated>,
}

/// The settings of the measurement under way, repeated ([`RunLog::write_settings`]).
struct Repeated {
    settings: crate::metadata::EstimatorSettings,
    /// Backend time of the next copy, s.
    next_s: f64,
    /// A frame of the measurement was logged since the last copy.
    since_copy: bool,
}

/// A block of the 1 kHz channels being filled, with the log time of its latest frame.
struct Block<B, C> {
    block: B,
    last: C,
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
        Ok(Self::around(
            McapLog::create_with(path, &channels(), delivery)?,
            start_unix_ns,
        ))
    }

    /// [`Self::create_with`], every message handed to `tap` as well when it is given (the
    /// live view; [`McapLog::create_tapped`]: the log's writer thread hands the messages to
    /// it, so the thread writing the log never calls into it; see [`crate::tap`]).
    pub fn create_tapped(
        path: &Path,
        start_unix_ns: u64,
        delivery: Delivery,
        tap: Option<Box<dyn Tap>>,
    ) -> Result<Self> {
        let log = match tap {
            Some(tap) => McapLog::create_tapped(path, &channels(), delivery, tap)?,
            None => McapLog::create_with(path, &channels(), delivery)?,
        };
        Ok(Self::around(log, start_unix_ns))
    }

    fn around(log: McapLog, start_unix_ns: u64) -> Self {
        Self {
            log,
            start_unix_ns,
            first_time_s: None,
            last_ns: start_unix_ns,
            sensors: Block {
                block: SensorBlock::new(""),
                last: SensorCounts::default(),
                last_ns: 0,
            },
            commands: Block {
                block: CommandBlock::new(""),
                last: CommandCounts::default(),
                last_ns: 0,
            },
            settings: None,
        }
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

    /// Logs sensor frame `f` of measurement `run` on `/sensors`, in blocks of [`BLOCK_FRAMES`]
    /// frames of one measurement ([`crate::compact`]); a block is written when full, when the
    /// measurement changes, and by [`Self::flush`] and [`Self::finish`]. Its log time is its
    /// last frame's, the moment it is complete, so log times never decrease in the file (its
    /// first frame's time is in the block, `time_ns[0]`).
    ///
    /// Every [`SETTINGS_REPEAT_S`] of the measurement's frames after its settings, the settings
    /// are written again ([`Self::write_settings`]); a frame of another measurement ends them.
    pub fn write_sensor(&mut self, run: &'static str, f: &control::io::SensorFrame) -> Result<()> {
        match &mut self.settings {
            Some(r) if r.settings.run == run => {
                r.since_copy = true;
                if f.time_s >= r.next_s {
                    r.next_s = f.time_s + SETTINGS_REPEAT_S;
                    r.since_copy = false;
                    let copy = r.settings.clone();
                    self.write(topics::ESTIMATOR_SETTINGS, f.time_s, &copy)?;
                }
            }
            Some(_) => self.end_settings()?,
            None => {}
        }
        if self.sensors.block.run != run {
            self.flush_sensors()?;
            self.sensors.block.clear(run);
        }
        self.sensors.last_ns = self.time_ns(f.time_s);
        self.sensors.block.push(f, &mut self.sensors.last);
        if self.sensors.block.len() >= BLOCK_FRAMES {
            self.flush_sensors()?;
        }
        Ok(())
    }

    /// Logs command `c` of measurement `run`, answering the sensor frame of time `time_s`, on
    /// `/commands`, in blocks as [`Self::write_sensor`].
    pub fn write_command(
        &mut self,
        run: &'static str,
        time_s: f64,
        c: &control::io::CommandFrame,
    ) -> Result<()> {
        if self.commands.block.run != run {
            self.flush_commands()?;
            self.commands.block.clear(run);
        }
        self.commands.last_ns = self.time_ns(time_s);
        self.commands.block.push(time_s, c, &mut self.commands.last);
        if self.commands.block.len() >= BLOCK_FRAMES {
            self.flush_commands()?;
        }
        Ok(())
    }

    fn flush_sensors(&mut self) -> Result<()> {
        let b = &mut self.sensors;
        if b.block.is_empty() {
            return Ok(());
        }
        b.block.finish();
        let written = self.log.write_proto(topics::SENSORS, b.last_ns, &b.block);
        let run = b.block.run;
        b.block.clear(run);
        written
    }

    fn flush_commands(&mut self) -> Result<()> {
        let b = &mut self.commands;
        if b.block.is_empty() {
            return Ok(());
        }
        b.block.finish();
        let written = self.log.write_proto(topics::COMMANDS, b.last_ns, &b.block);
        let run = b.block.run;
        b.block.clear(run);
        written
    }

    /// Writes measurement `settings.run`'s estimator settings (`/run/estimator`) at backend time
    /// `time_s`, its excitation's start, and keeps them to write again: every
    /// [`SETTINGS_REPEAT_S`] of its frames and once more at its end ([`Self::end_settings`]).
    /// `stewart estimate` needs them for every frame of the measurement, so one damaged chunk
    /// must not take them; a reader takes the first copy that decodes, and every copy is the
    /// same record.
    pub fn write_settings(
        &mut self,
        time_s: f64,
        settings: &crate::metadata::EstimatorSettings,
    ) -> Result<()> {
        self.end_settings()?;
        self.write(topics::ESTIMATOR_SETTINGS, time_s, settings)?;
        self.settings = Some(Repeated {
            settings: settings.clone(),
            next_s: time_s + SETTINGS_REPEAT_S,
            since_copy: false,
        });
        Ok(())
    }

    /// The measurement under way ended: its settings are written once more, at the latest log
    /// time, when a frame came since their last copy, and no longer repeated.
    pub fn end_settings(&mut self) -> Result<()> {
        match self.settings.take() {
            Some(r) if r.since_copy => self.write_now(topics::ESTIMATOR_SETTINGS, &r.settings),
            _ => Ok(()),
        }
    }

    /// Writes `message` on `topic` at the latest log time (for run-level records).
    pub fn write_now<T: Serialize>(&mut self, topic: &str, message: &T) -> Result<()> {
        let ns = self.last_ns;
        self.log.write(topic, ns, message)
    }

    /// Writes the run's metadata (`/run/metadata`) twice, each copy in a chunk of its own:
    /// it is written once per run and `stewart estimate` needs it (the platform's design, the
    /// rig description as run), so one damaged chunk must not take it. The second copy
    /// follows the first rather than ending the log, so that a log cut short (a crash, the
    /// commonest damage) still holds both; the reader takes the first copy that decodes
    /// (docs/log-schema.md, "Damaged and cut logs"). Written before anything else of the run.
    pub fn write_metadata(&mut self, meta: &crate::metadata::RunMetadata) -> Result<()> {
        for _ in 0..METADATA_COPIES {
            self.write_now(topics::METADATA, meta)?;
            self.flush()?;
        }
        Ok(())
    }

    /// Writes the blocks being filled and flushes the current chunk to the file.
    pub fn flush(&mut self) -> Result<()> {
        self.flush_sensors()?;
        self.flush_commands()?;
        self.log.flush()
    }

    /// Writes the settings' last copy ([`Self::end_settings`]) and the blocks being filled,
    /// then the summary and footer.
    pub fn finish(&mut self) -> Result<()> {
        let settings = self.end_settings();
        let blocks = settings
            .and(self.flush_sensors())
            .and(self.flush_commands());
        let finished = self.log.finish();
        blocks.and(finished)
    }
}

pub use crate::clock::unix_now_ns;
