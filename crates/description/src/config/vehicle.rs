//! `[vehicle]`: where the payload (a vehicle) stands on the plate, as the operator measured it,
//! so that the results can be given in the vehicle's own frame V as well as in P.
//!
//! V is the vehicle frame of ISO 8855: x forward, y left, z up, its origin on the ground plane
//! (the surface the tyres stand on: the plate's top when the car stands on the plate) below
//! the centre of the front axle. `origin_m` is that point in P, `orientation_deg` V's axes in P
//! as roll, pitch, yaw (the pose convention: a vector v in V's axes is `R v` in P with
//! `R = Rx(roll) Ry(pitch) Rz(yaw)`). `convention` only changes how the results are written:
//! SAE J670 turns y to the right and z down (its CG height is then −c_z).

use serde::{Deserialize, Serialize};

/// How the vehicle-frame results are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum VehicleConvention {
    /// ISO 8855: x forward, y left, z up.
    #[default]
    Iso8855,
    /// SAE J670: x forward, y right, z down.
    SaeJ670,
}

impl VehicleConvention {
    /// The convention and its axes in words.
    pub fn describe(self) -> &'static str {
        match self {
            VehicleConvention::Iso8855 => "ISO 8855 (x forward, y left, z up)",
            VehicleConvention::SaeJ670 => "SAE J670 (x forward, y right, z down)",
        }
    }

    /// The signs that turn ISO 8855 axes into this convention's (a diagonal rotation).
    pub fn axis_signs(self) -> [f64; 3] {
        match self {
            VehicleConvention::Iso8855 => [1.0, 1.0, 1.0],
            VehicleConvention::SaeJ670 => [1.0, -1.0, -1.0],
        }
    }
}

/// `[vehicle]`: the vehicle frame's placement on the plate and its tolerances (one sigma).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleConfig {
    /// V's origin in P, m: on the ground plane below the front axle's centre.
    pub origin_m: [f64; 3],
    /// V's axes (ISO 8855) in P: roll, pitch, yaw, degrees.
    #[serde(default)]
    pub orientation_deg: [f64; 3],
    /// One standard deviation of each coordinate of `origin_m` as it was measured, m.
    pub origin_tolerance_m: f64,
    /// One standard deviation of V's orientation about each of its axes, degrees.
    pub orientation_tolerance_deg: f64,
    /// How the results are written (ISO 8855 unless `sae_j670`).
    #[serde(default)]
    pub convention: VehicleConvention,
    /// Distance from the front axle to the rear axle along V's x, m: gives the static
    /// front/rear load split.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheelbase_m: Option<f64>,
    /// Distance between the left and right wheels' contact centres, m: gives the static
    /// left/right load split.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_m: Option<f64>,
}
