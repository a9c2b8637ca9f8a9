//! An accuracy campaign: what accuracy will I get with these sensors?
//!
//! N runs of the configured scenario with seeds `seed, seed+1, …` (every random number of a run
//! — sensor errors, the built joints — follows from its seed; each error source draws from its
//! own stream, so a campaign with [`SimulateOptions::only`] sees exactly that source's errors
//! of the full world's runs), J at a time on a rayon pool. Each run is the ordinary single run
//! ([`crate::simulate::run`], its log written to a temporary file and deleted). Then, per
//! parameter of the payload (mass, centre of mass, J_C): mean error, spread, largest error
//! against the acceptance, mean z² and the share within 2σ ([`measure::accuracy`]).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use measure::accuracy::{statistics, ParameterStats};
use measure::observer::{Observer, TickEvent};
use measure::report::Report;
use measure::End;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::measurement::{refuse, Error, Message, Operator, Pass};
use crate::simulate::{self, SimulateOptions};

/// A campaign's options.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct CampaignOptions {
    /// Each run's options; run k has the seed `simulate.seed` (or the world's) + k.
    pub simulate: SimulateOptions,
    /// How many runs.
    pub runs: u32,
    /// Runs in parallel (`None`: one per CPU).
    pub jobs: Option<usize>,
}

/// Who watches a campaign, from every run's thread.
pub trait CampaignObserver: Sync {
    /// A run ended (completed or not).
    fn run_done(&self) {}

    /// A run's warning.
    fn warning(&self, text: &str) {
        let _ = text;
    }
}

/// Watches nothing.
impl CampaignObserver for () {}

/// A run's operator: its warnings to the campaign's observer, nothing else.
struct Warnings<'a>(&'a dyn CampaignObserver);

impl Observer for Warnings<'_> {
    fn tick(&mut self, _: &TickEvent<'_>) -> anyhow::Result<()> {
        Ok(())
    }
}

impl Operator for Warnings<'_> {
    fn tell(&mut self, message: Message<'_>) {
        if let Message::Warning(text) = message {
            self.0.warning(text);
        }
    }
}

/// A run that produced no report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FailedRun {
    /// Its seed.
    pub seed: u64,
    /// Why (fault, interrupt, error).
    pub reason: String,
}

/// The campaign's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CampaignReport {
    /// Scenario file, or the embedded default.
    pub config: String,
    /// Noise preset.
    pub noise: String,
    /// The one error source the simulated rig had ([`SimulateOptions::only`]), or every source switched on in
    /// `[world.imperfections]` (`None`).
    pub only: Option<String>,
    /// 10 or 6.
    pub params: u8,
    /// Excitation time of each loaded run including the fades, s.
    pub duration_s: f64,
    /// Tare excitation time, s (0 with a saved tare).
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

/// The most runs a campaign takes. The campaign holds every run's report (and a slot for each
/// run's outcome) in memory until the statistics are made, so the count sizes an allocation:
/// a hundred thousand runs are a few hundred megabytes and, at seconds a run, days of work;
/// statistics of an error need far fewer (the standard error of a sigma falls as 1/√(2N)).
pub const MAX_RUNS: u32 = 100_000;

/// The most runs in parallel (`--jobs`): each job is a thread with its own simulator, and more
/// threads than cores only share the cores.
pub const MAX_JOBS: usize = 1024;

/// Why `options` cannot make a campaign, if they cannot; `single_run_outputs`: the front end
/// was also asked for outputs of a single run (figures, a page).
pub fn refusal(options: &CampaignOptions, single_run_outputs: bool) -> Option<String> {
    let m = &options.simulate.measure;
    if !(1..=MAX_RUNS).contains(&options.runs) {
        Some(format!(
            "--runs must be between 1 and {MAX_RUNS} (a campaign holds every run's report in memory), got {}",
            options.runs
        ))
    } else if options.jobs.is_some_and(|j| !(1..=MAX_JOBS).contains(&j)) {
        Some(format!(
            "--jobs must be between 1 and {MAX_JOBS} (one thread and simulator each), got {}",
            options.jobs.unwrap_or_default()
        ))
    } else if m.log.is_some() || m.save_tare.is_some() || single_run_outputs {
        Some("--log, --plot, --save-tare and --html apply to a single run, not to --runs".into())
    } else {
        None
    }
}

/// Runs the campaign of `options`, telling `observer`. Configuration problems are refused
/// before any run starts. `interrupt` parks the runs in flight and skips the rest.
pub fn run(
    options: &CampaignOptions,
    observer: &dyn CampaignObserver,
    interrupt: &AtomicBool,
) -> Result<CampaignReport, Error> {
    if let Some(problem) = refusal(options, false) {
        return Err(refuse(problem));
    }
    let args = &options.simulate;
    let scenario = args.scenario()?;
    let config = &scenario.loaded.config;
    let runs = options.runs;
    let jobs = options
        .jobs
        .unwrap_or_else(|| rayon::current_num_threads().max(1));
    let first_seed = scenario.world.seed;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| Error::Run(e.into()))?;
    let log_dir = std::env::temp_dir().join(format!("stewart-campaign-{}", std::process::id()));
    std::fs::create_dir_all(&log_dir).map_err(|e| Error::Run(e.into()))?;
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
                        observer,
                        interrupt,
                    )
                };
                observer.run_done();
                (seed, result)
            })
            .collect()
    });
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
    args: &SimulateOptions,
    seed: u64,
    log: PathBuf,
    observer: &dyn CampaignObserver,
    interrupt: &AtomicBool,
) -> Result<Report, String> {
    let run_options = SimulateOptions {
        seed: Some(seed),
        measure: crate::measurement::MeasureOptions {
            log: Some(log.clone()),
            ..args.measure.clone()
        },
        ..args.clone()
    };
    let outcome = simulate::run(&run_options, &mut Warnings(observer), interrupt);
    let _ = std::fs::remove_file(&log);
    for pass in [Pass::Imu, Pass::LoadCells] {
        let (pass_log, pass_file) = simulate::pass_paths(pass, &log);
        let _ = std::fs::remove_file(pass_log);
        let _ = std::fs::remove_file(pass_file);
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiny_campaign_runs_seeds_in_parallel_and_reports_each() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = dir.path().join("short.toml");
        // Short, so the test stays fast; the statistics themselves are checked above.
        std::fs::write(&cfg, "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n").unwrap();
        let options = CampaignOptions {
            simulate: SimulateOptions {
                measure: crate::measurement::MeasureOptions {
                    config: Some(cfg),
                    ..Default::default()
                },
                noise: Some(sim::NoisePreset::Realistic),
                seed: Some(40),
                ..Default::default()
            },
            runs: 2,
            jobs: Some(2),
        };
        let c = run(&options, &(), &AtomicBool::new(false)).unwrap();
        assert_eq!((c.completed, c.runs, c.jobs, c.first_seed), (2, 2, 2, 40));
        assert_eq!(
            c.reports.iter().map(|r| r.run.seed).collect::<Vec<_>>(),
            [40, 41]
        );
        // Different seeds, different noise, different estimates.
        assert_ne!(c.reports[0].estimate, c.reports[1].estimate);
        assert_eq!(c.parameters.len(), 10);
        assert!(c.parameters.iter().all(|p| p.spread > 0.0));
    }
}
