//! `stewart estimate` on a log streamed from disk in one pass: each `/sensors` frame is decoded
//! and fed to its measurement's replay as its chunk is read, and nothing else of the 1 kHz
//! channels is kept, so memory does not grow with the log's length (the replays' own history
//! and trace are bounded, see [`measure::replay::Replay`]).
//!
//! A measurement's frames before its `/run/estimator` message (written when its excitation
//! starts) wait in a bounded queue, [`WAITING_FRAMES`]; the replay starts on that message with
//! them. Each measurement's frames are put back in sequence order, duplicates dropped, and
//! the spans out of place or missing named ([`super::order`]). The settings are repeated while
//! a measurement runs and at its end (`RunLog::write_settings`): when the first copy was lost
//! the replay starts on a later one with the frames held, and the report says so
//! (`data.recovered`).
//!
//! A log that holds two runs written into one file is refused ([`TwoRuns`]): two different
//! `/run/metadata` or `/run/estimator` records of one measurement, or frames of one
//! measurement that carry one sequence number with different readings.
//!
//! The result is the one [`super::reestimate`] gives on the same log read whole.

use std::collections::VecDeque;
use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use control::io::SensorFrame;
use measure::replay::{Replay, ReplayError, ReplayOutcome};
use measure::{Report, TareFile};
use rig_description::LoadedConfig;

use super::{
    build_report, logged_tare, measured_tare, no_settings, rig_description_of, run_estimate,
    settings_of, start_replay, tare_file, LogFacts, RunEstimate, SettingsOverride, TareOrigin,
};
use runlog::messages as topics;
use runlog::metadata::{EstimatorSettings, RunMetadata, TruthMsg};
use runlog::proto;
use runlog::read::order::{SequenceReport, Sequencer};
use runlog::read::{decode, no_metadata, visit, Channels, Damage, Message, Visitor};

/// Frames of a measurement held while its estimator settings have not been read: two minutes
/// at 1 kHz (about 20 MB). Beyond, the oldest are dropped (they only warm the conditioning).
pub const WAITING_FRAMES: usize = 120_000;

pub use runlog::read::{is_two_runs, TwoRuns};

/// A copy of the settings read this much backend time after the excitation's start, or later,
/// is not the first one (written at the start): the first was lost, s.
const FIRST_COPY_WITHIN_S: f64 = 0.5;

enum RunState {
    /// Frames waiting for the settings.
    Waiting(VecDeque<SensorFrame>),
    /// The replay under way (boxed: it carries the frame-to-sample stage).
    Running(Box<Worker>),
}

/// Frames handed to a replay's thread at a time.
const BATCH_FRAMES: usize = 512;

/// Batches a replay's thread may have waiting: 32 768 frames (33 s at 1 kHz, about 7 MB),
/// whatever the log's length. Deep enough that the reader runs through a tare run (its
/// estimator takes about 1.6 times the CPU of decoding and forward kinematics per frame)
/// and starts the loaded run's replay while the tare's catches up on the other core: with a
/// shallow queue the reader waits for the tare's estimator, and the loaded run's replay,
/// the longest chain of work, starts only once the tare's frames are all in.
const QUEUE_BATCHES: usize = 64;

/// A frame's backend time and its sample (`None`: forward kinematics failed).
type Fed = (f64, Option<estimator::Sample>);

/// What a replay's thread gives once its measurement's frames are all in.
type Finished = std::result::Result<ReplayOutcome, ReplayError>;

/// A replay on a thread of its own, fed in batches: the log is read, decoded and posed by
/// forward kinematics ([`Replay::feed`]) on the caller's thread while the estimator runs on
/// another ([`Replay::push_fed`]), which splits the per-frame work about evenly over two cores.
/// Once its input is closed ([`Worker::close`]: the next measurement began) the thread also
/// finishes the replay, error budget included, while the next measurement is read.
struct Worker {
    /// The frames as they came, put back in sequence order before the feed
    /// ([`super::order`]).
    order: Sequencer,
    sink: Sink,
    frames: u64,
    /// Frames that came after the input was closed.
    late: u64,
    thread: std::thread::JoinHandle<Finished>,
}

