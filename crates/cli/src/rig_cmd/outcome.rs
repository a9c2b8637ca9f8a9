//! What `stewart rig` produces: the tare file, the report (the `simulate` report without
//! `truth`, plus the link counters and loop timing of each measurement) and what is printed.

use std::path::PathBuf;

use anyhow::Context;
use estimator::{Estimate, InertialParameters, ParameterCovariance};
use kinematics::Geometry;
use serde::Serialize;

use super::link::{Failure, LinkCounters, TimingSummary};
use super::RigArgs;
use crate::args::RunArgs;
use crate::config_load::LoadedConfig;
use crate::report::{self, Report, ReportInputs, RunInfo, TareKind};
use crate::run::{End, MeasureOutcome};
use crate::run_log::RunLog;
use crate::tare::TareFile;

/// What the metadata and the report give as the noise preset: the rig's sensors are what they
/// are.
pub const NOISE: &str = "rig";

/// The link over one measurement.
#[derive(Clone, Debug, Serialize)]
pub struct LinkReport {
    /// `"tare"` or `"loaded"`.
    pub run: String,
    /// Counters over the measurement.
    pub counters: LinkCounters,
    /// The loop's timing.
    pub timing: TimingSummary,
}

/// What a `stewart rig` run produced.
#[derive(Debug)]
pub struct RigOutcome {
    /// The report of the loaded run (`None` for `rig tare` and runs that ended early).
    pub report: Option<Report>,
    /// The MCAP log written.
    pub log_path: PathBuf,
    /// How the run ended (anything but `Completed` is a non-zero exit).
    pub end: End,
    /// The measured tare, when a tare run completed.
    pub tare: Option<TareFile>,
    /// The link and loop timing of each measurement made, in order.
    pub link: Vec<LinkReport>,
    /// The link, sensor or rig failure that ended the run, with when the host noticed it.
    pub failure: Option<Failure>,
    /// The rig as it described itself in the (last) handshake.
    pub rig: rig::host::RigInfo,
}

impl RigOutcome {
    /// The report as JSON with the rig's extras: `link` (per measurement: counters and loop
    /// timing) and `rig` (address, identity).
    pub fn report_json(&self) -> Option<serde_json::Value> {
        let report = self.report.as_ref()?;
        let mut value = serde_json::to_value(report).ok()?;
        if let Some(map) = value.as_object_mut() {
            map.insert(
                "link".into(),
                serde_json::to_value(&self.link).unwrap_or_default(),
            );
            map.insert(
                "rig".into(),
                serde_json::json!({
                    "address": self.rig.address,
                    "identity": self.rig.identity,
                    "sample_period_s": self.rig.sample_period_s,
                }),
            );
        }
        Some(value)
    }
}

/// Filled in as the run goes.
#[derive(Default)]
pub(super) struct Produced {
    pub end: Option<End>,
    pub report: Option<Report>,
    pub tare: Option<TareFile>,
    pub link: Vec<LinkReport>,
    pub failure: Option<Failure>,
}

impl Produced {
    pub fn into_outcome(self, log_path: PathBuf, rig: rig::host::RigInfo) -> RigOutcome {
        RigOutcome {
            report: self.report,
            log_path,
            end: self.end.unwrap_or(End::Completed),
            tare: self.tare,
            link: self.link,
            failure: self.failure,
            rig,
        }
    }
}

/// The tare run's accelerometer-bias and load-cell-offset effects (θ change per one sigma),
/// kept through the session change so that the loaded run's report counts the tare's share.
#[derive(Clone, Copy, Default)]
pub(super) struct TareEffects {
    pub accel: Option<[[f64; 10]; 3]>,
    pub load_cell: Option<[[f64; 10]; 6]>,
}

impl TareEffects {
    pub fn of(outcome: &MeasureOutcome) -> Self {
        Self {
            accel: outcome.accel_bias_effect,
            load_cell: outcome.load_cell_bias_effect,
        }
    }
}

