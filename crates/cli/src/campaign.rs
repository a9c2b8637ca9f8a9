//! `stewart simulate --runs N [--jobs J]`: what accuracy will I get with these sensors?
//!
//! N runs of the configured scenario with seeds `seed, seed+1, …` (every random number of a run
//! — sensor errors, the built joints — follows from its seed; each error source draws from its
//! own stream, so a `--only SOURCE` campaign sees exactly that source's errors of the full
//! world's runs), J at a time on a rayon pool. Each run is
//! the ordinary single run ([`crate::simulate::simulate`], quiet, its log written to a
//! temporary file and deleted). Then, per parameter of the payload (mass, centre of mass, J_C):
//!
//! mean error, spread, largest error against the acceptance, mean z² and the share within 2σ
//! ([`measure::accuracy`]).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use measure::accuracy::{statistics, ParameterStats};
use measure::report::Report;
use measure::End;
use rayon::prelude::*;
use serde::Serialize;

use crate::common::CommandError;
use crate::simulate::{self, SimulateArgs};

/// A run that produced no report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FailedRun {
    /// Its seed.
    pub seed: u64,
    /// Why (fault, interrupt, error).
    pub reason: String,
}

/// The campaign's result (`--report` writes it as JSON).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CampaignReport {
    /// Scenario file, or the embedded default.
    pub config: String,
    /// Noise preset.
    pub noise: String,
    /// The one error source the simulated rig had (`--only`), or every source switched on in
    /// `[world.imperfections]` (`None`).
    pub only: Option<String>,
    /// 10 or 6.
    pub params: u8,
    /// Excitation time of each loaded run including the fades, s.
    pub duration_s: f64,
    /// Tare excitation time, s (0 with `--tare FILE`).
    pub tare_duration_s: f64,
    /// Runs asked for.
    pub runs: u32,
    /// Threads used.
    pub jobs: usize,
    /// Seed of the first run; run k has `first_seed + k`.
    pub first_seed: u64,
    /// Runs that produced a report (the statistics are over these).
    pub completed: u32,
    /// Runs that did not.
    pub failed: Vec<FailedRun>,
    /// Wall time of the whole campaign, s.
    pub wall_s: f64,
    /// One row per parameter (empty when no run completed or the truth is unknown).
    pub parameters: Vec<ParameterStats>,
    /// Every run's report, in seed order (completed runs only).
    pub reports: Vec<Report>,
}

/// Why the flags cannot make a campaign, if they cannot.
fn refuse(args: &SimulateArgs) -> Option<&'static str> {
    let m = &args.measure;
    if args.runs == Some(0) {
        Some("--runs must be at least 1")
    } else if args.jobs == Some(0) {
        Some("--jobs must be at least 1")
    } else if m.shared.log.is_some()
        || m.shared.plot.is_some()
        || m.save_tare.is_some()
        || m.html.is_some()
    {
        Some("--log, --plot, --save-tare and --html apply to a single run, not to --runs")
    } else {
        None
    }
}

fn progress_bar(total: u64, quiet: bool) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("[{elapsed_precise}] {bar:40} {pos}/{len} runs")
    {
        bar.set_style(style);
    }
    bar
}

