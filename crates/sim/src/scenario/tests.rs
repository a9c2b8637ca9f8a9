//! The world's switches, the built rig and the turned IMU, through the scenario that builds the
//! simulator.

use super::*;
use control::io::Backend;
use rig_description::load::{load, load_str};

use crate::{Imperfections, SensorConfig};

fn default_scenario() -> Scenario {
    Scenario::new(load(None).unwrap(), None, None).unwrap()
}

/// Every figure of the sensor model with its name.
fn figures(c: &SensorConfig) -> Vec<(&'static str, f64)> {
    let (l, f, g, a) = (c.leg_length, c.load_cell, c.gyro, c.accelerometer);
    vec![
        ("encoder noise", l.noise_sigma_m),
        ("encoder resolution", l.resolution_m),
        ("cell noise", f.noise_sigma_n),
        ("cell offset", f.bias_sigma_n),
        ("cell resolution", f.resolution_n),
        ("cell gain", f.gain_sigma),
        ("cell transverse", f.transverse_sigma),
        ("cell drift", f.drift_sigma_n_s),
        ("gyro noise", g.noise_density_rad_s_sqrt_hz),
        ("gyro bias", g.bias_sigma_rad_s),
        ("gyro scale", g.scale_sigma),
        ("accel noise", a.noise_density_m_s2_sqrt_hz),
        ("accel bias", a.bias_sigma_m_s2),
        ("accel scale", a.scale_sigma),
        ("accel position", a.mount_sigma_m),
        ("misalignment", c.imu.misalignment_sigma_deg),
        ("skew", c.timing.imu_skew_sigma_s),
        ("jitter", c.timing.jitter_sigma_s),
        ("frame loss", c.timing.frame_loss),
    ]
}

#[test]
fn each_switch_turns_on_its_own_figures_from_the_datasheet() {
    let mut s = default_scenario();
    let expected: [(ErrorSource, &[&str]); 10] = [
        (
            ErrorSource::Noise,
            &[
                "encoder noise",
                "encoder resolution",
                "cell noise",
                "cell resolution",
                "gyro noise",
                "gyro bias",
                "accel noise",
            ],
        ),
        (ErrorSource::AccelBias, &["accel bias"]),
        (ErrorSource::LoadCellOffset, &["cell offset", "cell drift"]),
        (ErrorSource::LoadCellScale, &["cell gain"]),
        (ErrorSource::LoadCellCrosstalk, &["cell transverse"]),
        (
            ErrorSource::ImuMisalignment,
            &["gyro scale", "accel scale", "misalignment"],
        ),
        (ErrorSource::ImuLeverArm, &["accel position"]),
        (ErrorSource::TimeSkew, &["skew"]),
        (ErrorSource::TimestampJitter, &["jitter"]),
        (ErrorSource::FrameLoss, &["frame loss"]),
    ];
    for (source, names) in expected {
        s.world.imperfections = Imperfections::only(source);
        let on: Vec<&str> = figures(&s.sim_config().sensors)
            .into_iter()
            .filter(|(_, v)| *v != 0.0)
            .map(|(name, _)| name)
            .collect();
        assert_eq!(on, names, "{source}");
    }
    for source in [
        ErrorSource::LegDynamics,
        ErrorSource::JointFriction,
        ErrorSource::Geometry,
    ] {
        s.world.imperfections = Imperfections::only(source);
        assert!(figures(&s.sim_config().sensors)
            .iter()
            .all(|(_, v)| *v == 0.0));
    }
    // All on: the datasheet's figures, the drift per second.
    s.world.imperfections = Imperfections::default();
    let c = s.sim_config().sensors;
    let d = &s.loaded.config.sensors;
    assert_eq!(c.load_cell.gain_sigma, d.load_cell.gain_error);
    assert_eq!(
        c.load_cell.drift_sigma_n_s,
        d.load_cell.zero_drift_n_per_min / 60.0
    );
    assert_eq!(c.imu.misalignment_sigma_deg, d.imu.misalignment_deg);
    assert_eq!(c.timing.frame_loss, d.timing.frame_loss);
    assert!(figures(&c).iter().all(|(_, v)| *v > 0.0));
}

