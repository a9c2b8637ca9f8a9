//! The sensors' errors: what a real rig reports for the simulator's true channels.
//!
//! Each error source draws from its own stream ([`crate::streams`]) of the world's seed, and is
//! sized by one figure of [`SensorConfig`] (zero: the source is off; `Scenario::sim_config`
//! zeroes the figures of the sources `[world.imperfections]` switches off). Notation: `x` a
//! true channel value, `N(0, σ²)` a normal draw, `T` the sample period, `t_k = k T`.
//!
//! Drawn once when the simulator is built (the rig as built):
//! - **zero offset** `b ~ N(0, bias_sigma_n²)` and **zero drift** rate `ṙ ~ N(0, drift²)` per
//!   load cell (`load_cell_offset`; default 4 N and 0.4 N/min / 60: creep and temperature,
//!   0.02 % of range per 10 minutes). The drift runs linearly from the simulator's start.
//! - **gain** `g ~ N(0, gain_sigma²)` per load cell (`load_cell_scale`; default 5·10⁻⁴: a
//!   C3-class cell's 0.02 % plus its mounting).
//! - **transverse sensitivities** `s₁, s₂ ~ N(0, transverse_sigma²)` per load cell
//!   (`load_cell_crosstalk`; default 2·10⁻³, a column or S-beam cell's side-load rejection),
//!   acting along the leg's transverse basis ([`crate::cell_loads::transverse_basis`]).
//! - **gyro bias** `b_g ~ N(0, bias_sigma_rad_s²)` per axis (`noise`; default 4 °/h) and
//!   **accelerometer bias** `b_a ~ N(0, bias_sigma_m_s2²)` per axis (`accel_bias`; 100 µg),
//!   both in the IMU's axes.
//! - **IMU axes** `R = exp([θ]×) R_d` (IMU → P), `R_d` the described orientation, `θ` a small
//!   rotation about P's axes with each component `~ N(0, misalignment²)`, and **scale errors**
//!   `k_g, k_a ~ N(0, scale_sigma²)` per axis of the gyro and the accelerometer
//!   (`imu_misalignment`; default 0.05° after aligning the case to a datum face, 500 ppm).
//! - **accelerometer position** `r_a = described + N(0, mount_sigma_m²)` per coordinate
//!   (`imu_lever_arm`; default 1 mm, the sensing point inside the case): the simulator evaluates
//!   the specific force there ([`SensorModel::mount_m`]).
//! - **IMU skew** `τ ~ N(0, imu_skew_sigma_s²)`, clipped to `±T` (`time_skew`; default 100 µs,
//!   an IMU behind its own decimation filter, not synchronised to the load cells' ADC).
//!
//! Drawn every frame `k`:
//! - **jitter** `δ_k ~ N(0, jitter_sigma_s²)`, clipped to `±T/2` so that time stamps keep
//!   increasing (`timestamp_jitter`; default 10 µs).
//! - **loss** with probability `frame_loss` (`frame_loss`; default 0.1 %): the simulator runs
//!   one more period on the same command and the host never sees the frame
//!   ([`SensorModel::frame_lost`]).
//! - **white noise** `n ~ N(0, σ²)` per channel (`noise`): encoders and load cells their
//!   `noise_sigma`, the IMU `σ = N_d √(1/T)` from its noise density `N_d` (the usual
//!   discrete-time equivalent of continuous white noise).
//!
//! Timing. Frame `k`'s channels describe `t_k + δ_k`, the IMU's `t_k + δ_k − τ`. With the clean
//! values `x_k` and `x_{k−1}` of this and the previous frame, each channel is
//! `x_k + Δ (x_k − x_{k−1}) / T` with `Δ = δ_k` (encoders, load cells) or `Δ = δ_k − τ` (gyro,
//! accelerometer): linear interpolation for `−T ≤ Δ ≤ 0` and extrapolation from the last two
//! values for `Δ > 0`. Its error against the true `x(t_k + Δ)` is `½ Δ (Δ + T) ẍ`: second order
//! in the small times, against the shift's own first-order `Δ ẋ` (a share `(|Δ| + T) ω / 2` of
//! it for a motion at `ω`: 0.6 % at 1.8 Hz and 1 kHz). The frame's `time_s` is `t_k + δ_k`; its
//! `sequence` stays `k`. The first frame after a state change has no previous one and is not
//! shifted (its time stamp still is). The transverse loads enter unshifted (their effect is
//! itself small).
//!
//! Channels, in order:
//! - encoders: `quantize(x + n)`;
//! - load cell `i`: `quantize((1 + gᵢ) F + s₁ T₁ + s₂ T₂ + bᵢ + ṙᵢ t_k + n)`, `F` the axial
//!   force, `T₁, T₂` the transverse force through the cell ([`CellLoads`]);
//! - gyro: `(1 + k_g) ⊙ (Rᵀ ω) + b_g + n`, the accelerometer alike with `f` at `r_a`: the IMU
//!   reports in its own axes, and the measurement turns them into P by the described `R_d`.
//!
//! Quantisation rounds to the resolution (0: none). With every figure zero the frame is the
//! clean one bit for bit.

