//! The sensors' configuration: each channel's datasheet figures as the simulator uses them
//! (one standard deviation each), and the named grades [`NoisePreset`]. The model that draws
//! from them is [`crate::sensor_model`]; its docs give every error's equation.
//!
//! The `realistic` figures are the default rig description's (`configs/default.toml`, which
//! gives each one's source): load cells 4 N noise and zero offset (0.02 % of 20 kN), 0.5 N
//! resolution, 0.05 % gain error (a C3-class cell's 0.02 % plus its mounting), 0.2 % transverse
//! sensitivity (a column or S-beam cell's side-load rejection), 0.4 N/min zero drift (creep and
//! temperature, 0.02 % of range per 10 minutes); encoders 1 µm resolution, 0.5 µm noise; a
//! tactical-grade MEMS IMU (gyro 0.17 °/√h, 4 °/h bias, accelerometer 40 µg/√Hz, 100 µg bias,
//! both 500 ppm scale factor) aligned to 0.05° per axis and placed to 1 mm per coordinate;
//! timing: the IMU 100 µs apart from the load cells, 10 µs sampling jitter, 0.1 % lost frames.

use core::fmt;
use core::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{check_finite, check_non_negative, SimError};

/// Leg-length encoders (joint centre to joint centre).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LegLengthSensorConfig {
    /// White noise, one standard deviation, m.
    pub noise_sigma_m: f64,
    /// Resolution (quantization step), m; 0 = continuous.
    pub resolution_m: f64,
}

/// Load cells between each leg and the plate, reading the applied axial force.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoadCellConfig {
    /// White noise, one standard deviation, N.
    pub noise_sigma_n: f64,
    /// Standard deviation of each cell's constant zero offset, N.
    pub bias_sigma_n: f64,
    /// Resolution (quantization step), N; 0 = continuous.
    pub resolution_n: f64,
    /// Standard deviation of each cell's relative gain error `g` (reading `(1 + g) F`).
    pub gain_sigma: f64,
    /// Standard deviation of each cell's two transverse sensitivities `s₁, s₂` (reading
    /// `s₁ T₁ + s₂ T₂` of the force `T` across its axis).
    pub transverse_sigma: f64,
    /// Standard deviation of each cell's zero drift rate, N/s (the rig description gives it
    /// per minute).
    pub drift_sigma_n_s: f64,
}

/// Three-axis gyroscope on the plate, in the IMU's axes ([`ImuAxesConfig`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroConfig {
    /// Rate noise density (angle random walk), rad/s/√Hz.
    pub noise_density_rad_s_sqrt_hz: f64,
    /// Standard deviation of each axis' constant bias, rad/s.
    pub bias_sigma_rad_s: f64,
    /// Standard deviation of each axis' relative scale-factor error.
    pub scale_sigma: f64,
}

/// Three-axis accelerometer on the plate, in the IMU's axes ([`ImuAxesConfig`]), reading
/// specific force `a − g` at its mounting point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AccelerometerConfig {
    /// Noise density (velocity random walk), m/s²/√Hz.
    pub noise_density_m_s2_sqrt_hz: f64,
    /// Standard deviation of each axis' constant bias, m/s².
    pub bias_sigma_m_s2: f64,
    /// Standard deviation of each axis' relative scale-factor error.
    pub scale_sigma: f64,
    /// Described mounting point in P, m (default: the P origin).
    pub mount_m: [f64; 3],
    /// Standard deviation of each coordinate of the true mounting point about `mount_m`, m.
    pub mount_sigma_m: f64,
}

/// How the IMU's axes (gyro and accelerometer alike) are turned against P.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuAxesConfig {
    /// Described orientation as roll, pitch, yaw, degrees: a vector `v` in the IMU's axes is
    /// `R v` in P with `R = Rx(roll) Ry(pitch) Rz(yaw)` (the rig description's convention).
    pub orientation_deg: [f64; 3],
    /// Standard deviation of the mounting rotation about each of P's axes on top of the
    /// described orientation, degrees.
    pub misalignment_sigma_deg: f64,
}

/// How the channels of one frame are timed and how many frames arrive.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TimingConfig {
    /// Standard deviation of the IMU's constant delay `τ` against the load cells and encoders,
    /// s (positive: the IMU reports an older instant).
    pub imu_skew_sigma_s: f64,
    /// Standard deviation of each frame's sampling instant about its place on the grid, s.
    pub jitter_sigma_s: f64,
    /// Probability that a frame is lost on the way to the host (0 to 0.5).
    pub frame_loss: f64,
}