/// The frames in sequence order, posed and batched for the replay's thread.
struct Sink {
    feed: measure::feed::Feed,
    batch: Vec<Fed>,
    queue: Option<std::sync::mpsc::SyncSender<Vec<Fed>>>,
}

impl Sink {
    fn push(&mut self, frame: &SensorFrame) {
        let sample = self.feed.next(frame);
        self.batch.push((frame.time_s, sample));
        if self.batch.len() >= BATCH_FRAMES {
            self.send();
        }
    }

    fn send(&mut self) {
        let batch = std::mem::replace(&mut self.batch, Vec::with_capacity(BATCH_FRAMES));
        if let Some(q) = &self.queue {
            // A send fails only when the thread died; `finish` reports it.
            let _ = q.send(batch);
        }
    }
}

/// A measurement's replay finished, with what its frames' order showed.
struct Replayed {
    finished: Finished,
    order: SequenceReport,
    /// Frames in all, and those that came after the next measurement's began.
    frames: u64,
    late: u64,
}

impl Worker {
    fn start(mut replay: Replay, run: &str) -> Result<Self> {
        let feed = replay.feed();
        // A bounded queue bounds the memory whichever side is faster.
        let (queue, batches) = std::sync::mpsc::sync_channel::<Vec<Fed>>(QUEUE_BATCHES);
        let thread = std::thread::Builder::new()
            .name("replay".into())
            .spawn(move || {
                for batch in batches {
                    for (time_s, sample) in batch {
                        replay.push_fed(time_s, sample);
                    }
                }
                replay.finish()
            })
            .context("cannot start the replay thread")?;
        Ok(Self {
            order: Sequencer::new(run),
            sink: Sink {
                feed,
                batch: Vec::with_capacity(BATCH_FRAMES),
                queue: Some(queue),
            },
            frames: 0,
            late: 0,
            thread,
        })
    }

    fn push(&mut self, frame: SensorFrame) {
        if self.sink.queue.is_none() {
            self.late += 1;
            return;
        }
        self.frames += 1;
        let sink = &mut self.sink;
        self.order.push(frame, &mut |f| sink.push(&f));
    }

    /// No more frames: the thread finishes the replay.
    fn close(&mut self) {
        if self.sink.queue.is_some() {
            let sink = &mut self.sink;
            self.order.flush(&mut |f| sink.push(&f));
            self.sink.send();
            self.sink.queue = None;
        }
    }

    fn finish(mut self) -> Result<Replayed> {
        self.close();
        let order = self.order.report();
        let counts = measure::reorder::ReorderCounts {
            late: order.counts.late,
            duplicates: order.counts.duplicates,
        };
        let finished = self
            .thread
            .join()
            .map_err(|_| anyhow!("the replay thread panicked"))?
            .map(|mut outcome| {
                outcome.reordered = counts;
                outcome
            });
        Ok(Replayed {
            finished,
            order,
            frames: self.frames,
            late: self.late,
        })
    }
}

/// The visitor: the small channels kept, the frames replayed.
struct Stream<'a> {
    /// The log.
    path: &'a Path,
    o: &'a SettingsOverride,
    rig_arg: Option<&'a LoadedConfig>,
    /// The measurements replayed (`tare` only when no tare file is given).
    wanted: Vec<&'static str>,
    meta: Option<RunMetadata>,
    /// The bytes of the first `/run/metadata` copy read, which every other copy repeats.
    meta_bytes: Option<Vec<u8>>,
    /// Records lost and read from another copy, in words.
    recovered: Vec<String>,
    /// `meta` is the rig description's ([`RunMetadata::of_rig`]): its `runs` are the
    /// measurements whose frames are read.
    meta_of_rig: bool,
    rig: Option<LoadedConfig>,
    settings: Vec<EstimatorSettings>,
    tare: Option<TareFile>,
    truth: Option<TruthMsg>,
    runs: Vec<(&'static str, RunState)>,
    /// First and last sequence of the `/sensors` block just decoded.
    sequences: Option<(u64, u64)>,
    /// The protobuf `/sensors` message decoded into, its buffers reused.
    scratch: proto::SensorBlock,
    /// The measurement of the last frame read.
    current: Option<String>,
}