use control::io::SensorFrame;
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::rngs::StdRng;
use rand::Rng;
use rig_description::sources::ErrorSource;

use crate::cell_loads::CellLoads;
use crate::sensors::SensorConfig;
use crate::streams::{normal, stream};

/// The sensors' random state: the errors drawn for the rig as built, and the per-frame streams.
#[derive(Clone, Debug)]
pub(crate) struct SensorModel {
    config: SensorConfig,
    period_s: f64,
    /// White noise of every channel.
    noise: StdRng,
    /// Each frame's sampling-instant offset.
    jitter: StdRng,
    /// Each frame's loss.
    loss: StdRng,
    gyro_sigma_rad_s: f64,
    accel_sigma_m_s2: f64,
    gyro_bias_rad_s: [f64; 3],
    accel_bias_m_s2: [f64; 3],
    load_cell_bias_n: [f64; 6],
    load_cell_drift_n_s: [f64; 6],
    load_cell_gain: [f64; 6],
    load_cell_transverse: [[f64; 2]; 6],
    /// `Rᵀ`, P → IMU axes; `None` when the IMU's axes are P's exactly.
    to_imu: Option<Rotation3<f64>>,
    gyro_scale: [f64; 3],
    accel_scale: [f64; 3],
    /// The accelerometer's true position in P.
    mount_m: Vector3<f64>,
    /// The IMU's delay τ, s.
    skew_s: f64,
    /// The previous clean frame, while the motion is continuous.
    previous: Option<SensorFrame>,
    lost: bool,
}

/// The simulated IMU as built ([`SensorModel::imu_as_built`]): the gyro's and the
/// accelerometer's readings in P are `gyro_matrix · ω` and `accel_matrix · f` (plus bias and
/// noise), the accelerometer sits at `accelerometer_position_m` in P, and both read `delay_s`
/// late.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuAsBuilt {
    /// G.
    pub gyro_matrix: Matrix3<f64>,
    /// A.
    pub accel_matrix: Matrix3<f64>,
    /// r, m.
    pub accelerometer_position_m: Vector3<f64>,
    /// τ, s.
    pub delay_s: f64,
}

fn quantize(value: f64, step: f64) -> f64 {
    if step > 0.0 {
        (value / step).round() * step
    } else {
        value
    }
}

/// The rotation from the IMU's axes into P: `exp([θ]×) R_d`.
fn imu_to_p(orientation_deg: [f64; 3], theta_rad: Vector3<f64>) -> Option<Rotation3<f64>> {
    if orientation_deg == [0.0; 3] && theta_rad == Vector3::zeros() {
        return None;
    }
    let described = rig_description::config::ImuMounting {
        orientation_deg,
        ..Default::default()
    }
    .rotation();
    Some(Rotation3::new(theta_rad) * described)
}

impl SensorModel {
    /// Ground truth: each load cell's gain error g_i (it reads (1 + g_i) times its force).
    pub fn load_cell_gains(&self) -> [f64; 6] {
        self.load_cell_gain
    }

