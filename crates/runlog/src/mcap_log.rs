//! The MCAP log writer: JSON messages with JSON schemas and protobuf messages with their
//! `FileDescriptorSet` ([`Encoding`]), chunked and compressed, streamed as the
//! run goes so that a crash loses at most the chunk being written and the messages still
//! queued, and finished (summary, footer) on every normal or interrupted end.
//!
//! **A writer thread.** The caller only serializes a message (JSON or protobuf), into a batch of up to
//! [`BATCH_MESSAGES`] messages (recycled buffers, so no allocation once warm), and queues full
//! batches; a thread of its own frames them into MCAP chunks, compresses them and writes the
//! file. So compression and disk writes (and a disk that stalls) stay off the caller's thread:
//! the run loop, and on a rig the control loop. (Batches, not single messages: waking the
//! writer for each of a run's 250 000 messages cost more CPU than the compression it moved.)
//! The queue is bounded ([`QUEUE_BATCHES`]). With [`Delivery::Lossless`] (`simulate`) a full
//! queue makes the caller wait for the writer; with [`Delivery::DropWhenFull`] (`rig`) the
//! batch is dropped and its messages counted ([`McapLog::dropped`]), so a slow disk never
//! stalls the control loop. Dropped messages leave gaps in the MCAP sequence numbers.
//!
//! **A tap** ([`McapLog::create_tapped`], the live view) is served from the writer thread
//! too: it hands each message of a batch to [`Tap::message`] before writing the batch, so the
//! caller's thread never calls into it (see [`crate::tap`] for the threads and the pace).
//!
//! **Integrity.** Every chunk carries the CRC-32 of its records (`uncompressed_crc`, the mcap
//! crate's default, checked by [`crate::read`]), so a damaged chunk is recognised and skipped.
//!
//! **Compression.** zstd at level 3, single-threaded on the writer thread (a pool of zstd
//! worker threads cost more CPU than it saved). On the default run's log, whose 1 kHz channels
//! are compact blocks of counts ([`crate::compact`]), level 3 gives 12.45 MB against 12.77 MB
//! at level 1 and 12.35 MB at level 6, for no measurable CPU against level 1 and 0.1 s more at
//! level 6 (docs/performance.md, "The log's size").

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use anyhow::{anyhow, Context, Result};
use serde::Serialize;

use crate::proto::{Encode, Encoder};
use crate::tap::{Pace, Tap};

pub use crate::channel::{well_known_schema, ChannelSpec, Encoding};

/// A registered channel.
#[derive(Clone, Copy, Debug)]
struct Registered {
    id: u16,
    encoding: Encoding,
    schema_name: &'static str,
}

/// Target uncompressed chunk size: about a second of a 1 kHz run's compact log, so that a crash
/// or a damaged chunk loses about a second; 512 KiB would hold three seconds and save 1 % of
/// the file.
pub const CHUNK_SIZE_BYTES: u64 = 160 * 1024;

/// zstd level of the chunks (see the module docs for the measurements behind it).
pub const ZSTD_LEVEL: u32 = 3;

/// Messages per batch handed to the writer thread: about 0.1 s of a 1 kHz run's log (about 580
/// messages a second: `/sensors` and `/commands` ten frames a message). Batches of 16 cost
/// `simulate` 0.05 s more CPU (1.46 against 1.40 s, median of 5).
pub const BATCH_MESSAGES: usize = 64;

/// Batches the queue to the writer thread holds: about 28 s of a 1 kHz run's log, a few MB.
pub const QUEUE_BATCHES: usize = 256;

/// With a tap (the live view), a batch goes to the writer (and so to the view) once its messages span
/// this much log time, ns, even with fewer than [`BATCH_MESSAGES`]: the view is at most 40 ms
/// behind the log and moves 25 times a second, where batches of 64 messages (about 0.11 s)
/// would move it 9 times a second.
pub const LIVE_BATCH_SPAN_NS: u64 = 40_000_000;

/// Batches the queue holds with a tap: [`QUEUE_BATCHES`] times the ratio of a full
/// batch's span to [`LIVE_BATCH_SPAN_NS`] (0.11 s / 0.04 s), so that the queue holds as many
/// seconds of log (about 28 s) as without one before [`Delivery::DropWhenFull`] drops.
pub const QUEUE_BATCHES_LIVE: usize = 3 * QUEUE_BATCHES;

