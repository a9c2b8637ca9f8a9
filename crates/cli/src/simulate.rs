//! `stewart simulate`: the whole measurement on the simulator — tare run with the empty
//! fixture (or a saved tare), the payload put on, the loaded run, park — then the report.
//!
//! Every check that can refuse the run (configuration, design, both trajectories, the tare
//! file, the simulator's own stability checks) runs before the first sample. The simulator's
//! truth goes only into the report's `truth`, the table and `/run/truth`; the estimator sees
//! sensor frames only.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{anyhow, Context};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use kinematics::Geometry;

use crate::args::RunArgs;
use crate::config::{Config, ParamCount};
use crate::config_load::{self, ConfigError, ConfigIssue, LoadedConfig, Overrides};
use crate::foxglove::SceneGeometry;
use crate::log_messages as topics;
use crate::mcap_log::default_log_path;
use crate::metadata::{BodyTruth, RunMetadata, TruthMsg};
use crate::preflight::{self, Measurement};
use crate::report::{self, Quantities, Report, ReportInputs, RunInfo, TareKind};
use crate::run::{self, End, Hooks, MeasureOutcome, MeasureSetup};
use crate::run_log::RunLog;
use crate::tare::TareFile;

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The configuration was refused before anything ran.
    #[error("{0}")]
    Config(ConfigError),
    /// An input other than the configuration (a tare file) was refused before anything ran.
    #[error("{0:#}")]
    Input(anyhow::Error),
    /// The run failed (backend, log).
    #[error("{0:#}")]
    Run(anyhow::Error),
}

impl CommandError {
    /// Process exit code: 2 for refused inputs (nothing ran), 1 for a failed run.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Config(_) | Self::Input(_) => 2,
            Self::Run(_) => 1,
        }
    }
}

impl From<ConfigError> for CommandError {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

/// What a `simulate` run produced.
#[derive(Debug)]
pub struct SimulateOutcome {
    /// The report (estimate, sigma, truth, ...); `None` when the run ended before an estimate.
    pub report: Option<Report>,
    /// The MCAP log written.
    pub log_path: PathBuf,
    /// How the run ended (anything but `Completed` is a non-zero exit).
    pub end: End,
    /// The measured tare, when a tare run was made.
    pub tare: Option<TareFile>,
}

fn overrides(args: &RunArgs) -> Overrides {
    Overrides {
        duration_s: args.duration,
        seed: args.seed,
        noise: args.noise,
        params: args.params.as_deref().map(|p| {
            if p == "6" {
                ParamCount::Six
            } else {
                ParamCount::Ten
            }
        }),
    }
}

/// The configuration of `args`, validated with the command-line values applied.
pub fn load_config(args: &RunArgs) -> Result<LoadedConfig, ConfigError> {
    config_load::load(args.config.as_deref())?.with_overrides(&overrides(args))
}

fn joints(g: &Geometry) -> ([[f64; 3]; 6], [[f64; 3]; 6]) {
    (
        g.base_joints_m().map(|v| [v.x, v.y, v.z]),
        g.plate_joints_m().map(|v| [v.x, v.y, v.z]),
    )
}

fn sim_config(config: &Config) -> sim::SimConfig {
    let mut sensors = sim::SensorConfig::preset(config.sensors.noise.to_sim());
    sensors.accelerometer.mount_m = config.sensors.imu_position_m;
    sim::SimConfig {
        sample_rate_hz: config.sensors.sample_rate_hz,
        substeps: config.sensors.physics_substeps,
        actuator: config.actuator,
        sensors,
        ..sim::SimConfig::default()
    }
}

/// Maps a simulator refusal to the configuration key it names.
fn sim_issue(loaded: &LoadedConfig, e: &sim::SimError) -> ConfigIssue {
    match e {
        sim::SimError::InvalidConfig {
            field,
            reason,
            value,
        } => {
            let key = if field.starts_with("actuator.") {
                field.to_string()
            } else if *field == "substeps" {
                "sensors.physics_substeps".to_string()
            } else if field.starts_with("sensors.") {
                "sensors.noise".to_string()
            } else {
                "platform".to_string()
            };
            loaded.issue(
                &key,
                format!("refused by the simulator: {reason} (value {value})"),
            )
        }
        sim::SimError::InvalidBody { body, reason } => {
            let key = if *body == "fixture" {
                "fixture"
            } else {
                "payload"
            };
            loaded.issue(key, format!("refused by the simulator: {reason}"))
        }
        other => loaded.issue("platform", format!("refused by the simulator: {other}")),
    }
}

fn body_truth(b: &sim::BodyProperties) -> BodyTruth {
    BodyTruth {
        mass_kg: b.mass_kg,
        com_m: b.com_m,
        inertia_com_kg_m2: b.inertia_com_kg_m2,
        theta: sim::InertialParameters::from_body(b).theta(),
    }
}

fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(10));
    if let Ok(style) =
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
    {
        bar.set_style(style);
    }
    bar
}

