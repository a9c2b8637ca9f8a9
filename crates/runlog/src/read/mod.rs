//! Reading a run's MCAP log back: every channel's schema, encoding, count and time span, and the
//! messages that `stewart estimate` and the figures need, decoded into owned records.
//!
//! A damaged or cut log still opens and loses only what is damaged ([`scan`]): a chunk that
//! fails its checks is skipped and reading resumes at the next good one; a message that does
//! not match its schema is skipped and counted. [`LogContents::damaged`] lists every region
//! lost (its time span and the `/sensors` frames it held, counted by their sequence numbers),
//! [`LogContents::truncated`] says whether and where the file was cut short (the writer emits a
//! chunk only when it is complete, see [`crate::mcap_log`], so a crash loses the chunk being
//! written).
//!
//! The file is read in a single pass, one record at a time: [`visit`] hands each message to a
//! caller that keeps only what it needs, so memory does not grow with the log's length;
//! [`LogContents::read`] keeps every record of the channels it knows.

pub mod order;
pub mod records;
/// The damage-tolerant MCAP reader under this one (crate `mcap-scan`).
pub use mcap_scan as scan;

use std::collections::BTreeMap;
use std::io::{BufReader, Read, Seek};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::Deserialize;

use crate::messages as topics;
use crate::metadata::{EstimatorSettings, RunMetadata, TruthMsg};
use measure::tare::TareFile;
pub use records::{
    BodyRecord, EstimateRecord, FromProto, LegsRecord, PoseRecord, PoseRecordValue, SensorRecord,
};
pub use scan::{Event, Gap, Message};

/// A log that holds two runs written into one file (two processes logging to one path): its
/// frames mix two measurements, so it is refused rather than estimated or drawn.
#[derive(Debug, thiserror::Error)]
#[error(
    "{} holds two runs written into one file ({evidence}): neither run's record is whole, so \
     it is not estimated; estimate each run from a log of its own, or measure again",
    path.display()
)]
pub struct TwoRuns {
    /// The log.
    pub path: PathBuf,
    /// What shows it.
    pub evidence: String,
}

/// Whether `e` is, or was caused by, [`TwoRuns`].
pub fn is_two_runs(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| cause.is::<TwoRuns>())
}

/// What the log holds on one channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelInfo {
    /// Topic.
    pub topic: String,
    /// Schema name (empty when the channel has no schema).
    pub schema_name: String,
    /// Schema encoding (`jsonschema` or `protobuf`).
    pub schema_encoding: String,
    /// The schema document's text (a binary protobuf descriptor set, read lossily as UTF-8).
    pub schema_text: String,
    /// Message encoding (`json` or `protobuf`).
    pub message_encoding: String,
    /// Messages read.
    pub count: u64,
    /// First and last log time, ns.
    pub first_ns: u64,
    /// Last log time, ns.
    pub last_ns: u64,
    /// Log times never went backwards on this channel.
    pub monotonic: bool,
}

/// A region of the log that was lost, with what it held.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Loss {
    /// Where it lies in the file, why it was lost, and the log times around it.
    pub gap: Gap,
    /// `/sensors` frames lost in it, from the sequence numbers of the frames either side
    /// (`None`: no frame follows it to count from).
    pub sensor_frames: Option<u64>,
    /// The sequence number of the first of those frames (`None` when none was lost or none
    /// follows): the loss holds frames `first ..= first + sensor_frames − 1`.
    pub first_lost_sequence: Option<u64>,
}

impl Loss {
    /// The lost time span, s from `origin_ns` (the log's first message): (after, before).
    pub fn span_s(&self, origin_ns: u64) -> (Option<f64>, Option<f64>) {
        let s = |ns: u64| ns.saturating_sub(origin_ns) as f64 * 1e-9;
        (self.gap.after_ns.map(s), self.gap.before_ns.map(s))
    }

    /// The sequence numbers of the `/sensors` frames it lost, first and last, when known.
    pub fn lost_sequences(&self) -> Option<(u64, u64)> {
        let first = self.first_lost_sequence?;
        let n = self.sensor_frames.filter(|&n| n > 0)?;
        Some((first, first.saturating_add(n - 1)))
    }

