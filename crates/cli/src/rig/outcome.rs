//! What `stewart rig` prints: the link's lines, the tare, the calibration or the report.

use ops::measurement::Outcome;

use super::RigArgs;

/// Prints the outcome, writes the report and the tare; returns the exit code.
pub fn finish(args: &RigArgs, outcome: &Outcome) -> u8 {
    let (plan, common) = match super::resolve(args) {
        Ok(x) => x,
        Err(e) => return e.exit_code(),
    };
    let run_args = &common.run;
    for line in ops::rig::link_lines(&outcome.link) {
        eprintln!("{line}");
    }
    for r in &outcome.repeated {
        eprintln!(
            "repeated after a stall: {} (its log: {})",
            r.cause,
            r.log.display()
        );
    }
    let noticed = outcome
        .failure
        .as_ref()
        .and_then(|f| f.after_last_frame_s)
        .map(|s| format!(" (noticed {:.1} ms after the last valid frame)", s * 1e3))
        .unwrap_or_default();
    let braked_at_once = outcome.end == measure::End::Interrupted
        && outcome
            .failure
            .as_ref()
            .is_some_and(|f| f.kind == rig::ErrorKind::Stopped);
    let code = if braked_at_once {
        // The second stopping signal braked where the platform stood: it did not park.
        eprintln!("interrupted: the platform was braked at once, without parking; no report");
        ops::exit::INTERRUPTED
    } else {
        crate::common::end_code(&outcome.end, &noticed)
    };
    if let (ops::rig::RigPlan::CalibrateImu(path), Some(file)) = (&plan, &outcome.calibration) {
        crate::calibrate::print_imu_calibration(file, path, run_args.shared.quiet);
        return code;
    }
    if let (ops::rig::RigPlan::CalibrateLoadCells(path), Some(file)) =
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
            ops::rig::RigPlan::TareOnly(out) => Some(out),
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
