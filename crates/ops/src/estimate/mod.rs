//! `stewart estimate`'s work: a log's measurements re-estimated offline
//! ([`measure::replay`]) with the settings the log recorded or others, and the report built as
//! the online run builds it ([`run`]). The datasheet figures (the estimator's gyro and
//! accelerometer noise, the IMU's mounting, the systematic part of sigma) come from the rig
//! description the log recorded, or from another one.
//!
//! Options change the settings of every measurement alike ([`SettingsOverride`]): the
//! cut-off, the forgetting factor, the parameter model and a [`Window`] (seconds from the
//! start of each measurement's recorded window, its excitation; either end may be left open; a
//! window shorter than the recorded one gets the residual half-blocks a measurement of its
//! length would, `measure::quality::half_block_samples_for`). With the recorded settings the
//! result is the online report, to rounding (JSON keeps every f64 exactly, so in practice bit
//! for bit).
//!
//! [`save_tare`] writes the tare of the log's tare run; a log with a tare run only (as
//! `stewart import` writes from a tare-only table) gives that file and no report.

pub mod stream;

use rig_description::calibration::CalibrationDocument;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use estimator::{EstimatorConfig, ParameterSet};
use kinematics::FkOptions;
use measure::replay::{BiasSigmas, Replay, ReplayOutcome};
use measure::report::{Quantities, Report, ReportInputs, RunInfo, TareKind};
use measure::{setup, TareFile};
use rig_description::config::ParamCount;
use rig_description::range::ranges;
use rig_description::LoadedConfig;

use runlog::messages as topics;
use runlog::metadata::{EstimatorSettings, RunMetadata, TruthMsg};
use runlog::read::{geometry_of, Damage, LogContents};
use runlog::run_log::rates;

/// A time window relative to the excitation's start, s.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Window {
    /// Start, s (`None`: the recorded start).
    pub start_s: Option<f64>,
    /// End, s (`None`: the recorded end).
    pub end_s: Option<f64>,
}

/// Parses a cut-off frequency (`--cutoff-hz`): a number of Hz in the range of
/// `estimator.cutoff_hz` ([`cutoff_problem`]), or `0` / `none` for no filter (0.0).
pub fn parse_cutoff_hz(text: &str) -> Result<f64, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("none") {
        return Ok(0.0);
    }
    match t.parse::<f64>() {
        Ok(v) => match cutoff_problem(v) {
            None => Ok(v),
            Some(problem) => Err(problem),
        },
        Err(_) => Err(format!(
            "`{text}` is not a cut-off frequency: give a number of Hz, at least {} \
             (estimator.cutoff_hz), or 0 or `none` for no filter",
            ranges::CUTOFF_HZ_MIN
        )),
    }
}

/// Parses a forgetting factor (`--forgetting-factor`) in the range of
/// `estimator.forgetting_factor` ([`ranges::FORGETTING_FACTOR`]).
pub fn parse_forgetting_factor(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    match ranges::FORGETTING_FACTOR.problem(v) {
        None => Ok(v),
        Some(problem) => Err(format!("{problem} (as estimator.forgetting_factor)")),
    }
}

/// What is wrong with a cut-off of `hz` before the log's sample rate is known: 0 is no
/// filter; any other value must be finite and at least `estimator.cutoff_hz`'s least value.
/// The upper end of the key's range ([`ranges::cutoff_hz`]) is checked against the log's
/// sample rate in [`settings_of`].
pub fn cutoff_problem(hz: f64) -> Option<String> {
    if hz == 0.0 || (hz.is_finite() && hz >= ranges::CUTOFF_HZ_MIN) {
        None
    } else {
        Some(format!(
            "must be 0 or `none` (no filter), or at least {} Hz (as estimator.cutoff_hz), got {}",
            ranges::CUTOFF_HZ_MIN,
            rig_description::range::number(hz)
        ))
    }
}

/// A setting of [`SettingsOverride`] that the log's measurement cannot take, blamed on the
/// flag that gave it (`--window`, `--cutoff-hz`), not on the log.
#[derive(Debug, thiserror::Error)]
#[error("`{flag}` {problem}")]
pub struct FlagRefused {
    /// The flag.
    pub flag: &'static str,
    /// What is wrong, and what to give instead.
    pub problem: String,
}

