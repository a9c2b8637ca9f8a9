//! The MCAP log writer: JSON messages with JSON schemas, chunked and compressed, streamed as the
//! run goes so that a crash loses at most the chunk being written, and finished (summary,
//! footer) on every normal or interrupted end.

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;

use crate::schema::Schema;

/// One channel of the log.
#[derive(Clone, Debug)]
pub struct ChannelSpec {
    /// Topic, e.g. `/sensors`.
    pub topic: &'static str,
    /// Schema name, e.g. `stewart.SensorFrame` or `foxglove.SceneUpdate`.
    pub schema_name: &'static str,
    /// The JSON schema of its messages.
    pub schema: Schema,
}

/// Target uncompressed chunk size: small enough that a crash loses little (about a quarter of
/// a second of a 1 kHz run), large enough for zstd to compress JSON well.
pub const CHUNK_SIZE_BYTES: u64 = 512 * 1024;

/// An open MCAP log.
pub struct McapLog {
    writer: Option<mcap::Writer<BufWriter<File>>>,
    channels: HashMap<&'static str, u16>,
    sequence: u32,
    path: PathBuf,
    buffer: Vec<u8>,
}

impl McapLog {
    /// Creates `path` (and its parent directory) and registers every channel.
    pub fn create(path: &Path, specs: &[ChannelSpec]) -> Result<Self> {
        if let Some(dir) = path.parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir).with_context(|| {
                    format!("cannot create the log directory {}", dir.display())
                })?;
            }
        }
        let file = File::create(path)
            .with_context(|| format!("cannot create the log file {}", path.display()))?;
        let options = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("stewart-cli ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(CHUNK_SIZE_BYTES));
        let mut writer = options
            .create(BufWriter::new(file))
            .context("cannot start the MCAP log")?;
        let mut channels = HashMap::new();
        for spec in specs {
            let schema_text = serde_json::to_vec(&spec.schema.document(spec.schema_name))?;
            let schema_id = writer.add_schema(spec.schema_name, "jsonschema", &schema_text)?;
            let id = writer.add_channel(
                schema_id,
                spec.topic,
                "json",
                &std::collections::BTreeMap::new(),
            )?;
            channels.insert(spec.topic, id);
        }
        Ok(Self {
            writer: Some(writer),
            channels,
            sequence: 0,
            path: path.to_path_buf(),
            buffer: Vec::with_capacity(4096),
        })
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `message` as JSON on `topic` at `log_time_ns` (nanoseconds since the Unix epoch).
    pub fn write<T: Serialize>(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        message: &T,
    ) -> Result<()> {
        let id = *self
            .channels
            .get(topic)
            .with_context(|| format!("log channel {topic} was not registered"))?;
        self.buffer.clear();
        serde_json::to_writer(&mut self.buffer, message)?;
        self.sequence = self.sequence.wrapping_add(1);
        let writer = self
            .writer
            .as_mut()
            .context("the log is already finished")?;
        writer.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: id,
                sequence: self.sequence,
                log_time: log_time_ns,
                publish_time: log_time_ns,
            },
            &self.buffer,
        )?;
        Ok(())
    }

    /// Adds an MCAP metadata record (string key/value pairs).
    pub fn metadata(&mut self, name: &str, pairs: &[(&str, String)]) -> Result<()> {
        let writer = self
            .writer
            .as_mut()
            .context("the log is already finished")?;
        writer.write_metadata(&mcap::records::Metadata {
            name: name.into(),
            metadata: pairs
                .iter()
                .map(|(k, v)| ((*k).to_string(), v.clone()))
                .collect(),
        })?;
        Ok(())
    }

    /// Ends the current chunk and flushes it to the file, so that everything so far survives a
    /// crash.
    pub fn flush(&mut self) -> Result<()> {
        if let Some(w) = self.writer.as_mut() {
            w.flush()?;
        }
        Ok(())
    }

    /// Writes the summary and footer. Safe to call more than once.
    pub fn finish(&mut self) -> Result<()> {
        if let Some(mut w) = self.writer.take() {
            w.finish()
                .with_context(|| format!("cannot finish the log {}", self.path.display()))?;
            let mut inner = w.into_inner();
            std::io::Write::flush(&mut inner)?;
        }
        Ok(())
    }
}

impl Drop for McapLog {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// `runs/<UTC timestamp>.mcap` under `dir`, e.g. `runs/20250101T120000Z.mcap`.
pub fn default_log_path(dir: &Path, unix_s: u64) -> PathBuf {
    dir.join(format!("{}.mcap", utc_stamp(unix_s)))
}

/// `YYYYMMDDTHHMMSSZ` for a Unix time (civil-from-days, H. Hinnant's algorithm).
pub fn utc_stamp(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let secs = unix_s % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        secs / 3600,
        (secs / 60) % 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::{num, object};

    #[test]
    fn utc_stamps() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        assert_eq!(utc_stamp(951_782_400), "20000229T000000Z");
        assert_eq!(utc_stamp(1_735_689_599), "20241231T235959Z");
    }

    #[test]
    fn writes_a_readable_log() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/x.mcap");
        let spec = ChannelSpec {
            topic: "/t",
            schema_name: "test.T",
            schema: object(vec![("v", num(""))], ""),
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
}
