//! Frames lost from a log reach the report: `estimate` of a log with every 100th `/sensors`
//! frame taken out says how many sample periods had no frame, that each was bridged, and which
//! time base placed the samples; its figures stay within their sigmas of the whole log's.

use crate::support;

use std::process::Command;

fn stewart(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(args)
        .output()
        .expect("the stewart binary runs")
}

/// Copies the log without every `every`-th `/sensors` frame (channels and schemas kept, every
/// other message's bytes untouched); returns how many were dropped.
fn drop_sensor_frames(from: &std::path::Path, to: &std::path::Path, every: u64) -> u64 {
    let (mut seen, mut dropped) = (0u64, 0u64);
    support::rewrite_sensor_frames(from, to, |frames| {
        frames
            .into_iter()
            .filter(|_| {
                seen += 1;
                let drop = seen % every == 0;
                dropped += u64::from(drop);
                !drop
            })
            .collect()
    });
    dropped
}

fn report(dir: &std::path::Path, log: &std::path::Path, name: &str) -> serde_json::Value {
    let path = dir.join(name);
    let out = stewart(&[
        "estimate",
        log.to_str().unwrap(),
        "--quiet",
        "--report",
        path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn frames_lost_from_a_log_are_bridged_and_reported() {
    let dir = support::scratch_dir();
    let whole = dir.path().join("whole.mcap");
    // A simulated rig that loses no frame of its own: every gap is the one made below.
    let config = dir.path().join("no_loss.toml");
    std::fs::write(&config, "[world.imperfections]\nframe_loss = false\n").unwrap();
    let out = stewart(&[
        "simulate",
        "--quiet",
        "--config",
        config.to_str().unwrap(),
        "--duration",
        "20",
        "--log",
        whole.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lossy = dir.path().join("lossy.mcap");
    let dropped = drop_sensor_frames(&whole, &lossy, 100);
    assert!(dropped > 50, "{dropped}");

    let a = report(dir.path(), &whole, "whole.json");
    let b = report(dir.path(), &lossy, "lossy.json");
    assert_eq!(a["data"]["frames_lost"], 0);
    assert_eq!(a["data"]["time_base"], "sequence");
    let lost = b["data"]["frames_lost"].as_u64().unwrap();
    let samples = b["samples"].as_u64().unwrap();
    // One frame in a hundred of the loaded run up to its window's end (the used samples and
    // the brake hold and settle before them), never more than were taken out of the log.
    assert!(
        lost >= samples / 100 - 1 && lost <= dropped,
        "{lost} lost, {samples} used, {dropped} dropped"
    );
    assert_eq!(b["data"]["frames_bridged"].as_u64(), Some(lost));
    assert_eq!(b["data"]["restarts"], 0);
    // What was lost costs little: each figure within two of its sigmas of the whole log's,
    // and its sigma within 20 % of the whole log's.
    let (ea, eb) = (
        a["estimate"]["mass"].as_f64().unwrap(),
        b["estimate"]["mass"].as_f64().unwrap(),
    );
    let (sa, sb) = (
        a["sigma"]["mass"].as_f64().unwrap(),
        b["sigma"]["mass"].as_f64().unwrap(),
    );
    assert!((ea - eb).abs() < 2.0 * sa, "mass: {ea} vs {eb} ± {sa}");
    assert!(sb < 1.2 * sa, "mass: sigma {sb} vs {sa}");
    for r in 0..3 {
        for c in 0..3 {
            let sa = a["sigma"]["inertia_com"][r][c].as_f64().unwrap();
            let sb = b["sigma"]["inertia_com"][r][c].as_f64().unwrap();
            let ea = a["estimate"]["inertia_com"][r][c].as_f64().unwrap();
            let eb = b["estimate"]["inertia_com"][r][c].as_f64().unwrap();
            assert!(sb < 1.2 * sa, "J[{r}][{c}] sigma {sb} vs {sa}");
            assert!(sb < 1.2 * sa, "J[{r}][{c}] sigma {sb} vs {sa}");
            assert!(
                (ea - eb).abs() < 2.0 * sa,
                "J[{r}][{c}]: {ea} vs {eb} ± {sa}"
            );
        }
    }
}