/// What [`McapLog::write`] does when the writer thread falls behind and its queue is full.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Delivery {
    /// Wait for the writer: every message reaches the file.
    #[default]
    Lossless,
    /// Drop the message and count it: the caller never waits for the disk (a control loop).
    DropWhenFull,
}

/// Where one message of a [`Batch`] lies.
#[derive(Clone, Copy, Debug)]
struct Entry {
    channel_id: u16,
    sequence: u32,
    log_time_ns: u64,
    end: usize,
}

/// Messages serialized back to back.
#[derive(Debug, Default)]
struct Batch {
    entries: Vec<Entry>,
    data: Vec<u8>,
}

impl Batch {
    fn clear(&mut self) {
        self.entries.clear();
        self.data.clear();
    }
}

/// The tap as the writer thread holds it: the tap and each channel's topic.
struct Forward {
    tap: Box<dyn Tap>,
    topics: HashMap<u16, &'static str>,
}

impl Forward {
    /// Hands every message of `batch` to the tap, with its log time.
    fn batch(&self, batch: &Batch) {
        let mut start = 0;
        for e in &batch.entries {
            if let (Some(topic), Some(bytes)) =
                (self.topics.get(&e.channel_id), batch.data.get(start..e.end))
            {
                self.tap.message(topic, bytes, e.log_time_ns);
            }
            start = e.end;
        }
    }
}

/// Work for the writer thread.
enum Job {
    Messages(Batch),
    Metadata(mcap::records::Metadata),
    /// End the chunk, flush the file, then answer.
    Flush(Sender<()>),
    /// Tests: say so, then stall until released (a disk that blocks).
    #[cfg(test)]
    Stall {
        stalled: Sender<()>,
        release: Receiver<()>,
    },
    /// Tests: fail like a write to a full disk.
    #[cfg(test)]
    Fail,
}

/// An open MCAP log.
pub struct McapLog {
    jobs: Option<SyncSender<Job>>,
    thread: Option<JoinHandle<Result<()>>>,
    /// The batch being filled.
    batch: Batch,
    /// Batches the writer is done with, for the next messages.
    spare: Receiver<Batch>,
    /// The writer's first error, when it failed.
    failure: Arc<Mutex<Option<String>>>,
    failed: Arc<AtomicBool>,
    channels: HashMap<&'static str, Registered>,
    sequence: u32,
    dropped: u64,
    delivery: Delivery,
    path: PathBuf,
    /// The tap's pace, when the log has one (the tap itself is the writer thread's).
    tapped: Option<Pace>,
}

impl McapLog {
    /// Creates `path` (and its parent directory), registers every channel and starts the
    /// writer thread; every message reaches the file ([`Delivery::Lossless`]).
    pub fn create(path: &Path, specs: &[ChannelSpec]) -> Result<Self> {
        Self::create_with(path, specs, Delivery::Lossless)
    }

    /// [`Self::create`] with the given behaviour when the writer falls behind.
    pub fn create_with(path: &Path, specs: &[ChannelSpec], delivery: Delivery) -> Result<Self> {
        Self::create_queued(path, specs, delivery, QUEUE_BATCHES, None)
    }

    /// [`Self::create_with`], and every message written is handed to `tap` as well: the same
    /// bytes at the same log time, handed over by the writer thread (a message dropped for a
    /// full queue is dropped from both). Batches are handed over every
    /// [`LIVE_BATCH_SPAN_NS`] of log time at least, in a queue of [`QUEUE_BATCHES_LIVE`];
    /// with [`Pace::WallClock`] each write waits for its log time ([`Pace::hold`]).
    pub fn create_tapped(
        path: &Path,
        specs: &[ChannelSpec],
        delivery: Delivery,
        tap: Box<dyn Tap>,
    ) -> Result<Self> {
        let pace = tap.pace();
        let forward = Forward {
            tap,
            topics: HashMap::new(),
        };
        let mut log =
            Self::create_queued(path, specs, delivery, QUEUE_BATCHES_LIVE, Some(forward))?;
        log.tapped = Some(pace);
        Ok(log)
    }

