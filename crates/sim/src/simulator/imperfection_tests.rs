//! The sensor model inside the simulator: lost frames in the backend, the accelerometer at its
//! drawn position, everything off reproducing the truth.

use super::tests::{car, geometry};
use super::*;
use crate::sensors::{NoisePreset, SensorConfig};

/// One physics step per sample, so a frame's IMU channels are the instant's (not a mean).
fn config(sensors: SensorConfig) -> SimConfig {
    SimConfig {
        sensors,
        substeps: 1,
        ..Default::default()
    }
}

fn simulator(sensors: SensorConfig, seed: u64) -> Simulator {
    Simulator::new(
        geometry(),
        BodyProperties::default(),
        Some(car()),
        &config(sensors),
        seed,
    )
    .unwrap()
}

/// The static load plus a few sines per leg at time `t`.
fn forces(hold: &[f64; 6], t: f64) -> [f64; 6] {
    core::array::from_fn(|i| {
        hold[i] + 600.0 * (2.0 * core::f64::consts::PI * (1.1 + 0.3 * i as f64) * t).sin()
    })
}

fn command(k: u64, forces: [f64; 6]) -> CommandFrame {
    CommandFrame {
        sequence: k,
        sensor_sequence: k,
        leg_forces_n: forces,
        enable: true,
    }
}

#[test]
fn everything_off_reproduces_the_truth_exactly() {
    let mut s = simulator(SensorConfig::preset(NoisePreset::None), 4);
    let hold = s.true_leg_forces_n();
    for k in 0..300 {
        let f = s.read().unwrap();
        assert_eq!(f, s.clean_frame());
        assert_eq!(f.sequence, k);
        s.write(&command(k, forces(&hold, s.time_s()))).unwrap();
    }
    // And the datasheet's errors do change it.
    let mut s = simulator(SensorConfig::preset(NoisePreset::Realistic), 4);
    s.write(&command(0, hold)).unwrap();
    assert_ne!(s.read().unwrap(), s.clean_frame());
}

#[test]
fn lost_frames_skip_sequences_at_the_configured_rate_and_the_rig_runs_on() {
    let mut lossy = SensorConfig::preset(NoisePreset::None);
    lossy.timing.frame_loss = 0.05;
    let mut s = simulator(lossy, 8);
    let mut reference = simulator(SensorConfig::preset(NoisePreset::None), 8);
    // A constant command: the lossy rig, which repeats it over each lost period, and the
    // lossless one must then be in the same state at the same sample.
    let hold = s.true_leg_forces_n();
    let cmd = command(0, forces(&hold, 0.3));
    let (mut reads, mut last, mut lost, mut double) = (0u64, 0u64, 0u64, 0u64);
    while last < 6000 {
        s.write(&cmd).unwrap();
        let f = s.read().unwrap();
        reads += 1;
        let gap = f.sequence - last;
        assert!(gap >= 1);
        lost += gap - 1;
        double += u64::from(gap == 2);
        assert_eq!(f.time_s, s.time_s());
        assert!((f.time_s - f.sequence as f64 * 1e-3).abs() < 1e-12);
        while reference.read().unwrap().sequence < f.sequence {
            reference.write(&cmd).unwrap();
        }
        assert_eq!(f, reference.read().unwrap(), "sample {}", f.sequence);
        last = f.sequence;
    }
    // Each sampled frame lost with p = 0.05: lost among all sampled, within 5 sigma.
    let n = (reads + lost) as f64;
    let (mean, sd) = (0.05 * n, (0.05 * 0.95 * n).sqrt());
    assert!((lost as f64 - mean).abs() < 5.0 * sd, "{lost} lost of {n}");
    assert!(
        double > 0 && double < lost,
        "single and repeated losses both occur"
    );
}

#[test]
fn the_accelerometer_reads_at_its_drawn_position() {
    let mut sensors = SensorConfig::preset(NoisePreset::None);
    sensors.accelerometer.mount_m = [0.3, -0.2, 0.1];
    sensors.accelerometer.mount_sigma_m = 0.05;
    let mut s = simulator(sensors, 2);
    let r = s.sensors.mount_m();
    let described = Vector3::new(0.3, -0.2, 0.1);
    assert!((r - described).norm() > 1e-3, "drawn {r}");
    let hold = s.true_leg_forces_n();
    for k in 0..200 {
        s.write(&command(k, forces(&hold, s.time_s()))).unwrap();
    }
    // f_a = f + ω̇ × r + ω × (ω × r), written out from the truth.
    let acc = s.true_acceleration();
    let omega = s.true_pose().rotation.inverse() * s.true_velocity().angular_rad_s;
    assert!(omega.norm() > 1e-3, "the plate turns: {omega}");
    let want =
        acc.specific_force_m_s2 + acc.angular_rad_s2.cross(&r) + omega.cross(&omega.cross(&r));
    let got = Vector3::from(s.read().unwrap().accel_m_s2);
    assert!((got - want).norm() < 1e-9, "{got} vs {want}");
    let at_described = acc.specific_force_m_s2
        + acc.angular_rad_s2.cross(&described)
        + omega.cross(&omega.cross(&described));
    assert!((got - at_described).norm() > 1e-6);
}

#[test]
fn jittered_frames_keep_their_sequence_and_stamp_their_instant() {
    let mut sensors = SensorConfig::preset(NoisePreset::None);
    sensors.timing.jitter_sigma_s = 1e-5;
    let mut s = simulator(sensors, 6);
    let hold = s.true_leg_forces_n();
    let mut offsets = Vec::new();
    for k in 0..2000 {
        let f = s.read().unwrap();
        assert_eq!(f.sequence, k);
        offsets.push(f.time_s - s.time_s());
        s.write(&command(k, forces(&hold, s.time_s()))).unwrap();
    }
    let n = offsets.len() as f64;
    let rms = (offsets.iter().map(|d| d * d).sum::<f64>() / n).sqrt();
    assert!((rms / 1e-5 - 1.0).abs() < 5.0 / (2.0 * n).sqrt(), "{rms}");
}
