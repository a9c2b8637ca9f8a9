//! `stewart rig calibrate-imu` and `stewart rig calibrate-load-cells` against `stewart
//! emulate` on loopback UDP: the calibration's sessions, a calibration file that a rig
//! description then applies, and a fit that agrees with `stewart simulate --calibrate-imu`
//! (`--calibrate-load-cells`) on the same simulated world within their sigmas (the emulated rig
//! is that world behind the wire protocol).

use crate::support;

use measure::End;
use rig_description::calibration::{CalibrationDocument, CalibrationFile, LoadCellFile};
use support::*;

#[test]
fn rig_calibrate_imu_agrees_with_the_simulated_calibration_of_the_same_world() {
    let _lock = real_time();
    let scratch = Scratch::new(RIG_SHORT);
    let emulator = start(&emulate_args_fast(&scratch));
    let file = scratch.path("rig-imu.toml");
    let args = rig_against(
        &scratch.config,
        emulator.address(),
        &scratch.path("rig.mcap"),
        ops::rig::RigPlan::CalibrateImu(file.clone()),
    );
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
    support::run_simulate(&sim_args).unwrap();
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
    let loaded = rig_description::load::load(Some(&described)).unwrap();
    let p = measure::setup::accelerometer_position(&loaded.config);
    assert_eq!([p.x, p.y, p.z], rig.imu.accelerometer_position_m);
}

/// `stewart rig calibrate-load-cells` against an emulator that puts the world's reference
/// weight on for the second session: two sessions (the empty fixture, then the reference), a
/// dated file of the rig that a rig description then applies, and gains that agree with
/// `stewart simulate --calibrate-load-cells` on the same world within their combined sigmas.
/// Neither calibrates the IMU (`measure_imu = false`), so both fit the same readings' model.
#[test]
fn rig_calibrate_load_cells_agrees_with_the_simulated_calibration_of_the_same_world() {
    let _lock = real_time();
    let scratch = Scratch::new(&format!("[calibration]\nmeasure_imu = false\n{RIG_SHORT}"));
    let emulator = start(&EmulateOptions {
        reference: true,
        ..emulate_args_fast(&scratch)
    });
    let file = scratch.path("rig-cells.toml");
    let log = scratch.path("rig.mcap");
    let args = rig_against(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::CalibrateLoadCells(file.clone()),
    );
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(sessions.len(), 2, "the empty fixture, then the reference");
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    assert!(
        outcome.report.is_none(),
        "a calibration measures no payload"
    );
    let rig = LoadCellFile::read(&file).unwrap();
    assert_eq!(rig.provenance.backend, "rig");
    assert_eq!(rig.provenance.log.as_deref(), log.to_str());
    assert_eq!(Some(&rig), outcome.load_cell_calibration.as_ref());
    // Both runs are in the log, like a measurement's.
    let topics = read_log(&log);
    let metadata = on(&topics, runlog::messages::METADATA);
    assert_eq!(metadata[0]["command"], "rig calibrate-load-cells");
    assert_eq!(metadata[0]["runs"], serde_json::json!(["tare", "loaded"]));
    assert_eq!(rig.load_cells.joint_sensitivity.len(), 36);

    let sim_file = scratch.path("sim-cells.toml");
    let mut sim_args = simulate_args(Some(scratch.config.clone()), scratch.path("sim.mcap"));
    sim_args.calibrate_load_cells = Some(sim_file.clone());
    support::run_simulate(&sim_args).unwrap();
    let sim = LoadCellFile::read(&sim_file).unwrap();
    // Same world, same motions: the two fits differ by the noise of two pairs of runs, within
    // two combined sigmas (the joints' share of each sigma is the same world's on both sides,
    // so they agree far closer: 2e-4 at most per gain). An emulator that put the reference on
    // without letting the plate settle scattered the rig's gains by up to 2e-3.
    let (a, b) = (&rig.load_cells, &sim.load_cells);
    for l in ops::rig::link_lines(&outcome.link) {
        println!("{l}");
    }
    println!(
        "rig: residual {:.2}, {} entries, fixture {:.2} kg; sim: residual {:.2}, {} entries, \
         fixture {:.2} kg",
        a.residual_rms, a.entries, a.fixture_mass_kg, b.residual_rms, b.entries, b.fixture_mass_kg
    );
    for i in 0..6 {
        let d = a.gains[i] - b.gains[i];
        let s = a.sigma(i).hypot(b.sigma(i));
        println!(
            "cell {i}: rig {:+.3e} sim {:+.3e} ± {s:.1e}",
            a.gains[i], b.gains[i]
        );
        assert!(d.abs() < 2.0 * s, "gain {i}: {d:e} against {s:e}");
    }
    // The gains' mean (what a mass reads) within two combined sigmas of the mean: it differed by
    // 7–9e-4 (six sigmas) with the unsettled plate.
    let mean = |g: &[f64; 6]| g.iter().sum::<f64>() / 6.0;
    let ones = nalgebra::DVector::from_element(6, 1.0 / 6.0);
    let mean_sigma = |c: &rig_description::calibration::LoadCellGains| {
        (ones.transpose() * c.covariance_matrix() * &ones)[(0, 0)].sqrt()
    };
    println!(
        "mean gain: rig {:+.2e} ± {:.1e}, sim {:+.2e} ± {:.1e}",
        mean(&a.gains),
        mean_sigma(a),
        mean(&b.gains),
        mean_sigma(b)
    );
    let (d, s) = (
        mean(&a.gains) - mean(&b.gains),
        mean_sigma(a).hypot(mean_sigma(b)),
    );
    assert!(d.abs() < 2.0 * s, "mean gain: {d:e} against {s:e}");

    // A rig description naming the file applies it.
    let described = scratch.path("with-cells.toml");
    std::fs::write(
        &described,
        format!("[calibration]\nload_cells = \"rig-cells.toml\"\n{RIG_SHORT}"),
    )
    .unwrap();
    let loaded = rig_description::load::load(Some(&described)).unwrap();
    assert_eq!(
        loaded.config.calibration.load_cell_gains(),
        Some(&rig.load_cells)
    );
}

/// A load-cell calibration that the link ends: the fault is named, the rig's last command from
/// the host brakes, and no calibration file is written.
#[test]
fn a_load_cell_calibration_cut_short_brakes_and_writes_nothing() {
    let _lock = real_time();
    // Not repeated (tests/rig_stall.rs repeats stalls): the fault itself is under test.
    let scratch = Scratch::new(&(quick() + "stall_retries = 0\n"));
    let emulator = start(&EmulateOptions {
        reference: true,
        stop_after: Some(1000),
        ..emulate_args(&scratch)
    });
    let file = scratch.path("cells.toml");
    let mut args = rig_against(
        &scratch.config,
        emulator.address(),
        &scratch.path("rig.mcap"),
        ops::rig::RigPlan::CalibrateLoadCells(file.clone()),
    );
    args.options.link.link_silence_ms = Some(50.0);
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    // Give the safe stop time to arrive before the emulator is stopped.
    std::thread::sleep(std::time::Duration::from_millis(50));
    let stopped = emulator.stop().unwrap();
    let End::Fault(cause) = &outcome.end else {
        panic!("expected a fault, got {:?}", outcome.end)
    };
    assert!(cause.contains("link silent"), "{cause}");
    assert_eq!(outcome.exit_code(), ops::exit::FAULT);
    let last = stopped.last_command().expect("commands were sent");
    assert!(!last.enable, "{last:?}");
    assert!(outcome.load_cell_calibration.is_none());
    assert!(!file.exists(), "no calibration from a failed run");
}