    fn create_queued(
        path: &Path,
        specs: &[ChannelSpec],
        delivery: Delivery,
        queue_batches: usize,
        mut forward: Option<Forward>,
    ) -> Result<Self> {
        if let Some(dir) = path.parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir).with_context(|| {
                    format!("cannot create the log directory {}", dir.display())
                })?;
            }
        }
        // Created exclusively: a log is never written over, whoever holds the name (another
        // run in the same second, an older log given again as `--log`).
        let file = match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
        {
            Ok(file) => file,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                return Err(LogExists(path.to_path_buf()).into())
            }
            Err(e) => {
                return Err(anyhow::Error::new(e)
                    .context(format!("cannot create the log file {}", path.display())))
            }
        };
        let options = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("stewart-cli ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(ZSTD_LEVEL)
            .compression_threads(0)
            .chunk_size(Some(CHUNK_SIZE_BYTES));
        let mut writer = options
            .create(BufWriter::with_capacity(1 << 20, file))
            .context("cannot start the MCAP log")?;
        let mut channels = HashMap::new();
        for spec in specs {
            let schema_data = spec.schema_data()?;
            let schema_id = writer.add_schema(
                spec.schema_name,
                spec.encoding.schema_encoding(),
                &schema_data,
            )?;
            let id = writer.add_channel(
                schema_id,
                spec.topic,
                spec.encoding.message_encoding(),
                &std::collections::BTreeMap::new(),
            )?;
            channels.insert(
                spec.topic,
                Registered {
                    id,
                    encoding: spec.encoding,
                    schema_name: spec.schema_name,
                },
            );
            if let Some(f) = forward.as_mut() {
                f.topics.insert(id, spec.topic);
            }
        }
        // The schemas and channels in a chunk of their own (the summary repeats them): a
        // damaged first data chunk then costs its messages, not every channel's definition.
        writer.flush().context("cannot start the MCAP log")?;
        let (jobs, queue) = mpsc::sync_channel(queue_batches);
        let (recycle, spare) = mpsc::channel();
        let failure = Arc::new(Mutex::new(None));
        let failed = Arc::new(AtomicBool::new(false));
        let thread = {
            let failure = Arc::clone(&failure);
            let failed = Arc::clone(&failed);
            let path = path.to_path_buf();
            std::thread::Builder::new()
                .name("mcap-writer".into())
                .spawn(move || {
                    let report = |e: &anyhow::Error| {
                        let mut slot = failure.lock().unwrap_or_else(|p| p.into_inner());
                        slot.get_or_insert_with(|| format!("{e:#}"));
                        failed.store(true, Ordering::SeqCst);
                    };
                    let result =
                        write_jobs(writer, &queue, &recycle, forward.as_ref(), &path, &report);
                    if let Err(e) = &result {
                        report(e);
                    }
                    result
                })
                .context("cannot start the log writer thread")?
        };
        Ok(Self {
            jobs: Some(jobs),
            thread: Some(thread),
            batch: Batch::default(),
            spare,
            failure,
            failed,
            channels,
            sequence: 0,
            dropped: 0,
            delivery,
            path: path.to_path_buf(),
            tapped: None,
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages dropped because the writer's queue was full ([`Delivery::DropWhenFull`]).
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    fn check_writer(&self) -> Result<&SyncSender<Job>> {
        if self.failed.load(Ordering::SeqCst) {
            let slot = self.failure.lock().unwrap_or_else(|p| p.into_inner());
            return Err(anyhow!(
                "the log writer failed: {}",
                slot.as_deref().unwrap_or("unknown error")
            ));
        }
        self.jobs.as_ref().context("the log is already finished")
    }

    /// The channel of `topic`, refused unless it is registered with `encoding`.
    fn channel(&self, topic: &str, encoding: Encoding) -> Result<Registered> {
        let channel = *self
            .channels
            .get(topic)
            .with_context(|| format!("log channel {topic} was not registered"))?;
        if channel.encoding != encoding {
            return Err(anyhow!(
                "log channel {topic} is {}, not {}",
                channel.encoding.message_encoding(),
                encoding.message_encoding()
            ));
        }
        Ok(channel)
    }

    /// Queues `message` as JSON on `topic` at `log_time_ns` (nanoseconds since the Unix epoch).
    /// Errors: an unregistered or non-JSON topic, a message that does not serialize, a finished
    /// or failed log. A message dropped for a full queue is not an error (see [`Self::dropped`]).
    pub fn write<T: Serialize>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        message: &T,
    ) -> Result<()> {
        let channel = self.channel(topic, Encoding::Json)?;
        self.check_writer()?;
        let start = self.batch.data.len();
        if let Err(e) = serde_json::to_writer(&mut self.batch.data, message) {
            self.batch.data.truncate(start);
            return Err(e.into());
        }
        self.queued(channel.id, log_time_ns)
    }

    /// Queues `message` in protobuf on `topic` at `log_time_ns`. Errors: an unregistered or
    /// non-protobuf topic, a channel whose schema is another message, a finished or failed log.
    pub fn write_proto<T: Encode>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        message: &T,
    ) -> Result<()> {
        let channel = self.channel(topic, Encoding::Protobuf)?;
        if channel.schema_name != T::NAME {
            return Err(anyhow!(
                "log channel {topic} carries {}, not {}",
                channel.schema_name,
                T::NAME
            ));
        }
        self.check_writer()?;
        message.encode(&mut Encoder::new(&mut self.batch.data));
        self.queued(channel.id, log_time_ns)
    }

    /// Queues `message`, one of the Foxglove SDK's well-known types, in protobuf on `topic` at
    /// `log_time_ns`. Errors: an unregistered topic or one not of [`Encoding::Foxglove`], a
    /// channel whose schema is another message, a finished or failed log.
    pub fn write_foxglove<T: foxglove::Encode>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        message: &T,
    ) -> Result<()>
    where
        T::Error: Send + Sync + 'static,
    {
        let channel = self.channel(topic, Encoding::Foxglove)?;
        let name = T::get_schema().map(|s| s.name);
        if name.as_deref() != Some(channel.schema_name) {
            return Err(anyhow!(
                "log channel {topic} carries {}, not {}",
                channel.schema_name,
                name.as_deref().unwrap_or("a message without a schema")
            ));
        }
        self.check_writer()?;
        let start = self.batch.data.len();
        if let Err(e) = message.encode(&mut self.batch.data) {
            self.batch.data.truncate(start);
            return Err(e.into());
        }
        self.queued(channel.id, log_time_ns)
    }

    /// Records the message just appended to the batch and hands a full batch to the writer:
    /// [`BATCH_MESSAGES`] messages, or with a tap [`LIVE_BATCH_SPAN_NS`] of log time. With a
    /// tap held to the wall clock, first waits for the message's log time. No call into the
    /// tap here: the writer thread makes them.
    fn queued(&mut self, channel_id: u16, log_time_ns: u64) -> Result<()> {
        let span_full = match self.tapped {
            Some(pace) => {
                pace.hold(log_time_ns);
                self.batch.entries.first().is_some_and(|first| {
                    log_time_ns.saturating_sub(first.log_time_ns) >= LIVE_BATCH_SPAN_NS
                })
            }
            None => false,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.batch.entries.push(Entry {
            channel_id,
            sequence: self.sequence,
            log_time_ns,
            end: self.batch.data.len(),
        });
        if self.batch.entries.len() >= BATCH_MESSAGES || span_full {
            self.send_batch(self.delivery)?;
        }
        Ok(())
    }

    /// Hands the current batch to the writer (waiting or dropping as `delivery` says) and
    /// starts the next one in a recycled buffer.
    fn send_batch(&mut self, delivery: Delivery) -> Result<()> {
        if self.batch.entries.is_empty() {
            return Ok(());
        }
        let mut next = self.spare.try_recv().unwrap_or_default();
        next.clear();
        let batch = std::mem::replace(&mut self.batch, next);
        let jobs = self.check_writer()?;
        match delivery {
            Delivery::Lossless => jobs
                .send(Job::Messages(batch))
                .map_err(|_| anyhow!("the log writer stopped")),
            Delivery::DropWhenFull => match jobs.try_send(Job::Messages(batch)) {
                Ok(()) => Ok(()),
                Err(TrySendError::Full(Job::Messages(mut batch))) => {
                    self.dropped += batch.entries.len() as u64;
                    // Keep the larger buffers for the next batch.
                    batch.clear();
                    self.batch = batch;
                    Ok(())
                }
                Err(_) => Err(anyhow!("the log writer stopped")),
            },
        }
    }

    /// Adds an MCAP metadata record (string key/value pairs), after the messages written so
    /// far; never dropped.
    pub fn metadata(&mut self, name: &str, pairs: &[(&str, String)]) -> Result<()> {
        self.send_batch(Delivery::Lossless)?;
        let job = Job::Metadata(mcap::records::Metadata {
            name: name.into(),
            metadata: pairs
                .iter()
                .map(|(k, v)| ((*k).to_string(), v.clone()))
                .collect(),
        });
        self.check_writer()?
            .send(job)
            .map_err(|_| anyhow!("the log writer stopped"))
    }

    /// Waits until everything written so far (the batch being filled too, never dropped here)
    /// is in the file, then ends the current chunk and flushes it, so that everything so far
    /// survives a crash. Not for a control loop's tick: it waits for the disk.
    pub fn flush(&mut self) -> Result<()> {
        self.send_batch(Delivery::Lossless)?;
        let (done, wait) = mpsc::channel();
        self.check_writer()?
            .send(Job::Flush(done))
            .map_err(|_| anyhow!("the log writer stopped"))?;
        if wait.recv().is_err() {
            // The writer ended without answering: it failed.
            self.check_writer()?;
        }
        Ok(())
    }

    /// Writes what is queued, then the summary and footer, and ends the writer thread. Safe to
    /// call more than once.
    pub fn finish(&mut self) -> Result<()> {
        if self.jobs.is_some() {
            // A failed writer reports its own error below.
            let _ = self.send_batch(Delivery::Lossless);
        }
        self.jobs = None;
        if let Some(thread) = self.thread.take() {
            thread
                .join()
                .map_err(|_| anyhow!("the log writer panicked"))?
                .with_context(|| format!("cannot finish the log {}", self.path.display()))?;
        }
        Ok(())
    }
}

