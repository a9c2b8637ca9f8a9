//! Shared by the log, estimate and plot tests: a short simulated measurement with its log.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use stewart_cli::args::RunArgs;

/// A short scenario: 6 s of excitation, 4 s of tare, realistic noise.
pub const SHORT: &str = "[run]\nduration_s = 6.0\ntare_duration_s = 4.0\n";

/// A finished simulate run: its directory (kept alive), log and report.
pub struct Simulated {
    pub dir: tempfile::TempDir,
    pub log: PathBuf,
    pub report: stewart_cli::report::Report,
}

/// Runs `stewart simulate` on `scenario` with `extra` applied to the arguments.
pub fn simulate_with(scenario: &str, extra: impl FnOnce(&mut RunArgs, &Path)) -> Simulated {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("short.toml");
    std::fs::write(&config, scenario).unwrap();
    let log = dir.path().join("run.mcap");
    let mut args = RunArgs {
        config: Some(config),
        log: Some(log.clone()),
        quiet: true,
        ..RunArgs::default()
    };
    extra(&mut args, dir.path());
    let outcome = stewart_cli::simulate::simulate(&args, &AtomicBool::new(false))
        .unwrap_or_else(|e| panic!("simulate failed: {e}"));
    let report = outcome.report.expect("a completed run has a report");
    Simulated { dir, log, report }
}

/// The short default run.
pub fn simulate() -> Simulated {
    simulate_with(SHORT, |_, _| {})
}

/// |a − b| ≤ tol·max(|a|, |b|), NaN only with NaN.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    if a.is_nan() || b.is_nan() {
        return a.is_nan() && b.is_nan();
    }
    (a - b).abs() <= tol * a.abs().max(b.abs())
}
