//! `stewart simulate --calibrate-imu` recovers the simulated rig's IMU as built (its axes and
//! scales, the accelerometer's position, the delay: the simulator's draws for the seed, which
//! the estimator never reads) within the calibration's reported sigmas, on the full world
//! (every imperfection on) and on a world with only the IMU's own errors.

use crate::support;

use rig_description::calibration::{CalibrationDocument, CalibrationFile};
use rig_description::sources::ErrorSource;
use support::*;

/// Calibrates the world of `seed` (only `source` when given) and returns the file and the
/// IMU as built.
fn calibrate(seed: u64, only: Option<ErrorSource>) -> (CalibrationFile, sim::ImuAsBuilt) {
    let scratch = Scratch::new("[run]\nduration_s = 12.0\ntare_duration_s = 12.0\n");
    let file = scratch.path("imu.toml");
    let mut args = simulate_args(Some(scratch.config.clone()), scratch.path("cal.mcap"));
    args.seed = Some(seed);
    args.only = only;
    args.calibrate_imu = Some(file.clone());
    let scenario = args.scenario().unwrap();
    let geometry = measure::setup::geometry(&scenario.loaded).unwrap();
    let built = scenario.simulator(geometry, false).unwrap().imu_as_built();
    support::run_simulate(&args).unwrap();
    (CalibrationFile::read(&file).unwrap(), built)
}

/// Every parameter within `k` of its sigma; returns the largest |error|/sigma.
fn check(file: &CalibrationFile, built: &sim::ImuAsBuilt, k: f64) -> f64 {
    let a = &file.imu;
    let mut worst: f64 = 0.0;
    let mut within = |name: String, error: f64, sigma: f64| {
        let z = (error / sigma).abs();
        assert!(z < k, "{name}: error {error:e}, sigma {sigma:e}");
        worst = worst.max(z);
    };
    for i in 0..3 {
        for j in 0..3 {
            let e = a.gyro_matrix[i][j] - built.gyro_matrix[(i, j)];
            within(format!("G {i}{j}"), e, a.gyro_sigma(3 * i + j));
        }
        let e = a.accelerometer_position_m[i] - built.accelerometer_position_m[i];
        within(format!("r {i}"), e, a.position_sigma(i));
    }
    within("tau".into(), a.imu_delay_s - built.delay_s, a.gyro_sigma(9));
    // The accelerometer takes the gyro's axes: its rotation, not its scales, is the built one's.
    let turned = rig_description::calibration::imu::rotation_of(&built.accel_matrix);
    let e = (a.accel() - turned).amax();
    within(
        "A's axes".into(),
        e,
        3.0 * a.gyro_sigma(1).max(a.gyro_sigma(3)),
    );
    worst
}

#[test]
fn the_calibration_recovers_the_simulated_imu_within_its_sigmas() {
    for seed in [3, 7] {
        let (file, built) = calibrate(seed, None);
        let worst = check(&file, &built, 4.0);
        eprintln!("seed {seed}, every imperfection: largest |error|/sigma {worst:.2}");
    }
    let (file, built) = calibrate(7, Some(ErrorSource::ImuMisalignment));
    let worst = check(&file, &built, 4.0);
    eprintln!("seed 7, only imu_misalignment: largest |error|/sigma {worst:.2}");
}