impl Drop for McapLog {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

fn write_batch(writer: &mut mcap::Writer<BufWriter<File>>, batch: &Batch) -> Result<()> {
    let mut start = 0;
    for e in &batch.entries {
        let data = batch
            .data
            .get(start..e.end)
            .context("log batch out of order")?;
        writer.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: e.channel_id,
                sequence: e.sequence,
                log_time: e.log_time_ns,
                publish_time: e.log_time_ns,
            },
            data,
        )?;
        start = e.end;
    }
    Ok(())
}

/// The writer thread: writes every job until the queue closes, then the summary and footer.
/// After an error it reports it at once, keeps draining (so the caller never blocks on a dead
/// writer) and returns it.
fn write_jobs(
    mut writer: mcap::Writer<BufWriter<File>>,
    queue: &Receiver<Job>,
    recycle: &Sender<Batch>,
    forward: Option<&Forward>,
    path: &Path,
    report: &dyn Fn(&anyhow::Error),
) -> Result<()> {
    let mut first_error: Option<anyhow::Error> = None;
    for job in queue {
        if first_error.is_some() {
            continue;
        }
        let mut ack = None;
        let result = match job {
            Job::Messages(batch) => {
                // The tap first: it only queues, the file may wait on compression.
                if let Some(f) = forward {
                    f.batch(&batch);
                }
                let r = write_batch(&mut writer, &batch);
                let _ = recycle.send(batch);
                r
            }
            Job::Metadata(m) => writer.write_metadata(&m).map_err(anyhow::Error::from),
            Job::Flush(done) => {
                ack = Some(done);
                writer.flush().map_err(anyhow::Error::from)
            }
            #[cfg(test)]
            Job::Stall { stalled, release } => {
                let _ = stalled.send(());
                let _ = release.recv();
                Ok(())
            }
            #[cfg(test)]
            Job::Fail => Err(anyhow!("No space left on device")),
        };
        if let Err(e) = result {
            let e = e.context(format!("cannot write the log {}", path.display()));
            report(&e);
            first_error = Some(e);
        }
        if let Some(done) = ack {
            let _ = done.send(());
        }
    }
    if let Some(e) = first_error {
        return Err(e);
    }
    writer.finish()?;
    let mut inner = writer.into_inner();
    std::io::Write::flush(&mut inner)?;
    Ok(())
}