/// Where the subtracted tare came from.
pub(super) enum TareSource {
    /// Measured in this invocation (the effects boxed: the variants stay about one size).
    Measured(TareFile, Box<TareEffects>),
    /// A saved tare (its sensitivities, if it has them, give its share).
    File(TareFile),
}

impl TareSource {
    pub fn file(&self) -> &TareFile {
        match self {
            Self::Measured(f, _) | Self::File(f) => f,
        }
    }

    fn effects(&self) -> TareEffects {
        match self {
            Self::Measured(_, e) => **e,
            Self::File(_) => TareEffects::default(),
        }
    }
}

/// Base and plate joints as arrays, as tare files and metadata store them.
pub(super) fn joints(g: &Geometry) -> ([[f64; 3]; 6], [[f64; 3]; 6]) {
    (
        g.base_joints_m().map(|v| [v.x, v.y, v.z]),
        g.plate_joints_m().map(|v| [v.x, v.y, v.z]),
    )
}

/// The tare file of a tare run, with the run's bias sensitivities (so that `rig measure
/// --tare FILE` counts the tare's share of the systematic part as a same-session tare does).
pub(super) fn tare_file_of(
    estimate: &Estimate,
    effects: &TareEffects,
    loaded: &LoadedConfig,
    base_joints: &[[f64; 3]; 6],
    plate_joints: &[[f64; 3]; 6],
) -> TareFile {
    let config = &loaded.config;
    TareFile::from_estimate(estimate, base_joints, plate_joints, &loaded.source, "rig")
        .with_bias_effects(
            effects.accel.as_ref(),
            crate::preflight::accel_bias_sigma(config),
            effects.load_cell.as_ref(),
            crate::systematic::load_cell_bias_sigma(config),
        )
}

/// The report of a loaded run on the rig: as `simulate`'s ([`report::build`]), without truth.
/// The systematic part counts the payload's share of the accelerometer bias and of the load
/// cells' zero offsets (loaded effect minus the tare's): the tare's effects come from the
/// tare run of this invocation, or from the sensitivities a saved tare carries (a tare file
/// written before they were kept counts as zero share, which overstates sigma slightly), as
/// `stewart estimate` of the rig's log computes them.
pub(super) fn build_report(
    args: &RunArgs,
    loaded: &LoadedConfig,
    outcome: &MeasureOutcome,
    tare: &TareSource,
    _tare_params: &(InertialParameters, ParameterCovariance),
    log: &RunLog,
) -> anyhow::Result<Report> {
    let config = &loaded.config;
    let loaded_estimate = outcome
        .estimate
        .as_ref()
        .context("the loaded run produced no estimate")?;
    let tare_effects = tare.effects();
    Ok(report::build(&ReportInputs {
        loaded: loaded_estimate,
        theta_history: &outcome.theta_history,
        excitation_s: outcome.excitation_s,
        fk_failures: outcome.fk_failures,
        tare: tare.file(),
        tare_kind: match tare {
            TareSource::Measured(..) => TareKind::Measured,
            TareSource::File(_) => TareKind::File,
        },
        tare_path: args.tare.as_ref().map(|p| p.display().to_string()),
        loaded_bias_effect: outcome.accel_bias_effect.as_ref(),
        tare_bias_effect: tare_effects.accel.as_ref(),
        accel_bias_sigma_m_s2: crate::preflight::accel_bias_sigma(config),
        loaded_load_cell_effect: outcome.load_cell_bias_effect.as_ref(),
        tare_load_cell_effect: tare_effects.load_cell.as_ref(),
        load_cell_bias_sigma_n: crate::systematic::load_cell_bias_sigma(config),
        params: config.estimator.params,
        truth: None,
        run: RunInfo {
            config: loaded.source.clone(),
            seed: config.run.seed,
            noise: NOISE.into(),
            params: config.estimator.params.into(),
            log: Some(log.path().display().to_string()),
            backend: "rig".into(),
        },
    }))
}

