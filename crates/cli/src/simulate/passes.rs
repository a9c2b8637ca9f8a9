//! The calibration passes of `stewart simulate` (`[calibration] measure_imu`,
//! `measure_load_cells`): each a [`simulate`] of its own on the same simulated world before the
//! measurement, its log and file beside the measurement's log.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use measure::End;

use super::{simulate, SimulateArgs, SimulateOutcome};
use crate::common::{CommandError, MeasureArgs};

/// What a calibration pass (`[calibration] measure_imu`, `measure_load_cells`) gave.
pub(super) enum Pass<F> {
    /// The calibration file written, and its contents.
    Calibrated(PathBuf, Box<F>),
    /// It could not be fitted (said on standard error): the measurement goes on with the
    /// sensors as the rig description describes them.
    Skipped,
    /// It was interrupted or faulted: the command ends with this outcome.
    Ended(Box<SimulateOutcome>),
}

/// The log and calibration file of the calibration pass beside the measurement's log `log`:
/// `NAME.imu.mcap` and `NAME.imu.toml`.
pub fn calibration_pass_paths(log: &std::path::Path) -> (PathBuf, PathBuf) {
    (
        log.with_extension("imu.mcap"),
        log.with_extension("imu.toml"),
    )
}

/// The log and calibration file of the load-cell calibration pass beside the measurement's log
/// `log`: `NAME.cells.mcap` and `NAME.cells.toml`.
pub fn load_cell_pass_paths(log: &std::path::Path) -> (PathBuf, PathBuf) {
    (
        log.with_extension("cells.mcap"),
        log.with_extension("cells.toml"),
    )
}

/// `[calibration] measure_imu`: before the measurement, the empty fixture moves once through
/// the tare run's excitation and the IMU's alignment is fitted ([`simulate`] with
/// `--calibrate-imu`), on the same simulated world; its log and file go beside the
/// measurement's log.
pub(super) fn calibration_pass(
    args: &SimulateArgs,
    log: &std::path::Path,
    interrupt: &AtomicBool,
) -> Result<Pass<measure::calibration::CalibrationFile>, CommandError> {
    let (pass_log, file) = calibration_pass_paths(log);
    let pass_args = SimulateArgs {
        calibrate_imu: Some(file.clone()),
        calibrate_load_cells: None,
        measure: pass_measure_args(args, pass_log),
        ..args.clone()
    };
    if !args.measure.shared.quiet {
        println!("IMU calibration on the empty fixture (calibration.measure_imu) …");
    }
    match simulate(&pass_args, interrupt) {
        Ok(outcome) => match (outcome.end.clone(), outcome.calibration.clone()) {
            (End::Completed, Some(c)) => {
                if !args.measure.shared.quiet {
                    crate::calibrate::print_imu_calibration(&c, &file, false);
                }
                Ok(Pass::Calibrated(file, Box::new(c)))
            }
            (End::Completed, None) => Ok(Pass::Skipped),
            _ => Ok(Pass::Ended(Box::new(outcome))),
        },
        Err(CommandError::Run(e)) => {
            eprintln!(
                "warning: the IMU calibration pass failed ({e:#}); measuring with the IMU as \
                 [sensors.imu] describes it"
            );
            Ok(Pass::Skipped)
        }
        Err(e) => Err(e),
    }
}

/// A calibration pass's measurement options: `args`' own, quiet, logging to `pass_log`, with
/// no tare, report, live view, figures or budget of its own.
fn pass_measure_args(args: &SimulateArgs, pass_log: PathBuf) -> MeasureArgs {
    MeasureArgs {
        shared: crate::common::SharedArgs {
            log: Some(pass_log),
            quiet: true,
            live: None,
            plot: None,
            ..args.measure.shared.clone()
        },
        tare: None,
        save_tare: None,
        report: None,
        html: None,
        budget: false,
        ..args.measure.clone()
    }
}

/// `[calibration] measure_load_cells`: before the measurement, a tare run and a run with the
/// world's reference body, and the cells' gains fitted ([`simulate`] with
/// `--calibrate-load-cells`), on the same simulated world with the IMU calibration `imu` the
/// measurement applies; its log and file go beside the measurement's log.
pub(super) fn load_cell_pass(
    args: &SimulateArgs,
    log: &std::path::Path,
    imu: Option<(PathBuf, Box<measure::calibration::CalibrationFile>)>,
    interrupt: &AtomicBool,
) -> Result<Pass<measure::calibration::LoadCellFile>, CommandError> {
    let (pass_log, file) = load_cell_pass_paths(log);
    let pass_args = SimulateArgs {
        calibrate_imu: None,
        calibrate_load_cells: Some(file.clone()),
        apply_imu: imu,
        measure: pass_measure_args(args, pass_log),
        ..args.clone()
    };
    if !args.measure.shared.quiet {
        println!(
            "load-cell calibration with the reference weight (calibration.measure_load_cells) …"
        );
    }
    match simulate(&pass_args, interrupt) {
        Ok(outcome) => match (outcome.end.clone(), outcome.load_cell_calibration.clone()) {
            (End::Completed, Some(c)) => {
                if !args.measure.shared.quiet {
                    crate::calibrate::print_load_cell_calibration(&c, &file, false);
                }
                Ok(Pass::Calibrated(file, Box::new(c)))
            }
            (End::Completed, None) => Ok(Pass::Skipped),
            _ => Ok(Pass::Ended(Box::new(outcome))),
        },
        Err(CommandError::Run(e)) => {
            eprintln!(
                "warning: the load-cell calibration pass failed ({e:#}); measuring with the \
                 cells as [sensors.load_cell] describes them"
            );
            Ok(Pass::Skipped)
        }
        Err(e) => Err(e),
    }
}
