//! `stewart plan`: the flags of [`ops::plan`], which designs the excitation for the rig and the
//! payload's prior before anything moves; prints the predicted sigma of every quantity with
//! the limit that binds.

use std::path::PathBuf;

use clap::Args;
use ops::plan::{Error, PlanOptions};

/// Flags of `stewart plan`.
#[derive(Clone, Debug, Default, Args)]
pub struct PlanArgs {
    /// Rig description TOML, laid over the embedded default (configs/default.toml); its
    /// `[plan]` table holds the payload's prior, the targets and the margins.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Write the designed excitation here (TOML, an `[excitation]` table) for
    /// `simulate --excitation FILE` and `rig --excitation FILE`.
    #[arg(long, short = 'o', value_name = "FILE.toml")]
    pub out: Option<PathBuf>,
    /// Print `{"predicted_sigma": {...}, ...}` (shaped like the report's `sigma`) instead of a
    /// table.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Take the payload's and the fixture's mass and c_x, c_y from this report's
    /// `static_weighing` section (the brake holds' weighing) instead of `[plan]`'s prior.
    #[arg(long, value_name = "REPORT.json")]
    pub prior: Option<PathBuf>,
}

/// Runs `stewart plan`; the exit code: 0 planned, 2 the rig description, the prior or the
/// design refused, 1 a file could not be read or written.
pub fn main(args: &PlanArgs) -> u8 {
    match run(args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                Error::ReadPrior(_) | Error::Write(_) => 1,
                Error::Config(_) | Error::Prior(_) | Error::Design(_) => 2,
            }
        }
    }
}

fn run(args: &PlanArgs) -> Result<(), Error> {
    let options = PlanOptions {
        config: args.config.clone(),
        duration_s: args.duration,
        out: args.out.clone(),
        prior: args.prior.clone(),
    };
    let progress = crate::progress::Progress::new(1, args.quiet || args.json);
    let bar = progress.handle();
    bar.set_message("planning: scoring candidate excitations");
    let outcome = ops::plan::run(&options, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    progress.finish();
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&outcome.summary()).unwrap_or_default()
        );
    } else {
        print!("{}", outcome.table());
        if let Some(line) = outcome.degrees_line() {
            println!("{line}");
        }
        if let Some(path) = &args.out {
            println!(
                "written: {} (use it with `stewart simulate --excitation {}` or `stewart rig --excitation …`)",
                path.display(),
                path.display()
            );
        }
    }
    Ok(())
}
