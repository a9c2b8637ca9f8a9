//! The rig's calibrations fitted from its own data, each with its uncertainty, into the dated
//! files a rig description applies (`rig_description::calibration`, re-exported as [`rig_description::calibration`]). docs/calibration.md
//! says when to run each and what it reaches.
//!
//! - [`imu`]: the IMU's alignment against the forward kinematics (its axes' rotation and
//!   scales, the accelerometer's position, the IMU's delay), from a moving plate's record.
//! - [`load_cells`]: the load cells' gains from a reference body of known mass, measured like
//!   a payload (tare run, then the reference on the fixture).
//!
//! Both fits accumulate least-squares normal equations with a block-sandwich covariance
//! (`normal`).
#![warn(missing_docs)]

pub mod imu;
pub mod load_cells;
mod normal;
