use prost::Message as _;

use super::*;
use crate::proto::{self, Encoder};

fn awkward(i: usize) -> f64 {
    [
        f64::NAN,
        -0.0,
        f64::INFINITY,
        1.924_573,
        f64::NEG_INFINITY,
        1.0 / 3.0,
        -1e-300,
        f64::MAX,
        -2.0e6,
        5e-324,
    ][i % 10]
}

/// A frame whose values wander like a run's (sine plus a fixed pseudo-random wobble).
fn frame(k: u64) -> SensorFrame {
    let x = k as f64;
    let wobble = |j: usize| ((x * 12.9898 + j as f64 * 78.233).sin() * 43_758.545_3).fract();
    SensorFrame {
        sequence: 1000 + k,
        time_s: 0.001 * x + 1e-5 * wobble(0),
        leg_lengths_m: core::array::from_fn(|j| 1.9 + 0.01 * (x * 0.01 + j as f64).sin()),
        leg_forces_n: core::array::from_fn(|j| 3000.0 + 4.0 * wobble(j + 1)),
        gyro_rad_s: core::array::from_fn(|j| 0.1 * (x * 0.003).cos() + 1.6e-3 * wobble(j + 7)),
        accel_m_s2: core::array::from_fn(|j| 9.8 * (j == 2) as u8 as f64 + 0.0126 * wobble(j)),
        status: Status(k as u32 % 3),
    }
}

fn encode_decode(frames: &[SensorFrame]) -> Vec<SensorFrame> {
    let mut block = SensorBlock::new("loaded");
    let mut last = SensorCounts::default();
    for f in frames {
        block.push(f, &mut last);
    }
    block.finish();
    let mut buf = Vec::new();
    block.encode(&mut Encoder::new(&mut buf));
    let p = proto::SensorBlock::decode(buf.as_slice()).unwrap();
    assert_eq!(p.run, "loaded");
    sensor_frames(&p).unwrap()
}

fn bits(f: &SensorFrame) -> Vec<u64> {
    let mut v = vec![f.sequence, f.time_s.to_bits(), u64::from(f.status.0)];
    for x in f
        .leg_lengths_m
        .iter()
        .chain(&f.leg_forces_n)
        .chain(&f.gyro_rad_s)
        .chain(&f.accel_m_s2)
    {
        v.push(x.to_bits());
    }
    v
}

#[test]
fn quantising_twice_changes_nothing_and_errs_by_at_most_half_a_count() {
    for k in [LENGTH_PER_M, FORCE_PER_N, GYRO_PER_RAD_S, TIME_PER_S] {
        for i in 0..20_000 {
            let v = (i as f64 * 0.618_033_988_749_895).sin() * 10f64.powi(i % 13 - 6);
            let q = quantise(v, k);
            assert_eq!(quantise(q, k).to_bits(), q.to_bits(), "{v} at {k}");
            // Half a count, plus the rounding of v · k and of c / k.
            let bound = 0.5 / k + 2.0 * f64::EPSILON * v.abs();
            assert!((q - v).abs() <= bound, "{v} at {k}: {q}");
        }
        // The largest counts round-trip too.
        let big = MAX_COUNT / k;
        assert_eq!(quantise(quantise(big, k), k), quantise(big, k));
        assert_eq!(quantise(big * 4.0, k), big * 4.0, "beyond the counts: kept");
    }
    assert!(quantise(f64::NAN, 1e9).is_nan());
    assert_eq!(quantise(f64::INFINITY, 1e9), f64::INFINITY);
}

#[test]
fn a_quantised_block_reads_back_bit_for_bit() {
    let frames: Vec<SensorFrame> = (0..BLOCK_FRAMES as u64)
        .map(|k| quantise_frame(&frame(k)))
        .collect();
    let back = encode_decode(&frames);
    assert_eq!(back.len(), frames.len());
    for (a, b) in frames.iter().zip(&back) {
        assert_eq!(bits(a), bits(b));
    }
}

