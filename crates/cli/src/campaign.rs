//! `stewart simulate --runs N [--jobs J]`: the accuracy campaign's flags ([`ops::campaign`]),
//! its progress bar and its table.

use std::sync::atomic::{AtomicBool, Ordering};

use std::fmt::Write as _;

use ops::campaign::{CampaignOptions, CampaignReport};

use crate::simulate::SimulateArgs;

/// The campaign's options from the flags.
pub fn options(args: &SimulateArgs) -> CampaignOptions {
    CampaignOptions {
        simulate: args.options(),
        runs: args.runs.unwrap_or(1),
        jobs: args.jobs,
    }
}

/// The terminal's view of a campaign: a bar counting runs (hidden with `--quiet` or when
/// standard error is not a terminal) and each run's warnings.
struct Bar(indicatif::ProgressBar);

impl ops::campaign::CampaignObserver for Bar {
    fn run_done(&self) {
        self.0.inc(1);
    }

    fn warning(&self, text: &str) {
        eprintln!("warning: {text}");
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

/// `stewart simulate --runs N`: runs, prints, writes `--report`. Exit code: 0 when every run
/// completed, 1 when some did not, 2 when the input was refused, 130 after Ctrl-C.
pub fn main(args: &SimulateArgs, interrupt: &AtomicBool) -> u8 {
    let options = options(args);
    let m = &args.measure;
    let refused = ops::campaign::refusal(&options, m.shared.plot.is_some() || m.html.is_some());
    let result = match refused {
        Some(problem) => Err(ops::measurement::refuse(problem)),
        None => {
            let bar = Bar(progress_bar(u64::from(options.runs), m.shared.quiet));
            let result = ops::campaign::run(&options, &bar, interrupt);
            bar.0.finish_and_clear();
            result
        }
    };
    let report = match result {
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

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.decimals$}"))
}

/// The campaign as a table: a summary line, the failed runs, one row per parameter.
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The table says how many runs completed, which seeds, and why a run failed.
    #[test]
    fn the_table_names_the_seeds_and_the_failed_runs() {
        let report = CampaignReport {
            config: "c.toml".into(),
            noise: "realistic".into(),
            only: None,
            params: 10,
            duration_s: 20.0,
            tare_duration_s: 20.0,
            runs: 2,
            jobs: 2,
            first_seed: 40,
            completed: 1,
            failed: vec![ops::campaign::FailedRun {
                seed: 41,
                reason: "fault: link silent".into(),
            }],
            wall_s: 12.0,
            parameters: Vec::new(),
            reports: Vec::new(),
        };
        let text = render(&report);
        assert!(
            text.starts_with("1 of 2 runs completed (seeds 40–41)"),
            "{text}"
        );
        assert!(text.contains("  seed 41: fault: link silent"), "{text}");
        assert!(text.contains("no statistics"), "{text}");
    }

    #[test]
    fn single_run_flags_are_refused() {
        let base = SimulateArgs {
            runs: Some(3),
            ..SimulateArgs::default()
        };
        let refused = |a: &SimulateArgs| {
            let m = &a.measure;
            ops::campaign::refusal(&options(a), m.shared.plot.is_some() || m.html.is_some())
        };
        assert!(refused(&base).is_none());
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
            assert!(refused(&bad).is_some(), "{bad:?}");
        }
    }
}
