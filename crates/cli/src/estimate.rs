//! `stewart estimate LOG.mcap`: the estimator re-run offline from a log's sensor channel, with
//! the settings the log recorded or others, and the same table and report as the run.
//!
//! The inputs are rebuilt exactly as the online run ([`crate::run`]) built them: every
//! `/sensors` frame of a measurement, in order, gives its pose by forward kinematics
//! warm-started from the previous frame's solution (the measurement's first frame from the home
//! pose); the estimator, configured from that measurement's `/run/estimator` message, is fed
//! every frame with a pose from the measurement's first frame to its window's end (frames before
//! the window only warm the conditioning). When the configuration in the log gives an
//! accelerometer bias, three more estimators are fed the same frames with one sigma of bias
//! along x, y and z, as the run does ([`crate::systematic`]), and the payload's share of their
//! shifts joins the reported sigma. With the recorded settings the result is the online report,
//! to rounding (JSON keeps every f64 exactly, so in practice bit for bit).
//!
//! Options change the settings of every measurement alike: `--cutoff-hz`, `--forgetting-factor`,
//! `--params` and `--window START:END` (seconds from the start of each measurement's recorded
//! window, its excitation; either end may be left open).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use estimator::{Estimate, EstimatorConfig, OnlineEstimator, Outcome, ParameterSet, Sample};
use kinematics::{FkOptions, Geometry, Pose, Vector3, Vector6};

use crate::config::ParamCount;
use crate::log_messages as topics;
use crate::log_read::{LogContents, SensorRecord};
use crate::metadata::EstimatorSettings;
use crate::report::{Quantities, Report, ReportInputs, RunInfo, TareKind};
use crate::run_log::rates;
use crate::tare::TareFile;

/// `stewart estimate` arguments.
#[derive(Clone, Debug, Default, Args)]
pub struct EstimateArgs {
    /// MCAP log of a `simulate` or `rig` run (a log cut short is read up to its last chunk).
    #[arg(value_name = "LOG.mcap")]
    pub log: PathBuf,
    /// Subtract this saved tare (JSON) instead of the log's tare run or tare.
    #[arg(long, value_name = "FILE")]
    pub tare: Option<PathBuf>,
    /// 10: mass, centre of mass and inertia; 6: the paper's inertia-only model (known mass and
    /// centre of mass from the logged configuration).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["10", "6"]))]
    pub params: Option<String>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Low-pass cut-off of the signal conditioning, Hz (0: no filter).
    #[arg(long, value_name = "HZ")]
    pub cutoff_hz: Option<f64>,
    /// RLS forgetting factor λ in (0, 1].
    #[arg(long, value_name = "LAMBDA")]
    pub forgetting_factor: Option<f64>,
    /// Time window START:END in seconds from the start of each measurement's excitation;
    /// either end may be empty (e.g. `5:` or `:30`).
    #[arg(long, value_name = "START:END", value_parser = parse_window)]
    pub window: Option<Window>,
    /// Write SVG and PNG figures (estimates with ±σ and truth, tracking error, excitation) here.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// No table.
    #[arg(long)]
    pub quiet: bool,
}

/// A time window relative to the excitation's start, s.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Window {
    /// Start, s (`None`: the recorded start).
    pub start_s: Option<f64>,
    /// End, s (`None`: the recorded end).
    pub end_s: Option<f64>,
}