impl Stream<'_> {
    fn state(&mut self, run: &str) -> Option<&mut RunState> {
        let name = *self.wanted.iter().find(|w| **w == run)?;
        if let Some(i) = self.runs.iter().position(|(r, _)| *r == name) {
            return Some(&mut self.runs[i].1);
        }
        self.runs.push((name, RunState::Waiting(VecDeque::new())));
        self.runs.last_mut().map(|(_, s)| s)
    }

    /// Starts `run`'s replay once its settings and the metadata are known.
    fn start(&mut self, run: &str) -> Result<()> {
        let (Some(meta), Some(rig)) = (&self.meta, &self.rig) else {
            return Ok(());
        };
        let Some(recorded) = self.settings.iter().find(|s| s.run == run) else {
            return Ok(());
        };
        let (config, fk) = settings_of(meta, recorded, rig, run, self.o)
            .with_context(|| format!("re-estimating the {run} run"))?;
        let replay = start_replay(config, fk, rig)?;
        let Some(state) = self.state(run) else {
            return Ok(());
        };
        if let RunState::Waiting(frames) = state {
            let mut worker = Worker::start(replay, run)?;
            for f in frames.drain(..) {
                worker.push(f);
            }
            *state = RunState::Running(Box::new(worker));
        }
        Ok(())
    }

    /// Takes `meta` as the log's metadata and starts the replays whose settings are known.
    fn adopt(&mut self, meta: RunMetadata) -> Result<()> {
        self.rig = Some(rig_description_of(&meta, self.rig_arg)?);
        self.meta = Some(meta);
        for run in self.wanted.clone() {
            self.start(run)?;
        }
        Ok(())
    }

    /// The run's frames or settings come and no copy of `/run/metadata` (written before
    /// anything else of the run) was read: every copy was lost. With a rig description given
    /// (`--rig FILE`) the run is read with its platform ([`RunMetadata::of_rig`]); without,
    /// the frames wait and the end says what is missing.
    fn metadata_lost(&mut self) -> Result<()> {
        if let Some(rig) = self.rig_arg {
            self.adopt(RunMetadata::of_rig(rig)?)?;
            self.meta_of_rig = true;
        }
        Ok(())
    }

    /// Notes the settings `s` as recovered when frames of its measurement from well after its
    /// excitation's start were read before them: the copy written at that start was lost.
    fn first_settings(&mut self, s: &EstimatorSettings) {
        let Some(start_s) = s.window_start_s else {
            return;
        };
        let run = s.run.clone();
        let latest = match self.state(&run) {
            Some(RunState::Waiting(q)) => q.back().map(|f| f.time_s),
            _ => None,
        };
        if let Some(latest_s) = latest.filter(|t| *t >= start_s + FIRST_COPY_WITHIN_S) {
            self.recovered.push(format!(
                "the {run} measurement's estimator settings ({}, written as its excitation \
                 started at {start_s:.3} s) were lost with a damaged part of the log; they were \
                 read from a copy repeated later, after its frames up to {latest_s:.3} s, which \
                 waited for them",
                topics::ESTIMATOR_SETTINGS
            ));
        }
    }

    /// A `/sensors` block, decoded into a reused message.
    fn sensor(&mut self, m: &Message<'_>) -> Result<Option<String>> {
        let frames = match runlog::read::sensor_block(m, &mut self.scratch)? {
            Ok(frames) => frames,
            Err(e) => return Ok(Some(e)),
        };
        if let (Some(a), Some(b)) = (frames.first(), frames.last()) {
            self.sequences = Some((a.sequence, b.sequence));
        }
        let run = std::mem::take(&mut self.scratch.run);
        if let Some(meta) = self.meta.as_mut().filter(|_| self.meta_of_rig) {
            if !frames.is_empty() && !meta.runs.contains(&run) {
                meta.runs.push(run.clone());
            }
        }
        for f in frames {
            self.frame(&run, f);
        }
        self.scratch.run = run;
        Ok(None)
    }

    /// Hands `frame` of measurement `run` to its replay, or holds it until the replay starts.
    /// Measurements are logged one after another: the first frame of one closes the input of
    /// the others, whose threads then finish while this one is read.
    fn frame(&mut self, run: &str, frame: SensorFrame) {
        if self.current.as_deref() != Some(run) {
            for (name, state) in &mut self.runs {
                if let RunState::Running(w) = state {
                    if *name != run {
                        w.close();
                    }
                }
            }
            self.current = Some(run.to_string());
        }
        match self.state(run) {
            Some(RunState::Running(w)) => w.push(frame),
            Some(RunState::Waiting(q)) => {
                if q.len() >= WAITING_FRAMES {
                    q.pop_front();
                }
                q.push_back(frame);
            }
            None => {}
        }
    }
}

