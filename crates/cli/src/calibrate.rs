//! What is printed of a calibration: the IMU's alignment and the load cells' gains found, with
//! one sigma ([`ops::calibration`]), and where they were written.

use std::path::Path;

use rig_description::calibration::{CalibrationFile, LoadCellFile};

/// Prints what a load-cell calibration found (unless `quiet`) and where it was written.
pub fn print_load_cell_calibration(file: &LoadCellFile, path: &Path, quiet: bool) {
    if !quiet {
        ops::calibration::load_cell_lines(file)
            .iter()
            .for_each(|l| println!("{l}"));
    }
    println!("load-cell calibration: {}", path.display());
}

/// Prints what an IMU calibration found (unless `quiet`) and where it was written.
pub fn print_imu_calibration(file: &CalibrationFile, path: &Path, quiet: bool) {
    if !quiet {
        ops::calibration::imu_lines(file)
            .iter()
            .for_each(|l| println!("{l}"));
    }
    println!("IMU calibration: {}", path.display());
}