#[test]
fn values_without_a_count_are_kept_exactly_wherever_they_are() {
    let mut frames: Vec<SensorFrame> = (0..7).map(|k| quantise_frame(&frame(k))).collect();
    for (k, f) in frames.iter_mut().enumerate() {
        f.leg_lengths_m[k % 6] = awkward(k);
        f.leg_forces_n[(k + 1) % 6] = awkward(k + 3);
        f.gyro_rad_s[k % 3] = awkward(k + 5);
        f.accel_m_s2[(k + 2) % 3] = awkward(k + 7);
        if k == 3 {
            f.time_s = f64::NAN;
        }
    }
    let expected: Vec<SensorFrame> = frames.iter().map(quantise_frame).collect();
    let back = encode_decode(&frames);
    for (a, b) in expected.iter().zip(&back) {
        assert_eq!(bits(a), bits(b));
    }
    assert!(back[3].time_s.is_nan() && back[0].leg_lengths_m[0].is_nan());
}

#[test]
fn the_first_frame_is_in_plain_counts_and_the_rest_are_differences() {
    let frames: Vec<SensorFrame> = (0..3).map(|k| quantise_frame(&frame(k))).collect();
    let mut block = SensorBlock::new("tare");
    let mut last = SensorCounts::default();
    for f in &frames {
        block.push(f, &mut last);
    }
    let nm = |f: &SensorFrame, j: usize| (f.leg_lengths_m[j] * 1e9).round() as i64;
    assert_eq!(block.leg_lengths_nm[2], nm(&frames[0], 2));
    assert_eq!(
        block.leg_lengths_nm[6 + 2],
        nm(&frames[1], 2) - nm(&frames[0], 2)
    );
    assert_eq!(block.sequence, vec![1000, 1, 1]);
}

#[test]
fn a_block_whose_columns_disagree_is_refused() {
    let frames: Vec<SensorFrame> = (0..4).map(frame).collect();
    let mut block = SensorBlock::new("tare");
    let mut last = SensorCounts::default();
    for f in &frames {
        block.push(f, &mut last);
    }
    block.finish();
    block.gyro_urad_s.pop();
    let mut buf = Vec::new();
    block.encode(&mut Encoder::new(&mut buf));
    let p = proto::SensorBlock::decode(buf.as_slice()).unwrap();
    let err = sensor_frames(&p).unwrap_err();
    assert!(
        err.contains("gyro_urad_s holds 11 numbers, not 12"),
        "{err}"
    );
    let mut p2 = p.clone();
    p2.gyro_urad_s.push(0);
    p2.raw_index = vec![1_000];
    p2.raw_value = vec![1.0];
    assert!(sensor_frames(&p2).unwrap_err().contains("raw_index"));
}

#[test]
fn commands_read_back_at_the_millinewton() {
    let mut block = CommandBlock::new("loaded");
    let mut last = CommandCounts::default();
    let commands: Vec<(f64, CommandFrame)> = (0..BLOCK_FRAMES as u64)
        .map(|k| {
            let f = frame(k);
            let mut c = CommandFrame::safe_stop(7 + k, f.sequence);
            c.leg_forces_n = f.leg_forces_n;
            c.leg_forces_n[1] = if k == 4 { f64::NAN } else { 1.0e4 / 3.0 };
            c.enable = k % 2 == 0;
            (f.time_s, c)
        })
        .collect();
    for (t, c) in &commands {
        block.push(*t, c, &mut last);
    }
    block.finish();
    let mut buf = Vec::new();
    block.encode(&mut Encoder::new(&mut buf));
    let back = command_frames(&proto::CommandBlock::decode(buf.as_slice()).unwrap()).unwrap();
    for ((t, c), r) in commands.iter().zip(&back) {
        assert_eq!(r.time_s, quantise(*t, TIME_PER_S));
        assert_eq!(r.command.sequence, c.sequence);
        assert_eq!(r.command.sensor_sequence, c.sensor_sequence);
        assert_eq!(r.command.enable, c.enable);
        for (a, b) in c.leg_forces_n.iter().zip(&r.command.leg_forces_n) {
            assert!(
                a.is_nan() && b.is_nan() || (a - b).abs() <= 0.5e-3,
                "{a} {b}"
            );
        }
    }
}