    /// The rig's sensors as built from `config` at `sample_rate_hz`, every draw from `seed`.
    pub fn new(config: SensorConfig, sample_rate_hz: f64, seed: u64) -> Self {
        let period_s = 1.0 / sample_rate_hz;
        let mut noise = stream(seed, ErrorSource::Noise);
        let gyro_bias_rad_s =
            core::array::from_fn(|_| normal(&mut noise, config.gyro.bias_sigma_rad_s));
        let mut rng = stream(seed, ErrorSource::AccelBias);
        let accel_bias_m_s2 =
            core::array::from_fn(|_| normal(&mut rng, config.accelerometer.bias_sigma_m_s2));
        let lc = &config.load_cell;
        let mut rng = stream(seed, ErrorSource::LoadCellOffset);
        let load_cell_bias_n = core::array::from_fn(|_| normal(&mut rng, lc.bias_sigma_n));
        let load_cell_drift_n_s = core::array::from_fn(|_| normal(&mut rng, lc.drift_sigma_n_s));
        let mut rng = stream(seed, ErrorSource::LoadCellScale);
        let load_cell_gain = core::array::from_fn(|_| normal(&mut rng, lc.gain_sigma));
        let mut rng = stream(seed, ErrorSource::LoadCellCrosstalk);
        let load_cell_transverse = core::array::from_fn(|_| {
            let s1 = normal(&mut rng, lc.transverse_sigma);
            [s1, normal(&mut rng, lc.transverse_sigma)]
        });
        let mut rng = stream(seed, ErrorSource::ImuMisalignment);
        let sigma_rad = config.imu.misalignment_sigma_deg.to_radians();
        let theta = Vector3::from_fn(|_, _| normal(&mut rng, sigma_rad));
        let gyro_scale = core::array::from_fn(|_| normal(&mut rng, config.gyro.scale_sigma));
        let accel_scale =
            core::array::from_fn(|_| normal(&mut rng, config.accelerometer.scale_sigma));
        let mut rng = stream(seed, ErrorSource::ImuLeverArm);
        let a = &config.accelerometer;
        let mount_m =
            Vector3::from(a.mount_m) + Vector3::from_fn(|_, _| normal(&mut rng, a.mount_sigma_m));
        let mut rng = stream(seed, ErrorSource::TimeSkew);
        let skew_s = normal(&mut rng, config.timing.imu_skew_sigma_s).clamp(-period_s, period_s);
        let root_rate = sample_rate_hz.sqrt();
        Self {
            config,
            period_s,
            noise,
            jitter: stream(seed, ErrorSource::TimestampJitter),
            loss: stream(seed, ErrorSource::FrameLoss),
            gyro_sigma_rad_s: config.gyro.noise_density_rad_s_sqrt_hz * root_rate,
            accel_sigma_m_s2: config.accelerometer.noise_density_m_s2_sqrt_hz * root_rate,
            gyro_bias_rad_s,
            accel_bias_m_s2,
            load_cell_bias_n,
            load_cell_drift_n_s,
            load_cell_gain,
            load_cell_transverse,
            to_imu: imu_to_p(config.imu.orientation_deg, theta).map(|r| r.inverse()),
            gyro_scale,
            accel_scale,
            mount_m,
            skew_s,
            previous: None,
            lost: false,
        }
    }

    /// The accelerometer's true position in P, m: the described one plus its draw.
    pub fn mount_m(&self) -> Vector3<f64> {
        self.mount_m
    }

    /// The IMU as built, in the IMU calibration's terms (`rig_description::calibration::imu`): ground
    /// truth for tests, never read by the estimator.
    pub fn imu_as_built(&self) -> ImuAsBuilt {
        let described = rig_description::config::ImuMounting {
            orientation_deg: self.config.imu.orientation_deg,
            ..Default::default()
        }
        .rotation();
        let to_imu = self.to_imu.map_or(Matrix3::identity(), |r| *r.matrix());
        // Readings in P after the described mounting: R_d · diag(1 + s) · (P → IMU axes).
        let reading = |scale: &[f64; 3]| {
            described.matrix()
                * Matrix3::from_diagonal(&Vector3::from(scale.map(|s| 1.0 + s)))
                * to_imu
        };
        ImuAsBuilt {
            gyro_matrix: reading(&self.gyro_scale),
            accel_matrix: reading(&self.accel_scale),
            accelerometer_position_m: self.mount_m,
            delay_s: self.skew_s,
        }
    }

