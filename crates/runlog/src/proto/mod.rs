//! The log's 1 kHz channels in protobuf: `/sensors`, `/commands`, `/pose`, `/legs` and
//! `/control/pid` (schema encoding `protobuf`, a `FileDescriptorSet`; message encoding
//! `protobuf`), about a fifth of the bytes of their JSON and much cheaper to decode. The other
//! channels stay JSON, where people read them.
//!
//! - [`descriptor`]: the schema, one table from which the log's descriptor and the `.proto`
//!   text are made.
//! - [`Encode`] and [`Encoder`]: the writer's side, straight from the message types of
//!   [`crate::messages`] into the batch buffer (no allocation per message). Every `double` is
//!   written unless its bits are all zero, so `-0.0`, NaN and the infinities read back exactly.
//! - [`SensorFrame`], [`CommandFrame`], [`Legs`], [`PoseState`], [`PidTerms`]: the reader's
//!   side, derived by prost; [`crate::read`] decodes them into its records.

pub mod descriptor;

use prost::encoding::{encode_key, encode_varint, encoded_len_varint, WireType};

/// A message type written to a protobuf channel.
pub trait Encode {
    /// The message's full name in [`descriptor::PACKAGE`] (`stewart.SensorFrame`).
    const NAME: &'static str;
    /// Appends the message's protobuf encoding.
    fn encode(&self, e: &mut Encoder<'_>);
}

/// Appends protobuf fields to a buffer (proto3 wire format: a field at its default value is
/// left out, except a `double` whose sign or payload bits are set).
pub struct Encoder<'a> {
    buf: &'a mut Vec<u8>,
}

impl<'a> Encoder<'a> {
    /// Appends to `buf`.
    pub fn new(buf: &'a mut Vec<u8>) -> Self {
        Self { buf }
    }

    /// A `string` field.
    pub fn string(&mut self, tag: u32, v: &str) {
        if !v.is_empty() {
            encode_key(tag, WireType::LengthDelimited, self.buf);
            encode_varint(v.len() as u64, self.buf);
            self.buf.extend_from_slice(v.as_bytes());
        }
    }

    /// A `uint64` (or `uint32`) field.
    pub fn uint(&mut self, tag: u32, v: u64) {
        if v != 0 {
            encode_key(tag, WireType::Varint, self.buf);
            encode_varint(v, self.buf);
        }
    }

    /// A `bool` field.
    pub fn bool(&mut self, tag: u32, v: bool) {
        self.uint(tag, u64::from(v));
    }

    /// A `double` field; `0.0` left out, `-0.0` kept.
    pub fn double(&mut self, tag: u32, v: f64) {
        if v.to_bits() != 0 {
            encode_key(tag, WireType::SixtyFourBit, self.buf);
            self.buf.extend_from_slice(&v.to_le_bytes());
        }
    }

    /// A packed `repeated double` field.
    pub fn doubles(&mut self, tag: u32, v: &[f64]) {
        if !v.is_empty() {
            encode_key(tag, WireType::LengthDelimited, self.buf);
            encode_varint(8 * v.len() as u64, self.buf);
            for x in v {
                self.buf.extend_from_slice(&x.to_le_bytes());
            }
        }
    }

    /// A packed `repeated bool` field.
    pub fn bools(&mut self, tag: u32, v: &[bool]) {
        if !v.is_empty() {
            encode_key(tag, WireType::LengthDelimited, self.buf);
            encode_varint(v.len() as u64, self.buf);
            self.buf.extend(v.iter().map(|&b| u8::from(b)));
        }
    }

    /// A message field: `write` appends its fields, then their length is put in front.
    pub fn message(&mut self, tag: u32, write: impl FnOnce(&mut Encoder<'_>)) {
        encode_key(tag, WireType::LengthDelimited, self.buf);
        let start = self.buf.len();
        write(&mut Encoder { buf: self.buf });
        let len = (self.buf.len() - start) as u64;
        let mut prefix = [0u8; 10];
        let n = encoded_len_varint(len);
        let mut slot = &mut prefix[..];
        encode_varint(len, &mut slot);
        self.buf.splice(start..start, prefix[..n].iter().copied());
    }
}

/// `stewart.SensorFrame`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct SensorFrame {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// Backend sample counter.
    #[prost(uint64, tag = "2")]
    pub sequence: u64,
    /// s.
    #[prost(double, tag = "3")]
    pub time_s: f64,
    /// m.
    #[prost(double, repeated, tag = "4")]
    pub leg_lengths_m: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "5")]
    pub leg_forces_n: Vec<f64>,
    /// rad/s.
    #[prost(double, repeated, tag = "6")]
    pub gyro_rad_s: Vec<f64>,
    /// m/s².
    #[prost(double, repeated, tag = "7")]
    pub accel_m_s2: Vec<f64>,
    /// Status bits.
    #[prost(uint32, tag = "8")]
    pub status: u32,
}

/// `stewart.CommandFrame`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct CommandFrame {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// s.
    #[prost(double, tag = "2")]
    pub time_s: f64,
    /// Host command counter.
    #[prost(uint64, tag = "3")]
    pub sequence: u64,
    /// Sensor sequence answered.
    #[prost(uint64, tag = "4")]
    pub sensor_sequence: u64,
    /// N.
    #[prost(double, repeated, tag = "5")]
    pub leg_forces_n: Vec<f64>,
    /// Actuators enabled.
    #[prost(bool, tag = "6")]
    pub enable: bool,
}

/// `stewart.Pose`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Pose {
    /// m.
    #[prost(double, repeated, tag = "1")]
    pub position_m: Vec<f64>,
    /// rad.
    #[prost(double, repeated, tag = "2")]
    pub rpy_rad: Vec<f64>,
}

/// `stewart.PoseState`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct PoseState {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// s.
    #[prost(double, tag = "2")]
    pub time_s: f64,
    /// The trajectory's pose.
    #[prost(message, optional, tag = "3")]
    pub desired: Option<Pose>,
    /// Forward kinematics of the measured legs.
    #[prost(message, optional, tag = "4")]
    pub measured: Option<Pose>,
}

/// `stewart.Legs`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Legs {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// s.
    #[prost(double, tag = "2")]
    pub time_s: f64,
    /// m.
    #[prost(double, repeated, tag = "3")]
    pub desired_length_m: Vec<f64>,
    /// m.
    #[prost(double, repeated, tag = "4")]
    pub measured_length_m: Vec<f64>,
    /// m.
    #[prost(double, repeated, tag = "5")]
    pub error_m: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "6")]
    pub command_force_n: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "7")]
    pub measured_force_n: Vec<f64>,
}

/// `stewart.PidTerms`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct PidTerms {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// s.
    #[prost(double, tag = "2")]
    pub time_s: f64,
    /// N.
    #[prost(double, repeated, tag = "3")]
    pub p_n: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "4")]
    pub i_n: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "5")]
    pub d_n: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "6")]
    pub feedforward_n: Vec<f64>,
    /// N.
    #[prost(double, repeated, tag = "7")]
    pub output_n: Vec<f64>,
    /// Output clamped.
    #[prost(bool, repeated, tag = "8")]
    pub saturated: Vec<bool>,
}

/// `v` as an array of `N`, or an error naming `field` when its length differs.
pub fn array<const N: usize>(field: &str, v: &[f64]) -> Result<[f64; N], String> {
    v.try_into().map_err(|_| {
        format!(
            "does not match its schema ({field} holds {} numbers, not {N})",
            v.len()
        )
    })
}

#[cfg(test)]
mod tests;