    /// In words, times in s from `origin_ns`.
    pub fn describe(&self, origin_ns: u64) -> String {
        let (a, b) = self.span_s(origin_ns);
        let t = |v: Option<f64>| v.map_or("?".to_string(), |v| format!("{v:.3} s"));
        let frames = self
            .sensor_frames
            .map_or("an unknown number of".to_string(), |n| n.to_string());
        let what = if self.gap.messages > 0 {
            format!("{} messages", self.gap.messages)
        } else {
            format!("{} bytes at byte {}", self.gap.bytes, self.gap.offset)
        };
        let which = self
            .lost_sequences()
            .map_or(String::new(), |(first, last)| {
                format!(" (sequence {first} to {last})")
            });
        format!(
            "{what} lost ({}): messages between {} and {} of the log, {frames} /sensors \
             frames{which}",
            self.gap.reason,
            t(a),
            t(b)
        )
    }
}

/// Counts the `/sensors` frames each [`Gap`] lost, from the frames' sequence numbers either side.
#[derive(Clone, Debug, Default)]
pub struct LossCounter {
    losses: Vec<Loss>,
    /// Losses waiting for the next frame.
    open: usize,
    last_sequence: Option<u64>,
}

impl LossCounter {
    /// A region lost.
    pub fn gap(&mut self, gap: &Gap) {
        self.losses.push(Loss {
            gap: gap.clone(),
            sensor_frames: None,
            first_lost_sequence: None,
        });
        self.open += 1;
    }

    /// A `/sensors` frame read, with its sequence number.
    pub fn sensor(&mut self, sequence: u64) {
        if self.open > 0 {
            let lost = self
                .last_sequence
                .map_or(sequence, |l| sequence.saturating_sub(l.saturating_add(1)));
            let first = self.last_sequence.map_or(0, |l| l.saturating_add(1));
            let n = self.losses.len();
            for (k, loss) in self.losses[n - self.open..].iter_mut().enumerate() {
                // A frame that was never there is not lost: the whole count goes to the first.
                loss.sensor_frames = Some(if k == 0 { lost } else { 0 });
                loss.first_lost_sequence = (k == 0 && lost > 0).then_some(first);
            }
            self.open = 0;
        }
        self.last_sequence = Some(sequence);
    }

    /// The losses, with the log times the reader filled in at its end (`gaps`, in file order).
    pub fn finish(mut self, gaps: &[Gap]) -> Vec<Loss> {
        // The reader may add gaps (messages on lost channels) that were never handed out as
        // events: take the final list and keep the frame counts where the gaps match.
        let mut out = Vec::with_capacity(gaps.len());
        let mut mine = std::mem::take(&mut self.losses).into_iter().peekable();
        for g in gaps {
            let (frames, first) = match mine.peek() {
                Some(l) if l.gap.offset == g.offset && l.gap.reason == g.reason => mine
                    .next()
                    .map_or((None, None), |l| (l.sensor_frames, l.first_lost_sequence)),
                _ => (None, None),
            };
            out.push(Loss {
                gap: g.clone(),
                sensor_frames: frames,
                first_lost_sequence: first,
            });
        }
        out
    }
}

/// How reading a log ended: whether it was cut short, what was lost, what was skipped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Damage {
    /// Why reading stopped before the end of a complete file (a log cut short), if it did.
    pub truncated: Option<String>,
    /// Every region lost to damage, in file order (empty for an intact log).
    pub damaged: Vec<Loss>,
    /// Messages that did not match their schema, skipped.
    pub skipped_messages: u64,
    /// The first such message's error.
    pub first_skipped: Option<String>,
    /// Log time of the log's first message, ns (the origin of the spans' seconds).
    pub first_ns: u64,
}

impl Damage {
    /// True when nothing was lost or skipped and the file is whole.
    pub fn is_clean(&self) -> bool {
        self.truncated.is_none() && self.damaged.is_empty() && self.skipped_messages == 0
    }

    /// The `/sensors` frames lost to damage (counted where frames follow the damage).
    pub fn sensor_frames_lost(&self) -> u64 {
        self.damaged.iter().filter_map(|l| l.sensor_frames).sum()
    }

    /// The lost spans for a report.
    pub fn lost_spans(&self) -> Vec<measure::report::LostSpan> {
        self.damaged
            .iter()
            .map(|l| {
                let (from_s, to_s) = l.span_s(self.first_ns);
                measure::report::LostSpan {
                    from_s,
                    to_s,
                    sensor_frames: l.sensor_frames,
                    reason: l.gap.reason.clone(),
                }
            })
            .collect()
    }

