//! Calibrations of the rig that the measurement applies: each fitted from the rig's own data,
//! with its uncertainty, written to a dated calibration file the rig description references
//! ([`file`]). docs/calibration.md says when to run each and what it reaches.
//!
//! - [`imu`]: the IMU's alignment against the forward kinematics (its axes' rotation and
//!   scales, the accelerometer's position, the IMU's delay), from a moving plate.
//! - [`load_cells`]: the load cells' gains from a reference body of known mass, measured like
//!   a payload (tare run, then the reference on the fixture).
//! - [`file`]: the dated calibration file.

pub mod file;
pub mod imu;
pub mod load_cells;
mod normal;

pub use file::CalibrationFile;
pub use imu::ImuAlignment;
pub use load_cells::{LoadCellFile, LoadCellGains};