/// Whether `e` is, or was caused by, a [`FlagRefused`].
pub fn is_flag_refusal(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| cause.is::<FlagRefused>())
}

/// `START:END` in seconds, either side optional (`5:`, `:30`); the start before the end.
impl std::str::FromStr for Window {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let (a, b) = text
            .split_once(':')
            .ok_or_else(|| format!("expected START:END in seconds, got `{text}`"))?;
        let num = |s: &str| -> Result<Option<f64>, String> {
            let s = s.trim();
            if s.is_empty() {
                return Ok(None);
            }
            let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
            if v.is_finite() {
                Ok(Some(v))
            } else {
                Err(format!("`{s}` is not finite"))
            }
        };
        let w = Self {
            start_s: num(a)?,
            end_s: num(b)?,
        };
        if let (Some(s), Some(e)) = (w.start_s, w.end_s) {
            if s >= e {
                return Err(format!(
                    "the window's start {s} s is not before its end {e} s"
                ));
            }
        }
        Ok(w)
    }
}

/// Changes to the recorded estimator settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SettingsOverride {
    /// Parameter model.
    pub params: Option<ParamCount>,
    /// Low-pass cut-off, Hz (≤ 0: none).
    pub cutoff_hz: Option<f64>,
    /// Forgetting factor.
    pub forgetting_factor: Option<f64>,
    /// Window relative to the excitation start.
    pub window: Option<Window>,
}

impl SettingsOverride {
    /// True when nothing is changed.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// The settings that no log can take, each blamed on its flag with the range of the key it
    /// stands for ([`cutoff_problem`], [`ranges::FORGETTING_FACTOR`]); the ones that depend
    /// on the log are checked in [`settings_of`].
    pub fn problems(&self) -> Vec<rig_description::ConfigIssue> {
        let mut issues = Vec::new();
        if let Some(problem) = self.cutoff_hz.and_then(cutoff_problem) {
            issues.push(crate::measurement::flag_issue("--cutoff-hz", problem));
        }
        if let Some(problem) = self
            .forgetting_factor
            .and_then(|l| ranges::FORGETTING_FACTOR.problem(l))
        {
            issues.push(crate::measurement::flag_issue(
                "--forgetting-factor",
                problem,
            ));
        }
        issues
    }
}

/// The offline estimate of one measurement.
#[derive(Clone, Debug)]
pub struct RunEstimate {
    /// `tare` or `loaded`.
    pub run: String,
    /// The replay.
    pub replay: ReplayOutcome,
    /// What the order of its frames showed: spans put back in order, dropped or missing.
    pub order: runlog::read::order::SequenceReport,
}

/// The rig description a log's measurement is re-estimated with: `rig` when given, else the
/// one the log recorded.
pub fn rig_description(log: &LogContents, rig: Option<&LoadedConfig>) -> Result<LoadedConfig> {
    if let Some(r) = rig {
        return Ok(r.clone());
    }
    rig_description_of(log.require_metadata()?, None)
}

/// [`rig_description`] from the log's metadata.
pub fn rig_description_of(meta: &RunMetadata, rig: Option<&LoadedConfig>) -> Result<LoadedConfig> {
    if let Some(r) = rig {
        return Ok(r.clone());
    }
    let imu = meta
        .imu_calibration_toml
        .as_deref()
        .map(|t| {
            rig_description::calibration::CalibrationFile::parse(t, "the log's IMU calibration")
        })
        .transpose()
        .map_err(|e| anyhow!("{e}"))?;
    let load_cells = meta
        .load_cell_calibration_toml
        .as_deref()
        .map(|t| {
            rig_description::calibration::LoadCellFile::parse(t, "the log's load-cell calibration")
        })
        .transpose()
        .map_err(|e| anyhow!("{e}"))?;
    let loaded = rig_description::load::load_recorded(
        &meta.config_toml,
        RECORDED_DESCRIPTION,
        imu,
        load_cells,
    )
    .map_err(|e| {
        anyhow!(
            "the log's rig description is refused (a log of an older version? give the rig \
                 description with --rig FILE): {e}"
        )
    })?;
    Ok(loaded)
}