impl Visitor for Stream<'_> {
    fn message(&mut self, m: &Message<'_>) -> Result<Option<String>> {
        self.sequences = None;
        let data = m.data;
        let topic = m.channel.topic.as_str();
        if self.meta.is_none() && (topic == topics::SENSORS || topic == topics::ESTIMATOR_SETTINGS)
        {
            self.metadata_lost()?;
        }
        match topic {
            topics::SENSORS => return self.sensor(m),
            // The first copy that decodes (a log holds two, see `RunLog::write_metadata`).
            topics::METADATA => {
                let meta: RunMetadata = match decode(data) {
                    Ok(v) => v,
                    Err(e) => return Ok(Some(e)),
                };
                match &self.meta_bytes {
                    None if self.meta.is_none() => {
                        self.meta_bytes = Some(data.to_vec());
                        self.adopt(meta)?;
                    }
                    Some(first) if first[..] != *data => {
                        let started = self.meta.as_ref().map_or(0, |m| m.start_unix_ns);
                        return Err(TwoRuns {
                            path: self.path.to_path_buf(),
                            evidence: format!(
                                "two different {} records, of runs started at Unix time {} \
                                 and {} ns",
                                topics::METADATA,
                                started,
                                meta.start_unix_ns
                            ),
                        }
                        .into());
                    }
                    _ => {}
                }
            }
            topics::ESTIMATOR_SETTINGS => {
                let s: EstimatorSettings = match decode(data) {
                    Ok(v) => v,
                    Err(e) => return Ok(Some(e)),
                };
                match self.settings.iter().find(|k| k.run == s.run) {
                    Some(known) if *known != s => {
                        return Err(TwoRuns {
                            path: self.path.to_path_buf(),
                            evidence: format!(
                                "two different {} records of the {} measurement",
                                topics::ESTIMATOR_SETTINGS,
                                s.run
                            ),
                        }
                        .into());
                    }
                    Some(_) => {}
                    None => {
                        self.first_settings(&s);
                        let run = s.run.clone();
                        self.settings.push(s);
                        self.start(&run)?;
                    }
                }
            }
            topics::TARE => match decode(data) {
                Ok(v) => self.tare = Some(v),
                Err(e) => return Ok(Some(e)),
            },
            topics::TRUTH => match decode(data) {
                Ok(v) => self.truth = Some(v),
                Err(e) => return Ok(Some(e)),
            },
            _ => {}
        }
        Ok(None)
    }

    fn sensor_sequences(&mut self) -> Option<(u64, u64)> {
        self.sequences.take()
    }
}

/// What [`reestimate_file`] gives.
#[derive(Clone, Debug)]
pub struct Streamed {
    /// The report.
    pub report: Report,
    /// The loaded measurement's replay.
    pub loaded: RunEstimate,
    /// The tare subtracted.
    pub tare: TareFile,
    /// Where it came from.
    pub tare_origin: TareOrigin,
    /// What the log lost.
    pub damage: Damage,
    /// Every channel met.
    pub channels: Channels,
}

