//! Calibrations of the rig that the measurement applies, fitted from the rig's own data with
//! their uncertainty; their dated files are part of the rig description
//! ([`rig_description::calibration`], re-exported here). docs/calibration.md says when to run
//! each and what it reaches.
//!
//! - [`imu`]: the IMU's alignment against the forward kinematics (its axes' rotation and
//!   scales, the accelerometer's position, the IMU's delay), from a moving plate.
//! - [`load_cells`]: the load cells' gains from a reference body of known mass, measured like
//!   a payload (tare run, then the reference on the fixture; [`crate::reference_mass`] fits
//!   them).

pub mod imu;
pub(crate) mod normal;

pub use rig_description::calibration::{
    file, load_cells, tool, AppliedCalibration, CalibrationDocument, CalibrationFile, ImuAlignment,
    LoadCellFile, LoadCellGains, Provenance,
};