/// Runs `stewart simulate` with `args`. `interrupt` is the Ctrl-C flag: when it is set the
/// platform parks, the log is finished and the outcome says [`End::Interrupted`].
pub fn simulate(args: &RunArgs, interrupt: &AtomicBool) -> Result<SimulateOutcome, CommandError> {
    // Everything that can refuse the run, before the first sample.
    let loaded = load_config(args)?;
    let config = &loaded.config;
    let geometry = preflight::geometry(&loaded)?;
    // The controllers checked here are the ones that run (no second feasibility check).
    let loaded_trajectory = preflight::trajectory(&loaded, &geometry, config.run.duration_s)?;
    let loaded_controller = preflight::controller(&loaded, &geometry, loaded_trajectory)?;
    let (base_joints, plate_joints) = joints(&geometry);
    let tare_file = match &args.tare {
        Some(path) => {
            Some(TareFile::load(path, &base_joints, &plate_joints).map_err(CommandError::Input)?)
        }
        None => None,
    };
    let tare_controller = if tare_file.is_none() {
        let t = preflight::trajectory(&loaded, &geometry, config.run.tare_duration_s)
            .map_err(|e| rename_duration(e, "run.tare_duration_s"))?;
        Some(preflight::controller(&loaded, &geometry, t)?)
    } else {
        None
    };
    let fixture = config.fixture.to_sim();
    let payload = config.payload.to_sim();
    let start_payload = if tare_controller.is_some() {
        None
    } else {
        Some(payload)
    };
    let mut sim = sim::Simulator::new(
        geometry,
        fixture,
        start_payload,
        &sim_config(config),
        config.run.seed,
    )
    .map_err(|e| CommandError::Config(ConfigError::single(sim_issue(&loaded, &e))))?;
    if tare_controller.is_some() {
        // The loaded world must be accepted too, before the tare run moves anything.
        sim::Simulator::new(geometry, fixture, Some(payload), &sim_config(config), 0)
            .map_err(|e| CommandError::Config(ConfigError::single(sim_issue(&loaded, &e))))?;
    }

    // The log.
    let start_ns = unix_ns();
    let log_path = match &args.log {
        Some(p) => p.clone(),
        None => default_log_path(Path::new("runs"), start_ns / 1_000_000_000),
    };
    let mut log = RunLog::create(&log_path, start_ns).map_err(CommandError::Run)?;
    let result = simulate_logged(
        args,
        &loaded,
        geometry,
        &mut sim,
        &mut log,
        tare_file,
        tare_controller,
        loaded_controller,
        interrupt,
    );
    let finished = log.finish();
    let (report, end, tare) = result.map_err(CommandError::Run)?;
    finished.map_err(CommandError::Run)?;
    Ok(SimulateOutcome {
        report,
        log_path,
        end,
        tare,
    })
}

fn rename_duration(mut e: ConfigError, key: &str) -> ConfigError {
    for issue in &mut e.issues {
        if issue.key == "run.duration_s" {
            issue.key = key.to_string();
        }
    }
    e
}

