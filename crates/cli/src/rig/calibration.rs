//! The calibration commands of `stewart rig` (`calibrate-imu`, `calibrate-load-cells`;
//! docs/calibration.md): what their runs leave out of the rig description, and the files
//! fitted on their runs. A measurement whose description asks for a calibration each run (a
//! `simulate` feature) is told how to calibrate a rig instead.

use std::path::Path;

use measure::calibration::{CalibrationDocument, CalibrationFile, LoadCellFile};
use measure::load::LoadedConfig;
use measure::session::SessionOutcome;

use super::Plan;
use crate::common::CommandError;

/// Readies `loaded` for `plan`. A calibration fits the raw readings: the IMU's calibration is
/// left out of `calibrate-imu`'s run, the load cells' out of `calibrate-load-cells`' runs
/// (which also need the reference's known mass). Otherwise, unless `quiet`, a description
/// asking for an IMU or load-cell calibration each run is told how to calibrate on a rig.
pub(super) fn prepare(
    plan: &Plan,
    loaded: &mut LoadedConfig,
    quiet: bool,
) -> Result<(), CommandError> {
    let calibrating_cells = matches!(plan, Plan::CalibrateLoadCells(_));
    if matches!(plan, Plan::CalibrateImu(_)) {
        // The calibration fits the raw readings: nothing of an older calibration applied.
        loaded.config.calibration.imu = None;
        loaded.config.calibration.imu_file = None;
    } else if calibrating_cells {
        crate::calibrate::prepare_reference_runs(loaded)?;
    } else if loaded.config.calibration.calibrates_imu_each_run() && !quiet {
        eprintln!(
            "note: calibration.measure_imu calibrates the IMU in `stewart simulate` only; on a \
             rig, run `stewart rig calibrate-imu --out FILE` once and set calibration.imu = \
             \"FILE\" (the budget counts the IMU's datasheet figures until then)"
        );
    }
    if !calibrating_cells && loaded.config.calibration.calibrates_load_cells_each_run() && !quiet {
        eprintln!(
            "note: calibration.measure_load_cells calibrates the load cells in `stewart \
             simulate` only; on a rig, run `stewart rig calibrate-load-cells --out FILE` with the \
             reference weight and set calibration.load_cells = \"FILE\" (the budget counts the \
             cells' datasheet gains until then)"
        );
    }
    Ok(())
}

/// The calibration `plan` fits on `outcome` when its runs completed, written to the plan's
/// path: the IMU's (`calibrate-imu`) or the load cells' (`calibrate-load-cells`); `None` for
/// the other plans, or runs that ended early. `loaded`, `start_ns` and `log_path` date and
/// trace the file.
pub(super) fn fit_and_write(
    plan: &Plan,
    outcome: &SessionOutcome,
    loaded: &LoadedConfig,
    start_ns: u64,
    log_path: &Path,
) -> Result<(Option<CalibrationFile>, Option<LoadCellFile>), CommandError> {
    if outcome.end != measure::End::Completed {
        return Ok((None, None));
    }
    match plan {
        Plan::CalibrateImu(path) => {
            let file =
                crate::calibrate::imu_calibration(outcome, loaded, "rig", start_ns, log_path)
                    .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Ok((Some(file), None))
        }
        Plan::CalibrateLoadCells(path) => {
            let file =
                crate::calibrate::load_cell_calibration(outcome, loaded, "rig", start_ns, log_path)
                    .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Ok((None, Some(file)))
        }
        _ => Ok((None, None)),
    }
}
