//! Sensor models: leg-length encoders, load cells, gyroscope, accelerometer.
//!
//! Each channel is `quantize(truth + bias + noise)`:
//! - **bias**: a constant per channel, drawn once when the simulator is built from
//!   `N(0, bias_sigma)` (a turn-on bias / zero offset that calibration left behind);
//! - **noise**: white, drawn every sample. For the IMU it is given as a noise density `N_d`
//!   (unit/√Hz) and the per-sample standard deviation is `σ = N_d √f_s` at sample rate `f_s`
//!   (the usual discrete-time equivalent of continuous white noise, e.g. Kalibr's IMU model);
//! - **quantization** to `resolution` (rounding; 0 = none), after bias and noise.
//!
//! All draws come from one seeded generator in a fixed order, so a seed reproduces a run exactly.

use core::fmt;
use core::str::FromStr;

use control::io::SensorFrame;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
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
}

/// Three-axis gyroscope on the plate, axes along P.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GyroConfig {
    /// Rate noise density (angle random walk), rad/s/√Hz.
    pub noise_density_rad_s_sqrt_hz: f64,
    /// Standard deviation of each axis' constant bias, rad/s.
    pub bias_sigma_rad_s: f64,
}

/// Three-axis accelerometer on the plate, axes along P, reading specific force `a − g`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AccelerometerConfig {
    /// Noise density (velocity random walk), m/s²/√Hz.
    pub noise_density_m_s2_sqrt_hz: f64,
    /// Standard deviation of each axis' constant bias, m/s².
    pub bias_sigma_m_s2: f64,
    /// Mounting point in P, m (default: the P origin).
    pub mount_m: [f64; 3],
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
}

/// Named sensor quality levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoisePreset {
    /// Ideal sensors: no noise, no bias, no quantization.
    None,
    /// Industrial grade: load cells 0.02 % of a 20 kN range (4 N), 1 µm encoders,
    /// tactical-grade MEMS IMU.
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
impl Default for SensorConfig {
    fn default() -> Self {
        SensorConfig::preset(NoisePreset::Realistic)
    }
}

impl SensorConfig {
    /// The figures of a preset (accelerometer at the P origin).
    ///
    /// `realistic`: encoders 1 µm resolution, 0.5 µm noise; load cells 4 N noise (0.02 % of
    /// 20 kN), 4 N zero offset, 0.5 N resolution; gyro 5·10⁻⁵ rad/s/√Hz (0.17 °/√h) and
    /// 2·10⁻⁵ rad/s (4 °/h) bias; accelerometer 4·10⁻⁴ m/s²/√Hz (40 µg/√Hz) and 10⁻³ m/s²
    /// (100 µg) bias. `harsh` multiplies every figure by ten.
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
            },
            gyro: GyroConfig {
                noise_density_rad_s_sqrt_hz: k * 5e-5,
                bias_sigma_rad_s: k * 2e-5,
            },
            accelerometer: AccelerometerConfig {
                noise_density_m_s2_sqrt_hz: k * 4e-4,
                bias_sigma_m_s2: k * 1e-3,
                mount_m: [0.0; 3],
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
        let g = &self.gyro;
        check_non_negative(
            "sensors.gyro.noise_density_rad_s_sqrt_hz",
            g.noise_density_rad_s_sqrt_hz,
        )?;
        check_non_negative("sensors.gyro.bias_sigma_rad_s", g.bias_sigma_rad_s)?;
        let a = &self.accelerometer;
        check_non_negative(
            "sensors.accelerometer.noise_density_m_s2_sqrt_hz",
            a.noise_density_m_s2_sqrt_hz,
        )?;
        check_non_negative("sensors.accelerometer.bias_sigma_m_s2", a.bias_sigma_m_s2)?;
        for v in a.mount_m {
            check_finite("sensors.accelerometer.mount_m", v)?;
        }
        Ok(())
    }
}

/// The sensors' random state: one seeded generator and the biases drawn from it.
#[derive(Clone, Debug)]
pub(crate) struct SensorModel {
    config: SensorConfig,
    rng: StdRng,
    load_cell_bias_n: [f64; 6],
    gyro_bias_rad_s: [f64; 3],
    accel_bias_m_s2: [f64; 3],
    gyro_sigma_rad_s: f64,
    accel_sigma_m_s2: f64,
}

fn quantize(value: f64, step: f64) -> f64 {
    if step > 0.0 {
        (value / step).round() * step
    } else {
        value
    }
}

impl SensorModel {
    pub fn new(config: SensorConfig, sample_rate_hz: f64, seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut normal = |sigma: f64| sigma * rng.sample::<f64, _>(StandardNormal);
        let load_cell_bias_n = core::array::from_fn(|_| normal(config.load_cell.bias_sigma_n));
        let gyro_bias_rad_s = core::array::from_fn(|_| normal(config.gyro.bias_sigma_rad_s));
        let accel_bias_m_s2 =
            core::array::from_fn(|_| normal(config.accelerometer.bias_sigma_m_s2));
        let root_rate = sample_rate_hz.sqrt();
        Self {
            config,
            rng,
            load_cell_bias_n,
            gyro_bias_rad_s,
            accel_bias_m_s2,
            gyro_sigma_rad_s: config.gyro.noise_density_rad_s_sqrt_hz * root_rate,
            accel_sigma_m_s2: config.accelerometer.noise_density_m_s2_sqrt_hz * root_rate,
        }
    }

    /// Per-sample standard deviations of the gyro and accelerometer noise.
    #[cfg(test)]
    pub fn imu_sigmas(&self) -> (f64, f64) {
        (self.gyro_sigma_rad_s, self.accel_sigma_m_s2)
    }