/// Runs the campaign. Configuration problems are refused before any run starts. `interrupt`
/// parks the runs in flight and skips the rest.
pub fn run(args: &SimulateArgs, interrupt: &AtomicBool) -> Result<CampaignReport, CommandError> {
    if let Some(problem) = refuse(args) {
        return Err(CommandError::Input(anyhow::anyhow!(problem)));
    }
    let scenario = args.scenario()?;
    let config = &scenario.loaded.config;
    let runs = args.runs.unwrap_or(1);
    let jobs = args
        .jobs
        .unwrap_or_else(|| rayon::current_num_threads().max(1));
    let first_seed = scenario.world.seed;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| CommandError::Run(e.into()))?;
    let log_dir = std::env::temp_dir().join(format!("stewart-campaign-{}", std::process::id()));
    std::fs::create_dir_all(&log_dir).map_err(|e| CommandError::Run(e.into()))?;
    let progress = progress_bar(u64::from(runs), args.measure.shared.quiet);
    let start = Instant::now();

    let outcomes: Vec<(u64, Result<Report, String>)> = pool.install(|| {
        (0..u64::from(runs))
            .into_par_iter()
            .map(|k| {
                let seed = first_seed.wrapping_add(k);
                let result = if interrupt.load(Ordering::SeqCst) {
                    Err("skipped: interrupted".to_string())
                } else {
                    one_run(
                        args,
                        seed,
                        log_dir.join(format!("seed-{seed}.mcap")),
                        interrupt,
                    )
                };
                progress.inc(1);
                (seed, result)
            })
            .collect()
    });
    progress.finish_and_clear();
    let _ = std::fs::remove_dir_all(&log_dir);

    let mut reports = Vec::new();
    let mut failed = Vec::new();
    for (seed, result) in outcomes {
        match result {
            Ok(r) => reports.push(r),
            Err(reason) => failed.push(FailedRun { seed, reason }),
        }
    }
    Ok(CampaignReport {
        config: scenario.loaded.source.clone(),
        noise: scenario.noise.name().into(),
        only: args.only.map(|s| s.id().to_string()),
        params: config.estimator.params.into(),
        duration_s: config.run.duration_s,
        tare_duration_s: if args.measure.tare.is_some() {
            0.0
        } else {
            config.run.tare_duration_s
        },
        runs,
        jobs,
        first_seed,
        completed: reports.len() as u32,
        failed,
        wall_s: start.elapsed().as_secs_f64(),
        parameters: statistics(&reports).unwrap_or_default(),
        reports,
    })
}

/// One seeded run through the ordinary single-run path; its log is deleted afterwards.
fn one_run(
    args: &SimulateArgs,
    seed: u64,
    log: PathBuf,
    interrupt: &AtomicBool,
) -> Result<Report, String> {
    let run_args = SimulateArgs {
        seed: Some(seed),
        runs: None,
        jobs: None,
        measure: crate::common::MeasureArgs {
            shared: crate::common::SharedArgs {
                log: Some(log.clone()),
                quiet: true,
                ..args.measure.shared.clone()
            },
            report: None,
            ..args.measure.clone()
        },
        ..args.clone()
    };
    let outcome = simulate::simulate(&run_args, interrupt);
    let _ = std::fs::remove_file(&log);
    let (pass_log, pass_file) = simulate::calibration_pass_paths(&log);
    let _ = std::fs::remove_file(pass_log);
    let _ = std::fs::remove_file(pass_file);
    let (pass_log, pass_file) = simulate::load_cell_pass_paths(&log);
    let _ = std::fs::remove_file(pass_log);
    let _ = std::fs::remove_file(pass_file);
    let outcome = outcome.map_err(|e| e.to_string())?;
    match (outcome.end, outcome.report) {
        // The rules a single run's table obeys: a run that measured nothing trustworthy is a
        // failed run, not a row of the statistics.
        (End::Completed, Some(report)) => report
            .check_quality()
            .map(|()| report)
            .map_err(|e| e.to_string()),
        (End::Completed, None) => Err("no report".into()),
        (End::Interrupted, _) => Err("interrupted".into()),
        (End::Fault(f), _) => Err(format!("fault: {f}")),
    }
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.decimals$}"))
}

/// The table: one row per parameter.
pub fn render(c: &CampaignReport) -> String {
    let mut out = String::new();
    let last = c
        .first_seed
        .wrapping_add(u64::from(c.runs).saturating_sub(1));
    let only = c
        .only
        .as_ref()
        .map_or_else(String::new, |s| format!(", only {s}"));
    let _ = writeln!(
        out,
        "{} of {} runs completed (seeds {}–{}), noise {}{only}, {} parameters, {} s excitation, {} jobs, {:.0} s wall",
        c.completed, c.runs, c.first_seed, last, c.noise, c.params, c.duration_s, c.jobs, c.wall_s
    );
    for f in &c.failed {
        let _ = writeln!(out, "  seed {}: {}", f.seed, f.reason);
    }
    if c.parameters.is_empty() {
        let _ = writeln!(out, "no statistics: no run completed with a known truth");
        return out;
    }
    let _ = writeln!(
        out,
        "{:<7} {:<6} {:>11} {:>11} {:>10} {:>10} {:>10} {:>10} {:>8} {:>6} {:>10} {:>4}",
        "param",
        "unit",
        "truth",
        "mean err",
        "(in s.e.)",
        "spread",
        "max |err|",
        "mean σ",
        "mean z²",
        "≤2σ",
        "accept",
        "ok"
    );
    for p in &c.parameters {
        let _ = writeln!(
            out,
            "{:<7} {:<6} {:>11.5} {:>11.3e} {:>10} {:>10.3e} {:>10.3e} {:>10.3e} {:>8} {:>5.0}% {:>10.3e} {:>4}",
            p.name,
            p.unit,
            p.truth,
            p.mean_error,
            opt(p.mean_error_in_standard_errors, 2),
            p.spread,
            p.max_abs_error,
            p.mean_sigma,
            opt(p.mean_z2, 2),
            100.0 * p.within_2_sigma,
            p.acceptance,
            if p.within_acceptance { "yes" } else { "NO" }
        );
    }
    out
}

