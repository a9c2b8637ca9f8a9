//! Logs never overwrite each other: the default `runs/<UTC time>.mcap` of a second that has a
//! log already gets `-2`, `-3`, …, and a `--log FILE` that exists is refused before anything
//! moves (exit 2, no calibration pass, the file untouched).

use crate::support;

use std::path::Path;

use support::stewart_limited as stewart;

/// The short scenario of the log tests, without the IMU calibration pass unless `imu_pass`.
fn scenario(dir: &Path, imu_pass: bool) {
    std::fs::write(
        dir.join("short.toml"),
        format!(
            "{}[calibration]\nmeasure_imu = {imu_pass}\n",
            support::SHORT
        ),
    )
    .unwrap();
}

#[test]
fn a_second_run_in_the_same_second_gets_its_own_log_and_the_first_is_kept() {
    let dir = support::scratch_dir();
    scenario(dir.path(), false);
    let runs = dir.path().join("runs");
    std::fs::create_dir(&runs).unwrap();
    // Logs of earlier runs in every second this run may start in.
    let now_s = runlog::run_log::unix_now_ns() / 1_000_000_000;
    let earlier: Vec<_> = (now_s..now_s + 60)
        .map(|s| runs.join(format!("{}.mcap", runlog::mcap_log::utc_stamp(s))))
        .collect();
    for path in &earlier {
        std::fs::write(path, "an earlier run's log").unwrap();
    }
    let (code, err) = stewart(
        dir.path(),
        &["simulate", "--quiet", "--config", "short.toml"],
    );
    assert_eq!(code, 0, "{err}");
    for path in &earlier {
        assert_eq!(
            std::fs::read_to_string(path).unwrap(),
            "an earlier run's log",
            "{} was written over",
            path.display()
        );
    }
    let new: Vec<_> = std::fs::read_dir(&runs)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with("-2.mcap"))
        .collect();
    assert_eq!(new.len(), 1, "one new log beside the earlier ones: {new:?}");
    assert!(
        !support::sensor_frames(&runs.join(&new[0])).is_empty(),
        "the new log holds the run"
    );
}

#[test]
fn an_existing_log_given_as_log_is_refused_before_anything_moves() {
    let dir = support::scratch_dir();
    scenario(dir.path(), true);
    std::fs::write(dir.path().join("run.mcap"), "an earlier run's log").unwrap();
    let (code, err) = stewart(
        dir.path(),
        &[
            "simulate",
            "--quiet",
            "--config",
            "short.toml",
            "--log",
            "run.mcap",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("run.mcap") && err.contains("exists already"),
        "{err}"
    );
    assert!(err.contains("choose another name, or remove"), "{err}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("run.mcap")).unwrap(),
        "an earlier run's log"
    );
    assert!(
        !dir.path().join("run.imu.mcap").exists(),
        "no calibration pass ran: {err}"
    );
    // `rig` refuses it before contacting the rig (nothing listens at the address).
    let (code, err) = stewart(
        dir.path(),
        &[
            "rig",
            "--quiet",
            "--no-prompt",
            "--insecure",
            "--connect",
            "udp://127.0.0.1:9",
            "--log",
            "run.mcap",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("exists already"), "{err}");
}