/// All sensors. `Default` is the `realistic` preset.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorConfig {
    /// Leg-length encoders.
    pub leg_length: LegLengthSensorConfig,
    /// Load cells.
    pub load_cell: LoadCellConfig,
    /// Gyroscope.
    pub gyro: GyroConfig,
    /// Accelerometer.
    pub accelerometer: AccelerometerConfig,
    /// The IMU's axes.
    pub imu: ImuAxesConfig,
    /// Timing of the channels and lost frames.
    pub timing: TimingConfig,
}

/// Named sensor quality levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoisePreset {
    /// Ideal sensors: no noise, no bias, no quantization.
    None,
    /// Industrial grade, the default rig description's figures: load cells 0.02 % of a
    /// 20 kN range (4 N), 1 µm encoders, tactical-grade MEMS IMU (see the module docs).
    Realistic,
    /// About ten times worse than `realistic` on every figure.
    Harsh,
}

impl NoisePreset {
    /// Every preset, in order of increasing noise.
    pub const ALL: [NoisePreset; 3] = [
        NoisePreset::None,
        NoisePreset::Realistic,
        NoisePreset::Harsh,
    ];

    /// The factor on every datasheet figure: 0, 1 or 10.
    pub fn scale(self) -> f64 {
        match self {
            NoisePreset::None => 0.0,
            NoisePreset::Realistic => 1.0,
            NoisePreset::Harsh => 10.0,
        }
    }

    /// The preset's name as used in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            NoisePreset::None => "none",
            NoisePreset::Realistic => "realistic",
            NoisePreset::Harsh => "harsh",
        }
    }
}

impl fmt::Display for NoisePreset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The name was not one of `none`, `realistic`, `harsh`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown noise preset `{0}` (expected none, realistic or harsh)")]
pub struct UnknownPreset(pub String);

impl FromStr for NoisePreset {
    type Err = UnknownPreset;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        NoisePreset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| UnknownPreset(s.to_owned()))
    }
}

impl Default for LegLengthSensorConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).leg_length
    }
}
impl Default for LoadCellConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).load_cell
    }
}
impl Default for GyroConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).gyro
    }
}
impl Default for AccelerometerConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).accelerometer
    }
}
impl Default for ImuAxesConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).imu
    }
}
impl Default for TimingConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic).timing
    }
}
impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic)
    }
}

