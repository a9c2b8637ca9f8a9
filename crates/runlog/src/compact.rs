//! The compact encoding of the 1 kHz channels (`/sensors`, `/commands`; docs/log-schema.md,
//! "The 1 kHz channels"): every value an integer count at a fixed resolution far finer than
//! its sensor's noise, [`BLOCK_FRAMES`] frames a message, each count after a block's first
//! frame written as its difference from the same value in the frame before.
//!
//! - Resolution: a value `v` in its unit is the count `c = round(v · k)` with `k` counts per
//!   unit ([`TIME_PER_S`], [`LENGTH_PER_M`], [`FORCE_PER_N`], [`GYRO_PER_RAD_S`],
//!   [`ACCEL_PER_M_S2`]), read back as `c / k` (one correctly rounded division). A value that
//!   has no count (non-finite, or |v · k| > [`MAX_COUNT`]) is kept as its exact `f64` in the
//!   block's `raw_index`/`raw_value` fields.
//! - [`quantise`] is that round trip. It is idempotent (`quantise(quantise(v)) ==
//!   quantise(v)` bit for bit, since `|c| ≤ 2⁵⁰` keeps `(c / k) · k` within 0.25 of `c`), so
//!   a frame made with [`quantise_frame`] is logged exactly: the backends of `stewart
//!   simulate` and `stewart rig` pass their frames through it ([`AtLogResolution`]) before the
//!   estimator sees them, and `stewart estimate` re-runs the estimator on the very numbers the
//!   online one used.
//! - Delta: element `i` of a column of `w` values a frame holds `c[i] − c[i − w]` for `i ≥ w`
//!   and `c[i]` for the first frame (wrapping `i64` arithmetic), so the first frame of every
//!   message reads in plain counts (Foxglove plots `leg_lengths_nm[0]` at the block rate) and
//!   the rest are small numbers that zstd packs tightly.

use control::io::{Backend, CommandFrame, SensorFrame, Status};
use serde::Serialize;

use crate::proto::{Encode, Encoder};

/// Frames in one `/sensors` or `/commands` message: 10 ms at 1 kHz, the rate of the derived
/// channels. A block holds frames of one measurement only.
pub const BLOCK_FRAMES: usize = 10;

/// Time counts per second: ns (the timestamps' jitter on a rig is microseconds).
pub const TIME_PER_S: f64 = 1e9;
/// Leg length counts per metre: nm (encoder noise 0.5 µm, resolution 1 µm: 500× finer).
pub const LENGTH_PER_M: f64 = 1e9;
/// Force counts per newton: mN (load cell noise 4 N, resolution 0.5 N: 500× finer).
pub const FORCE_PER_N: f64 = 1e3;
/// Angular rate counts per rad/s: µrad/s (gyro noise 1.6 mrad/s a sample at 1 kHz: 1600×
/// finer).
pub const GYRO_PER_RAD_S: f64 = 1e6;
/// Specific force counts per m/s²: µm/s² (accelerometer noise 12.6 mm/s² a sample at 1 kHz:
/// 12 600× finer).
pub const ACCEL_PER_M_S2: f64 = 1e6;

/// The largest count: 2⁵⁰, so that `(c / k) · k` rounds back to `c` (see [`quantise`]).
pub const MAX_COUNT: f64 = 1_125_899_906_842_624.0;

/// The count of `v` at `per_unit` counts a unit: `round(v · per_unit)`, or `None` when it has
/// none (non-finite, or beyond ±[`MAX_COUNT`]).
pub fn count(v: f64, per_unit: f64) -> Option<i64> {
    let c = (v * per_unit).round();
    (c.abs() <= MAX_COUNT).then_some(c as i64)
}

/// The value of count `c`: `c / per_unit`.
pub fn value(c: i64, per_unit: f64) -> f64 {
    c as f64 / per_unit
}

/// `v` at the log's resolution: `count(v) / per_unit`, or `v` itself when it has no count.
pub fn quantise(v: f64, per_unit: f64) -> f64 {
    count(v, per_unit).map_or(v, |c| value(c, per_unit))
}