/// One line per measurement: the link counters and the loop's timing.
pub fn link_lines(link: &[LinkReport]) -> Vec<String> {
    link.iter()
        .map(|l| {
            let c = &l.counters;
            let t = &l.timing;
            format!(
                "link ({}): accepted {}, lost {}, late {}, duplicate {}, out of sequence {}, \
                 corrupt {}, foreign {}, auth failed {}, clamped commands {}; loop period median \
                 {:.3} ms, jitter median {:.0} µs, p99 {:.0} µs, max {:.1} ms; work per tick \
                 median {:.0} µs, p99 {:.0} µs",
                l.run,
                c.accepted,
                c.lost,
                c.late,
                c.duplicate,
                c.out_of_sequence,
                c.corrupt,
                c.foreign,
                c.auth_failed,
                c.commands_clamped,
                t.median_period_s * 1e3,
                t.jitter_median_s * 1e6,
                t.jitter_p99_s * 1e6,
                t.jitter_max_s * 1e3,
                t.work_median_s * 1e6,
                t.work_p99_s * 1e6,
            )
        })
        .collect()
}

/// Prints the outcome, writes the report and the tare; returns the exit code.
pub fn finish(args: &RigArgs, outcome: &RigOutcome) -> u8 {
    let (plan, common) = match super::resolve(args) {
        Ok(x) => x,
        Err(e) => return e.exit_code(),
    };
    let run_args = &common.run;
    let mut code = 0;
    for line in link_lines(&outcome.link) {
        eprintln!("{line}");
    }
    match &outcome.end {
        End::Completed => {}
        End::Interrupted => {
            eprintln!("interrupted: the platform was parked and braked; no report");
            code = crate::EXIT_INTERRUPTED;
        }
        End::Fault(cause) => {
            let noticed = outcome
                .failure
                .as_ref()
                .and_then(|f| f.after_last_frame_s)
                .map(|s| format!(" (noticed {:.1} ms after the last valid frame)", s * 1e3))
                .unwrap_or_default();
            eprintln!("fault: {cause}{noticed}; a safe stop was commanded; no report");
            code = crate::EXIT_FAULT;
        }
    }
    if let Some(report) = &outcome.report {
        if !run_args.quiet {
            print!("{}", crate::table::render(report));
        }
        if let Some(path) = &run_args.report {
            let text = outcome
                .report_json()
                .and_then(|v| serde_json::to_string_pretty(&v).ok())
                .unwrap_or_default();
            if let Err(e) = std::fs::write(path, text) {
                eprintln!("error: cannot write the report {}: {e}", path.display());
                code = 1;
            } else if !run_args.quiet {
                println!("report: {}", path.display());
            }
        }
    }
    if let Some(tare) = &outcome.tare {
        if !run_args.quiet {
            let m = tare.theta[0];
            let c = if m.abs() > 0.0 {
                [tare.theta[1] / m, tare.theta[2] / m, tare.theta[3] / m]
            } else {
                [f64::NAN; 3]
            };
            println!(
                "tare: {m:.3} kg, centre of mass [{:.4}, {:.4}, {:.4}] m",
                c[0], c[1], c[2]
            );
        }
        let saved = match &plan {
            super::Plan::TareOnly(out) => Some(out),
            _ => run_args.save_tare.as_ref(),
        };
        if let Some(path) = saved {
            println!("tare saved: {}", path.display());
        }
    }
    println!("log: {}", outcome.log_path.display());
    if let Some(dir) = &run_args.plot {
        match crate::plot::plot_log(&outcome.log_path, dir) {
            Ok(files) => println!("figures: {} ({} files)", dir.display(), files.len()),
            Err(e) => {
                eprintln!("error: cannot plot the log: {e:#}");
                code = code.max(1);
            }
        }
    }
    code
}