/// The parameter set of `params` for `run`, from the rig description: with 6, the known mass
/// and centre of mass of its `estimator.known_*` keys, whichever model the run itself used.
fn parameter_set(
    geometry: &kinematics::Geometry,
    rig: &LoadedConfig,
    run: &str,
    params: ParamCount,
) -> Result<ParameterSet> {
    if params == ParamCount::Ten {
        return Ok(ParameterSet::Full);
    }
    let measurement = if run == "tare" {
        measure::Measurement::Tare
    } else {
        measure::Measurement::Loaded
    };
    let mut config = rig.config.clone();
    config.estimator.params = ParamCount::Six;
    let c = setup::estimator_config(&config, geometry, measurement, 0.0, 1.0);
    match c.parameters {
        ParameterSet::InertiaAboutKnownCom { mass_kg, .. } if mass_kg > 0.0 => Ok(c.parameters),
        _ => bail!(
            "--params 6 needs the known mass and centre of mass (estimator.known_* in the rig \
             description), which it does not give"
        ),
    }
}

/// The message that says the log has no estimator settings for `run`.
fn no_settings(run: &str) -> anyhow::Error {
    anyhow!(
        "the log has no {} message for the {run} measurement: its excitation never started",
        topics::ESTIMATOR_SETTINGS
    )
}

/// The estimator settings of `run` as recorded, the datasheet's figures from `rig`, with `o`
/// applied.
pub fn settings_for(
    log: &LogContents,
    rig: &LoadedConfig,
    run: &str,
    o: &SettingsOverride,
) -> Result<(EstimatorConfig, FkOptions)> {
    log.require_channel(
        topics::ESTIMATOR_SETTINGS,
        "the estimator's settings (stewart.EstimatorSettings)",
    )?;
    let recorded = log.settings_of(run).ok_or_else(|| no_settings(run))?;
    settings_of(log.require_metadata()?, recorded, rig, run, o)
}

/// [`settings_for`] from the log's metadata and the run's recorded settings.
pub fn settings_of(
    meta: &RunMetadata,
    recorded: &EstimatorSettings,
    rig: &LoadedConfig,
    run: &str,
    o: &SettingsOverride,
) -> Result<(EstimatorConfig, FkOptions)> {
    let geometry = geometry_of(meta)?;
    let (mut c, fk) = recorded.to_config(geometry)?;
    // What the datasheet says: the recorded figures, or another rig description's.
    let sensors = &rig.config.sensors;
    c.gyro_noise_rad_s = sensors.gyro_noise_rad_s();
    c.accel_noise_m_s2 = sensors.accel_noise_m_s2();
    c.accelerometer_position_m = setup::accelerometer_position(&rig.config);
    c.leg_force_offsets = setup::load_cell_bias_sigma(&rig.config) > 0.0;
    c.load_cell_drift = setup::fits_load_cell_drift(&rig.config);
    c.local_gravity_m_s2 = rig.config.estimator.local_gravity_m_s2.unwrap_or(0.0);
    c.legs = setup::leg_model(&rig.config);
    if let Some(p) = o.params {
        c.parameters = parameter_set(&geometry, rig, run, p)?;
    }
    if let Some(f) = o.cutoff_hz {
        let range = ranges::cutoff_hz(1.0 / c.sample_period_s);
        if let Some(problem) = range.problem(f).filter(|_| f != 0.0) {
            return Err(FlagRefused {
                flag: "--cutoff-hz",
                problem: format!("{problem} at the log's sample rate, or 0 for no filter"),
            }
            .into());
        }
        c.lowpass_cutoff_hz = (f > 0.0).then_some(f);
    }
    if let Some(l) = o.forgetting_factor {
        c.forgetting_factor = l;
    }
    if let Some(w) = o.window {
        let origin_s = recorded.window_start_s.with_context(|| {
            format!("the log's {run} settings have no window start to measure --window from")
        })?;
        if let Some(s) = w.start_s {
            c.window_start_s = origin_s + s;
            // The accelerometer's offset comes from the rest before the excitation, not from
            // the motion before a later window.
            c.hold_end_s = Some(origin_s);
        }
        if let Some(e) = w.end_s {
            c.window_end_s = origin_s + e;
        }
        if c.window_start_s.partial_cmp(&c.window_end_s) != Some(std::cmp::Ordering::Less) {
            let recorded = match recorded.window_end_s {
                Some(end_s) => format!("0 to {:.3} s", end_s - origin_s),
                None => "0 s on".to_string(),
            };
            return Err(FlagRefused {
                flag: "--window",
                problem: format!(
                    "gives the {run} measurement a window from {:.3} s to {:.3} s of its \
                     excitation, which ends before it starts; the log records it from \
                     {recorded}: give START:END with START before END",
                    c.window_start_s - origin_s,
                    c.window_end_s - origin_s
                ),
            }
            .into());
        }
        // As a measurement does for a short excitation: a window shorter than the recorded
        // one gets half-blocks short enough for a measured sigma, never longer than the
        // recorded ones.
        let recorded_end_s = recorded.window_end_s.unwrap_or(f64::INFINITY);
        let span_s = c.window_end_s.min(recorded_end_s) - c.window_start_s.max(origin_s);
        if span_s.is_finite() && span_s > 0.0 {
            c.covariance_half_block_samples = measure::quality::half_block_samples_for(
                EstimatorConfig::default_covariance_half_block_samples(c.sample_period_s),
                span_s,
                c.sample_period_s,
            )
            .min(c.covariance_half_block_samples);
        }
    }
    Ok((c, fk))
}