fn require(channels: &Channels, topic: &str, needed_for: &str) -> Result<()> {
    if channels.get(topic).is_some_and(|c| c.count > 0) {
        Ok(())
    } else {
        bail!("the log lacks channel {topic}, needed for {needed_for}")
    }
}

/// [`super::reestimate`] on the log at `path`, streamed: the same report, in memory bounded
/// whatever the log's length.
pub fn reestimate_file(
    path: &Path,
    o: &SettingsOverride,
    tare_path: Option<&Path>,
    rig: Option<&LoadedConfig>,
) -> Result<Streamed> {
    let wanted = if tare_path.is_some() {
        vec!["loaded"]
    } else {
        vec!["tare", "loaded"]
    };
    let mut s = Stream::new(path, o, rig, wanted);
    let (channels, damage) = stream_file(path, &mut s)?;
    let outcome = finish_stream(&mut s, &channels, &damage, path, tare_path);
    let (report, loaded, tare, origin) = said_damaged(outcome, &damage, path)?;
    Ok(Streamed {
        report,
        loaded,
        tare,
        tare_origin: origin,
        damage,
        channels,
    })
}

/// `outcome`, an error of it with what the damage took when the log is damaged.
fn said_damaged<T>(outcome: Result<T>, damage: &Damage, path: &Path) -> Result<T> {
    match outcome {
        Err(e) if !damage.is_clean() => {
            let lines = damage.warnings(path);
            Err(e.context(format!(
                "the log is damaged or cut short: {}",
                lines.join("; ")
            )))
        }
        other => other,
    }
}

/// Streams the log at `path` through `s`.
fn stream_file(path: &Path, s: &mut Stream<'_>) -> Result<(Channels, Damage)> {
    let file = runlog::read::open_log(path)?;
    visit(std::io::BufReader::with_capacity(1 << 16, file), s).map_err(|e| {
        // A flag the log's measurement cannot take is the flag's fault, not the log's; a log
        // of two runs is readable, and refused for what it holds.
        if super::is_flag_refusal(&e) || is_two_runs(&e) {
            e
        } else {
            e.context(format!("{} is not a readable MCAP log", path.display()))
        }
    })
}

/// The tare run of a log re-estimated, as a tare file to save ([`super::saved_tare`]).
#[derive(Clone, Debug)]
pub struct StreamedTare {
    /// The tare file.
    pub tare: TareFile,
    /// The tare run's replay.
    pub run: RunEstimate,
    /// The log plans a loaded run too (`/run/metadata`'s `runs`; with that metadata lost,
    /// the log holds frames of one).
    pub has_loaded: bool,
    /// What the log lost.
    pub damage: Damage,
}

/// The tare run of the log at `path` re-estimated with `o` and the rig description `rig` (the
/// log's when `None`), streamed; its loaded run, if any, is not replayed (`stewart estimate
/// --save-tare`).
pub fn tare_of_file(
    path: &Path,
    o: &SettingsOverride,
    rig: Option<&LoadedConfig>,
) -> Result<StreamedTare> {
    let mut s = Stream::new(path, o, rig, vec!["tare"]);
    let (_, damage) = stream_file(path, &mut s)?;
    let outcome = (|| {
        let meta = s.meta.as_ref().ok_or_else(no_metadata)?;
        let rig = s.rig.as_ref().ok_or_else(no_metadata)?;
        let worker = match s.runs.pop() {
            Some((_, RunState::Running(w))) if w.frames > 0 => w,
            _ => bail!(
                "the log has no tare run ({} frames and {} settings of the tare measurement): \
                 there is no tare to save",
                topics::SENSORS,
                topics::ESTIMATOR_SETTINGS
            ),
        };
        let run =
            estimated(worker.finish()?, "tare", path).context("re-estimating the tare run")?;
        Ok(StreamedTare {
            tare: super::saved_tare(&run, meta, rig),
            run,
            has_loaded: meta.runs.iter().any(|r| r == "loaded"),
            damage: damage.clone(),
        })
    })();
    said_damaged(outcome, &damage, path)
}