/// `stewart simulate --runs N`: runs, prints, writes `--report`. Exit code: 0 when every run
/// completed, 1 when some did not, 2 when the input was refused, 130 after Ctrl-C.
pub fn main(args: &SimulateArgs, interrupt: &AtomicBool) -> u8 {
    let report = match run(args, interrupt) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    print!("{}", render(&report));
    let mut code = u8::from(report.completed < report.runs);
    if let Some(path) = &args.measure.report {
        match serde_json::to_string_pretty(&report) {
            Ok(text) => match std::fs::write(path, text) {
                Ok(()) => println!("report: {}", path.display()),
                Err(e) => {
                    eprintln!("error: cannot write the report {}: {e}", path.display());
                    code = 1;
                }
            },
            Err(e) => {
                eprintln!("error: cannot encode the report: {e}");
                code = 1;
            }
        }
    }
    if interrupt.load(Ordering::SeqCst) {
        code = crate::EXIT_INTERRUPTED;
    }
    code
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_run_flags_are_refused() {
        let base = SimulateArgs {
            runs: Some(3),
            ..SimulateArgs::default()
        };
        assert!(refuse(&base).is_none());
        for bad in [
            SimulateArgs {
                runs: Some(0),
                ..base.clone()
            },
            SimulateArgs {
                jobs: Some(0),
                ..base.clone()
            },
            SimulateArgs {
                measure: crate::common::MeasureArgs {
                    shared: crate::common::SharedArgs {
                        log: Some("x.mcap".into()),
                        ..Default::default()
                    },
                    ..Default::default()
                },
                ..base.clone()
            },
            SimulateArgs {
                measure: crate::common::MeasureArgs {
                    shared: crate::common::SharedArgs {
                        plot: Some("d".into()),
                        ..Default::default()
                    },
                    ..Default::default()
                },
                ..base.clone()
            },
        ] {
            assert!(refuse(&bad).is_some(), "{bad:?}");
        }
    }

    #[test]
    fn a_tiny_campaign_runs_seeds_in_parallel_and_reports_each() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = dir.path().join("short.toml");
        // Short, so the test stays fast; the statistics themselves are checked above.
        std::fs::write(&cfg, "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n").unwrap();
        let args = SimulateArgs {
            measure: crate::common::MeasureArgs {
                shared: crate::common::SharedArgs {
                    config: Some(cfg),
                    quiet: true,
                    ..Default::default()
                },
                ..Default::default()
            },
            noise: Some(sim::NoisePreset::Realistic),
            seed: Some(40),
            runs: Some(2),
            jobs: Some(2),
            only: None,
            calibrate_imu: None,
            calibrate_load_cells: None,
            apply_imu: None,
        };
        let c = run(&args, &AtomicBool::new(false)).unwrap();
        assert_eq!((c.completed, c.runs, c.jobs, c.first_seed), (2, 2, 2, 40));
        assert_eq!(
            c.reports.iter().map(|r| r.run.seed).collect::<Vec<_>>(),
            [40, 41]
        );
        // Different seeds, different noise, different estimates.
        assert_ne!(c.reports[0].estimate, c.reports[1].estimate);
        assert_eq!(c.parameters.len(), 10);
        assert!(c.parameters.iter().all(|p| p.spread > 0.0));
        let text = render(&c);
        assert!(
            text.contains("2 of 2 runs completed (seeds 40–41)"),
            "{text}"
        );
    }
}