/// A replay of `run` configured from the log's settings.
fn start_replay(config: EstimatorConfig, fk: FkOptions, rig: &LoadedConfig) -> Result<Replay> {
    let trace_every = ((1.0 / config.sample_period_s / rates::ESTIMATE_HZ).round() as u64).max(1);
    let sigmas = BiasSigmas {
        accel_m_s2: setup::accel_bias_sigma(&rig.config),
        load_cell_n: setup::load_cell_bias_sigma(&rig.config),
    };
    Replay::new(config, fk, &rig.config.sensors.imu, sigmas, trace_every)
        .map(|r| {
            r.with_alignment(rig.config.calibration.imu_alignment())
                .with_load_cell_gains(rig.config.calibration.load_cell_gains())
                .with_budget(measure::budget::Figures::of(&rig.config))
                .with_weighing(&rig.config)
        })
        .map_err(|e| anyhow!("{e}"))
}

/// The replay's outcome, its error in the log's words.
fn finish_replay(r: Replay, run: &str) -> Result<RunEstimate> {
    run_estimate(r.finish(), run)
}

/// The estimate of measurement `run` from its finished replay.
fn run_estimate(
    outcome: Result<measure::replay::ReplayOutcome, measure::replay::ReplayError>,
    run: &str,
) -> Result<RunEstimate> {
    let replay = outcome.map_err(|e| match e {
        measure::replay::ReplayError::NoFramesInWindow { .. } => anyhow!(
            "the log has no {} frames of the {run} measurement from its excitation on",
            topics::SENSORS
        ),
        other => anyhow!("{other}"),
    })?;
    Ok(RunEstimate {
        run: run.to_string(),
        replay,
        order: runlog::read::order::SequenceReport::default(),
    })
}

/// Re-runs the estimator on measurement `run` of the log with the rig description `rig`.
pub fn reestimate_run(
    log: &LogContents,
    rig: &LoadedConfig,
    run: &str,
    o: &SettingsOverride,
) -> Result<RunEstimate> {
    log.require_channel(topics::SENSORS, "the sensor frames the estimator reads")?;
    let (config, fk) = settings_for(log, rig, run, o)?;
    let mut r = start_replay(config, fk, rig)?;
    // In sequence order as `estimate` streams them ([`order`]); the replay's own reordering
    // then finds nothing to do.
    let (frames, order) =
        runlog::read::order::sequenced(run, log.sensors_of(run).map(|f| f.to_frame()));
    for frame in &frames {
        r.push(frame);
    }
    let mut e = finish_replay(r, run)?;
    e.replay.reordered = measure::reorder::ReorderCounts {
        late: order.counts.late,
        duplicates: order.counts.duplicates,
    };
    e.order = order;
    Ok(e)
}

