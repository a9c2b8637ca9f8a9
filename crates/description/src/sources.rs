//! The error sources of a real rig, named once: the simulated world switches each on or off
//! (`[world.imperfections]`, `simulate --only SOURCE`) and the report's error budget gives each
//! one's contribution to the sigma of every reported quantity.

use core::fmt;
use core::str::FromStr;

/// One error source. Its magnitude comes from the rig description (datasheet figures,
/// tolerances, the legs' mass properties).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum ErrorSource {
    /// White noise and quantisation of every channel, and the gyro's constant bias (whose
    /// effect, through the products of rates, is far below the noise's).
    Noise,
    /// The accelerometer's constant bias.
    AccelBias,
    /// Each load cell's zero offset and its drift over the run.
    LoadCellOffset,
    /// Each load cell's gain (sensitivity) error.
    LoadCellScale,
    /// Each load cell's response to force across its axis.
    LoadCellCrosstalk,
    /// The IMU's axes turned against P, and its scale-factor errors.
    ImuMisalignment,
    /// The accelerometer's position in P known only to a tolerance.
    ImuLeverArm,
    /// A constant delay of the IMU's channels against the load cells and encoders.
    TimeSkew,
    /// Each frame's sampling instant off its place on the sample grid.
    TimestampJitter,
    /// Frames lost between the sensors and the host.
    FrameLoss,
    /// The legs' own weight and inertia, which a single-axis load cell does not see whole.
    LegDynamics,
    /// Coulomb and viscous torque in the universal and spherical joints.
    JointFriction,
    /// The built joints' positions off the drawing.
    Geometry,
}

impl ErrorSource {
    /// Every source, in the order of the budget's table.
    pub const ALL: [ErrorSource; 13] = [
        ErrorSource::Noise,
        ErrorSource::AccelBias,
        ErrorSource::LoadCellOffset,
        ErrorSource::LoadCellScale,
        ErrorSource::LoadCellCrosstalk,
        ErrorSource::ImuMisalignment,
        ErrorSource::ImuLeverArm,
        ErrorSource::TimeSkew,
        ErrorSource::TimestampJitter,
        ErrorSource::FrameLoss,
        ErrorSource::LegDynamics,
        ErrorSource::JointFriction,
        ErrorSource::Geometry,
    ];

    /// The source's id, as in the report's `error_budget` and on the command line.
    pub fn id(self) -> &'static str {
        match self {
            ErrorSource::Noise => "noise",
            ErrorSource::AccelBias => "accel_bias",
            ErrorSource::LoadCellOffset => "load_cell_offset",
            ErrorSource::LoadCellScale => "load_cell_scale",
            ErrorSource::LoadCellCrosstalk => "load_cell_crosstalk",
            ErrorSource::ImuMisalignment => "imu_misalignment",
            ErrorSource::ImuLeverArm => "imu_lever_arm",
            ErrorSource::TimeSkew => "time_skew",
            ErrorSource::TimestampJitter => "timestamp_jitter",
            ErrorSource::FrameLoss => "frame_loss",
            ErrorSource::LegDynamics => "leg_dynamics",
            ErrorSource::JointFriction => "joint_friction",
            ErrorSource::Geometry => "geometry",
        }
    }
}

impl fmt::Display for ErrorSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

/// The name was not one of [`ErrorSource::ALL`]'s ids.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownSource(pub String);

impl fmt::Display for UnknownSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ids: Vec<&str> = ErrorSource::ALL.iter().map(|s| s.id()).collect();
        write!(
            f,
            "unknown error source `{}` (expected one of {})",
            crate::load::abbreviate_echo(&self.0),
            ids.join(", ")
        )
    }
}

impl std::error::Error for UnknownSource {}

impl FromStr for ErrorSource {
    type Err = UnknownSource;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ErrorSource::ALL
            .into_iter()
            .find(|source| source.id() == s)
            .ok_or_else(|| UnknownSource(s.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_are_distinct() {
        for s in ErrorSource::ALL {
            assert_eq!(s.id().parse::<ErrorSource>(), Ok(s));
        }
        let mut ids: Vec<&str> = ErrorSource::ALL.iter().map(|s| s.id()).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), ErrorSource::ALL.len());
        let e = "wobble".parse::<ErrorSource>().unwrap_err();
        assert!(e.to_string().contains("leg_dynamics"), "{e}");
    }
}
