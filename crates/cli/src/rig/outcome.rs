//! What `stewart rig` produces: the tare file, the report (the `simulate` report without
//! `truth`, plus the link counters and loop timing of each measurement) and what is printed.

use std::path::PathBuf;

use measure::{End, Report, TareFile};
use runlog::link::{LinkCounters, TimingSummary};
use serde::Serialize;

use super::RigArgs;
use rig::link::Failure;

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
    /// The counters of the whole link, from the first handshake to the closing safe stop:
    /// unlike [`link`](Self::link) (each measurement's window) they include the brake
    /// heartbeats sent between measurements and while the log is finished.
    pub link_total: rig::LinkStats,
    /// The IMU calibration written (`rig calibrate-imu`).
    pub calibration: Option<measure::calibration::CalibrationFile>,
    /// The load-cell calibration written (`rig calibrate-load-cells`).
    pub load_cell_calibration: Option<measure::calibration::LoadCellFile>,
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
    for line in link_lines(&outcome.link) {
        eprintln!("{line}");
    }
    let noticed = outcome
        .failure
        .as_ref()
        .and_then(|f| f.after_last_frame_s)
        .map(|s| format!(" (noticed {:.1} ms after the last valid frame)", s * 1e3))
        .unwrap_or_default();
    let code = crate::common::end_code(&outcome.end, &noticed);
    if let (super::Plan::CalibrateImu(path), Some(file)) = (&plan, &outcome.calibration) {
        crate::calibrate::print_imu_calibration(file, path, run_args.shared.quiet);
        return code;
    }
    if let (super::Plan::CalibrateLoadCells(path), Some(file)) =
        (&plan, &outcome.load_cell_calibration)
    {
        crate::calibrate::print_load_cell_calibration(file, path, run_args.shared.quiet);
        return code;
    }
    if let Some(tare) = &outcome.tare {
        if !run_args.shared.quiet {
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
    let json = outcome
        .report_json()
        .and_then(|v| serde_json::to_string_pretty(&v).ok())
        .unwrap_or_default();
    let report = outcome.report.as_ref().map(|r| (r, json));
    crate::output::finish_measurement(run_args, report, &outcome.log_path, code)
}