fn quantise_all<const N: usize>(v: [f64; N], per_unit: f64) -> [f64; N] {
    v.map(|x| quantise(x, per_unit))
}

/// `f` at the log's resolution, every value through [`quantise`]: what the log holds of it.
pub fn quantise_frame(f: &SensorFrame) -> SensorFrame {
    SensorFrame {
        sequence: f.sequence,
        time_s: quantise(f.time_s, TIME_PER_S),
        leg_lengths_m: quantise_all(f.leg_lengths_m, LENGTH_PER_M),
        leg_forces_n: quantise_all(f.leg_forces_n, FORCE_PER_N),
        gyro_rad_s: quantise_all(f.gyro_rad_s, GYRO_PER_RAD_S),
        accel_m_s2: quantise_all(f.accel_m_s2, ACCEL_PER_M_S2),
        status: f.status,
    }
}

/// A backend whose sensor frames are read at the log's resolution ([`quantise_frame`]): the
/// estimator, the controller and the log see the same numbers.
pub struct AtLogResolution<'a, B: Backend>(pub &'a mut B);

impl<B: Backend> Backend for AtLogResolution<'_, B> {
    type Error = B::Error;

    fn read(&mut self) -> Result<SensorFrame, Self::Error> {
        self.0.read().map(|f| quantise_frame(&f))
    }

    fn write(&mut self, command: &CommandFrame) -> Result<(), Self::Error> {
        self.0.write(command)
    }

    fn sample_period_s(&self) -> f64 {
        self.0.sample_period_s()
    }
}

/// Appends frame `frame`'s `values` at `per_unit` to `counts` (delta-coded against `last`,
/// which it updates); a value without a count goes to `raw` at `offset` plus its position in
/// the column and repeats the previous count (difference 0).
fn push_column(
    counts: &mut Vec<i64>,
    raw: (&mut Vec<u32>, &mut Vec<f64>),
    offset: usize,
    frame: usize,
    values: &[f64],
    per_unit: f64,
    last: &mut [i64],
) {
    let w = values.len();
    for (j, (&v, prev)) in values.iter().zip(last.iter_mut()).enumerate() {
        let c = match count(v, per_unit) {
            Some(c) => c,
            None => {
                raw.0.push((offset + frame * w + j) as u32);
                raw.1.push(v);
                *prev
            }
        };
        counts.push(if frame == 0 { c } else { c.wrapping_sub(*prev) });
        *prev = c;
    }
}

/// Undoes the delta coding of `counts` (`w` values a frame, `n` frames), checking the length.
fn undelta(name: &str, counts: &[i64], w: usize, n: usize) -> Result<Vec<i64>, String> {
    if counts.len() != w * n {
        return Err(format!(
            "does not match its schema ({name} holds {} numbers, not {})",
            counts.len(),
            w * n
        ));
    }
    let mut out = counts.to_vec();
    for i in w..out.len() {
        out[i] = out[i].wrapping_add(out[i - w]);
    }
    Ok(out)
}

/// The values of undelta'd `counts`, with the raw values of the block put back.
fn values(counts: &[i64], per_unit: f64, offset: usize, raw: &[(u32, f64)]) -> Vec<f64> {
    let mut v: Vec<f64> = counts.iter().map(|&c| value(c, per_unit)).collect();
    for &(i, x) in raw {
        if let Some(slot) = (i as usize).checked_sub(offset).and_then(|k| v.get_mut(k)) {
            *slot = x;
        }
    }
    v
}

fn raw_pairs(index: &[u32], value: &[f64], len: usize) -> Result<Vec<(u32, f64)>, String> {
    if index.len() != value.len() || index.iter().any(|&i| i as usize >= len) {
        return Err("does not match its schema (raw_index and raw_value disagree)".into());
    }
    Ok(index.iter().copied().zip(value.iter().copied()).collect())
}

