//! The timing errors: skew, jitter and lost frames, on frames whose truth is known.

use super::tests::{assert_spread, channels, frame, off, only, RATE_HZ, T};
use super::*;

#[test]
fn skew_shifts_a_ramp_by_tau_and_leaves_the_other_channels() {
    let cfg = only(ErrorSource::TimeSkew);
    let mut taus = Vec::new();
    let mut signs = [false; 2];
    for seed in 0..2000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let tau = m.skew_s;
        taus.push(tau);
        signs[usize::from(tau > 0.0)] = true;
        if seed >= 50 {
            continue;
        }
        for k in 0..10 {
            let ramp = |t: f64| 3.0 * t;
            let out = m.measure(&frame(k, ramp), &CellLoads::default(), true);
            // The first frame has no previous one and is not shifted.
            let want = if k == 0 {
                frame(0, ramp)
            } else {
                frame(k, |t| ramp(t - tau))
            };
            assert_eq!(out.leg_lengths_m, frame(k, ramp).leg_lengths_m);
            assert_eq!(out.leg_forces_n, frame(k, ramp).leg_forces_n);
            assert_eq!(out.time_s, k as f64 * T);
            for (a, b) in out
                .gyro_rad_s
                .iter()
                .chain(&out.accel_m_s2)
                .zip(want.gyro_rad_s.iter().chain(&want.accel_m_s2))
            {
                assert!((a - b).abs() < 1e-12, "{a} vs {b}");
            }
        }
    }
    assert!(signs[0] && signs[1], "both signs of τ drawn");
    assert_spread(&taus, cfg.timing.imu_skew_sigma_s, "skew");
}

#[test]
fn the_shift_errs_by_the_documented_second_order_term() {
    // On x = t² the linear rule's error is exactly −½ Δ (Δ + T) ẍ = −Δ (Δ + T).
    let mut cfg = off();
    cfg.timing.imu_skew_sigma_s = 5e-4;
    for seed in 0..20 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let delta = -m.skew_s;
        let square = |k: u64| {
            let t = k as f64 * T;
            SensorFrame {
                gyro_rad_s: [t * t; 3],
                ..Default::default()
            }
        };
        m.measure(&square(4), &CellLoads::default(), true);
        let out = m.measure(&square(5), &CellLoads::default(), true);
        let t = 5.0 * T;
        let err = out.gyro_rad_s[0] - (t + delta).powi(2);
        assert!((err + delta * (delta + T)).abs() < 1e-15, "{err}");
    }
}

#[test]
fn jitter_moves_time_stamps_and_values_together() {
    let cfg = only(ErrorSource::TimestampJitter);
    let mut m = SensorModel::new(cfg, RATE_HZ, 9);
    let ramp = |t: f64| 2.0 * t - 0.3;
    let mut deltas = Vec::new();
    for k in 0..20_000u64 {
        let out = m.measure(&frame(k, ramp), &CellLoads::default(), true);
        assert_eq!(out.sequence, k);
        let delta = out.time_s - k as f64 * T;
        assert!(delta.abs() <= 0.5 * T);
        if k > 0 {
            // Every channel describes the frame's own time stamp.
            let want = frame(k, |t| ramp(t + delta));
            for (a, b) in channels(&out).iter().zip(channels(&want)) {
                assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
            }
        }
        deltas.push(delta);
    }
    assert_spread(&deltas, cfg.timing.jitter_sigma_s, "jitter");
    let lag1 = deltas.windows(2).map(|w| w[0] * w[1]).sum::<f64>()
        / (deltas.len() as f64 * cfg.timing.jitter_sigma_s.powi(2));
    assert!(lag1.abs() < 5.0 / (deltas.len() as f64).sqrt(), "{lag1}");
}

#[test]
fn skew_and_jitter_add() {
    let mut cfg = only(ErrorSource::TimeSkew);
    cfg.timing.jitter_sigma_s = 2e-5;
    let mut m = SensorModel::new(cfg, RATE_HZ, 4);
    let tau = m.skew_s;
    let ramp = |t: f64| 5.0 * t;
    m.measure(&frame(0, ramp), &CellLoads::default(), true);
    for k in 1..100 {
        let out = m.measure(&frame(k, ramp), &CellLoads::default(), true);
        let delta = out.time_s - k as f64 * T;
        let want = frame(k, |t| ramp(t + delta - tau));
        assert!((out.gyro_rad_s[2] - want.gyro_rad_s[2]).abs() < 1e-12);
        let lengths = frame(k, |t| ramp(t + delta)).leg_lengths_m;
        assert!((out.leg_lengths_m[1] - lengths[1]).abs() < 1e-12);
    }
}

#[test]
fn frames_are_lost_at_the_configured_rate() {
    let mut cfg = off();
    cfg.timing.frame_loss = 0.01;
    let mut m = SensorModel::new(cfg, RATE_HZ, 5);
    let n = 100_000;
    let clean = frame(0, |t| t);
    let lost = (0..n)
        .filter(|_| {
            m.measure(&clean, &CellLoads::default(), true);
            m.frame_lost()
        })
        .count() as f64;
    let (mean, sd) = (0.01 * n as f64, (0.01 * 0.99 * n as f64).sqrt());
    assert!((lost - mean).abs() < 5.0 * sd, "{lost} lost of {n}");
}