type Produced = (Option<Report>, End, Option<TareFile>);

#[allow(clippy::too_many_arguments)]
fn simulate_logged(
    args: &RunArgs,
    loaded: &LoadedConfig,
    geometry: Geometry,
    sim: &mut sim::Simulator,
    log: &mut RunLog,
    tare_file: Option<TareFile>,
    tare_controller: Option<control::controller::Controller>,
    loaded_controller: control::controller::Controller,
    interrupt: &AtomicBool,
) -> anyhow::Result<Produced> {
    let config = &loaded.config;
    let (base_joints, plate_joints) = joints(&geometry);
    let stroke = geometry.stroke();
    let mut runs = Vec::new();
    if tare_controller.is_some() {
        runs.push("tare".to_string());
    }
    runs.push("loaded".to_string());
    log.write_now(
        topics::METADATA,
        &RunMetadata {
            tool_version: env!("CARGO_PKG_VERSION").into(),
            command: "simulate".into(),
            backend: "sim".into(),
            config_source: loaded.source.clone(),
            config_text: loaded.text.clone(),
            config_toml: loaded.effective_toml(),
            seed: config.run.seed,
            noise: config.sensors.noise.name().into(),
            params: config.estimator.params.into(),
            sample_period_s: 1.0 / config.sensors.sample_rate_hz,
            start_unix_ns: log.start_unix_ns(),
            runs,
            tare_file: args.tare.as_ref().map(|p| p.display().to_string()),
            base_joints_m: base_joints,
            plate_joints_m: plate_joints,
            stroke_m: [stroke.min_length_m, stroke.max_length_m],
        },
    )?;
    let fixture = config.fixture.to_sim();
    let payload = config.payload.to_sim();
    log.write_now(
        topics::TRUTH,
        &TruthMsg {
            fixture: body_truth(&fixture),
            payload: body_truth(&payload),
        },
    )?;

    let scene = SceneGeometry {
        base_joints_m: *geometry.base_joints_m(),
        plate_joints_m: *geometry.plate_joints_m(),
        base_radius_m: config.platform.base_radius_m,
        plate_radius_m: config.platform.plate_radius_m,
        force_scale_n: config.control.max_force_n,
    };
    let total = tare_controller
        .as_ref()
        .map_or(0, |c| run::expected_samples(config, c.trajectory()))
        + run::expected_samples(config, loaded_controller.trajectory());
    let progress = progress_bar(total, args.quiet);
    let mut command_sequence = 0u64;

    // Tare: measured now, or from the file.
    let mut measured_tare = None;
    let mut tare_bias_effect = None;
    let mut tare_load_cell_effect = None;
    let tare = match (tare_file, tare_controller) {
        (Some(file), _) => {
            log.write_now(topics::TARE, &file)?;
            TareSource::File(file)
        }
        (None, Some(controller)) => {
            let outcome = run::measure_with(
                sim,
                &MeasureSetup {
                    config,
                    geometry,
                    measurement: Measurement::Tare,
                    trajectory: *controller.trajectory(),
                    tare: None,
                },
                controller,
                &mut Hooks {
                    log,
                    progress: &progress,
                    interrupt,
                    scene: &scene,
                    command_sequence: &mut command_sequence,
                },
            )?;
            if outcome.end != End::Completed {
                progress.finish_and_clear();
                return Ok((None, outcome.end, None));
            }
            let estimate = outcome
                .estimate
                .ok_or_else(|| anyhow!("the tare run produced no estimate"))?;
            // With the run's bias sensitivities, so a saved tare reused by `--tare` counts its
            // share of the systematic part as this same-run tare does (as `rig` writes it).
            let file = TareFile::from_estimate(
                &estimate,
                &base_joints,
                &plate_joints,
                &loaded.source,
                "sim",
            )
            .with_bias_effects(
                outcome.accel_bias_effect.as_ref(),
                crate::preflight::accel_bias_sigma(config),
                outcome.load_cell_bias_effect.as_ref(),
                crate::systematic::load_cell_bias_sigma(config),
            );
            log.write_now(topics::TARE, &file)?;
            if let Some(path) = &args.save_tare {
                file.save(path)?;
            }
            measured_tare = Some(file.clone());
            tare_bias_effect = outcome.accel_bias_effect;
            tare_load_cell_effect = outcome.load_cell_bias_effect;
            TareSource::Measured(file)
        }
        (None, None) => unreachable!("a tare file or a tare trajectory is always present"),
    };
    let tare_params = (tare.file().parameters(), tare.file().covariance_matrix());

    sim.set_payload(Some(payload))
        .map_err(|e| anyhow!("the simulator refused the payload: {e}"))?;
    let outcome = run::measure_with(
        sim,
        &MeasureSetup {
            config,
            geometry,
            measurement: Measurement::Loaded,
            trajectory: *loaded_controller.trajectory(),
            tare: Some(tare_params),
        },
        loaded_controller,
        &mut Hooks {
            log,
            progress: &progress,
            interrupt,
            scene: &scene,
            command_sequence: &mut command_sequence,
        },
    )?;
    progress.finish_and_clear();
    if outcome.end != End::Completed {
        return Ok((None, outcome.end, measured_tare));
    }
    let truth = sim.true_payload().map(|b| quantities_of_body(&b));
    let report = build_report(
        args,
        loaded,
        &outcome,
        &tare,
        (tare_bias_effect.as_ref(), tare_load_cell_effect.as_ref()),
        truth,
        log,
    )?;
    Ok((Some(report), End::Completed, measured_tare))
}

