//! The layers keep one direction of use: the library that carries the measurement procedure
//! (`measure`) reaches none of clap, indicatif, mcap, plotters, rapier or the live view's
//! server (foxglove, tokio, tungstenite) through any path of
//! its dependency tree, so rig software and GUIs can embed it; neither it nor the rig
//! description reaches the rig link's transports, the simulator reaches neither the procedure
//! nor the log; the cores stay free of std-side crates. Read from `cargo tree -e normal` (what a user's build of the crate pulls in; dev-
//! and build-only dependencies left out), on the locked, already fetched graph.

use std::process::Command;

/// Every package `root` reaches through normal dependencies.
fn normal_dependencies(root: &str) -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "tree", "--frozen", "-e", "normal", "--prefix", "none", "-p", root,
        ])
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree -p {root}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

fn forbidden_in(root: &str, forbidden: &[&str]) -> Vec<String> {
    let reached = normal_dependencies(root);
    assert!(
        reached.iter().any(|r| r == root),
        "{root} not in its own tree"
    );
    forbidden
        .iter()
        .filter(|f| reached.iter().any(|r| r == *f))
        .map(|f| f.to_string())
        .collect()
}

#[test]
fn the_measurement_library_needs_no_terminal_log_format_plotter_or_physics_engine() {
    let found = forbidden_in(
        "measure",
        &[
            "clap",
            "indicatif",
            "mcap",
            "plotters",
            "rapier3d-f64",
            "rapier3d",
            // The live view's server (runlog's `live` feature) and its async runtime.
            "foxglove",
            "tokio",
            "tungstenite",
        ],
    );
    assert!(found.is_empty(), "measure reaches {found:?}");
}

#[test]
fn the_simulator_reads_the_rig_description_not_the_procedure() {
    let found = forbidden_in("sim", &["measure", "runlog", "rig", "ops"]);
    assert!(found.is_empty(), "sim reaches {found:?}");
}

#[test]
fn the_procedure_and_the_rig_description_reach_no_transport() {
    for library in ["measure", "rig-description"] {
        let found = forbidden_in(library, &["rig", "serialport", "libc"]);
        assert!(found.is_empty(), "{library} reaches {found:?}");
    }
}

#[test]
fn the_cores_need_no_std_side_crates() {
    for core in ["stewart-types", "kinematics", "control", "estimator"] {
        let found = forbidden_in(
            core,
            &["serde_json", "toml", "anyhow", "thiserror", "measure"],
        );
        assert!(found.is_empty(), "{core} reaches {found:?}");
    }
}

#[test]
fn the_check_sees_a_forbidden_crate_where_there_is_one() {
    // The command line does use clap and the simulator rapier: the walk must find them.
    assert_eq!(
        forbidden_in("stewart-cli", &["clap", "rapier3d-f64"]).len(),
        2
    );
}

/// The end-to-end tests, benchmarks and examples run the commands' work through the operations
/// library: none names the binary's crate (its flags are tested in crates/cli/tests).
#[test]
fn tests_benches_and_examples_call_the_library_not_the_binary() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut offenders = Vec::new();
    for dir in ["tests", "tests/support", "benches", "examples"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap_or_default();
                // The needle split so that this file does not find itself.
                if text.contains(concat!("stewart", "_cli")) {
                    offenders.push(path.display().to_string());
                }
            }
        }
    }
    assert!(offenders.is_empty(), "{offenders:?}");
}
