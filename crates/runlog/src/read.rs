//! Reading a run's MCAP log back: every channel's schema, encoding, count and time span, and the
//! messages that `stewart estimate` and the figures need, decoded into owned records.
//!
//! A log cut short (the process killed mid-run) still opens: the reader streams records from
//! the start and stops at the first record it cannot read, which is the chunk being written
//! when the run died (the writer emits a chunk only when it is complete, see
//! [`crate::mcap_log`]). Everything before it is used, and [`LogContents::truncated`] says why
//! the reading stopped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Deserializer};

use crate::messages as topics;
use crate::metadata::{EstimatorSettings, RunMetadata, TruthMsg};
use measure::tare::TareFile;

/// What the log holds on one channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelInfo {
    /// Topic.
    pub topic: String,
    /// Schema name (empty when the channel has no schema).
    pub schema_name: String,
    /// Schema encoding (`jsonschema`).
    pub schema_encoding: String,
    /// The schema document's text.
    pub schema_text: String,
    /// Message encoding (`json`).
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

/// JSON `null` (a non-finite value when written) reads back as NaN.
fn nan_or<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
    let v: Vec<Option<f64>> = Deserialize::deserialize(d)?;
    if v.len() != N {
        return Err(serde::de::Error::invalid_length(
            v.len(),
            &"the schema's array length",
        ));
    }
    Ok(core::array::from_fn(|i| v[i].unwrap_or(f64::NAN)))
}

fn nan_or_one<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::NAN))
}

fn nan_or_33<'de, D: Deserializer<'de>>(d: D) -> Result<[[f64; 3]; 3], D::Error> {
    let v: [[Option<f64>; 3]; 3] = Deserialize::deserialize(d)?;
    Ok(v.map(|r| r.map(|x| x.unwrap_or(f64::NAN))))
}

/// A `/sensors` message.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct SensorRecord {
    /// Measurement (`tare`, `loaded`).
    pub run: String,
    /// Backend sample counter.
    pub sequence: u64,
    /// Sample time, s.
    #[serde(deserialize_with = "nan_or_one")]
    pub time_s: f64,
    /// Leg lengths, m.
    #[serde(deserialize_with = "nan_or")]
    pub leg_lengths_m: [f64; 6],
    /// Leg forces, N.
    #[serde(deserialize_with = "nan_or")]
    pub leg_forces_n: [f64; 6],
    /// Gyro, P, rad/s.
    #[serde(deserialize_with = "nan_or")]
    pub gyro_rad_s: [f64; 3],
    /// Accelerometer, P, m/s².
    #[serde(deserialize_with = "nan_or")]
    pub accel_m_s2: [f64; 3],
    /// Status bits.
    pub status: u32,
}

impl SensorRecord {
    /// The sensor frame as the backend gave it.
    pub fn to_frame(&self) -> control::io::SensorFrame {
        control::io::SensorFrame {
            sequence: self.sequence,
            time_s: self.time_s,
            leg_lengths_m: self.leg_lengths_m,
            leg_forces_n: self.leg_forces_n,
            gyro_rad_s: self.gyro_rad_s,
            accel_m_s2: self.accel_m_s2,
            status: control::io::Status(self.status),
        }
    }
}

/// Mass, centre of mass and J_C with sigmas, as in `/estimate`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct BodyRecord {
    /// kg.
    #[serde(deserialize_with = "nan_or_one")]
    pub mass_kg: f64,
    /// kg.
    #[serde(deserialize_with = "nan_or_one")]
    pub mass_sigma_kg: f64,
    /// P, m.
    #[serde(deserialize_with = "nan_or")]
    pub com_m: [f64; 3],
    /// m.
    #[serde(deserialize_with = "nan_or")]
    pub com_sigma_m: [f64; 3],
    /// J_C, P axes, kg·m².
    #[serde(deserialize_with = "nan_or_33")]
    pub inertia_com_kg_m2: [[f64; 3]; 3],
    /// kg·m².
    #[serde(deserialize_with = "nan_or_33")]
    pub inertia_com_sigma_kg_m2: [[f64; 3]; 3],
}

/// An `/estimate` message.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct EstimateRecord {
    /// Measurement.
    pub run: String,
    /// Sample time, s.
    #[serde(deserialize_with = "nan_or_one")]
    pub time_s: f64,
    /// Samples used.
    pub samples: u64,
    /// Samples rejected.
    pub rejected: u64,
    /// θ about the P origin.
    #[serde(deserialize_with = "nan_or")]
    pub theta: [f64; 10],
    /// One sigma of θ.
    #[serde(deserialize_with = "nan_or")]
    pub theta_sigma: [f64; 10],
    /// RMS residual per equation.
    #[serde(deserialize_with = "nan_or")]
    pub residual_rms: [f64; 6],
    /// Everything on the plate.
    pub body: BodyRecord,
    /// The payload alone, when a tare was known.
    pub payload: Option<BodyRecord>,
}