/// Where the tare came from.
enum TareSource {
    Measured(TareFile),
    File(TareFile),
}

impl TareSource {
    fn file(&self) -> &TareFile {
        match self {
            Self::Measured(f) | Self::File(f) => f,
        }
    }
}

fn quantities_of_body(b: &sim::BodyProperties) -> Quantities {
    Quantities {
        mass: b.mass_kg,
        com: b.com_m,
        inertia_com: b.inertia_com_kg_m2,
    }
}

/// The tare run's accelerometer-bias and load-cell-offset effects, when it was measured.
type TareEffects<'a> = (Option<&'a [[f64; 10]; 3]>, Option<&'a [[f64; 10]; 6]>);

#[allow(clippy::too_many_arguments)]
fn build_report(
    args: &RunArgs,
    loaded: &LoadedConfig,
    outcome: &MeasureOutcome,
    tare: &TareSource,
    (tare_bias_effect, tare_load_cell_effect): TareEffects<'_>,
    truth: Option<Quantities>,
    log: &RunLog,
) -> anyhow::Result<Report> {
    let config = &loaded.config;
    let loaded_estimate = outcome
        .estimate
        .as_ref()
        .context("the loaded run produced no estimate")?;
    Ok(report::build(&ReportInputs {
        loaded: loaded_estimate,
        theta_history: &outcome.theta_history,
        excitation_s: outcome.excitation_s,
        fk_failures: outcome.fk_failures,
        tare: tare.file(),
        tare_kind: match tare {
            TareSource::Measured(_) => TareKind::Measured,
            TareSource::File(_) => TareKind::File,
        },
        tare_path: args.tare.as_ref().map(|p| p.display().to_string()),
        loaded_bias_effect: outcome.accel_bias_effect.as_ref(),
        tare_bias_effect,
        accel_bias_sigma_m_s2: crate::preflight::accel_bias_sigma(config),
        loaded_load_cell_effect: outcome.load_cell_bias_effect.as_ref(),
        tare_load_cell_effect,
        load_cell_bias_sigma_n: crate::systematic::load_cell_bias_sigma(config),
        params: config.estimator.params,
        truth,
        run: RunInfo {
            config: loaded.source.clone(),
            seed: config.run.seed,
            noise: config.sensors.noise.name().into(),
            params: config.estimator.params.into(),
            log: Some(log.path().display().to_string()),
            backend: "sim".into(),
        },
    }))
}
