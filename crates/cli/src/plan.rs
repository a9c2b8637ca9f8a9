//! `stewart plan`: design the excitation for the rig and the payload's prior before anything
//! moves, print the predicted sigma of every quantity with the limit that binds, and write the
//! trajectory for `simulate --excitation FILE` and `rig --excitation FILE`.

use std::path::PathBuf;

use clap::Args;
use control::trajectory::Trajectory;
use measure::load::Overrides;
use measure::report::Quantities;
use planner::{Planner, Prediction};
use serde::Serialize;

use crate::common::{refuse, CommandError};

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

/// What `--json` prints.
#[derive(Debug, Serialize)]
struct PlanJson {
    predicted_sigma: Quantities,
    target_sigma: Quantities,
    criterion: f64,
    worst: &'static str,
    binding: String,
    usage: Usage,
    configured_predicted_sigma: Option<Quantities>,
    /// Degrees of freedom the loaded run's residual windows will give each sigma, in the order
    /// of the report's `covariance_basis.loaded_degrees_of_freedom`; `null` where the run
    /// does not determine them.
    predicted_degrees_of_freedom: [Option<f64>; 10],
    base_frequency_hz: f64,
    harmonics_per_axis: usize,
    components: usize,
    duration_s: f64,
}

#[derive(Debug, Serialize)]
struct Usage {
    leg_force: f64,
    payload_acceleration: f64,
    leg_speed: f64,
    stroke: f64,
}

/// Runs `stewart plan`; the exit code.
pub fn main(args: &PlanArgs) -> u8 {
    match run(args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

fn run(args: &PlanArgs) -> Result<(), CommandError> {
    let mut loaded = measure::load::load(args.config.as_deref())?.with_overrides(&Overrides {
        duration_s: args.duration,
        params: None,
    })?;
    if let Some(path) = &args.prior {
        let text = std::fs::read_to_string(path).map_err(|e| {
            CommandError::Run(anyhow::anyhow!("cannot read {}: {e}", path.display()))
        })?;
        let weighing = measure::report::static_weighing_of(&text)
            .map_err(|e| refuse(format!("{}: {e}", path.display())))?;
        measure::report::apply_prior(&mut loaded.config.plan, &weighing);
    }
    let config = &loaded.config;
    let planner = Planner::new(&loaded)?;
    let duration_s = config.run.duration_s;
    let progress = crate::progress::Progress::new(1, args.quiet || args.json);
    let bar = progress.handle();
    bar.set_message("planning: scoring candidate excitations");
    let plan = planner::design(
        &planner,
        &config.excitation,
        duration_s,
        config.run.tare_duration_s,
        &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
    )
    .map_err(|e| refuse(e.to_string()))?;
    progress.finish();
    // The rig description's own excitation, predicted alike, for comparison.
    let configured = configured_prediction(&loaded, &planner, duration_s);
    let degrees: [Option<f64>; 10] = planner
        .predicted_degrees_of_freedom(&plan.loaded)
        .map_or([None; 10], |d| d.map(|v| Some(v).filter(|v| v.is_finite())));
    let (worst_index, criterion) = plan.prediction.worst();
    let worst = Quantities::NAMES[worst_index];
    if let Some(path) = &args.out {
        let header = header(&plan, duration_s, &loaded.source);
        let text = planner::search::excitation_file(&plan.excitation, &header);
        // The export's atomic write: a reader never sees a half-written file.
        inertial_export::file::write_atomically(path, &text)
            .map_err(|e| CommandError::Run(anyhow::anyhow!("{e}")))?;
    }
    if args.json {
        let json = PlanJson {
            predicted_sigma: plan.prediction.sigma,
            target_sigma: Quantities::from_flat(&planner.targets),
            criterion,
            worst,
            binding: plan.binding.to_string(),
            usage: Usage {
                leg_force: plan.usage.force,
                payload_acceleration: plan.usage.acceleration,
                leg_speed: plan.usage.leg_speed,
                stroke: plan.usage.stroke,
            },
            configured_predicted_sigma: configured.as_ref().map(|p| p.sigma),
            predicted_degrees_of_freedom: degrees,
            base_frequency_hz: plan.base_frequency_hz,
            harmonics_per_axis: plan.harmonics_per_axis,
            components: plan.loaded.components().len(),
            duration_s,
        };
        println!(
            "{}",
            serde_json::to_string_pretty(&json).unwrap_or_default()
        );
    } else {
        print!(
            "{}",
            table(&plan, &planner, configured.as_ref(), duration_s)
        );
        if let Some(line) = degrees_line(&degrees) {
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

/// The loaded and tare runs' trajectories of the rig description's own `[excitation]`, the
/// loaded one `duration_s` long; `None` when either cannot be built.
pub fn configured_trajectories(
    loaded: &measure::LoadedConfig,
    planner: &Planner,
    duration_s: f64,
) -> Option<(Trajectory, Trajectory)> {
    measure::setup::trajectory(loaded, &planner.geometry, duration_s)
        .ok()
        .zip(measure::setup::tare_trajectory(loaded, &planner.geometry).ok())
}

/// The predicted sigma of the rig description's own excitation: the `configured σ` column of
/// `stewart plan` (`configured_predicted_sigma` in `--json`).
pub fn configured_prediction(
    loaded: &measure::LoadedConfig,
    planner: &Planner,
    duration_s: f64,
) -> Option<Prediction> {
    configured_trajectories(loaded, planner, duration_s).and_then(|(l, t)| planner.predict(&l, &t))
}

/// The file's header: what it is, when, for what, and what it predicts.
fn header(plan: &planner::Plan, duration_s: f64, source: &str) -> String {
    let mut h = format!(
        "Excitation designed by `stewart plan` (stewart {}) for the rig description {source}:\n\
         {} sines, base frequency {:.4} Hz, {} harmonics per axis, {duration_s} s loaded run.\n\
         Binding limit: {}.\n\
         Predicted one sigma from the sensors' noise (payload, loaded − tare):\n",
        env!("CARGO_PKG_VERSION"),
        plan.loaded.components().len(),
        plan.base_frequency_hz,
        plan.harmonics_per_axis,
        plan.binding,
    );
    for (name, s) in Quantities::NAMES.iter().zip(plan.prediction.sigma.flat()) {
        h.push_str(&format!("  {name}: {s:.3e}\n"));
    }
    h
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

fn table(
    plan: &planner::Plan,
    planner: &Planner,
    configured: Option<&Prediction>,
    duration_s: f64,
) -> String {
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
    let conf = configured.map(|p| p.sigma.flat());
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
            planner.targets[i] * scale,
            plan.prediction.ratios[i],
            conf.map_or("-".into(), |c| format!("{:.4}", c[i] * scale)),
        ));
    }
    out
}