    /// Warnings for the terminal, one a line (none for an intact log).
    pub fn warnings(&self, path: &Path) -> Vec<String> {
        let mut w = Vec::new();
        if let Some(why) = &self.truncated {
            w.push(format!(
                "{} was cut short ({why}); the messages before that are used",
                path.display()
            ));
        }
        for l in &self.damaged {
            w.push(format!(
                "{} is damaged: {}",
                path.display(),
                l.describe(self.first_ns)
            ));
        }
        if self.skipped_messages > 0 {
            w.push(format!(
                "{}: {} messages do not match their schema and were skipped (first: {})",
                path.display(),
                self.skipped_messages,
                self.first_skipped.as_deref().unwrap_or("?")
            ));
        }
        w
    }
}

/// What a caller of [`visit`] is handed, in file order.
pub trait Visitor {
    /// A message; `Err` stops the reading. A message the visitor cannot decode is returned as
    /// `Ok(Some(error))`: it is skipped and counted.
    fn message(&mut self, m: &Message<'_>) -> Result<Option<String>>;
    /// The first and last sequence numbers of the `/sensors` frames of the message just
    /// decoded, when it held any (counts losses).
    fn sensor_sequences(&mut self) -> Option<(u64, u64)> {
        None
    }
}

/// Every channel met, by topic, with counts and time spans.
pub type Channels = BTreeMap<String, ChannelInfo>;

/// Reads the log in `src` in one pass, handing each message to `v`; returns the channels met
/// and the damage. Errors: the source is not an MCAP log or cannot be read, or `v` failed.
pub fn visit<R: Read + Seek>(src: R, v: &mut dyn Visitor) -> Result<(Channels, Damage)> {
    let mut channels = Channels::new();
    let mut counter = LossCounter::default();
    let mut damage = Damage::default();
    let mut first_ns = None;
    let end = scan::scan(src, &mut |e| {
        match e {
            Event::Gap(g) => counter.gap(g),
            Event::Message(m) => {
                first_ns.get_or_insert(m.log_time_ns);
                let info = channels
                    .entry(m.channel.topic.clone())
                    .or_insert_with(|| ChannelInfo {
                        topic: m.channel.topic.clone(),
                        schema_name: m.channel.schema_name.clone(),
                        schema_encoding: m.channel.schema_encoding.clone(),
                        schema_text: m.channel.schema_text.clone(),
                        message_encoding: m.channel.message_encoding.clone(),
                        count: 0,
                        first_ns: m.log_time_ns,
                        last_ns: m.log_time_ns,
                        monotonic: true,
                    });
                if m.log_time_ns < info.last_ns {
                    info.monotonic = false;
                }
                info.last_ns = m.log_time_ns;
                info.count += 1;
                let index = info.count;
                if let Some(err) = v.message(&m)? {
                    damage.skipped_messages += 1;
                    damage.first_skipped.get_or_insert_with(|| {
                        format!("message {index} on {}: {err}", m.channel.topic)
                    });
                } else if let Some((first, last)) = v.sensor_sequences() {
                    counter.sensor(first);
                    counter.sensor(last);
                }
            }
        }
        Ok(())
    })?;
    damage.truncated = end.truncated;
    damage.damaged = counter.finish(&end.gaps);
    damage.first_ns = first_ns.unwrap_or(0);
    Ok((channels, damage))
}

/// Decodes one JSON message, the error in words.
pub fn decode<T: for<'de> Deserialize<'de>>(data: &[u8]) -> std::result::Result<T, String> {
    serde_json::from_slice(data).map_err(|e| format!("does not match its schema ({e})"))
}

/// Decodes one message of a channel that is protobuf in this writer's logs and JSON in older
/// ones, by the channel's message encoding; the error in words.
pub fn decode_record<T>(m: &Message<'_>) -> std::result::Result<T, String>
where
    T: FromProto + for<'de> Deserialize<'de>,
{
    match m.channel.message_encoding.as_str() {
        "protobuf" => <T::Proto as prost::Message>::decode(m.data)
            .map_err(|e| format!("does not match its schema ({e})"))
            .and_then(T::from_proto),
        "json" => decode(m.data),
        other => Err(format!(
            "has message encoding {other:?}, not json or protobuf"
        )),
    }
}

/// Everything read from a log.
#[derive(Clone, Debug, Default)]
pub struct LogContents {
    /// The file.
    pub path: PathBuf,
    /// Every channel met, by topic.
    pub channels: Channels,
    /// Why reading stopped before the end of a complete file (a log cut short), if it did.
    pub truncated: Option<String>,
    /// What was lost to damage or skipped (and `truncated` again, with the lost spans).
    pub damaged: Damage,
    /// `/run/metadata`.
    pub metadata: Option<RunMetadata>,
    /// `/run/estimator`, one per measurement that reached its excitation.
    pub settings: Vec<EstimatorSettings>,
    /// `/run/tare` (the last one).
    pub tare: Option<TareFile>,
    /// `/run/truth`.
    pub truth: Option<TruthMsg>,
    /// `/sensors`, in log order.
    pub sensors: Vec<SensorRecord>,
    /// `/estimate`.
    pub estimates: Vec<EstimateRecord>,
    /// `/legs`.
    pub legs: Vec<LegsRecord>,
    /// `/pose`.
    pub poses: Vec<PoseRecord>,
}

/// Keeps every record of the channels [`LogContents`] holds.
struct Collect<'a> {
    log: &'a mut LogContents,
    scratch: crate::proto::SensorBlock,
    sensor: Option<(u64, u64)>,
    /// The first `/run/metadata` record as written: a different one is another run's.
    metadata_bytes: Option<Vec<u8>>,
    /// The log's path, for [`TwoRuns`].
    path: &'a Path,
}

impl Collect<'_> {
    /// Keeps the first `/run/metadata` record; a second that differs is another run's.
    fn metadata(&mut self, data: &[u8]) -> Result<Option<String>> {
        let meta: RunMetadata = match decode(data) {
            Ok(v) => v,
            Err(e) => return Ok(Some(e)),
        };
        match (&self.metadata_bytes, &self.log.metadata) {
            (Some(first), Some(known)) if first[..] != *data => Err(TwoRuns {
                path: self.path.to_path_buf(),
                evidence: format!(
                    "two different {} records, of runs started at Unix time {} and {} ns",
                    topics::METADATA,
                    known.start_unix_ns,
                    meta.start_unix_ns
                ),
            }
            .into()),
            (None, _) => {
                self.metadata_bytes = Some(data.to_vec());
                self.log.metadata = Some(meta);
                Ok(None)
            }
            _ => Ok(None),
        }
    }

