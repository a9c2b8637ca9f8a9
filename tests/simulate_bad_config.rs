//! `stewart simulate` refuses a bad scenario before anything runs: unknown key, wrong unit,
//! wrong type, out-of-range value, unreachable trajectory, singular geometry, a key of the older
//! format, and a bad flag value, in the rig description and in the simulated `[world]` alike. Each through the built binary: exit code 2, a message naming the file (with the line)
//! and the dotted key, and no log written.

use std::path::Path;
use std::process::Command;

/// Runs `stewart simulate --config <file with text>` and returns (exit code, stderr, dir).
fn refuse(text: &str, extra: &[&str]) -> (i32, String, tempfile::TempDir) {
    let dir = tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap();
    let config = dir.path().join("bad.toml");
    std::fs::write(&config, text).unwrap();
    let log = dir.path().join("run.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_stewart"))
        .arg("simulate")
        .arg("--config")
        .arg(&config)
        .arg("--log")
        .arg(&log)
        .arg("--quiet")
        .args(extra)
        .current_dir(dir.path())
        .output()
        .expect("the stewart binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !log.exists(),
        "a refused run must not start a log:\n{stderr}"
    );
    assert!(!dir.path().join("runs").exists(), "nor a default log");
    (out.status.code().unwrap_or(-1), stderr, dir)
}

fn assert_names(stderr: &str, dir: &Path, line: Option<usize>, key: &str, what: &str) {
    let file = dir.join("bad.toml").display().to_string();
    let at = match line {
        Some(l) => format!("{file}:{l}:"),
        None => file.clone(),
    };
    assert!(stderr.contains(&at), "no `{at}` in:\n{stderr}");
    assert!(
        stderr.contains(&format!("`{key}`")),
        "no key `{key}` in:\n{stderr}"
    );
    assert!(stderr.contains(what), "no `{what}` in:\n{stderr}");
}

#[test]
fn unknown_key() {
    let (code, err, dir) = refuse("[world.payload]\nmass_kg = 1500.0\ncolour = \"red\"\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(3),
        "world.payload.colour",
        "unknown key",
    );
    let (code, err, dir) = refuse("[platform]\nbase_radius_m = 1.5\ncolour = \"red\"\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(&err, dir.path(), Some(3), "platform.colour", "unknown key");
}

#[test]
fn unknown_section() {
    let (code, err, dir) = refuse("[world.paylod]\nmass_kg = 1500.0\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(1),
        "world.paylod",
        "did you mean `payload`",
    );
    let (code, err, dir) = refuse("[platfrom]\nbase_radius_m = 1.5\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(1),
        "platfrom",
        "did you mean `platform`",
    );
}

#[test]
fn wrong_unit() {
    let (code, err, dir) = refuse("[world.payload]\n\nmass_lb = 3300.0\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(3),
        "world.payload.mass_lb",
        "mass_kg",
    );
    assert!(err.contains("unit"), "{err}");
}

#[test]
fn wrong_unit_in_a_sine_component() {
    let text = "[excitation]\nkind = \"sines\"\n[[excitation.sines]]\naxis = \"roll\"\namplitude_m = 0.05\nfrequency_hz = 0.5\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(5),
        "excitation.sines[0].amplitude_m",
        "amplitude_deg",
    );
}

#[test]
fn wrong_type() {
    let (code, err, dir) = refuse("[world.payload]\nmass_kg = \"1500 kg\"\n", &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(2),
        "world.payload.mass_kg",
        "wrong type",
    );
}

#[test]
fn out_of_range_values() {
    // Every problem of the rig description is reported at once ...
    let text = "[platform]\nbase_radius_m = -1.5\n[estimator]\nforgetting_factor = 1.5\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(2),
        "platform.base_radius_m",
        "positive",
    );
    assert_names(
        &err,
        dir.path(),
        Some(4),
        "estimator.forgetting_factor",
        "between",
    );
    // ... and every problem of the simulated world (checked once the rig description passes).
    let text = "[world.payload]\nmass_kg = -1500.0\n[world.fixture]\nmass_kg = -400.0\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(2),
        "world.payload.mass_kg",
        "positive",
    );
    assert_names(
        &err,
        dir.path(),
        Some(4),
        "world.fixture.mass_kg",
        "positive",
    );
}

#[test]
fn keys_of_the_older_format_say_where_they_moved() {
    let text = "[payload]\nmass_kg = 1500.0\n[sensors]\nnoise = \"none\"\nphysics_substeps = 2\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(&err, dir.path(), Some(1), "payload", "[world.payload]");
    assert_names(&err, dir.path(), Some(4), "sensors.noise", "--noise");
    assert_names(
        &err,
        dir.path(),
        Some(5),
        "sensors.physics_substeps",
        "world.physics_substeps",
    );
}

#[test]
fn unphysical_inertia() {
    let text = "[world.payload]\ninertia_com_kg_m2 = [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 500.0]]\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(2),
        "world.payload.inertia_com_kg_m2",
        "triangle",
    );
}

#[test]
fn unreachable_trajectory() {
    let text = "[excitation.multisine]\npeak_translation_m = [0.3, 0.3, 0.3]\n\n[excitation]\nkind = \"multisine\"\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(
        &err,
        dir.path(),
        Some(1),
        "excitation.multisine",
        "trajectory",
    );
}

#[test]
fn singular_geometry() {
    // Pair separations adding up to 120° put the plate's joints at the base's angles.
    let text = "[platform]\nbase_pair_separation_deg = 60.0\nplate_pair_separation_deg = 60.0\n";
    let (code, err, dir) = refuse(text, &[]);
    assert_eq!(code, 2, "{err}");
    assert_names(&err, dir.path(), Some(1), "platform", "singular");
}

#[test]
fn bad_duration_flag_names_the_flag() {
    let (code, err, _dir) = refuse("", &["--duration", "1.0"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--duration (run.duration_s)"), "{err}");
    assert!(err.contains("excitation.fade_s"), "{err}");
}

#[test]
fn bad_flag_value_is_a_usage_error() {
    let (code, err, _dir) = refuse("", &["--noise", "loud"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("loud"), "{err}");
}

#[test]
fn missing_file() {
    let out = Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(["simulate", "--config", "/nonexistent/car.toml", "--quiet"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent/car.toml") && err.contains("cannot read"),
        "{err}"
    );
}

/// A huge bad value (a flag or a config value) is echoed abbreviated, not whole.
#[test]
fn a_huge_bad_value_is_echoed_abbreviated() {
    // A single argument may hold at most 128 KiB (Linux MAX_ARG_STRLEN).
    let huge = "9".repeat(100_000);
    let out = Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(["simulate", "--quiet", "--seed", &huge])
        .output()
        .expect("the stewart binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.len() < 1_000, "{} bytes of error", stderr.len());
    assert!(stderr.contains("--seed"), "{stderr}");
    let (code, err, _dir) = refuse(
        &format!("[platform]\nbase_radius_m = \"{}\"\n", "x".repeat(200_000)),
        &[],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.len() < 1_000, "{} bytes of error", err.len());
    assert!(err.contains("platform.base_radius_m"), "{err}");
}
