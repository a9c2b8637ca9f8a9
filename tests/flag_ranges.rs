//! Every numeric flag is checked against the range of the rig description's key it stands for
//! (one definition, `rig_description::range::ranges`), and refused with exit 2, the flag
//! and the range named: `estimate --cutoff-hz` and `--forgetting-factor` as
//! `estimator.cutoff_hz` and `estimator.forgetting_factor`, `estimate --window` against the
//! log's measurement (blamed on the flag, not on the log), `emulate`'s fault injection; and
//! `simulate` refuses a `[rig]` table that `rig` refuses. A bad key file is named as such.

use crate::support;

use std::path::Path;

use support::stewart_limited as stewart;

/// A short log in `dir` (`run.mcap`), from `simulate`.
fn short_log(dir: &Path) {
    std::fs::write(
        dir.join("short.toml"),
        format!("{}[calibration]\nmeasure_imu = false\n", support::SHORT),
    )
    .unwrap();
    let (code, err) = stewart(
        dir,
        &[
            "simulate",
            "--quiet",
            "--config",
            "short.toml",
            "--log",
            "run.mcap",
        ],
    );
    assert_eq!(code, 0, "{err}");
}

/// `stewart estimate run.mcap ARGS` in `dir`: (exit code, stderr).
fn estimate(dir: &Path, args: &[&str]) -> (i32, String) {
    stewart(
        dir,
        &[&["estimate", "run.mcap", "--quiet"][..], args].concat(),
    )
}

#[test]
fn estimate_cutoff_and_forgetting_factor_out_of_their_keys_range_are_refused() {
    let dir = support::scratch_dir();
    short_log(dir.path());
    let (code, err) = estimate(dir.path(), &["--cutoff-hz", "1e-300"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--cutoff-hz") && err.contains("0.1 Hz"),
        "{err}"
    );
    assert!(err.contains("1e-300"), "the value, shortly: {err}");
    let (code, err) = estimate(dir.path(), &["--forgetting-factor", "1e-300"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--forgetting-factor") && err.contains("between 0.9 and 1"),
        "{err}"
    );
    // Above the key's range at the log's sample rate (1 kHz: 400 Hz at most).
    let (code, err) = estimate(dir.path(), &["--cutoff-hz", "1e6"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("`--cutoff-hz`") && err.contains("400 Hz"),
        "{err}"
    );
    assert!(!err.contains("not a readable MCAP log"), "{err}");
    // What the key admits is accepted.
    let (code, err) = estimate(
        dir.path(),
        &["--cutoff-hz", "none", "--forgetting-factor", "1"],
    );
    assert_eq!(code, 0, "{err}");
}

#[test]
fn estimate_window_the_run_cannot_take_blames_the_flag_not_the_log() {
    let dir = support::scratch_dir();
    short_log(dir.path());
    for window in ["--window=100:", "--window=:-10"] {
        let (code, err) = estimate(dir.path(), &[window]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("`--window`"), "{err}");
        assert!(!err.contains("not a readable MCAP log"), "{err}");
        assert!(!err.contains("estimator refused its settings"), "{err}");
    }
}

#[test]
fn emulate_fault_injection_out_of_range_is_refused_naming_each_flag() {
    let dir = support::scratch_dir();
    let (code, err) = stewart(
        dir.path(),
        &[
            "emulate",
            "--insecure",
            "--no-realtime",
            "--listen",
            "udp://127.0.0.1:0",
            "--delay-ms",
            "1e12",
            "--delay-fraction",
            "3",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--delay-ms") && err.contains("10000 ms"),
        "{err}"
    );
    assert!(
        err.contains("--delay-fraction") && err.contains("between 0 and 1"),
        "{err}"
    );
    let (code, err) = stewart(
        dir.path(),
        &["emulate", "--insecure", "--no-realtime", "--drop", "3"],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--drop"), "{err}");
    assert!(!err.contains("invalid rig address or option"), "{err}");
}

#[test]
fn simulate_refuses_a_rig_table_that_rig_refuses() {
    let dir = support::scratch_dir();
    std::fs::write(
        dir.path().join("rig.toml"),
        "[rig]\nlink_silence_ms = 0.0\nhandshake_timeout_s = 1e9\n",
    )
    .unwrap();
    let (code, err) = stewart(
        dir.path(),
        &[
            "simulate", "--quiet", "--config", "rig.toml", "--log", "run.mcap",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("rig.toml:2:") && err.contains("`rig.link_silence_ms`"),
        "{err}"
    );
    assert!(err.contains("`rig.handshake_timeout_s`"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "no log: {err}");
}

#[test]
fn a_bad_key_file_is_named_as_a_key_file_not_as_a_rig_address() {
    let dir = support::scratch_dir();
    std::fs::write(dir.path().join("bad.key"), "0123456789abcdef0").unwrap();
    let (code, err) = stewart(
        dir.path(),
        &[
            "rig",
            "--quiet",
            "--no-prompt",
            "--connect",
            "udp://127.0.0.1:9",
            "--key",
            "bad.key",
            "--log",
            "run.mcap",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("the key file bad.key"), "{err}");
    assert!(err.contains("odd number of hex digits"), "{err}");
    assert!(!err.contains("invalid rig address or option"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "no log: {err}");
}