/// Where the subtracted tare came from.
#[derive(Clone, Debug)]
pub enum TareOrigin {
    /// Re-estimated from the log's tare run.
    Measured(Box<RunEstimate>),
    /// A tare file (given to `estimate`, or the one the run used, from `/run/tare`).
    File(Option<String>),
}

/// The payload's truth from `/run/truth`, if logged.
pub fn payload_truth(log: &LogContents) -> Option<Quantities> {
    truth_of(log.truth.as_ref())
}

fn truth_of(t: Option<&TruthMsg>) -> Option<Quantities> {
    t.map(|t| Quantities {
        mass: t.payload.mass_kg,
        com: t.payload.com_m,
        inertia_com: t.payload.inertia_com_kg_m2,
    })
}

/// What a report takes from the log besides the replays.
#[derive(Clone, Copy, Debug)]
pub struct LogFacts<'a> {
    /// `/run/metadata`.
    pub meta: &'a RunMetadata,
    /// `/run/truth`.
    pub truth: Option<&'a TruthMsg>,
    /// The log file.
    pub path: &'a Path,
    /// What the log lost.
    pub damage: &'a Damage,
}

/// The report of a loaded re-run with `tare` subtracted, in `simulate`'s shape
/// ([`measure::report::build`]), with what the log lost.
pub fn build_report(
    log: &LogFacts<'_>,
    rig: &LoadedConfig,
    loaded: &RunEstimate,
    tare: &TareFile,
    tare_origin: &TareOrigin,
) -> Result<Report> {
    let meta = log.meta;
    let (tare_kind, tare_path, tare_budget) = match tare_origin {
        TareOrigin::Measured(r) => (TareKind::Measured, None, r.replay.budget.as_ref()),
        TareOrigin::File(p) => (TareKind::File, p.clone(), None),
    };
    let params = match loaded.replay.config.parameters {
        ParameterSet::InertiaAboutKnownCom { .. } => ParamCount::Six,
        ParameterSet::Full => ParamCount::Ten,
    };
    let r = &loaded.replay;
    let mut report = measure::report::build(&ReportInputs {
        loaded: &r.estimate,
        theta_history: &r.theta_history,
        excitation_s: r.excitation_s,
        fk_failures: r.fk_failures,
        tare,
        tare_kind,
        tare_path,
        loaded_budget: r.budget.as_ref(),
        tare_budget,
        accel_bias_sigma_m_s2: setup::accel_bias_sigma(&rig.config),
        load_cell_bias_sigma_n: setup::load_cell_bias_sigma(&rig.config),
        params,
        truth: truth_of(log.truth),
        run: RunInfo {
            config: meta.config_source.clone(),
            seed: meta.seed,
            noise: meta.noise.clone(),
            params: params.into(),
            log: Some(log.path.display().to_string()),
            backend: meta.backend.clone(),
            tool: rig_description::calibration::tool(),
            started_unix_s: (meta.start_unix_ns > 0).then_some(meta.start_unix_ns / 1_000_000_000),
            // The log does not say when the run's session closed; the start is its stamp.
            ended_unix_s: None,
            calibrations: rig.config.calibration.applied(),
            // The description's identification, hash and gravity: `report::build`'s.
            ..RunInfo::default()
        },
        loaded_weighing: r.static_weighing.as_ref(),
        description: Some(&rig.config),
    });
    if rig.source == RECORDED_DESCRIPTION {
        // The description as the log holds it, not as read back (its calibrations inlined).
        report.run.description_sha256 = Some(measure::report::sha256_hex(&meta.config_toml));
    }
    report.data.frames_late = r.reordered.late;
    report.data.frames_duplicate = r.reordered.duplicates;
    // The tare's spans too: its estimate is subtracted.
    let measured_tare = match tare_origin {
        TareOrigin::Measured(t) => Some(&t.order),
        TareOrigin::File(_) => None,
    };
    for o in measured_tare.into_iter().chain([&loaded.order]) {
        report.data.reordered.extend(o.reordered.iter().cloned());
        report.data.missing.extend(o.missing.iter().cloned());
    }
    report.data.truncated = log.damage.truncated.clone();
    report.data.damaged = log.damage.lost_spans();
    Ok(report)
}

