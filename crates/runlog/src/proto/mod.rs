//! The log's 1 kHz and 100 Hz channels in protobuf: `/sensors` and `/commands` in blocks of
//! integer counts ([`crate::compact`]), `/pose`, `/legs` and `/control/pid` in `float`
//! (display only) (schema encoding `protobuf`, a `FileDescriptorSet`; message encoding
//! `protobuf`). The other channels stay JSON, where people read them.
//!
//! - [`descriptor`]: the schema, one table from which the log's descriptor and the `.proto`
//!   text are made.
//! - [`Encode`] and [`Encoder`]: the writer's side, straight from the message types of
//!   [`crate::messages`] into the batch buffer (no allocation per message). Every `double` is
//!   written unless its bits are all zero, so `-0.0`, NaN and the infinities read back exactly.
//! - [`SensorBlock`], [`CommandBlock`], [`Legs`], [`PoseState`], [`PidTerms`]: the reader's
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

/// The protobuf encoding of `m`.
pub fn to_bytes<T: Encode>(m: &T) -> Vec<u8> {
    let mut buf = Vec::new();
    m.encode(&mut Encoder::new(&mut buf));
    buf
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

    /// A packed `repeated sint64` field (zigzag varints).
    pub fn sints(&mut self, tag: u32, v: &[i64]) {
        self.packed(tag, v.iter().map(|&x| ((x << 1) ^ (x >> 63)) as u64));
    }

    /// A packed `repeated uint32` field.
    pub fn uints(&mut self, tag: u32, v: &[u32]) {
        self.packed(tag, v.iter().map(|&x| u64::from(x)));
    }

    fn packed(&mut self, tag: u32, v: impl Iterator<Item = u64> + Clone) {
        let len: usize = v.clone().map(encoded_len_varint).sum();
        if len > 0 {
            encode_key(tag, WireType::LengthDelimited, self.buf);
            encode_varint(len as u64, self.buf);
            for x in v {
                encode_varint(x, self.buf);
            }
        }
    }

    /// A packed `repeated float` field: each value rounded to the nearest `f32`.
    pub fn floats(&mut self, tag: u32, v: &[f64]) {
        if !v.is_empty() {
            encode_key(tag, WireType::LengthDelimited, self.buf);
            encode_varint(4 * v.len() as u64, self.buf);
            for x in v {
                self.buf.extend_from_slice(&(*x as f32).to_le_bytes());
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

/// `stewart.SensorBlock`, as read ([`crate::compact`]).
#[derive(Clone, PartialEq, prost::Message)]
pub struct SensorBlock {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// Backend sample counters, delta-coded.
    #[prost(sint64, repeated, tag = "2")]
    pub sequence: Vec<i64>,
    /// ns, delta-coded.
    #[prost(sint64, repeated, tag = "3")]
    pub time_ns: Vec<i64>,
    /// nm, delta-coded.
    #[prost(sint64, repeated, tag = "4")]
    pub leg_lengths_nm: Vec<i64>,
    /// mN, delta-coded.
    #[prost(sint64, repeated, tag = "5")]
    pub leg_forces_mn: Vec<i64>,
    /// µrad/s, delta-coded.
    #[prost(sint64, repeated, tag = "6")]
    pub gyro_urad_s: Vec<i64>,
    /// µm/s², delta-coded.
    #[prost(sint64, repeated, tag = "7")]
    pub accel_um_s2: Vec<i64>,
    /// Status bits, one a frame.
    #[prost(uint32, repeated, tag = "8")]
    pub status: Vec<u32>,
    /// Positions of the values without a count.
    #[prost(uint32, repeated, tag = "9")]
    pub raw_index: Vec<u32>,
    /// Those values.
    #[prost(double, repeated, tag = "10")]
    pub raw_value: Vec<f64>,
}

/// `stewart.CommandBlock`, as read ([`crate::compact`]).
#[derive(Clone, PartialEq, prost::Message)]
pub struct CommandBlock {
    /// Measurement.
    #[prost(string, tag = "1")]
    pub run: String,
    /// ns, delta-coded.
    #[prost(sint64, repeated, tag = "2")]
    pub time_ns: Vec<i64>,
    /// Host command counters, delta-coded.
    #[prost(sint64, repeated, tag = "3")]
    pub sequence: Vec<i64>,
    /// Sensor sequences answered, delta-coded.
    #[prost(sint64, repeated, tag = "4")]
    pub sensor_sequence: Vec<i64>,
    /// mN, delta-coded.
    #[prost(sint64, repeated, tag = "5")]
    pub leg_forces_mn: Vec<i64>,
    /// Actuators enabled, one a frame.
    #[prost(bool, repeated, tag = "6")]
    pub enable: Vec<bool>,
    /// Positions of the values without a count.
    #[prost(uint32, repeated, tag = "7")]
    pub raw_index: Vec<u32>,
    /// Those values.
    #[prost(double, repeated, tag = "8")]
    pub raw_value: Vec<f64>,
}

/// `stewart.Pose`, as read.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Pose {
    /// m.
    #[prost(float, repeated, tag = "1")]
    pub position_m: Vec<f32>,
    /// rad.
    #[prost(float, repeated, tag = "2")]
    pub rpy_rad: Vec<f32>,
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
    #[prost(float, repeated, tag = "3")]
    pub desired_length_m: Vec<f32>,
    /// m.
    #[prost(float, repeated, tag = "4")]
    pub measured_length_m: Vec<f32>,
    /// m.
    #[prost(float, repeated, tag = "5")]
    pub error_m: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "6")]
    pub command_force_n: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "7")]
    pub measured_force_n: Vec<f32>,
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
    #[prost(float, repeated, tag = "3")]
    pub p_n: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "4")]
    pub i_n: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "5")]
    pub d_n: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "6")]
    pub feedforward_n: Vec<f32>,
    /// N.
    #[prost(float, repeated, tag = "7")]
    pub output_n: Vec<f32>,
    /// Output clamped.
    #[prost(bool, repeated, tag = "8")]
    pub saturated: Vec<bool>,
}

/// `v` (a `repeated float`) as an array of `N` f64, or an error naming `field` when its length
/// differs.
pub fn array<const N: usize>(field: &str, v: &[f32]) -> Result<[f64; N], String> {
    if v.len() != N {
        return Err(format!(
            "does not match its schema ({field} holds {} numbers, not {N})",
            v.len()
        ));
    }
    Ok(core::array::from_fn(|i| f64::from(v[i])))
}

#[cfg(test)]
mod tests;
