//! Each error of the rig as built: its statistics or exact effect, checked on frames whose truth
//! is known; and the helpers of `timing_tests`.

use super::*;
use crate::sensors::{
    AccelerometerConfig, GyroConfig, LegLengthSensorConfig, LoadCellConfig, NoisePreset,
};

pub(super) const RATE_HZ: f64 = 1000.0;
pub(super) const T: f64 = 1e-3;

/// Every figure zero.
pub(super) fn off() -> SensorConfig {
    SensorConfig::preset(NoisePreset::None)
}

/// The `realistic` figures of `source` alone (the others zero), as `Scenario::sim_config` maps
/// the switches.
pub(super) fn only(source: ErrorSource) -> SensorConfig {
    let r = SensorConfig::preset(NoisePreset::Realistic);
    let mut c = off();
    match source {
        ErrorSource::Noise => {
            c.leg_length = r.leg_length;
            c.load_cell.noise_sigma_n = r.load_cell.noise_sigma_n;
            c.load_cell.resolution_n = r.load_cell.resolution_n;
            c.gyro.noise_density_rad_s_sqrt_hz = r.gyro.noise_density_rad_s_sqrt_hz;
            c.gyro.bias_sigma_rad_s = r.gyro.bias_sigma_rad_s;
            c.accelerometer.noise_density_m_s2_sqrt_hz = r.accelerometer.noise_density_m_s2_sqrt_hz;
        }
        ErrorSource::AccelBias => c.accelerometer.bias_sigma_m_s2 = r.accelerometer.bias_sigma_m_s2,
        ErrorSource::LoadCellOffset => {
            c.load_cell.bias_sigma_n = r.load_cell.bias_sigma_n;
            c.load_cell.drift_sigma_n_s = r.load_cell.drift_sigma_n_s;
        }
        ErrorSource::LoadCellScale => c.load_cell.gain_sigma = r.load_cell.gain_sigma,
        ErrorSource::LoadCellCrosstalk => {
            c.load_cell.transverse_sigma = r.load_cell.transverse_sigma
        }
        ErrorSource::ImuMisalignment => {
            c.imu.misalignment_sigma_deg = r.imu.misalignment_sigma_deg;
            c.gyro.scale_sigma = r.gyro.scale_sigma;
            c.accelerometer.scale_sigma = r.accelerometer.scale_sigma;
        }
        ErrorSource::ImuLeverArm => c.accelerometer.mount_sigma_m = r.accelerometer.mount_sigma_m,
        ErrorSource::TimeSkew => c.timing.imu_skew_sigma_s = r.timing.imu_skew_sigma_s,
        ErrorSource::TimestampJitter => c.timing.jitter_sigma_s = r.timing.jitter_sigma_s,
        ErrorSource::FrameLoss => c.timing.frame_loss = r.timing.frame_loss,
        _ => {}
    }
    c
}