/// A log file that exists already: logs are created exclusively and never written over.
#[derive(Debug, thiserror::Error)]
#[error("the log file {} exists already; a log is never written over: choose another name, or remove that file", .0.display())]
pub struct LogExists(pub PathBuf);

/// Whether `e` is, or was caused by, a [`LogExists`].
pub fn is_log_exists(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| cause.is::<LogExists>())
}

/// The most names [`default_log_path`] tries in one second before it leaves the last one to
/// the exclusive creation (which refuses it when it is taken too).
const MAX_NAMES_PER_SECOND: u32 = 10_000;

/// `<UTC timestamp>.mcap` under `dir`, e.g. `runs/20250101T120000Z.mcap`, with `-2`, `-3`, …
/// after the stamp when that name is taken: a stamp is taken when any file under `dir` starts
/// with it and a dot, so that the files named after a log (`NAME.imu.mcap`, `NAME.imu.toml`)
/// are free too. Two runs in the same second may still pick one name at once; the log's
/// exclusive creation then refuses the second ([`LogExists`]) instead of writing over the first.
pub fn default_log_path(dir: &Path, unix_s: u64) -> PathBuf {
    let stamp = utc_stamp(unix_s);
    let names: std::collections::HashSet<String> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    let taken = |stem: &str| {
        let prefix = format!("{stem}.");
        names.iter().any(|n| n.starts_with(&prefix))
    };
    let mut stem = stamp.clone();
    for k in 2..=MAX_NAMES_PER_SECOND {
        if !taken(&stem) {
            break;
        }
        stem = format!("{stamp}-{k}");
    }
    dir.join(format!("{stem}.mcap"))
}

