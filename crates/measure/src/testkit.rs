//! What the tests of this crate and of the crates above it share (feature `testkit`): the
//! reference platform and a load-cell gains table.

use kinematics::{Geometry, StrokeLimits};

/// The default rig's design.
pub fn geometry() -> Geometry {
    Geometry::from_radii(
        1.5,
        1.2,
        20f64.to_radians(),
        20f64.to_radians(),
        StrokeLimits {
            min_length_m: 1.5,
            max_length_m: 2.3,
        },
    )
    .expect("reference design")
}

/// A gains table with these gains and a small diagonal covariance (other modules' tests).
pub fn gains_with(gains: [f64; 6]) -> rig_description::calibration::LoadCellGains {
    rig_description::calibration::LoadCellGains {
        gains,
        covariance: (0..6)
            .map(|i| (0..6).map(|j| if i == j { 1e-8 } else { 0.0 }).collect())
            .collect(),
        covariance_without_joints: Vec::new(),
        joint_sensitivity: Vec::new(),
        fitted_gains: gains,
        fitted_covariance: Vec::new(),
        prior_sigma: 0.0,
        noise_sigma: [1e-4; 6],
        joints_sigma: [0.0; 6],
        legs_sigma: [0.0; 6],
        drift_sigma: [0.0; 6],
        mass_sigma: [0.0; 6],
        reference_mass_kg: 1000.0,
        reference_mass_tolerance_kg: 0.05,
        reference_com_m: [0.0, 0.0, 0.3],
        fixture_mass_kg: 400.0,
        joint_tolerance_m: 2e-4,
        residual_rms: 1.0,
        entries: 4000,
    }
}
