//! The simulated world's switches for a real rig's imperfections (`[world.imperfections]`),
//! and the optional non-rigid payload (`[world.suspension]`).
//!
//! Each switch turns one [`ErrorSource`] on or off in the simulator; the magnitudes come from
//! the rig description (its datasheet figures, tolerances and the legs' mass properties), so a
//! campaign can run one source at a time against an estimator that still knows the whole
//! datasheet ([`Imperfections::only`]).

use rig_description::sources::ErrorSource;
use serde::{Deserialize, Serialize};

/// Which error sources the simulated rig has (`true`: on, sized by the rig description).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Imperfections {
    /// White noise and quantisation of every channel, the gyro's bias.
    pub noise: bool,
    /// The accelerometer's constant bias.
    pub accel_bias: bool,
    /// The load cells' zero offsets and their drift.
    pub load_cell_offset: bool,
    /// The load cells' gain errors.
    pub load_cell_scale: bool,
    /// The load cells' transverse sensitivity.
    pub load_cell_crosstalk: bool,
    /// The IMU's mounting rotation and scale-factor errors.
    pub imu_misalignment: bool,
    /// The accelerometer's position off its described place.
    pub imu_lever_arm: bool,
    /// The IMU's constant delay against the load cells and encoders.
    pub time_skew: bool,
    /// Each frame's sampling instant off the grid.
    pub timestamp_jitter: bool,
    /// Frames lost on the way to the host.
    pub frame_loss: bool,
    /// The legs' mass and inertia.
    pub leg_dynamics: bool,
    /// The joints' friction.
    pub joint_friction: bool,
    /// The built joints off the drawing.
    pub geometry: bool,
}

impl Default for Imperfections {
    /// Every source on.
    fn default() -> Self {
        Self::all(true)
    }
}

impl Imperfections {
    /// Every source on (`true`) or off.
    pub fn all(on: bool) -> Self {
        Self {
            noise: on,
            accel_bias: on,
            load_cell_offset: on,
            load_cell_scale: on,
            load_cell_crosstalk: on,
            imu_misalignment: on,
            imu_lever_arm: on,
            time_skew: on,
            timestamp_jitter: on,
            frame_loss: on,
            leg_dynamics: on,
            joint_friction: on,
            geometry: on,
        }
    }

    /// Only `source` on.
    pub fn only(source: ErrorSource) -> Self {
        let mut s = Self::all(false);
        *s.switch_mut(source) = true;
        s
    }

    /// Whether `source` is on.
    pub fn is_on(&self, source: ErrorSource) -> bool {
        let mut copy = *self;
        *copy.switch_mut(source)
    }

    fn switch_mut(&mut self, source: ErrorSource) -> &mut bool {
        match source {
            ErrorSource::Noise => &mut self.noise,
            ErrorSource::AccelBias => &mut self.accel_bias,
            ErrorSource::LoadCellOffset => &mut self.load_cell_offset,
            ErrorSource::LoadCellScale => &mut self.load_cell_scale,
            ErrorSource::LoadCellCrosstalk => &mut self.load_cell_crosstalk,
            ErrorSource::ImuMisalignment => &mut self.imu_misalignment,
            ErrorSource::ImuLeverArm => &mut self.imu_lever_arm,
            ErrorSource::TimeSkew => &mut self.time_skew,
            ErrorSource::TimestampJitter => &mut self.timestamp_jitter,
            ErrorSource::FrameLoss => &mut self.frame_loss,
            ErrorSource::LegDynamics => &mut self.leg_dynamics,
            ErrorSource::JointFriction => &mut self.joint_friction,
            ErrorSource::Geometry => &mut self.geometry,
            // A source this world cannot simulate stays off.
            #[allow(unreachable_patterns)]
            _ => &mut self.noise,
        }
    }
}

/// `[world.suspension]`: the payload as a car body on its suspension. A share of the payload
/// (the sprung mass, with the same share of its inertia, at its centre of mass) rides on four
/// spring-damper units at the wheels, the rest stays rigid on the plate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SuspensionConfig {
    /// Off by default: the payload is rigid.
    pub enabled: bool,
    /// Share of the payload's mass on the springs (0 to 1).
    pub sprung_share: f64,
    /// Heave (bounce) frequency of the sprung mass, Hz.
    pub bounce_hz: f64,
    /// Damping ratio of the heave mode.
    pub damping_ratio: f64,
    /// Lateral distance between the wheels, m.
    pub track_m: f64,
    /// Longitudinal distance between the axles, m.
    pub wheelbase_m: f64,
}

impl Default for SuspensionConfig {
    /// A passenger car: 85 % sprung, 1.3 Hz bounce, damping ratio 0.25, 1.55 m track and
    /// 2.7 m wheelbase; disabled.
    fn default() -> Self {
        Self {
            enabled: false,
            sprung_share: 0.85,
            bounce_hz: 1.3,
            damping_ratio: 0.25,
            track_m: 1.55,
            wheelbase_m: 2.7,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_switches_every_other_source_off() {
        for source in ErrorSource::ALL {
            let only = Imperfections::only(source);
            for other in ErrorSource::ALL {
                assert_eq!(only.is_on(other), other == source, "{source} / {other}");
            }
            assert!(Imperfections::default().is_on(source));
        }
    }

    #[test]
    fn the_tables_refuse_unknown_keys() {
        let i: Imperfections = toml::from_str("geometry = false\n").unwrap();
        assert!(!i.geometry && i.noise);
        assert!(toml::from_str::<Imperfections>("geometri = false\n").is_err());
        let s: SuspensionConfig = toml::from_str("enabled = true\n").unwrap();
        assert!(s.enabled && s.bounce_hz == 1.3);
        assert!(toml::from_str::<SuspensionConfig>("bounce = 1.0\n").is_err());
    }
}