pub(super) fn stats(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// The sample standard deviation of `xs` (zero-mean draws) is `sigma` within 5 standard errors
/// of a standard deviation, `sigma/√(2n)`.
pub(super) fn assert_spread(xs: &[f64], sigma: f64, what: &str) {
    let (mean, s) = stats(xs);
    let n = xs.len() as f64;
    assert!(mean.abs() < 5.0 * sigma / n.sqrt(), "{what}: mean {mean}");
    assert!(
        (s / sigma - 1.0).abs() < 5.0 / (2.0 * n).sqrt(),
        "{what}: spread {s} vs {sigma}"
    );
}

/// Frame `k` of a motion where every channel is `f(t)` plus a per-channel offset.
pub(super) fn frame(k: u64, f: impl Fn(f64) -> f64) -> SensorFrame {
    let t = k as f64 * T;
    let x = f(t);
    SensorFrame {
        sequence: k,
        time_s: t,
        leg_lengths_m: core::array::from_fn(|i| 1.5 + 0.01 * i as f64 + 0.2 * x),
        leg_forces_n: core::array::from_fn(|i| 5000.0 + 100.0 * i as f64 + 2000.0 * x),
        gyro_rad_s: [0.1 + x, -0.2 + 0.5 * x, 0.3 - x],
        accel_m_s2: [0.5 + x, 0.1 - 2.0 * x, 9.8 + 3.0 * x],
        ..Default::default()
    }
}

/// The channels of a frame as one list.
pub(super) fn channels(f: &SensorFrame) -> Vec<f64> {
    let mut v = f.leg_lengths_m.to_vec();
    v.extend(f.leg_forces_n);
    v.extend(f.gyro_rad_s);
    v.extend(f.accel_m_s2);
    v
}

fn loads(t: f64) -> CellLoads {
    CellLoads {
        transverse_n: core::array::from_fn(|i| [300.0 + 10.0 * i as f64 + t, -150.0]),
    }
}

#[test]
fn everything_off_passes_truth_through_exactly() {
    let mut m = SensorModel::new(off(), RATE_HZ, 7);
    for k in 0..50 {
        let clean = frame(k, |t| (7.0 * t).sin());
        assert_eq!(m.measure(&clean, &loads(k as f64), true), clean);
        assert!(!m.frame_lost());
    }
    assert_eq!(m.mount_m(), Vector3::zeros());
}

#[test]
fn noise_statistics_match_the_config() {
    for preset in [NoisePreset::Realistic, NoisePreset::Harsh] {
        let p = SensorConfig::preset(preset);
        // Noise and biases only.
        let cfg = SensorConfig {
            leg_length: p.leg_length,
            load_cell: LoadCellConfig {
                gain_sigma: 0.0,
                transverse_sigma: 0.0,
                drift_sigma_n_s: 0.0,
                ..p.load_cell
            },
            gyro: GyroConfig {
                scale_sigma: 0.0,
                ..p.gyro
            },
            accelerometer: AccelerometerConfig {
                scale_sigma: 0.0,
                mount_sigma_m: 0.0,
                ..p.accelerometer
            },
            ..off()
        };
        let mut m = SensorModel::new(cfg, RATE_HZ, 42);
        let (gyro_sigma, accel_sigma) = (m.gyro_sigma_rad_s, m.accel_sigma_m_s2);
        assert!((gyro_sigma - cfg.gyro.noise_density_rad_s_sqrt_hz * RATE_HZ.sqrt()).abs() < 1e-15);
        let clean = SensorFrame {
            leg_forces_n: [5000.0; 6],
            accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
            ..Default::default()
        };
        let n = 20_000;
        let mut force = Vec::with_capacity(n);
        let mut gyro = Vec::with_capacity(n);
        let mut accel = Vec::with_capacity(n);
        for _ in 0..n {
            let f = m.measure(&clean, &CellLoads::default(), true);
            force.push(f.leg_forces_n[2] - 5000.0);
            gyro.push(f.gyro_rad_s[1]);
            accel.push(f.accel_m_s2[2] - stewart_types::STANDARD_GRAVITY_M_S2);
        }
        // Sample standard deviation within 3 % (its own standard error is 0.5 % here);
        // quantization adds step²/12 to the variance.
        let q = cfg.load_cell.resolution_n;
        let want_force = (cfg.load_cell.noise_sigma_n.powi(2) + q * q / 12.0).sqrt();
        for ((_, s), want) in [
            (stats(&force), want_force),
            (stats(&gyro), gyro_sigma),
            (stats(&accel), accel_sigma),
        ] {
            assert!((s / want - 1.0).abs() < 0.03, "{preset}: {s} vs {want}");
        }
        // The mean is the channel's constant bias: the same over both halves of the run,
        // within the noise of the means (5 standard errors).
        for (xs, sigma) in [
            (&force, want_force),
            (&gyro, gyro_sigma),
            (&accel, accel_sigma),
        ] {
            let (a, _) = stats(&xs[..n / 2]);
            let (b, _) = stats(&xs[n / 2..]);
            assert!((a - b).abs() < 5.0 * sigma * (4.0 / n as f64).sqrt());
        }
    }
}

#[test]
fn biases_spread_like_their_sigma() {
    let cfg = SensorConfig::preset(NoisePreset::Realistic);
    let models: Vec<SensorModel> = (0..3000)
        .map(|seed| SensorModel::new(cfg, RATE_HZ, seed))
        .collect();
    let cells: Vec<f64> = models.iter().flat_map(|m| m.load_cell_bias_n).collect();
    assert_spread(&cells, cfg.load_cell.bias_sigma_n, "load cell offset");
    let accel: Vec<f64> = models.iter().flat_map(|m| m.accel_bias_m_s2).collect();
    assert_spread(&accel, cfg.accelerometer.bias_sigma_m_s2, "accel bias");
    let gyro: Vec<f64> = models.iter().flat_map(|m| m.gyro_bias_rad_s).collect();
    assert_spread(&gyro, cfg.gyro.bias_sigma_rad_s, "gyro bias");
}

#[test]
fn quantization_rounds_to_the_resolution() {
    let cfg = SensorConfig {
        leg_length: LegLengthSensorConfig {
            noise_sigma_m: 0.0,
            resolution_m: 1e-6,
        },
        ..off()
    };
    let mut m = SensorModel::new(cfg, RATE_HZ, 1);
    let clean = SensorFrame {
        leg_lengths_m: [1.000_000_7; 6],
        ..Default::default()
    };
    let out = m.measure(&clean, &CellLoads::default(), true);
    assert!((out.leg_lengths_m[0] - 1.000_001).abs() < 1e-12);
}

#[test]
fn zero_drift_grows_linearly_at_a_rate_spread_like_its_figure() {
    let cfg = only(ErrorSource::LoadCellOffset);
    let at = |m: &mut SensorModel, t: f64| {
        let clean = SensorFrame {
            time_s: t,
            leg_forces_n: [8000.0; 6],
            ..Default::default()
        };
        m.measure(&clean, &CellLoads::default(), false).leg_forces_n
    };
    let mut rates = Vec::new();
    for seed in 0..1000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let (start, half, full) = (at(&mut m, 0.0), at(&mut m, 30.0), at(&mut m, 60.0));
        for i in 0..6 {
            let offset = start[i] - 8000.0;
            assert!((offset - m.load_cell_bias_n[i]).abs() < 1e-9);
            let (d30, d60) = (half[i] - start[i], full[i] - start[i]);
            assert!((d60 - 2.0 * d30).abs() < 1e-9, "not linear: {d30} {d60}");
            rates.push(d60 / 60.0);
        }
    }
    assert_spread(&rates, cfg.load_cell.drift_sigma_n_s, "drift rate");
    assert!((60.0 * cfg.load_cell.drift_sigma_n_s - 0.4).abs() < 1e-12);
}