#[test]
fn the_built_rig_differs_from_the_drawing_by_the_tolerance() {
    let mut s = default_scenario();
    let described = rig_description::derived::geometry(&s.loaded).unwrap();
    let sigma = s.loaded.config.platform.joint_position_tolerance_m;
    assert_eq!(sigma, 2e-4);
    let mut offsets = Vec::new();
    for seed in 0..100 {
        s.world.seed = seed;
        let built = s.built_geometry(&described).unwrap();
        // One rig per seed: the tare world and the loaded world are the same machine.
        assert_eq!(built, s.built_geometry(&described).unwrap());
        assert_eq!(built.stroke(), described.stroke());
        let pairs = built
            .base_joints_m()
            .iter()
            .zip(described.base_joints_m())
            .chain(
                built
                    .plate_joints_m()
                    .iter()
                    .zip(described.plate_joints_m()),
            );
        for (b, d) in pairs {
            offsets.extend((b - d).iter().copied());
        }
    }
    let n = offsets.len() as f64;
    let mean = offsets.iter().sum::<f64>() / n;
    let sd = (offsets.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(mean.abs() < 5.0 * sigma / n.sqrt(), "{mean}");
    assert!((sd / sigma - 1.0).abs() < 5.0 / (2.0 * n).sqrt(), "{sd}");
    // Switched off, or an ideal grade: the drawing.
    s.world.imperfections.geometry = false;
    assert_eq!(s.built_geometry(&described).unwrap(), described);
    let ideal = Scenario::new(load(None).unwrap(), None, Some(NoisePreset::None)).unwrap();
    assert_eq!(ideal.loaded.config.platform.joint_position_tolerance_m, 0.0);
    assert_eq!(ideal.built_geometry(&described).unwrap(), described);
    // Its draw does not depend on the other switches.
    let mut full = default_scenario();
    full.world.seed = 5;
    let mut only = full.clone();
    only.world.imperfections = Imperfections::only(ErrorSource::Geometry);
    assert_eq!(
        full.built_geometry(&described).unwrap(),
        only.built_geometry(&described).unwrap()
    );
}

#[test]
fn a_turned_imu_reports_in_its_own_axes() {
    let text = "[sensors.imu]\norientation_deg = [0.0, 0.0, 90.0]\n";
    let mut s = Scenario::new(load_str(text, "t.toml").unwrap(), None, None).unwrap();
    s.world.imperfections = Imperfections::all(false);
    let described = rig_description::derived::geometry(&s.loaded).unwrap();
    let mut sim = s.simulator(described, true).unwrap();
    let home = sim.true_pose();
    let spin = nalgebra::Vector3::new(0.2, -0.1, 0.05);
    sim.set_state(&home, &nalgebra::Vector3::new(0.01, 0.02, 0.0), &spin)
        .unwrap();
    for k in 0..20 {
        sim.write(&control::io::CommandFrame::safe_stop(k, k))
            .unwrap();
    }
    // Yawed 90°: the IMU's x axis is P's y, so a P vector (a, b, c) reads (b, −a, c).
    let (f, c) = (sim.read().unwrap(), sim.clean_frame());
    for (got, p) in [(f.gyro_rad_s, c.gyro_rad_s), (f.accel_m_s2, c.accel_m_s2)] {
        let want = [p[1], -p[0], p[2]];
        assert!(p[0].abs() > 1e-3 || p[1].abs() > 1e-3, "{p:?}");
        for i in 0..3 {
            assert!((got[i] - want[i]).abs() < 1e-12, "{got:?} vs {want:?}");
        }
    }
    assert_eq!(f.leg_forces_n, c.leg_forces_n);
}

#[test]
fn the_default_world_is_a_car_on_a_fixture() {
    let s = Scenario::new(load(None).unwrap(), None, None).unwrap();
    assert_eq!(s.world.payload.mass_kg, 1500.0);
    assert_eq!(s.world.seed, 1);
    assert_eq!(s.noise, NoisePreset::Realistic);
    let s = Scenario::new(load(None).unwrap(), Some(9), Some(NoisePreset::None)).unwrap();
    assert_eq!(s.world.seed, 9);
    assert_eq!(s.loaded.config.sensors.load_cell.zero_offset_n, 0.0);
}

#[test]
fn the_simulated_sensors_follow_the_rig_descriptions_datasheet() {
    let text =
        "[sensors.load_cell]\nzero_offset_n = 7.5\n[sensors.imu]\nposition_m = [0.1, 0.0, 0.2]\n";
    let harsh = Scenario::new(
        load_str(text, "s.toml").unwrap(),
        None,
        Some(NoisePreset::Harsh),
    )
    .unwrap();
    let sim = harsh.sim_config();
    assert_eq!(sim.sensors.load_cell.bias_sigma_n, 75.0);
    assert_eq!(harsh.loaded.config.sensors.load_cell.zero_offset_n, 75.0);
    assert_eq!(sim.sensors.accelerometer.mount_m, [0.1, 0.0, 0.2]);
}

#[test]
fn a_bad_world_is_refused_with_its_key_and_line() {
    let text = "[world.payload]\n\nmass_kg = -3.0\n";
    let err = Scenario::new(load_str(text, "w.toml").unwrap(), None, None).unwrap_err();
    assert_eq!(err.issues[0].key, "world.payload.mass_kg");
    assert_eq!(err.issues[0].line, Some(3));
    let text = "[world]\nsed = 3\n";
    let err = Scenario::new(load_str(text, "w.toml").unwrap(), None, None).unwrap_err();
    assert_eq!(err.issues[0].key, "world.sed");
    assert_eq!(err.issues[0].line, Some(2));
    assert!(err.issues[0].problem.contains("seed"), "{err}");
}

#[test]
fn the_suspension_reaches_the_simulator_and_its_refusals_name_its_keys() {
    let text = "[world.suspension]\nenabled = true\n";
    let s = Scenario::new(load_str(text, "s.toml").unwrap(), None, None).unwrap();
    assert!(s.sim_config().suspension.enabled);
    let geometry = rig_description::derived::geometry(&s.loaded).unwrap();
    let sim = s.simulator(geometry, true).unwrap();
    assert!(sim.true_sprung_pose().is_some());
    assert_eq!(sim.true_payload(), Some(s.world.payload.to_sim()));
    let text = "[world.suspension]\nenabled = true\nsprung_share = 1.5\n";
    let s = Scenario::new(load_str(text, "s.toml").unwrap(), None, None).unwrap();
    let err = s.simulator(geometry, true).unwrap_err();
    assert_eq!(err.issues[0].key, "world.suspension.sprung_share");
}