/// `YYYYMMDDTHHMMSSZ` for a Unix time.
pub fn utc_stamp(unix_s: u64) -> String {
    let t = rig_description::calendar::UtcTime::from_unix_s(unix_s);
    format!(
        "{:04}{:02}{:02}T{:02}{:02}{:02}Z",
        t.year, t.month, t.day, t.hour, t.minute, t.second
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::{num, object};

    #[test]
    fn two_logs_in_one_second_get_two_names_and_neither_is_written_over() {
        let dir = tempfile::tempdir().unwrap();
        let first = default_log_path(dir.path(), 0);
        assert_eq!(first, dir.path().join("19700101T000000Z.mcap"));
        let mut log = McapLog::create(&first, &[spec()]).unwrap();
        log.finish().unwrap();
        let second = default_log_path(dir.path(), 0);
        assert_eq!(second, dir.path().join("19700101T000000Z-2.mcap"));
        // A file named after a log takes its stem too.
        std::fs::write(dir.path().join("19700101T000000Z-2.imu.toml"), "").unwrap();
        assert_eq!(
            default_log_path(dir.path(), 0),
            dir.path().join("19700101T000000Z-3.mcap")
        );
        // The same name given twice: the second creation is refused, the first log kept.
        let before = std::fs::read(&first).unwrap();
        let e = McapLog::create(&first, &[spec()]).err().unwrap();
        assert!(is_log_exists(&e), "{e:#}");
        assert!(e.to_string().contains("exists already"), "{e:#}");
        assert_eq!(std::fs::read(&first).unwrap(), before);
    }

    #[test]
    fn utc_stamps() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        assert_eq!(utc_stamp(951_782_400), "20000229T000000Z");
        assert_eq!(utc_stamp(1_735_689_599), "20241231T235959Z");
    }

    fn spec() -> ChannelSpec {
        ChannelSpec {
            topic: "/t",
            schema_name: "test.T",
            schema: object(vec![("v", num(""))], ""),
            encoding: Encoding::Json,
        }
    }

    /// (sequence, value) of every message in the file.
    fn read_back(path: &Path) -> Vec<(u32, f64)> {
        let bytes = std::fs::read(path).unwrap();
        mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                (m.sequence, v["v"].as_f64().unwrap())
            })
            .collect()
    }

    /// Stalls the writer thread until the returned sender is dropped or sends.
    fn stall(log: &McapLog) -> std::sync::mpsc::Sender<()> {
        let (stalled, is_stalled) = mpsc::channel();
        let (release, wait) = mpsc::channel();
        log.jobs
            .as_ref()
            .unwrap()
            .send(Job::Stall {
                stalled,
                release: wait,
            })
            .unwrap();
        is_stalled.recv().unwrap();
        release
    }

    #[test]
    fn a_full_queue_drops_and_counts_without_waiting_when_asked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        let mut log =
            McapLog::create_queued(&path, &[spec()], Delivery::DropWhenFull, 2, None).unwrap();
        let release = stall(&log);
        // The writer is stuck: two batches fit in the queue, the next three are dropped, and
        // no write waits (this test would hang if one did).
        let n = 5 * BATCH_MESSAGES as u32 + 3;
        for i in 0..n {
            log.write("/t", u64::from(i), &serde_json::json!({"v": f64::from(i)}))
                .unwrap();
        }
        assert_eq!(log.dropped(), 3 * BATCH_MESSAGES as u64);
        release.send(()).unwrap();
        log.flush().unwrap();
        log.finish().unwrap();
        // Dropped messages leave a gap in the sequence numbers.
        let kept = 2 * BATCH_MESSAGES as u32;
        let want: Vec<(u32, f64)> = (0..kept)
            .chain(n - 3..n)
            .map(|i| (i + 1, f64::from(i)))
            .collect();
        assert_eq!(read_back(&path), want);
    }

    #[test]
    fn a_lossless_log_waits_for_a_slow_writer_and_keeps_everything() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        let mut log =
            McapLog::create_queued(&path, &[spec()], Delivery::Lossless, 1, None).unwrap();
        let release = stall(&log);
        let releaser = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(20));
            release.send(()).unwrap();
        });
        for i in 0..1000u32 {
            log.write("/t", u64::from(i), &serde_json::json!({"v": f64::from(i)}))
                .unwrap();
        }
        releaser.join().unwrap();
        assert_eq!(log.dropped(), 0);
        log.finish().unwrap();
        let got = read_back(&path);
        assert_eq!(got.len(), 1000);
        assert!(got
            .iter()
            .enumerate()
            .all(|(i, &(seq, v))| seq == i as u32 + 1 && v == i as f64));
    }

    #[test]
    fn a_failing_writer_is_reported_by_flush_later_writes_and_finish() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        let mut log = McapLog::create(&path, &[spec()]).unwrap();
        log.write("/t", 0, &serde_json::json!({"v": 0.0})).unwrap();
        log.jobs.as_ref().unwrap().send(Job::Fail).unwrap();
        let err = format!("{:#}", log.flush().unwrap_err());
        assert!(
            err.contains("No space left") && err.contains("x.mcap"),
            "{err}"
        );
        assert!(log.write("/t", 1, &serde_json::json!({"v": 1.0})).is_err());
        assert!(log.finish().is_err());
    }

    #[test]
    fn writes_a_readable_log() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/x.mcap");
        let spec = ChannelSpec {
            topic: "/t",
            schema_name: "test.T",
            schema: object(vec![("v", num(""))], ""),
            encoding: Encoding::Json,
        };
        let mut log = McapLog::create(&path, &[spec]).unwrap();
        for i in 0..1000u64 {
            log.write("/t", 1_000 + i, &serde_json::json!({"v": i as f64}))
                .unwrap();
        }
        assert!(log.write("/nope", 0, &1).is_err());
        log.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let messages: Vec<_> = mcap::MessageStream::new(&bytes)
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(messages.len(), 1000);
        assert_eq!(messages[0].channel.topic, "/t");
        assert_eq!(messages[0].channel.message_encoding, "json");
        let schema = messages[0].channel.schema.as_ref().unwrap();
        assert_eq!(schema.name, "test.T");
        assert_eq!(schema.encoding, "jsonschema");
        let v: serde_json::Value = serde_json::from_slice(&messages[999].data).unwrap();
        assert_eq!(v["v"], 999.0);
    }

    /// A tap that records what the log hands it, with the name of the thread that handed it.
    #[derive(Clone, Default)]
    struct Recorder {
        got: Arc<Mutex<Vec<Recorded>>>,
    }

    /// Topic, bytes, log time and the name of the thread that handed them over.
    type Recorded = (String, Vec<u8>, u64, Option<String>);

    impl Tap for Recorder {
        fn message(&self, topic: &'static str, bytes: &[u8], log_time_ns: u64) {
            let thread = std::thread::current().name().map(String::from);
            let record = (topic.into(), bytes.to_vec(), log_time_ns, thread);
            self.got.lock().unwrap().push(record);
        }
    }

    /// The writer thread, not the writing one, hands the messages to the tap: with the
    /// writer stalled, a write (and the hand-over of its batch) returns with nothing sent to
    /// the tap; once the writer runs, the tap has each message, the file's bytes at the
    /// file's log time, handed over on the writer's thread.
    #[test]
    fn the_writer_thread_serves_the_tap_not_the_caller() {
        use crate::messages as topics;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        let specs = crate::messages::channels();
        let recorder = Recorder::default();
        let tap = Box::new(recorder.clone());
        let mut log = McapLog::create_tapped(&path, &specs, Delivery::DropWhenFull, tap).unwrap();
        let release = stall(&log);
        let t0 = 1_700_000_000_000_000_000;
        log.write(topics::METADATA, t0, &serde_json::json!({"command": "rig"}))
            .unwrap();
        log.write(
            topics::ESTIMATE,
            t0 + 10_000_000,
            &serde_json::json!({"n": 1}),
        )
        .unwrap();
        assert!(
            !log.batch.entries.is_empty(),
            "two messages 10 ms apart wait"
        );
        let t2 = t0 + LIVE_BATCH_SPAN_NS;
        log.write(topics::ESTIMATE, t2, &serde_json::json!({"n": 2}))
            .unwrap();
        // The batch spanned LIVE_BATCH_SPAN_NS: it went to the (stalled) writer, and no
        // message reached the view from this thread.
        assert!(
            log.batch.entries.is_empty(),
            "a batch of 40 ms is handed over"
        );
        assert!(
            recorder.got.lock().unwrap().is_empty(),
            "sent by the caller"
        );
        release.send(()).unwrap();
        log.flush().unwrap();
        log.finish().unwrap();

        let got = recorder.got.lock().unwrap().clone();
        let bytes = std::fs::read(&path).unwrap();
        let in_file: Vec<(String, Vec<u8>, u64)> = mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                (m.channel.topic.clone(), m.data.to_vec(), m.log_time)
            })
            .collect();
        assert_eq!(in_file.len(), 3);
        let sent: Vec<_> = got
            .iter()
            .map(|(topic, data, time, _)| (topic.clone(), data.clone(), *time))
            .collect();
        assert_eq!(sent, in_file, "the tap gets the file's messages");
        assert!(
            got.iter()
                .all(|(.., thread)| thread.as_deref() == Some("mcap-writer")),
            "{:?}",
            got.iter().map(|g| &g.3).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_message_in_the_wrong_encoding_is_refused() {
        use crate::compact::{CommandBlock, SensorBlock};
        use crate::messages as topics;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        let specs = crate::messages::channels();
        let mut log = McapLog::create(&path, &specs).unwrap();
        let sensor = SensorBlock::new("tare");
        let err = log.write(topics::SENSORS, 0, &sensor).unwrap_err();
        assert!(format!("{err}").contains("is protobuf, not json"), "{err}");
        let err = log.write_proto(topics::METADATA, 0, &sensor).unwrap_err();
        assert!(format!("{err}").contains("is json, not protobuf"), "{err}");
        let command = CommandBlock::new("tare");
        let err = log.write_proto(topics::SENSORS, 0, &command).unwrap_err();
        assert!(
            format!("{err}").contains("carries stewart.SensorBlock"),
            "{err}"
        );
        log.write_proto(topics::SENSORS, 0, &sensor).unwrap();
        log.finish().unwrap();
    }
}