/// A `/legs` message.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct LegsRecord {
    /// Measurement.
    pub run: String,
    /// Sample time, s.
    #[serde(deserialize_with = "nan_or_one")]
    pub time_s: f64,
    /// m.
    #[serde(deserialize_with = "nan_or")]
    pub desired_length_m: [f64; 6],
    /// m.
    #[serde(deserialize_with = "nan_or")]
    pub measured_length_m: [f64; 6],
    /// Desired − measured, m.
    #[serde(deserialize_with = "nan_or")]
    pub error_m: [f64; 6],
    /// N.
    #[serde(deserialize_with = "nan_or")]
    pub command_force_n: [f64; 6],
    /// N.
    #[serde(deserialize_with = "nan_or")]
    pub measured_force_n: [f64; 6],
}

/// A pose as logged.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct PoseRecordValue {
    /// P origin in B, m.
    #[serde(deserialize_with = "nan_or")]
    pub position_m: [f64; 3],
    /// Roll, pitch, yaw, rad.
    #[serde(deserialize_with = "nan_or")]
    pub rpy_rad: [f64; 3],
}

/// A `/pose` message.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct PoseRecord {
    /// Measurement.
    pub run: String,
    /// Sample time, s.
    #[serde(deserialize_with = "nan_or_one")]
    pub time_s: f64,
    /// The trajectory's pose.
    pub desired: PoseRecordValue,
    /// FK of the measured legs.
    pub measured: PoseRecordValue,
}

/// Everything read from a log.
#[derive(Clone, Debug, Default)]
pub struct LogContents {
    /// The file.
    pub path: PathBuf,
    /// Every channel met, by topic.
    pub channels: BTreeMap<String, ChannelInfo>,
    /// Why reading stopped before the end of a complete file (a log cut short), if it did.
    pub truncated: Option<String>,
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

fn decode<T: for<'de> Deserialize<'de>>(topic: &str, index: u64, data: &[u8]) -> Result<T> {
    serde_json::from_slice(data)
        .with_context(|| format!("message {index} on {topic} does not match its schema"))
}

impl LogContents {
    /// Reads `path`; a log cut short is read up to its last complete chunk.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read the log {}", path.display()))?;
        let mut log = Self::from_bytes(&bytes)
            .with_context(|| format!("{} is not a readable MCAP log", path.display()))?;
        log.path = path.to_path_buf();
        Ok(log)
    }

