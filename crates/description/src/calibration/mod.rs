//! The calibrations a rig description applies, as their dated files hold them: each fitted
//! from the rig's own data (measure's `calibration` fits them), with its uncertainty
//! ([`file`]). docs/calibration.md says when to run each and what it reaches.
//!
//! - [`imu`]: the IMU's alignment against the forward kinematics (its axes' rotation and
//!   scales, the accelerometer's position, the IMU's delay).
//! - [`load_cells`]: the load cells' gains from a reference body of known mass.
//! - [`file`]: the dated calibration file.

pub mod file;
pub mod imu;
pub mod load_cells;
mod load_cells_file;

pub use file::{CalibrationDocument, CalibrationFile, Provenance};
pub use imu::ImuAlignment;
pub use load_cells::{LoadCellGains, JOINT_COORDINATES};
pub use load_cells_file::LoadCellFile;

/// A calibration a measurement applied, as its report records it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AppliedCalibration {
    /// What it calibrates (`"imu"`).
    pub kind: String,
    /// Where it came from: the file the rig description names, or the calibration pass.
    pub source: String,
    /// When its data were taken (`2026-11-24T17:40:00Z`).
    pub calibrated_utc: String,
    /// The tool that fitted it.
    pub tool: String,
    /// SHA-256 of the calibration as applied: its file's TOML as the log records it
    /// (`run_metadata.imu_calibration_toml`, `load_cell_calibration_toml`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub sha256: String,
}

/// This tool and its version, as reports and calibration files name it.
pub fn tool() -> String {
    format!("stewart {}", env!("CARGO_PKG_VERSION"))
}
