//! What `stewart rig` prints: the link's lines, the tare, the calibration or the report.

use ops::session::{LinkReport, Outcome};

use super::RigArgs;

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
pub fn finish(args: &RigArgs, outcome: &Outcome) -> u8 {
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
    let json = outcome.report_json().unwrap_or_default();
    let report = outcome.report.as_ref().map(|r| (r, json));
    crate::output::finish_measurement(run_args, report, &outcome.log_path, code)
}