#[test]
fn the_gain_scales_the_reading() {
    let cfg = only(ErrorSource::LoadCellScale);
    let mut gains = Vec::new();
    for seed in 0..1000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let read = |m: &mut SensorModel, f: f64| {
            let clean = SensorFrame {
                leg_forces_n: [f; 6],
                ..Default::default()
            };
            m.measure(&clean, &loads(0.0), true).leg_forces_n
        };
        let (one, two) = (read(&mut m, 6000.0), read(&mut m, 12000.0));
        for i in 0..6 {
            // A pure gain: no offset, and twice the force reads twice.
            assert!((two[i] - 2.0 * one[i]).abs() < 1e-9);
            gains.push(one[i] / 6000.0 - 1.0);
        }
    }
    assert_spread(&gains, cfg.load_cell.gain_sigma, "gain");
}

#[test]
fn crosstalk_reads_the_transverse_force_along_the_basis() {
    let cfg = only(ErrorSource::LoadCellCrosstalk);
    let (mut s1, mut s2) = (Vec::new(), Vec::new());
    for seed in 0..1000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let mut read = |t: [f64; 2]| {
            let clean = SensorFrame {
                leg_forces_n: [4000.0; 6],
                ..Default::default()
            };
            let cell = CellLoads {
                transverse_n: [t; 6],
            };
            m.measure(&clean, &cell, true)
                .leg_forces_n
                .map(|f| f - 4000.0)
        };
        let (a, b, both) = (
            read([1000.0, 0.0]),
            read([0.0, 1000.0]),
            read([300.0, -700.0]),
        );
        for i in 0..6 {
            // Linear in the transverse force: s₁ T₁ + s₂ T₂.
            let predicted = 0.3 * a[i] - 0.7 * b[i];
            assert!(
                (both[i] - predicted).abs() < 1e-9,
                "{} vs {predicted}",
                both[i]
            );
            s1.push(a[i] / 1000.0);
            s2.push(b[i] / 1000.0);
        }
    }
    assert_spread(&s1, cfg.load_cell.transverse_sigma, "s1");
    assert_spread(&s2, cfg.load_cell.transverse_sigma, "s2");
    let correlation = s1.iter().zip(&s2).map(|(a, b)| a * b).sum::<f64>()
        / (s1.len() as f64 * cfg.load_cell.transverse_sigma.powi(2));
    assert!(
        correlation.abs() < 5.0 / (s1.len() as f64).sqrt(),
        "{correlation}"
    );
}