/// `stewart.SensorBlock` on `/sensors`: up to [`BLOCK_FRAMES`] consecutive frames of one
/// measurement, in counts (see the module's docs).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct SensorBlock {
    /// Measurement (`tare`, `loaded`).
    pub run: &'static str,
    /// Backend sample counters, delta-coded.
    pub sequence: Vec<i64>,
    /// Sample instants, ns, delta-coded.
    pub time_ns: Vec<i64>,
    /// Leg lengths, nm, 6 a frame, delta-coded.
    pub leg_lengths_nm: Vec<i64>,
    /// Axial leg forces, mN, 6 a frame, delta-coded.
    pub leg_forces_mn: Vec<i64>,
    /// Angular rates in the IMU's axes, µrad/s, 3 a frame, delta-coded.
    pub gyro_urad_s: Vec<i64>,
    /// Specific force in the IMU's axes, µm/s², 3 a frame, delta-coded.
    pub accel_um_s2: Vec<i64>,
    /// Backend status bits, one a frame.
    pub status: Vec<u32>,
    /// Positions (time 0..n, lengths n..7n, forces 7n..13n, gyro 13n..16n, accel 16n..19n)
    /// of the values without a count.
    pub raw_index: Vec<u32>,
    /// Those values, exactly.
    pub raw_value: Vec<f64>,
}

impl SensorBlock {
    /// An empty block of measurement `run`.
    pub fn new(run: &'static str) -> Self {
        Self {
            run,
            ..Self::default()
        }
    }

    /// The block of `frames` of measurement `run`, ready to write.
    pub fn of_frames(run: &'static str, frames: &[SensorFrame]) -> Self {
        let mut b = Self::new(run);
        let mut last = SensorCounts::default();
        for f in frames {
            b.push(f, &mut last);
        }
        b.finish();
        b
    }

    /// Frames held.
    pub fn len(&self) -> usize {
        self.status.len()
    }

    /// No frame held.
    pub fn is_empty(&self) -> bool {
        self.status.is_empty()
    }

    /// Appends `f`; `last` carries the previous frame's counts (reset by [`Self::clear`]).
    pub fn push(&mut self, f: &SensorFrame, last: &mut SensorCounts) {
        let n = self.len();
        let seq = f.sequence as i64;
        self.sequence.push(if n == 0 {
            seq
        } else {
            seq.wrapping_sub(last.sequence)
        });
        last.sequence = seq;
        let (ri, rv) = (&mut self.raw_index, &mut self.raw_value);
        push_column(
            &mut self.time_ns,
            (ri, rv),
            0,
            n,
            &[f.time_s],
            TIME_PER_S,
            &mut last.time,
        );
        let lengths = &f.leg_lengths_m;
        push_column(
            &mut self.leg_lengths_nm,
            (ri, rv),
            LENGTHS,
            n,
            lengths,
            LENGTH_PER_M,
            &mut last.lengths,
        );
        let forces = &f.leg_forces_n;
        push_column(
            &mut self.leg_forces_mn,
            (ri, rv),
            FORCES,
            n,
            forces,
            FORCE_PER_N,
            &mut last.forces,
        );
        let gyro = &f.gyro_rad_s;
        push_column(
            &mut self.gyro_urad_s,
            (ri, rv),
            GYRO,
            n,
            gyro,
            GYRO_PER_RAD_S,
            &mut last.gyro,
        );
        let accel = &f.accel_m_s2;
        push_column(
            &mut self.accel_um_s2,
            (ri, rv),
            ACCEL,
            n,
            accel,
            ACCEL_PER_M_S2,
            &mut last.accel,
        );
        self.status.push(f.status.0);
    }

    /// Fixes the raw values' positions for the block's frame count (call once, before
    /// writing): during [`Self::push`] they are `column tag · 2²⁴ + position in the column`.
    pub fn finish(&mut self) {
        let n = self.len();
        for i in &mut self.raw_index {
            let (tag, k) = ((*i >> 24) as usize, (*i & 0xff_ffff) as usize);
            let start = match tag {
                0 => 0,
                1 => n,
                2 => 7 * n,
                3 => 13 * n,
                _ => 16 * n,
            };
            *i = (start + k) as u32;
        }
    }