    /// Keeps a run's estimator settings (repeated through the run); a copy that differs from
    /// the run's first is another run's.
    fn settings(&mut self, data: &[u8]) -> Result<Option<String>> {
        let s: EstimatorSettings = match decode(data) {
            Ok(v) => v,
            Err(e) => return Ok(Some(e)),
        };
        match self.log.settings.iter().find(|k| k.run == s.run) {
            Some(known) if *known != s => Err(TwoRuns {
                path: self.path.to_path_buf(),
                evidence: format!(
                    "two different {} records of the {} measurement",
                    topics::ESTIMATOR_SETTINGS,
                    s.run
                ),
            }
            .into()),
            Some(_) => Ok(None),
            None => {
                self.log.settings.push(s);
                Ok(None)
            }
        }
    }
}

/// The sensor frames of a `/sensors` message and its measurement; a message that does not fit
/// its schema is `Ok(Err(why))` (skipped and counted), a channel in an encoding this version
/// does not read is an error.
pub fn sensor_block(
    m: &Message<'_>,
    scratch: &mut crate::proto::SensorBlock,
) -> Result<std::result::Result<Vec<control::io::SensorFrame>, String>> {
    let c = &m.channel;
    if c.message_encoding != "protobuf" || c.schema_name != SENSOR_SCHEMA {
        bail!(
            "the log's {} channel is {} in {} encoding, which this version does not read (it \
             reads {SENSOR_SCHEMA} in protobuf; a log written by an older or newer version of \
             stewart needs that version)",
            c.topic,
            if c.schema_name.is_empty() {
                "unnamed"
            } else {
                c.schema_name.as_str()
            },
            c.message_encoding
        );
    }
    prost::Message::clear(scratch);
    if let Err(e) = prost::Message::merge(&mut *scratch, m.data) {
        return Ok(Err(format!("does not match its schema ({e})")));
    }
    Ok(crate::compact::sensor_frames(scratch))
}

/// The schema of `/sensors` this version reads.
pub const SENSOR_SCHEMA: &str = "stewart.SensorBlock";