#[test]
fn a_described_orientation_turns_the_readings_into_the_imus_axes() {
    // Yawed 90°: the IMU's x axis is P's y, so P's x is the IMU's −y.
    let mut cfg = off();
    cfg.imu.orientation_deg = [0.0, 0.0, 90.0];
    let mut m = SensorModel::new(cfg, RATE_HZ, 3);
    let clean = SensorFrame {
        gyro_rad_s: [1.0, 0.0, 0.0],
        accel_m_s2: [0.0, 2.0, 9.0],
        ..Default::default()
    };
    let out = m.measure(&clean, &CellLoads::default(), true);
    let close = |a: [f64; 3], b: [f64; 3]| (Vector3::from(a) - Vector3::from(b)).norm() < 1e-12;
    assert!(
        close(out.gyro_rad_s, [0.0, -1.0, 0.0]),
        "{:?}",
        out.gyro_rad_s
    );
    assert!(
        close(out.accel_m_s2, [2.0, 0.0, 9.0]),
        "{:?}",
        out.accel_m_s2
    );
}

#[test]
fn misalignment_rotates_a_known_vector_by_its_spread() {
    let mut cfg = only(ErrorSource::ImuMisalignment);
    cfg.gyro.scale_sigma = 0.0;
    cfg.accelerometer.scale_sigma = 0.0;
    let sigma = cfg.imu.misalignment_sigma_deg.to_radians();
    let mut angles = Vec::new();
    for seed in 0..1000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let read = |m: &mut SensorModel, v: [f64; 3]| {
            let clean = SensorFrame {
                gyro_rad_s: v,
                accel_m_s2: v,
                ..Default::default()
            };
            let out = m.measure(&clean, &CellLoads::default(), true);
            assert_eq!(out.gyro_rad_s, out.accel_m_s2, "one rotation for both");
            Vector3::from(out.gyro_rad_s)
        };
        // To first order Rᵀ v = v − θ × v: e_y reads (θz, 1, −θx), e_z reads (−θy, θx, 1).
        let (y, z) = (read(&mut m, [0.0, 1.0, 0.0]), read(&mut m, [0.0, 0.0, 1.0]));
        assert!((y.norm() - 1.0).abs() < 1e-12 && (z.norm() - 1.0).abs() < 1e-12);
        // θx read two ways agrees to second order (θy θz).
        assert!(
            (z.y + y.z).abs() < 20.0 * sigma * sigma,
            "θx: {} {}",
            z.y,
            -y.z
        );
        angles.extend([z.y, -z.x, y.x]);
    }
    assert_spread(&angles, sigma, "misalignment");
}

#[test]
fn scale_errors_multiply_each_axis() {
    let mut cfg = only(ErrorSource::ImuMisalignment);
    cfg.imu.misalignment_sigma_deg = 0.0;
    let (mut gyro, mut accel) = (Vec::new(), Vec::new());
    for seed in 0..1000 {
        let mut m = SensorModel::new(cfg, RATE_HZ, seed);
        let v = [1.0, -2.0, 4.0];
        let clean = SensorFrame {
            gyro_rad_s: v,
            accel_m_s2: v,
            ..Default::default()
        };
        let out = m.measure(&clean, &CellLoads::default(), true);
        for (i, x) in v.iter().enumerate() {
            gyro.push(out.gyro_rad_s[i] / x - 1.0);
            accel.push(out.accel_m_s2[i] / x - 1.0);
        }
    }
    assert_spread(&gyro, cfg.gyro.scale_sigma, "gyro scale");
    assert_spread(&accel, cfg.accelerometer.scale_sigma, "accel scale");
    assert_ne!(gyro, accel);
}