impl SensorConfig {
    /// The figures of a preset (IMU at the P origin, axes along P's).
    ///
    /// `realistic`: encoders 1 µm resolution, 0.5 µm noise; load cells 4 N noise (0.02 % of
    /// 20 kN), 4 N zero offset, 0.5 N resolution, 5·10⁻⁴ gain, 2·10⁻³ transverse sensitivity,
    /// 0.4 N/min drift; gyro 5·10⁻⁵ rad/s/√Hz (0.17 °/√h), 2·10⁻⁵ rad/s (4 °/h) bias, 5·10⁻⁴
    /// scale; accelerometer 4·10⁻⁴ m/s²/√Hz (40 µg/√Hz), 10⁻³ m/s² (100 µg) bias, 5·10⁻⁴ scale,
    /// 1 mm position; 0.05° misalignment; 100 µs IMU skew, 10 µs jitter, 0.1 % frame loss.
    /// `harsh` multiplies every figure by ten (the frame loss capped at 0.5).
    pub fn preset(preset: NoisePreset) -> Self {
        let k = preset.scale();
        Self {
            leg_length: LegLengthSensorConfig {
                noise_sigma_m: k * 0.5e-6,
                resolution_m: k * 1e-6,
            },
            load_cell: LoadCellConfig {
                noise_sigma_n: k * 4.0,
                bias_sigma_n: k * 4.0,
                resolution_n: k * 0.5,
                gain_sigma: k * 5e-4,
                transverse_sigma: k * 2e-3,
                drift_sigma_n_s: k * 0.4 / 60.0,
            },
            gyro: GyroConfig {
                noise_density_rad_s_sqrt_hz: k * 5e-5,
                bias_sigma_rad_s: k * 2e-5,
                scale_sigma: k * 5e-4,
            },
            accelerometer: AccelerometerConfig {
                noise_density_m_s2_sqrt_hz: k * 4e-4,
                bias_sigma_m_s2: k * 1e-3,
                scale_sigma: k * 5e-4,
                mount_m: [0.0; 3],
                mount_sigma_m: k * 1e-3,
            },
            imu: ImuAxesConfig {
                orientation_deg: [0.0; 3],
                misalignment_sigma_deg: k * 0.05,
            },
            timing: TimingConfig {
                imu_skew_sigma_s: k * 1e-4,
                jitter_sigma_s: k * 1e-5,
                frame_loss: (k * 1e-3).min(0.5),
            },
        }
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), SimError> {
        let l = &self.leg_length;
        check_non_negative("sensors.leg_length.noise_sigma_m", l.noise_sigma_m)?;
        check_non_negative("sensors.leg_length.resolution_m", l.resolution_m)?;
        let c = &self.load_cell;
        check_non_negative("sensors.load_cell.noise_sigma_n", c.noise_sigma_n)?;
        check_non_negative("sensors.load_cell.bias_sigma_n", c.bias_sigma_n)?;
        check_non_negative("sensors.load_cell.resolution_n", c.resolution_n)?;
        check_non_negative("sensors.load_cell.gain_sigma", c.gain_sigma)?;
        check_non_negative("sensors.load_cell.transverse_sigma", c.transverse_sigma)?;
        check_non_negative("sensors.load_cell.drift_sigma_n_s", c.drift_sigma_n_s)?;
        let g = &self.gyro;
        check_non_negative(
            "sensors.gyro.noise_density_rad_s_sqrt_hz",
            g.noise_density_rad_s_sqrt_hz,
        )?;
        check_non_negative("sensors.gyro.bias_sigma_rad_s", g.bias_sigma_rad_s)?;
        check_non_negative("sensors.gyro.scale_sigma", g.scale_sigma)?;
        let a = &self.accelerometer;
        check_non_negative(
            "sensors.accelerometer.noise_density_m_s2_sqrt_hz",
            a.noise_density_m_s2_sqrt_hz,
        )?;
        check_non_negative("sensors.accelerometer.bias_sigma_m_s2", a.bias_sigma_m_s2)?;
        check_non_negative("sensors.accelerometer.scale_sigma", a.scale_sigma)?;
        for v in a.mount_m {
            check_finite("sensors.accelerometer.mount_m", v)?;
        }
        check_non_negative("sensors.accelerometer.mount_sigma_m", a.mount_sigma_m)?;
        for v in self.imu.orientation_deg {
            check_finite("sensors.imu.orientation_deg", v)?;
        }
        check_non_negative(
            "sensors.imu.misalignment_sigma_deg",
            self.imu.misalignment_sigma_deg,
        )?;
        let t = &self.timing;
        check_non_negative("sensors.timing.imu_skew_sigma_s", t.imu_skew_sigma_s)?;
        check_non_negative("sensors.timing.jitter_sigma_s", t.jitter_sigma_s)?;
        check_non_negative("sensors.timing.frame_loss", t.frame_loss)?;
        if t.frame_loss > 0.5 {
            return Err(SimError::InvalidConfig {
                field: "sensors.timing.frame_loss",
                value: t.frame_loss,
                reason: "must be at most 0.5",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preset_names_round_trip_and_harsh_is_ten_times_realistic() {
        for p in NoisePreset::ALL {
            assert_eq!(p.name().parse::<NoisePreset>(), Ok(p));
        }
        assert!("loud".parse::<NoisePreset>().is_err());
        let r = SensorConfig::preset(NoisePreset::Realistic);
        let h = SensorConfig::preset(NoisePreset::Harsh);
        assert_eq!(h.load_cell.noise_sigma_n, 10.0 * r.load_cell.noise_sigma_n);
        assert_eq!(
            h.gyro.noise_density_rad_s_sqrt_hz,
            10.0 * r.gyro.noise_density_rad_s_sqrt_hz
        );
        assert_eq!(h.timing.frame_loss, 10.0 * r.timing.frame_loss);
        // 0.02 % of a 20 kN range; 0.4 N per minute.
        assert!((r.load_cell.noise_sigma_n - 2e-4 * 20_000.0).abs() < 1e-12);
        assert!((60.0 * r.load_cell.drift_sigma_n_s - 0.4).abs() < 1e-12);
        let n = SensorConfig::preset(NoisePreset::None);
        n.validate().unwrap();
        assert_eq!(n.load_cell.noise_sigma_n, 0.0);
        assert_eq!(
            n.timing,
            TimingConfig {
                imu_skew_sigma_s: 0.0,
                jitter_sigma_s: 0.0,
                frame_loss: 0.0
            }
        );
    }

    #[test]
    fn bad_figures_name_their_field() {
        let mut c = SensorConfig::default();
        c.timing.frame_loss = 0.7;
        assert!(matches!(
            c.validate(),
            Err(SimError::InvalidConfig {
                field: "sensors.timing.frame_loss",
                ..
            })
        ));
        let mut c = SensorConfig::default();
        c.imu.orientation_deg[1] = f64::INFINITY;
        assert!(matches!(
            c.validate(),
            Err(SimError::InvalidConfig {
                field: "sensors.imu.orientation_deg",
                ..
            })
        ));
        let mut c = SensorConfig::default();
        c.load_cell.gain_sigma = -1e-3;
        assert!(c.validate().is_err());
    }
}