    /// The channels a real rig would report for the true values in `clean`.
    pub fn measure(&mut self, clean: &SensorFrame) -> SensorFrame {
        let c = self.config;
        let rng = &mut self.rng;
        let mut normal = |sigma: f64| {
            if sigma > 0.0 {
                sigma * rng.sample::<f64, _>(StandardNormal)
            } else {
                0.0
            }
        };
        let mut out = *clean;
        for v in out.leg_lengths_m.iter_mut() {
            *v = quantize(
                *v + normal(c.leg_length.noise_sigma_m),
                c.leg_length.resolution_m,
            );
        }
        for (v, b) in out.leg_forces_n.iter_mut().zip(self.load_cell_bias_n) {
            *v = quantize(
                *v + b + normal(c.load_cell.noise_sigma_n),
                c.load_cell.resolution_n,
            );
        }
        for (v, b) in out.gyro_rad_s.iter_mut().zip(self.gyro_bias_rad_s) {
            *v += b + normal(self.gyro_sigma_rad_s);
        }
        for (v, b) in out.accel_m_s2.iter_mut().zip(self.accel_bias_m_s2) {
            *v += b + normal(self.accel_sigma_m_s2);
        }
        out
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
        // 0.02 % of a 20 kN range.
        assert!((r.load_cell.noise_sigma_n - 2e-4 * 20_000.0).abs() < 1e-12);
        let n = SensorConfig::preset(NoisePreset::None);
        n.validate().unwrap();
        assert_eq!(n.load_cell.noise_sigma_n, 0.0);
    }

    #[test]
    fn none_preset_passes_truth_through_exactly() {
        let mut m = SensorModel::new(SensorConfig::preset(NoisePreset::None), 1000.0, 7);
        let clean = SensorFrame {
            leg_lengths_m: [1.234_567_891; 6],
            leg_forces_n: [3210.987; 6],
            gyro_rad_s: [0.1, -0.2, 0.3],
            accel_m_s2: [0.5, 0.1, 9.8],
            ..Default::default()
        };
        assert_eq!(m.measure(&clean), clean);
    }

    fn stats(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    #[test]
    fn noise_statistics_match_the_config() {
        for preset in [NoisePreset::Realistic, NoisePreset::Harsh] {
            let cfg = SensorConfig::preset(preset);
            let mut m = SensorModel::new(cfg, 1000.0, 42);
            let (gyro_sigma, accel_sigma) = m.imu_sigmas();
            assert!(
                (gyro_sigma - cfg.gyro.noise_density_rad_s_sqrt_hz * 1000f64.sqrt()).abs() < 1e-15
            );
            let clean = SensorFrame {
                leg_forces_n: [5000.0; 6],
                accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
                ..Default::default()
            };
            let n = 20_000;
            let mut force = Vec::with_capacity(n);
            let mut gyro = Vec::with_capacity(n);
            let mut accel = Vec::with_capacity(n);
            for _ in 0..n {
                let f = m.measure(&clean);
                force.push(f.leg_forces_n[2] - 5000.0);
                gyro.push(f.gyro_rad_s[1]);
                accel.push(f.accel_m_s2[2] - stewart_types::STANDARD_GRAVITY_M_S2);
            }
            // Sample standard deviation within 3 % (its own standard error is 0.5 % here);
            // quantization adds step²/12 to the variance.
            let q = cfg.load_cell.resolution_n;
            let want_force = (cfg.load_cell.noise_sigma_n.powi(2) + q * q / 12.0).sqrt();
            for ((_, s), want) in [
                (stats(&force), want_force),
                (stats(&gyro), gyro_sigma),
                (stats(&accel), accel_sigma),
            ] {
                assert!((s / want - 1.0).abs() < 0.03, "{preset}: {s} vs {want}");
            }
            // The mean is the channel's constant bias: the same over both halves of the run,
            // within the noise of the means (5 standard errors).
            for (xs, sigma) in [
                (&force, want_force),
                (&gyro, gyro_sigma),
                (&accel, accel_sigma),
            ] {
                let (a, _) = stats(&xs[..n / 2]);
                let (b, _) = stats(&xs[n / 2..]);
                assert!((a - b).abs() < 5.0 * sigma * (4.0 / n as f64).sqrt());
            }
        }
    }

    #[test]
    fn biases_spread_like_their_sigma() {
        // Across many seeds, a load cell's bias has the configured standard deviation.
        let cfg = SensorConfig::preset(NoisePreset::Realistic);
        let biases: Vec<f64> = (0..4000)
            .flat_map(|seed| SensorModel::new(cfg, 1000.0, seed).load_cell_bias_n)
            .collect();
        let (mean, s) = stats(&biases);
        assert!(mean.abs() < 5.0 * cfg.load_cell.bias_sigma_n / (biases.len() as f64).sqrt());
        assert!((s / cfg.load_cell.bias_sigma_n - 1.0).abs() < 0.03);
    }

    #[test]
    fn quantization_rounds_to_the_resolution() {
        let cfg = SensorConfig {
            leg_length: LegLengthSensorConfig {
                noise_sigma_m: 0.0,
                resolution_m: 1e-6,
            },
            ..SensorConfig::preset(NoisePreset::None)
        };
        let mut m = SensorModel::new(cfg, 1000.0, 1);
        let clean = SensorFrame {
            leg_lengths_m: [1.000_000_7; 6],
            ..Default::default()
        };
        let out = m.measure(&clean);
        assert!((out.leg_lengths_m[0] - 1.000_001).abs() < 1e-12);
    }
}
