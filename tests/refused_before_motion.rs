//! A rig that passes every static check but could not run is refused before anything moves:
//! long, nearly vertical legs whose PID loops cannot hold the braked load (from the load the
//! rig description gives, `control::stability`; the brake hold's measured forces are checked
//! again), and a plate so small against the base that rotations barely change the leg lengths.
//! Both are refused with the configuration (exit 2, no log). Run, both would start moving and
//! fault mid-tare (leg speed limit; forward kinematics).

use std::process::Command;

fn simulate(config_text: &str) -> (i32, String, tempfile::TempDir) {
    let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let config = dir.path().join("rig.toml");
    std::fs::write(&config, config_text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(["simulate", "--quiet", "--duration", "4", "--config"])
        .arg(&config)
        .arg("--log")
        .arg(dir.path().join("run.mcap"))
        .current_dir(dir.path())
        .output()
        .expect("the stewart binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    (out.status.code().unwrap_or(-1), stderr, dir)
}

/// The loops' check on the load as the rig description gives it (`[plan.fixture]`,
/// `[plan.payload]`) comes with the configuration's: exit 2 and no log, not a log of a brake
/// hold (or of a whole tare run, for a loaded run the loops cannot hold) and exit 1.
#[test]
fn long_legs_that_cannot_hold_the_load_exit_2_with_no_log() {
    let (code, err, dir) = simulate("[platform]\nmin_leg_length_m = 5.0\nmax_leg_length_m = 6.0\n");
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("refused before motion"), "{err}");
    assert!(err.contains("control.ki_n_per_m_s"), "names the fix: {err}");
    assert!(!dir.path().join("run.mcap").exists(), "nothing ran");
    assert!(
        !dir.path().join("run.imu.mcap").exists(),
        "no calibration pass ran"
    );
}

#[test]
fn the_fix_the_refusal_names_lets_the_long_legged_rig_run() {
    let (code, err, _dir) = simulate(
        "[platform]\nmin_leg_length_m = 5.0\nmax_leg_length_m = 6.0\n\
         [control]\nki_n_per_m_s = 0.9e6\n",
    );
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_plate_tiny_against_the_base_is_refused_with_the_configuration() {
    let (code, err, dir) = simulate("[platform]\nplate_radius_m = 0.001\n");
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("platform.plate_radius_m"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "nothing ran");
}

/// The seed paper's 20 ms start with the load's feed-forward on: the feed-forward would ask a
/// leg for more than its 20 kN before the plate has left home, so the configuration is refused
/// before anything runs (no log), naming the leg's force and the ways out.
#[test]
fn a_motion_the_loads_feedforward_cannot_drive_is_refused_before_motion() {
    let paper = include_str!("../configs/paper.toml");
    let with_feedforward = paper.replace(
        "inertial_feedforward = false",
        "inertial_feedforward = true",
    );
    assert_ne!(
        paper, with_feedforward,
        "configs/paper.toml switches the feed-forward off"
    );
    let (code, err, dir) = simulate(&with_feedforward);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("refused before motion"), "{err}");
    assert!(err.contains("control.max_force_n"), "{err}");
    assert!(
        err.contains("control.inertial_feedforward = false"),
        "names a fix: {err}"
    );
    assert!(!dir.path().join("run.mcap").exists(), "nothing ran");
}

/// A tare run too short for a measured sigma (1.2 s of excitation with 0.25 s fades: three
/// residual windows where six must count) is refused with the configuration, naming the key and
/// how long to excite, before anything runs (no log) rather than after the motion.
#[test]
fn a_run_too_short_for_a_measured_sigma_is_refused_before_motion() {
    let (code, err, dir) = simulate("[excitation]\nfade_s = 0.25\n[run]\ntare_duration_s = 1.2\n");
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("run.tare_duration_s"), "{err}");
    assert!(err.contains("refused before motion"), "{err}");
    assert!(err.contains("excite for at least 1.8 s"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "nothing ran");
}