impl<'a> Stream<'a> {
    fn new(
        path: &'a Path,
        o: &'a SettingsOverride,
        rig: Option<&'a LoadedConfig>,
        wanted: Vec<&'static str>,
    ) -> Self {
        Self {
            path,
            o,
            rig_arg: rig,
            wanted,
            meta: None,
            meta_bytes: None,
            recovered: Vec::new(),
            meta_of_rig: false,
            rig: None,
            settings: Vec::new(),
            tare: None,
            truth: None,
            runs: Vec::new(),
            sequences: None,
            scratch: proto::SensorBlock::default(),
            current: None,
        }
    }
}

/// The estimate of measurement `run` from its finished replay, with what its frames' order
/// showed; refused as [`TwoRuns`] when frames of one sequence number differ.
fn estimated(r: Replayed, run: &str, path: &Path) -> Result<RunEstimate> {
    let c = r.order.counts;
    if let (true, Some(first)) = (c.conflicts > 0, c.first_conflict) {
        return Err(TwoRuns {
            path: path.to_path_buf(),
            evidence: format!(
                "{} frames of the {run} measurement carry a sequence number already read with \
                 other readings, the first {first}",
                c.conflicts
            ),
        }
        .into());
    }
    if r.late > 0 {
        bail!(
            "{} of its {} frames came after the next measurement's began: the log \
             interleaves its measurements, which are read one after another",
            r.late,
            r.frames + r.late
        );
    }
    let mut e = run_estimate(r.finished, run)?;
    e.order = r.order;
    Ok(e)
}

/// The tare and loaded replays finished and the report built, once the log is read.
fn finish_stream(
    s: &mut Stream<'_>,
    channels: &Channels,
    damage: &Damage,
    path: &Path,
    tare_path: Option<&Path>,
) -> Result<(Report, RunEstimate, TareFile, TareOrigin)> {
    let meta = s.meta.as_ref().ok_or_else(no_metadata)?;
    let rig = s.rig.as_ref().ok_or_else(no_metadata)?;
    require(
        channels,
        topics::SENSORS,
        "the sensor frames the estimator reads",
    )?;
    require(
        channels,
        topics::ESTIMATOR_SETTINGS,
        "the estimator's settings (stewart.EstimatorSettings)",
    )?;
    let mut take = |run: &str| {
        s.runs
            .iter()
            .position(|(r, _)| *r == run)
            .map(|i| s.runs.swap_remove(i).1)
    };
    let tare_state = take("tare");
    let loaded_state = take("loaded");
    let (tare, origin) = if let Some(p) = tare_path {
        tare_file(p, meta)?
    } else {
        match tare_state {
            Some(RunState::Running(w)) if w.frames > 0 => {
                let r =
                    estimated(w.finish()?, "tare", path).context("re-estimating the tare run")?;
                measured_tare(r, meta)
            }
            _ => logged_tare(s.tare.as_ref(), meta)?,
        }
    };
    let loaded = match loaded_state {
        Some(RunState::Running(w)) => w.finish().and_then(|r| estimated(r, "loaded", path)),
        _ if s.settings.iter().all(|k| k.run != "loaded") && !damage.damaged.is_empty() => {
            Err(anyhow!(
                "the log has no readable {} message for the loaded measurement: every copy was \
                 lost with the damaged parts of the log, or its excitation never started",
                topics::ESTIMATOR_SETTINGS
            ))
        }
        _ if s.settings.iter().all(|k| k.run != "loaded") => Err(no_settings("loaded")),
        _ => Err(anyhow!(
            "the log has no {} frames of the loaded measurement from its excitation on",
            topics::SENSORS
        )),
    }
    .context("re-estimating the loaded run")?;
    let facts = LogFacts {
        meta,
        truth: s.truth.as_ref(),
        path,
        damage,
    };
    let mut report = build_report(&facts, rig, &loaded, &tare, &origin)?;
    report.data.recovered = s.recovered.clone();
    Ok((report, loaded, tare, origin))
}