/// Whether two frames read the same (NaN equal to NaN: a missing reading is one too).
fn same_readings(a: &SensorRecord, b: &SensorRecord) -> bool {
    let same = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()))
    };
    a.time_s.to_bits() == b.time_s.to_bits()
        && same(&a.leg_lengths_m, &b.leg_lengths_m)
        && same(&a.leg_forces_n, &b.leg_forces_n)
        && same(&a.gyro_rad_s, &b.gyro_rad_s)
        && same(&a.accel_m_s2, &b.accel_m_s2)
        && a.status == b.status
}

fn keep<T: for<'de> Deserialize<'de>>(into: &mut Vec<T>, data: &[u8]) -> Option<String> {
    decode(data).map(|r| into.push(r)).err()
}

fn keep_record<T: FromProto + for<'de> Deserialize<'de>>(
    into: &mut Vec<T>,
    m: &Message<'_>,
) -> Option<String> {
    decode_record(m).map(|r| into.push(r)).err()
}

fn set<T: for<'de> Deserialize<'de>>(into: &mut Option<T>, data: &[u8]) -> Option<String> {
    decode(data).map(|r| *into = Some(r)).err()
}

impl Visitor for Collect<'_> {
    fn message(&mut self, m: &Message<'_>) -> Result<Option<String>> {
        let log = &mut *self.log;
        let data = m.data;
        self.sensor = None;
        Ok(match m.channel.topic.as_str() {
            topics::SENSORS => match sensor_block(m, &mut self.scratch)? {
                Ok(frames) => {
                    if let (Some(a), Some(b)) = (frames.first(), frames.last()) {
                        self.sensor = Some((a.sequence, b.sequence));
                    }
                    let run = &self.scratch.run;
                    log.sensors
                        .extend(frames.iter().map(|f| SensorRecord::of_frame(run, f)));
                    None
                }
                Err(e) => Some(e),
            },
            topics::ESTIMATE => keep(&mut log.estimates, data),
            topics::LEGS => keep_record(&mut log.legs, m),
            topics::POSE => keep_record(&mut log.poses, m),
            // A log holds two copies of its metadata (`RunLog::write_metadata`) and repeats
            // each run's settings: the first that decodes is kept, and one that differs is
            // another run's.
            topics::METADATA => return self.metadata(data),
            topics::ESTIMATOR_SETTINGS => return self.settings(data),
            topics::TARE => set(&mut log.tare, data),
            topics::TRUTH => set(&mut log.truth, data),
            _ => None,
        })
    }

    fn sensor_sequences(&mut self) -> Option<(u64, u64)> {
        self.sensor.take()
    }
}

/// Opens the log at `path` for reading; a directory is refused as one (opened, it would read
/// as a file that lacks the MCAP magic), naming what to give instead.
pub fn open_log(path: &Path) -> Result<std::fs::File> {
    if path.is_dir() {
        anyhow::bail!(
            "{} is a directory, not an MCAP log: name a log file in it (e.g. {})",
            path.display(),
            path.join("<UTC time>.mcap").display()
        );
    }
    std::fs::File::open(path).with_context(|| format!("cannot read the log {}", path.display()))
}

impl LogContents {
    /// Reads `path`; a damaged or cut log gives what is intact (see [`Self::damaged`]).
    pub fn read(path: &Path) -> Result<Self> {
        let file = open_log(path)?;
        let mut log =
            Self::from_source(BufReader::with_capacity(1 << 16, file), path).map_err(|e| {
                // A log of two runs is readable, and refused for what it holds.
                if is_two_runs(&e) {
                    e
                } else {
                    e.context(format!("{} is not a readable MCAP log", path.display()))
                }
            })?;
        log.path = path.to_path_buf();
        Ok(log)
    }