/// The tare file the log's own run used (`/run/tare`), when it has no tare run.
fn logged_tare(tare: Option<&TareFile>, meta: &RunMetadata) -> Result<(TareFile, TareOrigin)> {
    let t = tare.cloned().with_context(|| {
        format!(
            "the log lacks channel {} (and has no tare run), needed for the tare to subtract; \
             give one with --tare FILE",
            topics::TARE
        )
    })?;
    Ok((t, TareOrigin::File(meta.tare_file.clone())))
}

/// The tare measured by the log's tare run.
fn measured_tare(r: RunEstimate, meta: &RunMetadata) -> (TareFile, TareOrigin) {
    let t = TareFile::from_estimate(
        &r.replay.estimate,
        &meta.base_joints_m,
        &meta.plate_joints_m,
        &meta.config_source,
        &meta.backend,
    )
    .with_static_weighing(r.replay.static_weighing.clone());
    (t, TareOrigin::Measured(Box::new(r)))
}

/// The tare file of a re-estimated tare run `r`, as a measurement saves it (`--save-tare`): with
/// the run's exact bias effects per unit of the rig description's figures and its error-budget
/// inputs, so that a loaded run that subtracts it counts the tare's share of the error budget.
pub fn saved_tare(r: &RunEstimate, meta: &RunMetadata, rig: &LoadedConfig) -> TareFile {
    let replay = &r.replay;
    TareFile::from_estimate(
        &replay.estimate,
        &meta.base_joints_m,
        &meta.plate_joints_m,
        &meta.config_source,
        &meta.backend,
    )
    .with_bias_effects(
        replay.accel_bias_effect.as_ref(),
        setup::accel_bias_sigma(&rig.config),
        replay.load_cell_bias_effect.as_ref(),
        setup::load_cell_bias_sigma(&rig.config),
    )
    .with_budget(replay.budget.clone())
    .with_static_weighing(replay.static_weighing.clone())
}

/// A tare file given on the command line, checked against the log's design.
fn tare_file(path: &Path, meta: &RunMetadata) -> Result<(TareFile, TareOrigin)> {
    let t = TareFile::load(path, &meta.base_joints_m, &meta.plate_joints_m)?;
    Ok((t, TareOrigin::File(Some(path.display().to_string()))))
}

/// Re-estimates the log's measurements with `o` and the rig description `rig` (the log's when
/// `None`), subtracts the tare (`tare_path`, else the log's tare run, else the log's
/// `/run/tare`) and builds the report.
pub fn reestimate(
    log: &LogContents,
    o: &SettingsOverride,
    tare_path: Option<&Path>,
    rig: Option<&LoadedConfig>,
) -> Result<(Report, RunEstimate, TareFile, TareOrigin)> {
    let meta = log.require_metadata()?;
    log.require_channel(topics::SENSORS, "the sensor frames the estimator reads")?;
    log.require_channel(
        topics::ESTIMATOR_SETTINGS,
        "the estimator's settings (stewart.EstimatorSettings)",
    )?;
    let rig = rig_description(log, rig)?;
    let (tare, origin) = if let Some(path) = tare_path {
        tare_file(path, meta)?
    } else if log.sensors_of("tare").next().is_some() && log.settings_of("tare").is_some() {
        let r = reestimate_run(log, &rig, "tare", o).context("re-estimating the tare run")?;
        measured_tare(r, meta)
    } else {
        logged_tare(log.tare.as_ref(), meta)?
    };
    let loaded = reestimate_run(log, &rig, "loaded", o).context("re-estimating the loaded run")?;
    let facts = LogFacts {
        meta,
        truth: log.truth.as_ref(),
        path: &log.path,
        damage: &log.damaged,
    };
    let report = build_report(&facts, &rig, &loaded, &tare, &origin)?;
    Ok((report, loaded, tare, origin))
}

