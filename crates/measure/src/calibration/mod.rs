//! Calibrations of the rig that the measurement applies: each fitted from the rig's own data,
//! with its uncertainty, written to a dated calibration file the rig description references
//! ([`file`]). docs/calibration.md says when to run each and what it reaches.
//!
//! - [`imu`]: the IMU's alignment against the forward kinematics (its axes' rotation and
//!   scales, the accelerometer's position, the IMU's delay), from a moving plate.
//! - [`file`]: the dated calibration file.

pub mod file;
pub mod imu;

pub use file::CalibrationFile;
pub use imu::ImuAlignment;

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
}

/// The calibrations `config` applies, for the report.
pub fn applied(config: &crate::config::CalibrationConfig) -> Vec<AppliedCalibration> {
    match (&config.imu, &config.imu_file) {
        (Some(source), Some(file)) => vec![AppliedCalibration {
            kind: "imu".into(),
            source: source.clone(),
            calibrated_utc: file.calibrated_utc.clone(),
            tool: file.tool.clone(),
        }],
        _ => Vec::new(),
    }
}

/// This tool and its version, as reports and calibration files name it.
pub fn tool() -> String {
    format!("stewart {}", env!("CARGO_PKG_VERSION"))
}