    /// Empties the block for measurement `run`, keeping its buffers.
    pub fn clear(&mut self, run: &'static str) {
        self.run = run;
        self.sequence.clear();
        self.time_ns.clear();
        self.leg_lengths_nm.clear();
        self.leg_forces_mn.clear();
        self.gyro_urad_s.clear();
        self.accel_um_s2.clear();
        self.status.clear();
        self.raw_index.clear();
        self.raw_value.clear();
    }
}

/// While a block is filled, a raw value's position is `column tag · 2²⁴ + position in the
/// column` (tags: time 0, then the block's columns in order); `finish` makes it the position
/// in the block.
const TAG: usize = 1 << 24;
const LENGTHS: usize = TAG;
const FORCES: usize = 2 * TAG;
const GYRO: usize = 3 * TAG;
const ACCEL: usize = 4 * TAG;

/// The counts of the previous frame, which the next frame's differences are taken from.
#[derive(Clone, Copy, Debug, Default)]
pub struct SensorCounts {
    sequence: i64,
    time: [i64; 1],
    lengths: [i64; 6],
    forces: [i64; 6],
    gyro: [i64; 3],
    accel: [i64; 3],
}

impl Encode for SensorBlock {
    const NAME: &'static str = "stewart.SensorBlock";
    fn encode(&self, e: &mut Encoder<'_>) {
        e.string(1, self.run);
        e.sints(2, &self.sequence);
        e.sints(3, &self.time_ns);
        e.sints(4, &self.leg_lengths_nm);
        e.sints(5, &self.leg_forces_mn);
        e.sints(6, &self.gyro_urad_s);
        e.sints(7, &self.accel_um_s2);
        e.uints(8, &self.status);
        e.uints(9, &self.raw_index);
        e.doubles(10, &self.raw_value);
    }
}

/// The frames of a decoded `stewart.SensorBlock`, or why it does not fit its schema.
pub fn sensor_frames(p: &crate::proto::SensorBlock) -> Result<Vec<SensorFrame>, String> {
    let n = p.status.len();
    let seq = undelta("sequence", &p.sequence, 1, n)?;
    let raw = raw_pairs(&p.raw_index, &p.raw_value, 19 * n)?;
    let time = values(&undelta("time_ns", &p.time_ns, 1, n)?, TIME_PER_S, 0, &raw);
    let len = values(
        &undelta("leg_lengths_nm", &p.leg_lengths_nm, 6, n)?,
        LENGTH_PER_M,
        n,
        &raw,
    );
    let force = values(
        &undelta("leg_forces_mn", &p.leg_forces_mn, 6, n)?,
        FORCE_PER_N,
        7 * n,
        &raw,
    );
    let gyro = values(
        &undelta("gyro_urad_s", &p.gyro_urad_s, 3, n)?,
        GYRO_PER_RAD_S,
        13 * n,
        &raw,
    );
    let accel = values(
        &undelta("accel_um_s2", &p.accel_um_s2, 3, n)?,
        ACCEL_PER_M_S2,
        16 * n,
        &raw,
    );
    Ok((0..n)
        .map(|k| SensorFrame {
            sequence: seq[k] as u64,
            time_s: time[k],
            leg_lengths_m: core::array::from_fn(|j| len[6 * k + j]),
            leg_forces_n: core::array::from_fn(|j| force[6 * k + j]),
            gyro_rad_s: core::array::from_fn(|j| gyro[3 * k + j]),
            accel_m_s2: core::array::from_fn(|j| accel[3 * k + j]),
            status: Status(p.status[k]),
        })
        .collect())
}

mod commands;

pub use commands::{command_frames, CommandBlock, CommandCounts, CommandRecord};

#[cfg(test)]
mod tests;
