//! `stewart rig calibrate-imu` against `stewart emulate` on loopback UDP: one session of the
//! empty fixture, a calibration file that a rig description then applies, and a fit that
//! agrees with `stewart simulate --calibrate-imu` on the same simulated world within their
//! sigmas (the emulated rig is that world behind the wire protocol).

mod support;

use measure::calibration::{CalibrationDocument, CalibrationFile};
use measure::End;
use support::*;

#[test]
fn rig_calibrate_imu_agrees_with_the_simulated_calibration_of_the_same_world() {
    let _lock = real_time();
    let scratch = Scratch::new(RIG_SHORT);
    let emulator = start(&emulate_args(&scratch));
    let file = scratch.path("rig-imu.toml");
    let args = rig_args(&[
        "calibrate-imu",
        "--out",
        file.to_str().unwrap(),
        "--config",
        scratch.config_str(),
        "--connect",
        emulator.address(),
        "--no-prompt",
        "--log",
        scratch.path("rig.mcap").to_str().unwrap(),
        "--quiet",
    ]);
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(sessions.len(), 1, "one session: the empty fixture");
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    assert!(
        outcome.report.is_none(),
        "a calibration measures no payload"
    );
    let rig = CalibrationFile::read(&file).unwrap();
    assert_eq!(rig.provenance.backend, "rig");
    assert_eq!(Some(&rig), outcome.calibration.as_ref());

    let sim_file = scratch.path("sim-imu.toml");
    let mut sim_args = simulate_args(Some(scratch.config.clone()), scratch.path("sim.mcap"));
    sim_args.calibrate_imu = Some(sim_file.clone());
    stewart_cli::simulate::simulate(&sim_args, &std::sync::atomic::AtomicBool::new(false)).unwrap();
    let sim = CalibrationFile::read(&sim_file).unwrap();
    // Same world, same motion: the two fits differ by the noise of two runs at most.
    let (a, b) = (&rig.imu, &sim.imu);
    for k in 0..9 {
        let d = a.gyro_matrix[k / 3][k % 3] - b.gyro_matrix[k / 3][k % 3];
        let s = a.gyro_sigma(k).hypot(b.gyro_sigma(k));
        assert!(d.abs() < 4.0 * s, "G {k}: {d:e} against {s:e}");
    }
    for k in 0..3 {
        let d = a.accelerometer_position_m[k] - b.accelerometer_position_m[k];
        let s = a.position_sigma(k).hypot(b.position_sigma(k));
        assert!(d.abs() < 4.0 * s, "r {k}: {d:e} against {s:e}");
    }

    // A rig description naming the file applies it: its position reaches the estimator.
    let described = scratch.path("with-calibration.toml");
    std::fs::write(
        &described,
        format!("{RIG_SHORT}\n[calibration]\nimu = \"rig-imu.toml\"\n"),
    )
    .unwrap();
    let loaded = measure::load::load(Some(&described)).unwrap();
    let p = measure::setup::accelerometer_position(&loaded.config);
    assert_eq!([p.x, p.y, p.z], rig.imu.accelerometer_position_m);
}
