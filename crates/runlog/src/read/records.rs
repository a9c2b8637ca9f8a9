//! The records `stewart estimate` and the figures read from a log, decoded from their JSON
//! (docs/log-schema.md; a logged `null`, a non-finite value when written, reads back as NaN) or
//! from their protobuf ([`crate::proto`]; every f64 exactly as written).

use serde::{Deserialize, Deserializer};

use crate::proto::{self, array};

/// A record that a protobuf channel may carry.
pub trait FromProto: Sized {
    /// Its protobuf message.
    type Proto: prost::Message + Default;
    /// The record of `p`, or why `p` does not fit it (an array of the wrong length).
    fn from_proto(p: Self::Proto) -> Result<Self, String>;
}

/// JSON `null` (a non-finite value when written) reads back as NaN.
/// An array of `N` numbers, `null` as NaN, read in place (no allocation per message).
pub(crate) fn nan_or<'de, D: Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<[f64; N], D::Error> {
    struct Array<const N: usize>;
    impl<'de, const N: usize> serde::de::Visitor<'de> for Array<N> {
        type Value = [f64; N];
        fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            write!(f, "an array of {N} numbers or nulls")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut a: A) -> Result<[f64; N], A::Error> {
            let mut out = [f64::NAN; N];
            for (i, slot) in out.iter_mut().enumerate() {
                let v: Option<f64> = a
                    .next_element()?
                    .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                *slot = v.unwrap_or(f64::NAN);
            }
            if a.next_element::<serde::de::IgnoredAny>()?.is_some() {
                return Err(serde::de::Error::invalid_length(N + 1, &self));
            }
            Ok(out)
        }
    }
    d.deserialize_seq(Array::<N>)
}

pub(crate) fn nan_or_one<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
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

impl SensorRecord {
    /// The record of frame `f` of measurement `run`.
    pub fn of_frame(run: &str, f: &control::io::SensorFrame) -> Self {
        Self {
            run: run.to_string(),
            sequence: f.sequence,
            time_s: f.time_s,
            leg_lengths_m: f.leg_lengths_m,
            leg_forces_n: f.leg_forces_n,
            gyro_rad_s: f.gyro_rad_s,
            accel_m_s2: f.accel_m_s2,
            status: f.status.0,
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

impl FromProto for LegsRecord {
    type Proto = proto::Legs;
    fn from_proto(p: proto::Legs) -> Result<Self, String> {
        Ok(Self {
            time_s: p.time_s,
            desired_length_m: array("desired_length_m", &p.desired_length_m)?,
            measured_length_m: array("measured_length_m", &p.measured_length_m)?,
            error_m: array("error_m", &p.error_m)?,
            command_force_n: array("command_force_n", &p.command_force_n)?,
            measured_force_n: array("measured_force_n", &p.measured_force_n)?,
            run: p.run,
        })
    }
}

impl PoseRecordValue {
    fn from_proto(field: &str, p: Option<proto::Pose>) -> Result<Self, String> {
        let p = p.ok_or_else(|| format!("does not match its schema ({field} missing)"))?;
        Ok(Self {
            position_m: array("position_m", &p.position_m)?,
            rpy_rad: array("rpy_rad", &p.rpy_rad)?,
        })
    }
}

impl FromProto for PoseRecord {
    type Proto = proto::PoseState;
    fn from_proto(p: proto::PoseState) -> Result<Self, String> {
        Ok(Self {
            time_s: p.time_s,
            desired: PoseRecordValue::from_proto("desired", p.desired)?,
            measured: PoseRecordValue::from_proto("measured", p.measured)?,
            run: p.run,
        })
    }
}
