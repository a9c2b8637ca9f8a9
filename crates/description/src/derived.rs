//! What follows from a rig description beyond its own numbers: the platform's geometry built
//! from the `[platform]` table (with the refusal that names the key when the design cannot be
//! built) and the accelerometer's position once a calibration is applied.

use kinematics::{Geometry, KinematicsError, StrokeLimits};
use nalgebra::Vector3;

use crate::config::Config;
use crate::load::{ConfigError, ConfigIssue, LoadedConfig};

/// The platform design of `config`, or the reason it cannot be built (singular, unreachable
/// home, coincident joints).
pub fn geometry(loaded: &LoadedConfig) -> Result<Geometry, ConfigError> {
    let p = &loaded.config.platform;
    Geometry::from_radii(
        p.base_radius_m,
        p.plate_radius_m,
        p.base_pair_separation_deg.to_radians(),
        p.plate_pair_separation_deg.to_radians(),
        StrokeLimits {
            min_length_m: p.min_leg_length_m,
            max_length_m: p.max_leg_length_m,
        },
    )
    .map_err(|e| ConfigError::single(geometry_issue(loaded, &e)))
}

fn geometry_issue(loaded: &LoadedConfig, e: &KinematicsError) -> ConfigIssue {
    let (key, problem) = match e {
        KinematicsError::ArchitecturallySingular { inverse_condition } => (
            "platform",
            format!(
                "the design is singular at its home pose (inverse condition number {inverse_condition:.2e}): \
                 the plate could move with no (or too little) change of leg length. The plate's \
                 joint pairs must be turned against the base's: change \
                 platform.base_pair_separation_deg / platform.plate_pair_separation_deg (equal \
                 joint angles on both circles, e.g. separations adding up to 120°, are singular); \
                 and platform.plate_radius_m must not be tiny against platform.base_radius_m (or \
                 the reverse): rotations would barely change the leg lengths"
            ),
        ),
        KinematicsError::HomeUnreachable => (
            "platform.min_leg_length_m",
            "no level home pose has the mid-stroke mean leg length: the stroke is too short for \
             the joint circles (raise platform.min_leg_length_m / max_leg_length_m or change the radii)"
                .to_string(),
        ),
        KinematicsError::CoincidentJoints { .. } => (
            "platform",
            format!("two joints coincide: {e} (check the radii and pair separations)"),
        ),
        KinematicsError::InvalidStroke { .. } => ("platform.max_leg_length_m", e.to_string()),
        _ => ("platform", e.to_string()),
    };
    loaded.issue(key, problem)
}

/// The accelerometer's position in P, m: the IMU calibration's when one is applied, else the
/// described `sensors.imu.position_m`.
pub fn accelerometer_position(config: &Config) -> Vector3<f64> {
    Vector3::from(
        config
            .calibration
            .imu_alignment()
            .map_or(config.sensors.imu.position_m, |a| {
                a.accelerometer_position_m
            }),
    )
}
