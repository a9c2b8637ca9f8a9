//! `stewart plan`: the flags of [`ops::plan`], which designs the excitation for the rig and the
//! payload's prior before anything moves; prints the predicted sigma of every quantity with
//! the limit that binds.

use std::path::PathBuf;

use clap::Args;
use measure::report::Quantities;
use ops::plan::{Error, PlanOptions, PlanOutcome};

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
        print!("{}", table(&outcome));
        if let Some(line) = degrees_line(&outcome.degrees_of_freedom) {
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

/// The line on the sigmas' degrees of freedom: the fewest, and a warning when a quantity's
/// falls below [`measure::quality::HEAVY_TAIL_DEGREES_OF_FREEDOM`].
fn degrees_line(degrees: &[Option<f64>; 10]) -> Option<String> {
    let (name, fewest) = measure::quality::fewest_degrees_of_freedom(&Quantities::NAMES, degrees)?;
    Some(
        match measure::quality::heavy_tailed(&Quantities::NAMES, degrees) {
            Some((name, nu)) => format!(
                "residual windows: {name}'s sigma will rest on {nu:.1} degrees of freedom (fewer \
                 than {:.0}: its error can reach several sigmas more often than a normal one's); \
                 a longer excitation gives more",
                measure::quality::HEAVY_TAIL_DEGREES_OF_FREEDOM
            ),
            None => format!(
                "residual windows: every sigma will rest on at least {fewest:.1} degrees of freedom ({name})"
            ),
        },
    )
}

fn table(outcome: &PlanOutcome) -> String {
    let (plan, duration_s) = (&outcome.plan, outcome.duration_s);
    let mut out = format!(
        "planned excitation: {} sines, base {:.4} Hz, {} harmonics per axis, {duration_s} s \
         ({} candidates scored)\n",
        plan.loaded.components().len(),
        plan.base_frequency_hz,
        plan.harmonics_per_axis,
        plan.evaluated
    );
    out.push_str(&format!(
        "limits used: leg force {:.0} %, payload acceleration {:.0} %, leg speed {:.0} %, stroke {:.0} %; binding: {}\n\n",
        100.0 * plan.usage.force,
        100.0 * plan.usage.acceleration,
        100.0 * plan.usage.leg_speed,
        100.0 * plan.usage.stroke,
        plan.binding
    ));
    out.push_str(&format!(
        "{:<8} {:>12} {:>12} {:>7}   {:>14}\n",
        "", "predicted σ", "target σ", "σ/target", "configured σ"
    ));
    let sigma = plan.prediction.sigma.flat();
    let conf = outcome.configured.as_ref().map(|p| p.sigma.flat());
    for i in 0..10 {
        let unit = match i {
            0 => "kg",
            1..=3 => "mm",
            _ => "kg·m²",
        };
        let scale = if (1..=3).contains(&i) { 1e3 } else { 1.0 };
        out.push_str(&format!(
            "{:<8} {:>9.4} {:<5} {:>9.4} {:>7.2}   {:>14}\n",
            Quantities::NAMES[i],
            sigma[i] * scale,
            unit,
            outcome.targets[i] * scale,
            plan.prediction.ratios[i],
            conf.map_or("-".into(), |c| format!("{:.4}", c[i] * scale)),
        ));
    }
    out
}