    /// Reads a log held in memory.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        Self::from_source(std::io::Cursor::new(bytes), Path::new("the log in memory"))
    }

    fn from_source<R: Read + Seek>(src: R, path: &Path) -> Result<Self> {
        let mut log = Self::default();
        let (channels, damage) = visit(
            src,
            &mut Collect {
                log: &mut log,
                sensor: None,
                scratch: crate::proto::SensorBlock::default(),
                metadata_bytes: None,
                path,
            },
        )?;
        log.channels = channels;
        log.truncated = damage.truncated.clone();
        log.damaged = damage;
        log.refuse_conflicting_frames(path)?;
        Ok(log)
    }

    /// Refuses the log as [`TwoRuns`] when two frames of one measurement carry one sequence
    /// number with different readings (frames written twice, identical, are one frame read
    /// twice: [`order`] drops them).
    fn refuse_conflicting_frames(&self, path: &Path) -> Result<()> {
        let mut index: Vec<usize> = (0..self.sensors.len()).collect();
        index.sort_by(|&a, &b| {
            let (a, b) = (&self.sensors[a], &self.sensors[b]);
            (&a.run, a.sequence).cmp(&(&b.run, b.sequence))
        });
        let conflicting: Vec<&SensorRecord> = index
            .windows(2)
            .map(|w| (&self.sensors[w[0]], &self.sensors[w[1]]))
            .filter(|(a, b)| a.run == b.run && a.sequence == b.sequence && !same_readings(a, b))
            .map(|(a, _)| a)
            .collect();
        let Some(first) = conflicting.first() else {
            return Ok(());
        };
        let (conflicts, first) = (
            conflicting.len(),
            format!("{} frame {}", first.run, first.sequence),
        );
        Err(TwoRuns {
            path: path.to_path_buf(),
            evidence: format!(
                "{conflicts} sensor frame(s) whose sequence number another frame carries with \
                 other readings, the first {first}"
            ),
        }
        .into())
    }

    /// The run metadata, or an error naming its channel.
    pub fn require_metadata(&self) -> Result<&RunMetadata> {
        self.metadata.as_ref().ok_or_else(no_metadata)
    }

    /// Takes the metadata from the rig description `rig` when every copy of the log's was lost
    /// ([`RunMetadata::of_rig`]), its `runs` the measurements whose frames the log holds
    /// ([`Self::runs`]); a log whose metadata was read keeps it.
    pub fn or_metadata_of(&mut self, rig: Option<&rig_description::LoadedConfig>) -> Result<()> {
        if let (None, Some(rig)) = (&self.metadata, rig) {
            self.metadata = Some(RunMetadata {
                runs: self.runs(),
                ..RunMetadata::of_rig(rig)?
            });
        }
        Ok(())
    }

    /// Refuses the log when `topic` has no message, naming the channel and what it is for.
    pub fn require_channel(&self, topic: &str, needed_for: &str) -> Result<()> {
        if self.channels.get(topic).is_some_and(|c| c.count > 0) {
            Ok(())
        } else {
            bail!("the log lacks channel {topic}, needed for {needed_for}")
        }
    }

    /// The sensor frames of measurement `run`, in order.
    pub fn sensors_of<'a>(&'a self, run: &'a str) -> impl Iterator<Item = &'a SensorRecord> + 'a {
        self.sensors.iter().filter(move |s| s.run == run)
    }

    /// The estimator settings logged for measurement `run`.
    pub fn settings_of(&self, run: &str) -> Option<&EstimatorSettings> {
        self.settings.iter().find(|s| s.run == run)
    }

    /// Measurements present in the sensor data, in order of appearance.
    pub fn runs(&self) -> Vec<String> {
        let mut runs: Vec<String> = Vec::new();
        for s in &self.sensors {
            if !runs.contains(&s.run) {
                runs.push(s.run.clone());
            }
        }
        runs
    }

    /// The platform design recorded in the metadata.
    pub fn geometry(&self) -> Result<kinematics::Geometry> {
        geometry_of(self.require_metadata()?)
    }
}

/// The platform design recorded in a log's metadata.
pub fn geometry_of(m: &RunMetadata) -> Result<kinematics::Geometry> {
    let v = |p: &[f64; 3]| nalgebra::Vector3::new(p[0], p[1], p[2]);
    let g = kinematics::Geometry::from_points(
        m.base_joints_m.each_ref().map(v),
        m.plate_joints_m.each_ref().map(v),
        kinematics::StrokeLimits {
            min_length_m: m.stroke_m[0],
            max_length_m: m.stroke_m[1],
        },
    );
    match m.home_height_m {
        Some(z) => g.and_then(|g| g.with_home_height_m(z)),
        None => g,
    }
    .map_err(|e| anyhow::anyhow!("the log's platform design is refused: {e}"))
}

/// The message that says a log lacks its metadata, and the way out.
pub fn no_metadata() -> anyhow::Error {
    anyhow::anyhow!(
        "the log has no readable stewart.RunMetadata message (channel {}: every copy missing or \
         damaged), so it does not say which platform was run; give its rig description with \
         --rig FILE",
        topics::METADATA
    )
}

#[cfg(test)]
mod tests;