    /// Whether the frame of the last [`Self::measure`] was lost on its way to the host.
    pub fn frame_lost(&self) -> bool {
        self.lost
    }

    /// The frame a real rig reports for the true channels `clean` (their `time_s` is `t_k`) and
    /// the transverse loads through the cells. `continuous`: `clean` follows the previous
    /// call's frame by one sample period of unbroken motion (false after a state change).
    pub fn measure(
        &mut self,
        clean: &SensorFrame,
        loads: &CellLoads,
        continuous: bool,
    ) -> SensorFrame {
        let half = 0.5 * self.period_s;
        let delta_s =
            normal(&mut self.jitter, self.config.timing.jitter_sigma_s).clamp(-half, half);
        let u: f64 = self.loss.random();
        self.lost = u < self.config.timing.frame_loss;
        let previous = self.previous.filter(|_| continuous);
        self.previous = Some(*clean);
        let mut out = match previous {
            Some(p) => shifted(
                clean,
                &p,
                delta_s / self.period_s,
                (delta_s - self.skew_s) / self.period_s,
            ),
            None => *clean,
        };
        out.time_s = clean.time_s + delta_s;
        self.add_errors(&mut out, loads, clean.time_s);
        out
    }

    /// Every constant and white error on the channels of `out`, `t_s` the time since start.
    fn add_errors(&mut self, out: &mut SensorFrame, loads: &CellLoads, t_s: f64) {
        let c = &self.config;
        let rng = &mut self.noise;
        for v in out.leg_lengths_m.iter_mut() {
            *v = quantize(
                *v + normal(rng, c.leg_length.noise_sigma_m),
                c.leg_length.resolution_m,
            );
        }
        for (i, v) in out.leg_forces_n.iter_mut().enumerate() {
            let [s1, s2] = self.load_cell_transverse[i];
            let [t1, t2] = loads.transverse_n[i];
            let reading = (1.0 + self.load_cell_gain[i]) * *v
                + s1 * t1
                + s2 * t2
                + self.load_cell_bias_n[i]
                + self.load_cell_drift_n_s[i] * t_s;
            *v = quantize(
                reading + normal(rng, c.load_cell.noise_sigma_n),
                c.load_cell.resolution_n,
            );
        }
        let to_imu = self.to_imu;
        let imu = |x: [f64; 3], scale: &[f64; 3], bias: &[f64; 3], sigma: f64, rng: &mut StdRng| {
            let axes = match &to_imu {
                Some(r) => r * Vector3::from(x),
                None => Vector3::from(x),
            };
            core::array::from_fn(|i| (1.0 + scale[i]) * axes[i] + bias[i] + normal(rng, sigma))
        };
        out.gyro_rad_s = imu(
            out.gyro_rad_s,
            &self.gyro_scale,
            &self.gyro_bias_rad_s,
            self.gyro_sigma_rad_s,
            &mut *rng,
        );
        out.accel_m_s2 = imu(
            out.accel_m_s2,
            &self.accel_scale,
            &self.accel_bias_m_s2,
            self.accel_sigma_m_s2,
            rng,
        );
    }
}

/// `now` moved by `a` sample periods (encoders, load cells) and the IMU by `b`, to first order
/// from the previous frame: `x + a (x − x_prev)`.
fn shifted(now: &SensorFrame, prev: &SensorFrame, a: f64, b: f64) -> SensorFrame {
    let shift = |x: f64, p: f64, by: f64| x + by * (x - p);
    let mut out = *now;
    for (x, p) in out.leg_lengths_m.iter_mut().zip(prev.leg_lengths_m) {
        *x = shift(*x, p, a);
    }
    for (x, p) in out.leg_forces_n.iter_mut().zip(prev.leg_forces_n) {
        *x = shift(*x, p, a);
    }
    for (x, p) in out.gyro_rad_s.iter_mut().zip(prev.gyro_rad_s) {
        *x = shift(*x, p, b);
    }
    for (x, p) in out.accel_m_s2.iter_mut().zip(prev.accel_m_s2) {
        *x = shift(*x, p, b);
    }
    out
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod timing_tests;
