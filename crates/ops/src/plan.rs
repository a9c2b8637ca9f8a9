//! `stewart plan`'s work: design the excitation for the rig and the payload's prior before
//! anything moves ([`planner::design`]), predict the sigma of every quantity with the
//! limit that binds, and write the trajectory for `simulate --excitation FILE` and
//! `rig --excitation FILE`.

use std::path::PathBuf;

use control::trajectory::Trajectory;
use measure::report::Quantities;
use planner::{self as plan, Planner, Prediction};
use rig_description::load::{ConfigError, LoadedConfig, Overrides};
use serde::Serialize;

/// Options of `stewart plan`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlanOptions {
    /// Rig description TOML, laid over the embedded default; its `[plan]` table holds the
    /// payload's prior, the targets and the margins.
    pub config: Option<PathBuf>,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    pub duration_s: Option<f64>,
    /// Write the designed excitation here (TOML, an `[excitation]` table).
    pub out: Option<PathBuf>,
    /// Take the payload's and the fixture's mass and c_x, c_y from this report's
    /// `static_weighing` section instead of `[plan]`'s prior.
    pub prior: Option<PathBuf>,
}

/// Why `plan` designed nothing.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The rig description was refused.
    #[error("{0}")]
    Config(#[from] ConfigError),
    /// The prior's report could not be read.
    #[error("{0}")]
    ReadPrior(String),
    /// The prior's report holds no usable weighing.
    #[error("{0}")]
    Prior(String),
    /// No excitation fits the rig's limits.
    #[error("{0}")]
    Design(String),
    /// The excitation file could not be written.
    #[error("{0}")]
    Write(String),
}

/// The limits' use, as `--json` prints it (fractions of each limit).
#[derive(Clone, Debug, Serialize)]
pub struct Usage {
    /// Leg force.
    pub leg_force: f64,
    /// Payload acceleration.
    pub payload_acceleration: f64,
    /// Leg speed.
    pub leg_speed: f64,
    /// Stroke.
    pub stroke: f64,
}

/// The plan's figures, as `stewart plan --json` prints them (`predicted_sigma` shaped like
/// the report's `sigma`).
#[derive(Clone, Debug, Serialize)]
pub struct PlanSummary {
    /// Predicted one sigma of each quantity.
    pub predicted_sigma: Quantities,
    /// The targets of `[plan]`.
    pub target_sigma: Quantities,
    /// The largest sigma/target ratio.
    pub criterion: f64,
    /// The quantity with that ratio.
    pub worst: &'static str,
    /// The limit that binds.
    pub binding: String,
    /// Each limit's use.
    pub usage: Usage,
    /// The predicted sigma of the rig description's own excitation.
    pub configured_predicted_sigma: Option<Quantities>,
    /// Degrees of freedom the loaded run's residual windows will give each sigma, in the order
    /// of the report's `covariance_basis.loaded_degrees_of_freedom`; `null` where the run
    /// does not determine them.
    pub predicted_degrees_of_freedom: [Option<f64>; 10],
    /// Base frequency of the sines, Hz.
    pub base_frequency_hz: f64,
    /// Harmonics per axis.
    pub harmonics_per_axis: usize,
    /// Sines in the excitation.
    pub components: usize,
    /// Loaded run's excitation time, s.
    pub duration_s: f64,
}

/// What `plan` designed.
#[derive(Clone, Debug)]
pub struct PlanOutcome {
    /// The designed excitation and its prediction.
    pub plan: plan::Plan,
    /// The targets of `[plan]` (ten quantities).
    pub targets: [f64; 10],
    /// The prediction of the rig description's own excitation, for comparison.
    pub configured: Option<Prediction>,
    /// See [`PlanSummary::predicted_degrees_of_freedom`].
    pub degrees_of_freedom: [Option<f64>; 10],
    /// Loaded run's excitation time, s.
    pub duration_s: f64,
}