    /// Reads a log held in memory.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        if bytes.len() < mcap::MAGIC.len() || !bytes.starts_with(mcap::MAGIC) {
            bail!("it does not start with the MCAP magic bytes");
        }
        let mut log = Self::default();
        let stream = mcap::MessageStream::new(bytes)?;
        for item in stream {
            let message = match item {
                Ok(m) => m,
                Err(e) => {
                    log.truncated = Some(e.to_string());
                    break;
                }
            };
            let topic = message.channel.topic.as_str();
            let info = log
                .channels
                .entry(topic.to_string())
                .or_insert_with(|| ChannelInfo {
                    topic: topic.to_string(),
                    schema_name: message
                        .channel
                        .schema
                        .as_ref()
                        .map(|s| s.name.clone())
                        .unwrap_or_default(),
                    schema_encoding: message
                        .channel
                        .schema
                        .as_ref()
                        .map(|s| s.encoding.clone())
                        .unwrap_or_default(),
                    schema_text: message
                        .channel
                        .schema
                        .as_ref()
                        .map(|s| String::from_utf8_lossy(&s.data).into_owned())
                        .unwrap_or_default(),
                    message_encoding: message.channel.message_encoding.clone(),
                    count: 0,
                    first_ns: message.log_time,
                    last_ns: message.log_time,
                    monotonic: true,
                });
            if message.log_time < info.last_ns {
                info.monotonic = false;
            }
            info.last_ns = message.log_time;
            info.count += 1;
            let index = info.count;
            let data = &message.data[..];
            match topic {
                topics::SENSORS => log.sensors.push(decode(topic, index, data)?),
                topics::ESTIMATE => log.estimates.push(decode(topic, index, data)?),
                topics::LEGS => log.legs.push(decode(topic, index, data)?),
                topics::POSE => log.poses.push(decode(topic, index, data)?),
                topics::METADATA => log.metadata = Some(decode(topic, index, data)?),
                topics::ESTIMATOR_SETTINGS => log.settings.push(decode(topic, index, data)?),
                topics::TARE => log.tare = Some(decode(topic, index, data)?),
                topics::TRUTH => log.truth = Some(decode(topic, index, data)?),
                _ => {}
            }
        }
        Ok(log)
    }

    /// The run metadata, or an error naming its channel.
    pub fn require_metadata(&self) -> Result<&RunMetadata> {
        self.metadata.as_ref().with_context(|| {
            format!(
                "the log has no {} message (channel {} missing): it does not say what was run",
                "stewart.RunMetadata",
                topics::METADATA
            )
        })
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
        let m = self.require_metadata()?;
        let v = |p: &[f64; 3]| nalgebra::Vector3::new(p[0], p[1], p[2]);
        kinematics::Geometry::from_points(
            m.base_joints_m.each_ref().map(v),
            m.plate_joints_m.each_ref().map(v),
            kinematics::StrokeLimits {
                min_length_m: m.stroke_m[0],
                max_length_m: m.stroke_m[1],
            },
        )
        .map_err(|e| anyhow::anyhow!("the log's platform design is refused: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap_log::McapLog;
    use crate::messages::{channels, SensorMsg};

    fn frame(i: u64) -> control::io::SensorFrame {
        control::io::SensorFrame {
            sequence: i,
            time_s: i as f64 * 1e-3,
            leg_lengths_m: [1.9 + i as f64 * 1e-7; 6],
            leg_forces_n: [f64::NAN, 2.0, 3.0, 4.0, 5.0, 6.0],
            gyro_rad_s: [0.1, -0.2, 1.0 / 3.0],
            accel_m_s2: [0.0, 0.0, 9.80665],
            status: control::io::Status(0),
        }
    }

    /// A log of `n` sensor frames in small chunks, as bytes.
    fn log_bytes(n: u64) -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.mcap");
        let mut log = McapLog::create(&path, &channels()).unwrap();
        for i in 0..n {
            log.write(
                SENSORS_TOPIC,
                1_000 + i,
                &SensorMsg::new("loaded", &frame(i)),
            )
            .unwrap();
            if i % 100 == 99 {
                log.flush().unwrap();
            }
        }
        log.finish().unwrap();
        std::fs::read(&path).unwrap()
    }

    const SENSORS_TOPIC: &str = topics::SENSORS;

    #[test]
    fn reads_frames_back_exactly_with_nan_as_null() {
        let log = LogContents::from_bytes(&log_bytes(250)).unwrap();
        assert!(log.truncated.is_none());
        assert_eq!(log.sensors.len(), 250);
        let info = &log.channels[topics::SENSORS];
        assert_eq!(
            (info.count, info.first_ns, info.last_ns, info.monotonic),
            (250, 1_000, 1_249, true)
        );
        assert_eq!(info.schema_name, "stewart.SensorFrame");
        assert_eq!(info.message_encoding, "json");
        for (i, s) in log.sensors.iter().enumerate() {
            let f = frame(i as u64);
            assert_eq!(s.time_s.to_bits(), f.time_s.to_bits());
            assert_eq!(s.leg_lengths_m, f.leg_lengths_m);
            assert_eq!(s.gyro_rad_s[2].to_bits(), (1.0f64 / 3.0).to_bits());
            assert!(s.leg_forces_n[0].is_nan());
        }
        assert_eq!(log.runs(), vec!["loaded".to_string()]);
        let err = log
            .require_channel(topics::ESTIMATOR_SETTINGS, "the settings")
            .unwrap_err();
        assert!(err.to_string().contains("/run/estimator"), "{err}");
        assert!(log
            .require_metadata()
            .unwrap_err()
            .to_string()
            .contains("/run/metadata"));
    }

    #[test]
    fn a_cut_log_gives_its_complete_chunks() {
        let bytes = log_bytes(1000);
        let whole = LogContents::from_bytes(&bytes).unwrap().sensors;
        for cut in [bytes.len() / 3, bytes.len() / 2, bytes.len() - 50] {
            let log = LogContents::from_bytes(&bytes[..cut]).unwrap();
            assert!(log.truncated.is_some(), "cut at {cut}");
            // Whole chunks of 100 frames, the start of the full log.
            assert_eq!(log.sensors.len() % 100, 0, "cut at {cut}");
            // Debug text compares NaN (the logged non-finite force) as equal to itself.
            let prefix = format!("{:?}", &whole[..log.sensors.len()]);
            assert_eq!(format!("{:?}", &log.sensors[..]), prefix, "cut at {cut}");
        }
        assert!(LogContents::from_bytes(b"not an mcap file").is_err());
        assert!(LogContents::from_bytes(&bytes[..5]).is_err());
    }
}