/// Parses `START:END` with either side optional.
pub fn parse_window(text: &str) -> Result<Window, String> {
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
    let w = Window {
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

/// Changes to the recorded estimator settings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
    /// From the command line.
    pub fn from_args(args: &EstimateArgs) -> Self {
        Self {
            params: args.params.as_deref().map(|p| {
                if p == "6" {
                    ParamCount::Six
                } else {
                    ParamCount::Ten
                }
            }),
            cutoff_hz: args.cutoff_hz,
            forgetting_factor: args.forgetting_factor,
            window: args.window,
        }
    }

    /// True when nothing is changed.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// One estimate along the way (at the log's `/estimate` instants).
#[derive(Clone, Copy, Debug)]
pub struct TracePoint {
    /// Backend time, s.
    pub time_s: f64,
    /// The estimate of everything on the plate.
    pub estimate: Estimate,
}

/// The offline estimate of one measurement.
#[derive(Clone, Debug)]
pub struct RunEstimate {
    /// `tare` or `loaded`.
    pub run: String,
    /// The settings used.
    pub config: EstimatorConfig,
    /// The final estimate of everything on the plate.
    pub estimate: Estimate,
    /// θ after every used sample.
    pub theta_history: Vec<[f64; 10]>,
    /// Estimates at the `/estimate` rate, and the final one.
    pub trace: Vec<TracePoint>,
    /// Backend time of the first frame in the window (the excitation's start), s.
    pub excitation_start_s: f64,
    /// From there to the last sample used, s.
    pub excitation_s: f64,
    /// Frames fed whose forward kinematics failed.
    pub fk_failures: u64,
    /// Frames of the measurement in the log.
    pub frames: u64,
    /// Change of θ from one sigma of accelerometer bias along x, y, z (rows), when a bias
    /// figure is known.
    pub accel_bias_effect: Option<[[f64; 10]; 3]>,
    /// Change of θ from one sigma of zero offset on each load cell (rows), when a figure is
    /// known.
    pub load_cell_bias_effect: Option<[[f64; 10]; 6]>,
}

fn every(rate_hz: f64, sample_rate_hz: f64) -> u64 {
    ((sample_rate_hz / rate_hz).round() as u64).max(1)
}

/// The parameter set of `params` for `run`, from the configuration recorded in the log.
fn parameter_set(log: &LogContents, run: &str, params: ParamCount) -> Result<ParameterSet> {
    if params == ParamCount::Ten {
        return Ok(ParameterSet::Full);
    }
    let meta = log.require_metadata()?;
    let loaded = crate::config_load::load_str(&meta.config_toml, "<configuration in the log>")
        .map_err(|e| anyhow!("the log's configuration is refused: {e}"))?;
    let geometry = log.geometry()?;
    let measurement = if run == "tare" {
        crate::preflight::Measurement::Tare
    } else {
        crate::preflight::Measurement::Loaded
    };
    let c = crate::preflight::estimator_config(&loaded.config, &geometry, measurement, 0.0, 1.0);
    match c.parameters {
        ParameterSet::InertiaAboutKnownCom { mass_kg, .. } if mass_kg > 0.0 => Ok(c.parameters),
        _ => bail!(
            "--params 6 needs the known mass and centre of mass (estimator.known_* in the configuration), \
             which the log's configuration does not give"
        ),
    }
}

/// The estimator settings of `run` as recorded, with `o` applied.
pub fn settings_for(
    log: &LogContents,
    run: &str,
    o: &SettingsOverride,
) -> Result<(EstimatorConfig, FkOptions)> {
    log.require_channel(
        topics::ESTIMATOR_SETTINGS,
        "the estimator's settings (stewart.EstimatorSettings)",
    )?;
    let recorded: &EstimatorSettings = log.settings_of(run).with_context(|| {
        format!(
            "the log has no {} message for the {run} measurement: its excitation never started",
            topics::ESTIMATOR_SETTINGS
        )
    })?;
    let (mut c, fk) = recorded.to_config(log.geometry()?)?;
    if let Some(p) = o.params {
        c.parameters = parameter_set(log, run, p)?;
    }
    if let Some(f) = o.cutoff_hz {
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
        }
        if let Some(e) = w.end_s {
            c.window_end_s = origin_s + e;
        }
    }
    Ok((c, fk))
}

/// The accelerometer bias (one sigma, m/s²) the run assumed for the systematic part of sigma:
/// `estimator.accel_bias_m_s2` of the logged configuration, else its noise preset's figure.
pub fn accel_bias_sigma(log: &LogContents) -> Result<f64> {
    let meta = log.require_metadata()?;
    let loaded = crate::config_load::load_str(&meta.config_toml, "<configuration in the log>")
        .map_err(|e| anyhow!("the log's configuration is refused: {e}"))?;
    Ok(crate::preflight::accel_bias_sigma(&loaded.config))
}

/// One sigma of each load cell's zero offset the run assumed, N (its noise preset's figure).
pub fn load_cell_bias_sigma(log: &LogContents) -> Result<f64> {
    let meta = log.require_metadata()?;
    let loaded = crate::config_load::load_str(&meta.config_toml, "<configuration in the log>")
        .map_err(|e| anyhow!("the log's configuration is refused: {e}"))?;
    Ok(crate::systematic::load_cell_bias_sigma(&loaded.config))
}

/// Re-runs the estimator on measurement `run` of the log; `bias_m_s2` > 0 also gives the
/// accelerometer bias's effect (see [`crate::systematic`]).
pub fn reestimate_run(
    log: &LogContents,
    run: &str,
    o: &SettingsOverride,
    bias_m_s2: f64,
) -> Result<RunEstimate> {
    log.require_channel(topics::SENSORS, "the sensor frames the estimator reads")?;
    let (mut config, fk) = settings_for(log, run, o)?;
    // As the online run: the load cells' offset sensitivity when their datasheet gives one.
    let load_cell_sigma = load_cell_bias_sigma(log)?;
    config.leg_force_offsets = load_cell_sigma > 0.0;
    let geometry: Geometry = config.geometry;
    let mut estimator = OnlineEstimator::new(config)
        .map_err(|e| anyhow!("the estimator refused its settings: {e}"))?;
    let sample_rate_hz = 1.0 / config.sample_period_s;
    let estimate_every = every(rates::ESTIMATE_HZ, sample_rate_hz);
    let mut guess = geometry.home_pose();
    let mut history = Vec::new();
    let mut trace = Vec::new();
    let mut fk_failures = 0;
    let mut start_s = f64::NAN;
    let mut last_used_s = f64::NAN;
    let mut frames = 0u64;
    let mut last_time_s = f64::NAN;
    for (tick, frame) in log.sensors_of(run).enumerate() {
        frames += 1;
        let pose = forward_kinematics(&geometry, frame, &mut guess, &fk);
        if start_s.is_nan() && frame.time_s >= config.window_start_s {
            start_s = frame.time_s;
        }
        match pose {
            // Every frame up to the window's end, as the online run feeds them: frames before
            // the window only warm the conditioning.
            Some(p) if frame.time_s <= config.window_end_s => {
                let sample = Sample {
                    time_s: frame.time_s,
                    pose: p,
                    leg_forces_n: Vector6::from(frame.leg_forces_n),
                    gyro_rad_s: Vector3::from(frame.gyro_rad_s),
                    accel_m_s2: Vector3::from(frame.accel_m_s2),
                };
                if let Ok(Outcome::Used) = estimator.update(&sample) {
                    history.push(estimator.theta().into());
                    last_used_s = frame.time_s;
                }
            }
            Some(_) => {}
            None => fk_failures += 1,
        }
        if start_s.is_finite() && (tick as u64).is_multiple_of(estimate_every) {
            trace.push(TracePoint {
                time_s: frame.time_s,
                estimate: estimator.estimate(),
            });
        }
        last_time_s = frame.time_s;
    }
    if start_s.is_nan() {
        bail!(
            "the log has no {} frames of the {run} measurement from its excitation on",
            topics::SENSORS
        );
    }
    let estimate = estimator.estimate();
    if trace.last().is_none_or(|t| t.time_s != last_time_s) {
        trace.push(TracePoint {
            time_s: last_time_s,
            estimate,
        });
    }
    Ok(RunEstimate {
        run: run.to_string(),
        config,
        estimate,
        theta_history: history,
        trace,
        excitation_start_s: start_s,
        excitation_s: if last_used_s.is_finite() {
            last_used_s - start_s
        } else {
            0.0
        },
        fk_failures,
        frames,
        accel_bias_effect: crate::systematic::accel_bias_effect(&estimator, bias_m_s2),
        load_cell_bias_effect: crate::systematic::load_cell_bias_effect(
            &estimator,
            load_cell_sigma,
        ),
    })
}

/// Forward kinematics of the frame's leg lengths, warm-started from (and updating) `guess`, as
/// the online run does it.
fn forward_kinematics(
    geometry: &Geometry,
    frame: &SensorRecord,
    guess: &mut Pose,
    options: &FkOptions,
) -> Option<Pose> {
    let lengths = Vector6::from(frame.leg_lengths_m);
    match geometry.forward_kinematics(&lengths, guess, options) {
        Ok(s) => {
            *guess = s.pose;
            Some(s.pose)
        }
        Err(_) => None,
    }
}

/// Where the subtracted tare came from.
#[derive(Clone, Debug)]
pub enum TareOrigin {
    /// Re-estimated from the log's tare run.
    Measured(Box<RunEstimate>),
    /// A tare file (given to `estimate`, or the one the run used, from `/run/tare`).
    File(Option<String>),
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
    /// Figures written.
    pub figures: Vec<PathBuf>,
}

/// The tare file of a tare estimate, as the run saves it.
pub fn tare_file_of(e: &Estimate, log: &LogContents) -> Result<TareFile> {
    let meta = log.require_metadata()?;
    Ok(TareFile::from_estimate(
        e,
        &meta.base_joints_m,
        &meta.plate_joints_m,
        &meta.config_source,
        &meta.backend,
    ))
}

/// The payload's truth from `/run/truth`, if logged.
pub fn payload_truth(log: &LogContents) -> Option<Quantities> {
    log.truth.as_ref().map(|t| Quantities {
        mass: t.payload.mass_kg,
        com: t.payload.com_m,
        inertia_com: t.payload.inertia_com_kg_m2,
    })
}

/// The report of a loaded re-run with `tare` subtracted, in `simulate`'s shape
/// ([`crate::report::build`]).
pub fn build_report(
    log: &LogContents,
    loaded: &RunEstimate,
    tare: &TareFile,
    tare_origin: &TareOrigin,
    bias_m_s2: f64,
) -> Result<Report> {
    let meta = log.require_metadata()?;
    let (tare_kind, tare_path, tare_effect, tare_load_cell_effect) = match tare_origin {
        TareOrigin::Measured(r) => (
            TareKind::Measured,
            None,
            r.accel_bias_effect.as_ref(),
            r.load_cell_bias_effect.as_ref(),
        ),
        TareOrigin::File(p) => (TareKind::File, p.clone(), None, None),
    };
    let params = match loaded.config.parameters {
        ParameterSet::InertiaAboutKnownCom { .. } => ParamCount::Six,
        ParameterSet::Full => ParamCount::Ten,
    };
    Ok(crate::report::build(&ReportInputs {
        loaded: &loaded.estimate,
        theta_history: &loaded.theta_history,
        excitation_s: loaded.excitation_s,
        fk_failures: loaded.fk_failures,
        tare,
        tare_kind,
        tare_path,
        loaded_bias_effect: loaded.accel_bias_effect.as_ref(),
        tare_bias_effect: tare_effect,
        accel_bias_sigma_m_s2: bias_m_s2,
        loaded_load_cell_effect: loaded.load_cell_bias_effect.as_ref(),
        tare_load_cell_effect,
        load_cell_bias_sigma_n: load_cell_bias_sigma(log)?,
        params,
        truth: payload_truth(log),
        run: RunInfo {
            config: meta.config_source.clone(),
            seed: meta.seed,
            noise: meta.noise.clone(),
            params: params.into(),
            log: Some(log.path.display().to_string()),
            backend: meta.backend.clone(),
        },
    }))
}

/// Re-estimates the log's measurements with `o`, subtracts the tare (`tare_path`, else the
/// log's tare run, else the log's `/run/tare`) and builds the report.
pub fn reestimate(
    log: &LogContents,
    o: &SettingsOverride,
    tare_path: Option<&Path>,
) -> Result<(Report, RunEstimate, TareFile, TareOrigin)> {
    let meta = log.require_metadata()?;
    log.require_channel(topics::SENSORS, "the sensor frames the estimator reads")?;
    log.require_channel(
        topics::ESTIMATOR_SETTINGS,
        "the estimator's settings (stewart.EstimatorSettings)",
    )?;
    let bias_m_s2 = accel_bias_sigma(log)?;
    let (tare, origin) = if let Some(path) = tare_path {
        let t = TareFile::load(path, &meta.base_joints_m, &meta.plate_joints_m)?;
        (t, TareOrigin::File(Some(path.display().to_string())))
    } else if log.sensors_of("tare").next().is_some() && log.settings_of("tare").is_some() {
        let r = reestimate_run(log, "tare", o, bias_m_s2).context("re-estimating the tare run")?;
        let t = tare_file_of(&r.estimate, log)?;
        (t, TareOrigin::Measured(Box::new(r)))
    } else {
        let t = log.tare.clone().with_context(|| {
            format!(
                "the log lacks channel {} (and has no tare run), needed for the tare to subtract; \
                 give one with --tare FILE",
                topics::TARE
            )
        })?;
        (t, TareOrigin::File(meta.tare_file.clone()))
    };
    let loaded =
        reestimate_run(log, "loaded", o, bias_m_s2).context("re-estimating the loaded run")?;
    let report = build_report(log, &loaded, &tare, &origin, bias_m_s2)?;
    Ok((report, loaded, tare, origin))
}

/// Runs `stewart estimate`: prints the table (unless quiet), writes the report and figures.
pub fn estimate(args: &EstimateArgs) -> Result<EstimateOutcome> {
    let log = LogContents::read(&args.log)?;
    if let Some(why) = &log.truncated {
        eprintln!(
            "warning: {} ends early ({why}); using the {} sensor frames before that",
            args.log.display(),
            log.sensors.len()
        );
    }
    let o = SettingsOverride::from_args(args);
    let (report, loaded, tare, tare_origin) = reestimate(&log, &o, args.tare.as_deref())?;
    if !args.quiet {
        print!("{}", crate::table::render(&report));
    }
    if let Some(path) = &args.report {
        std::fs::write(path, report.to_json())
            .with_context(|| format!("cannot write the report {}", path.display()))?;
        if !args.quiet {
            println!("report: {}", path.display());
        }
    }
    let mut figures = Vec::new();
    if let Some(dir) = &args.plot {
        let f = crate::plot::figures_from_reestimate(&log, &loaded, &tare)?;
        figures = crate::plot::write_figures(dir, &f)?;
        if !args.quiet {
            println!("figures: {} ({} files)", dir.display(), figures.len());
        }
    }
    Ok(EstimateOutcome {
        report,
        loaded,
        tare,
        tare_origin,
        figures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_parse() {
        assert_eq!(
            parse_window("5:30"),
            Ok(Window {
                start_s: Some(5.0),
                end_s: Some(30.0)
            })
        );
        assert_eq!(
            parse_window(":12.5"),
            Ok(Window {
                start_s: None,
                end_s: Some(12.5)
            })
        );
        assert_eq!(parse_window("2:").unwrap().end_s, None);
        assert!(parse_window("5").is_err());
        assert!(parse_window("9:3").is_err());
        assert!(parse_window("a:3").is_err());
        assert!(parse_window("1:inf").is_err());
    }
}