/// Options of `stewart estimate`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EstimateOptions {
    /// MCAP log of a `simulate`, `rig` or `import` run (a log cut short is read up to its
    /// last chunk).
    pub log: PathBuf,
    /// Subtract this saved tare (JSON) instead of the log's tare run or tare.
    pub tare: Option<PathBuf>,
    /// Take the datasheet figures from this rig description instead of the one the log
    /// recorded; and the platform too when the log's metadata was lost to damage.
    pub rig: Option<PathBuf>,
    /// Changes to the recorded settings, alike for every measurement.
    pub settings: SettingsOverride,
    /// Write the JSON report here (only when something was measured).
    pub report: Option<PathBuf>,
    /// Write the report as one self-contained HTML page here (only when something was
    /// measured).
    pub html: Option<PathBuf>,
}

/// Why `estimate` failed; every case is a refused input (nothing measured).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// `--rig FILE` was refused.
    #[error("{0}")]
    Rig(#[from] rig_description::load::ConfigError),
    /// A flag (`--cutoff-hz`, `--forgetting-factor`, `--window`) was refused, before the log
    /// was read or against what the log records.
    #[error("{0:#}")]
    Flag(anyhow::Error),
    /// The log could not be read or re-estimated.
    #[error("{0:#}")]
    Log(anyhow::Error),
    /// The report could not be written.
    #[error("cannot write the report {}: {source}", path.display())]
    WriteReport {
        /// The report's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The HTML page could not be written.
    #[error("cannot write the page {}: {message}", path.display())]
    WritePage {
        /// The page's path.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The saved tare could not be written.
    #[error("{0:#}")]
    SaveTare(anyhow::Error),
}

/// What `estimate` produced.
#[derive(Clone, Debug)]
pub struct EstimateOutcome {
    /// The report, as `simulate` writes it.
    pub report: Report,
    /// The loaded measurement's re-run.
    pub loaded: RunEstimate,
    /// The tare subtracted.
    pub tare: TareFile,
    /// Where it came from.
    pub tare_origin: TareOrigin,
    /// What the log lost.
    pub damage: Damage,
    /// Whether anything was measured ([`measure::quality`]): when not, no report or page was
    /// written.
    pub quality: Result<(), measure::quality::QualityError>,
    /// The rig description of [`EstimateOptions::rig`], when given.
    pub rig: Option<LoadedConfig>,
}

impl EstimateOutcome {
    /// Warnings for the terminal, one a line, each naming the log at `path`: what its damage
    /// took ([`Damage::warnings`]), the spans of frames put back in order, dropped or missing,
    /// and the records read from another copy (none for a clean log). A missing span that a
    /// damaged region of the log lost is said once, by the damage's line (which names its
    /// sequence numbers).
    pub fn warnings(&self, path: &Path) -> Vec<String> {
        let mut w = self.damage.warnings(path);
        let data = &self.report.data;
        let lost_to_damage = |span: &measure::report::FrameSpan| {
            span.action == runlog::read::order::MISSING
                && self.damage.damaged.iter().any(|l| {
                    l.lost_sequences().is_some_and(|(first, last)| {
                        first <= span.first_sequence && span.last_sequence <= last
                    })
                })
        };
        for span in data.reordered.iter().chain(&data.missing) {
            if !lost_to_damage(span) {
                w.push(format!("{}: {}", path.display(), describe_span(span)));
            }
        }
        let measured_tare = match &self.tare_origin {
            TareOrigin::Measured(t) => t.order.unnamed,
            TareOrigin::File(_) => 0,
        };
        let unnamed = self.loaded.order.unnamed + measured_tare;
        if unnamed > 0 {
            w.push(format!(
                "{}: {unnamed} more spans of frames out of order, duplicated or missing are \
                 counted only (data.frames_duplicate, data.frames_late, data.frames_lost)",
                path.display()
            ));
        }
        for r in &data.recovered {
            w.push(format!("{}: {r}", path.display()));
        }
        w
    }
}

/// A span of frames and what was done with it, in words.
pub fn describe_span(span: &measure::report::FrameSpan) -> String {
    let what = format!(
        "frames {} to {} of the {} measurement ({} frames, {:.3} to {:.3} s)",
        span.first_sequence,
        span.last_sequence,
        span.run,
        span.frames,
        span.from_time_s,
        span.to_time_s
    );
    match span.action.as_str() {
        runlog::read::order::PUT_BACK => {
            format!("{what} came out of order, after later frames: put back in sequence order")
        }
        runlog::read::order::DUPLICATES => {
            format!("{what} came again with the same readings: dropped as duplicates")
        }
        runlog::read::order::LATE => format!(
            "{what} came after later frames had been used, too late to put back in order: \
             dropped"
        ),
        runlog::read::order::MISSING => format!(
            "{what} are missing: no frame of the log holds them (lost with a damaged or \
             removed part of the log, or never written); the estimate bridges or restarts \
             across the gap"
        ),
        other => format!("{what}: {other}"),
    }
}

/// The settings' refusals that need no log ([`SettingsOverride::problems`]).
fn check_flags(settings: &SettingsOverride) -> Result<(), Error> {
    let issues = settings.problems();
    if issues.is_empty() {
        Ok(())
    } else {
        Err(Error::Flag(rig_description::ConfigError { issues }.into()))
    }
}

/// An error of reading and re-estimating the log: [`Error::Flag`] when a flag caused it.
fn log_error(e: anyhow::Error) -> Error {
    if is_flag_refusal(&e) {
        Error::Flag(e)
    } else {
        Error::Log(e)
    }
}

/// The name of the rig description a log records, as messages give it.
const RECORDED_DESCRIPTION: &str = "<rig description in the log>";

/// The rig description of `--rig FILE`, when given.
fn rig_of(options: &EstimateOptions) -> Result<Option<LoadedConfig>, Error> {
    Ok(match &options.rig {
        Some(path) => Some(rig_description::load::load_scoped(
            Some(path),
            rig_description::validate::Scope::Estimation,
        )?),
        None => None,
    })
}

/// Runs `estimate`: streams the log once (memory bounded whatever its length) and, when
/// something was measured, writes the report and the page of `options`. A measurement that
/// measured nothing (see [`measure::quality`]) is not an error here but in
/// [`EstimateOutcome::quality`], with nothing written.
pub fn run(options: &EstimateOptions) -> Result<EstimateOutcome, Error> {
    check_flags(&options.settings)?;
    let rig = rig_of(options)?;
    let stream::Streamed {
        report,
        loaded,
        tare,
        tare_origin,
        damage,
        ..
    } = stream::reestimate_file(
        &options.log,
        &options.settings,
        options.tare.as_deref(),
        rig.as_ref(),
    )
    .map_err(log_error)?;
    let quality = report.check_quality();
    if quality.is_ok() {
        if let Some(path) = &options.report {
            std::fs::write(path, report.to_json()).map_err(|source| Error::WriteReport {
                path: path.clone(),
                source,
            })?;
        }
        if let Some(path) = &options.html {
            let source = format!("stewart estimate {}", options.log.display());
            crate::report::write_page(&report.to_json(), path, &source, rig.as_ref()).map_err(
                |e| Error::WritePage {
                    path: path.clone(),
                    message: e.to_string(),
                },
            )?;
        }
    }
    Ok(EstimateOutcome {
        report,
        loaded,
        tare,
        tare_origin,
        damage,
        quality,
        rig,
    })
}

/// The log's tare run re-estimated (streamed once, its loaded run not replayed) and written
/// to `out` (JSON, for later `--tare` runs).
pub fn save_tare(options: &EstimateOptions, out: &Path) -> Result<stream::StreamedTare, Error> {
    check_flags(&options.settings)?;
    let rig = rig_of(options)?;
    let saved =
        stream::tare_of_file(&options.log, &options.settings, rig.as_ref()).map_err(log_error)?;
    saved.tare.save(out).map_err(Error::SaveTare)?;
    Ok(saved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_parse() {
        let w = |t: &str| t.parse::<Window>();
        assert_eq!(
            w("5:30"),
            Ok(Window {
                start_s: Some(5.0),
                end_s: Some(30.0)
            })
        );
        assert_eq!(
            w(":12.5"),
            Ok(Window {
                start_s: None,
                end_s: Some(12.5)
            })
        );
        assert_eq!(w("2:").unwrap().end_s, None);
        assert!(w("5").is_err());
        assert!(w("9:3").is_err());
        assert!(w("a:3").is_err());
        assert!(w("1:inf").is_err());
    }
}