impl PlanOutcome {
    /// The figures `--json` prints.
    pub fn summary(&self) -> PlanSummary {
        let plan = &self.plan;
        let (worst_index, criterion) = plan.prediction.worst();
        PlanSummary {
            predicted_sigma: plan.prediction.sigma,
            target_sigma: Quantities::from_flat(&self.targets),
            criterion,
            worst: Quantities::NAMES[worst_index],
            binding: plan.binding.to_string(),
            usage: Usage {
                leg_force: plan.usage.force,
                payload_acceleration: plan.usage.acceleration,
                leg_speed: plan.usage.leg_speed,
                stroke: plan.usage.stroke,
            },
            configured_predicted_sigma: self.configured.as_ref().map(|p| p.sigma),
            predicted_degrees_of_freedom: self.degrees_of_freedom,
            base_frequency_hz: plan.base_frequency_hz,
            harmonics_per_axis: plan.harmonics_per_axis,
            components: plan.loaded.components().len(),
            duration_s: self.duration_s,
        }
    }
}

/// Runs `plan`: loads the rig description (and the prior), scores candidate excitations
/// (`progress(done, total)` after each), predicts the configured excitation alike and writes
/// the designed one to [`PlanOptions::out`].
pub fn run(
    options: &PlanOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<PlanOutcome, Error> {
    let mut loaded =
        rig_description::load::load(options.config.as_deref())?.with_overrides(&Overrides {
            duration_s: options.duration_s,
            params: None,
        })?;
    if let Some(path) = &options.prior {
        let text = rig_description::bounded::read_to_string_capped(
            path,
            rig_description::bounded::REPORT_CAP_BYTES,
            "a report",
        )
        .map_err(|e| Error::ReadPrior(format!("cannot read {}: {e}", path.display())))?;
        let weighing = measure::report::static_weighing_of(&text)
            .map_err(|e| Error::Prior(format!("{}: {e}", path.display())))?;
        measure::report::apply_prior(&mut loaded.config.plan, &weighing);
    }
    let config = &loaded.config;
    let planner = Planner::new(&loaded)?;
    let duration_s = config.run.duration_s;
    let plan = plan::design(
        &planner,
        &config.excitation,
        duration_s,
        config.run.tare_duration_s,
        progress,
    )
    .map_err(|e| Error::Design(e.to_string()))?;
    let configured = configured_prediction(&loaded, &planner, duration_s);
    let degrees_of_freedom = planner
        .predicted_degrees_of_freedom(&plan.loaded)
        .map_or([None; 10], |d| d.map(|v| Some(v).filter(|v| v.is_finite())));
    if let Some(path) = &options.out {
        let header = header(&plan, duration_s, &loaded.source);
        let text = plan::search::excitation_file(&plan.excitation, &header);
        // The export's atomic write: a reader never sees a half-written file.
        inertial_export::file::write_atomically(path, &text)
            .map_err(|e| Error::Write(e.to_string()))?;
    }
    Ok(PlanOutcome {
        targets: planner.targets,
        plan,
        configured,
        degrees_of_freedom,
        duration_s,
    })
}

/// The loaded and tare runs' trajectories of the rig description's own `[excitation]`, the
/// loaded one `duration_s` long; `None` when either cannot be built.
pub fn configured_trajectories(
    loaded: &LoadedConfig,
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
    loaded: &LoadedConfig,
    planner: &Planner,
    duration_s: f64,
) -> Option<Prediction> {
    configured_trajectories(loaded, planner, duration_s).and_then(|(l, t)| planner.predict(&l, &t))
}

/// The file's header: what it is, when, for what, and what it predicts.
fn header(plan: &plan::Plan, duration_s: f64, source: &str) -> String {
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

impl PlanOutcome {
    /// The line on the sigmas' degrees of freedom: the fewest, and a warning when a quantity's
    /// falls below [`measure::quality::HEAVY_TAIL_DEGREES_OF_FREEDOM`].
    pub fn degrees_line(&self) -> Option<String> {
        let degrees = &self.degrees_of_freedom;
        let (name, fewest) =
            measure::quality::fewest_degrees_of_freedom(&Quantities::NAMES, degrees)?;
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

    /// The plan as `stewart plan` prints it: the excitation, the limits' use and, per quantity,
    /// the predicted, target and configured sigma.
    pub fn table(&self) -> String {
        let (plan, duration_s) = (&self.plan, self.duration_s);
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
        let conf = self.configured.as_ref().map(|p| p.sigma.flat());
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
                self.targets[i] * scale,
                plan.prediction.ratios[i],
                conf.map_or("-".into(), |c| format!("{:.4}", c[i] * scale)),
            ));
        }
        out
    }
}