#[test]
fn the_lever_arm_spreads_about_the_described_point() {
    let mut cfg = only(ErrorSource::ImuLeverArm);
    cfg.accelerometer.mount_m = [0.1, -0.2, 0.3];
    let offsets: Vec<f64> = (0..2000)
        .flat_map(|seed| {
            let m = SensorModel::new(cfg, RATE_HZ, seed);
            (m.mount_m() - Vector3::new(0.1, -0.2, 0.3)).data.0[0]
        })
        .collect();
    assert_spread(&offsets, cfg.accelerometer.mount_sigma_m, "lever arm");
}

#[test]
fn each_source_draws_the_same_with_the_others_off() {
    let full_cfg = SensorConfig::preset(NoisePreset::Realistic);
    for seed in [0, 17, 123_456] {
        let full = SensorModel::new(full_cfg, RATE_HZ, seed);
        let one = |source| SensorModel::new(only(source), RATE_HZ, seed);
        assert_eq!(
            one(ErrorSource::Noise).gyro_bias_rad_s,
            full.gyro_bias_rad_s
        );
        assert_eq!(
            one(ErrorSource::AccelBias).accel_bias_m_s2,
            full.accel_bias_m_s2
        );
        let offset = one(ErrorSource::LoadCellOffset);
        assert_eq!(offset.load_cell_bias_n, full.load_cell_bias_n);
        assert_eq!(offset.load_cell_drift_n_s, full.load_cell_drift_n_s);
        assert_eq!(
            one(ErrorSource::LoadCellScale).load_cell_gain,
            full.load_cell_gain
        );
        assert_eq!(
            one(ErrorSource::LoadCellCrosstalk).load_cell_transverse,
            full.load_cell_transverse
        );
        let turned = one(ErrorSource::ImuMisalignment);
        assert_eq!(turned.to_imu, full.to_imu);
        assert_eq!(turned.gyro_scale, full.gyro_scale);
        assert_eq!(turned.accel_scale, full.accel_scale);
        assert_eq!(one(ErrorSource::ImuLeverArm).mount_m, full.mount_m);
        assert_eq!(one(ErrorSource::TimeSkew).skew_s, full.skew_s);
        // The per-frame streams: the same jitter, the same lost frames.
        let frames = |mut m: SensorModel| {
            (0..3000)
                .map(|k| {
                    let f = m.measure(&frame(k, |t| t), &CellLoads::default(), true);
                    (f.time_s, m.frame_lost())
                })
                .collect::<Vec<_>>()
        };
        let all = frames(full.clone());
        let jitter = frames(one(ErrorSource::TimestampJitter));
        let loss = frames(one(ErrorSource::FrameLoss));
        for k in 0..all.len() {
            assert_eq!(all[k].0, jitter[k].0);
            assert_eq!(all[k].1, loss[k].1);
        }
        assert!(all.iter().any(|f| f.1), "some frame lost");
    }
}

#[test]
fn the_sources_draws_are_uncorrelated() {
    // The first draw of each source per rig, over many seeds: no two move together.
    let cfg = SensorConfig::preset(NoisePreset::Realistic);
    let n = 2000;
    let draws: Vec<[f64; 8]> = (0..n)
        .map(|seed| {
            let m = SensorModel::new(cfg, RATE_HZ, seed);
            [
                m.gyro_bias_rad_s[0] / cfg.gyro.bias_sigma_rad_s,
                m.accel_bias_m_s2[0] / cfg.accelerometer.bias_sigma_m_s2,
                m.load_cell_bias_n[0] / cfg.load_cell.bias_sigma_n,
                m.load_cell_gain[0] / cfg.load_cell.gain_sigma,
                m.load_cell_transverse[0][0] / cfg.load_cell.transverse_sigma,
                m.gyro_scale[0] / cfg.gyro.scale_sigma,
                m.mount_m.x / cfg.accelerometer.mount_sigma_m,
                m.skew_s / cfg.timing.imu_skew_sigma_s,
            ]
        })
        .collect();
    for a in 0..8 {
        for b in 0..a {
            let c = draws.iter().map(|d| d[a] * d[b]).sum::<f64>() / n as f64;
            assert!(
                c.abs() < 5.0 / (n as f64).sqrt(),
                "sources {a} and {b}: {c}"
            );
        }
    }
}
