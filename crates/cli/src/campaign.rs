//! `stewart simulate --runs N [--jobs J]`: the accuracy campaign's flags ([`ops::campaign`]),
//! its progress bar and its table.

use std::sync::atomic::{AtomicBool, Ordering};

use ops::campaign::{render, CampaignOptions};

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
        Some(problem) => Err(ops::session::refuse(problem)),
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

#[cfg(test)]
mod tests {
    use super::*;

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
