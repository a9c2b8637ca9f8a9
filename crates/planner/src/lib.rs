//! Excitation design: before anything moves, predict how well a motion will measure the
//! payload, check it against every limit of the rig, and search for the motion that measures
//! best within them (`stewart plan`).
//!
//! - [`motion`]: a trajectory as the rig will see it (signals, regressor, leg forces).
//! - [`predict`]: the covariance the sensors' white noise gives the estimate on it.
//! - [`search`]: the family of periodic multi-sines searched and the search itself.
//!
//! **Criterion.** Each reported quantity q (mass, the three coordinates of the centre of mass,
//! the six entries of J_C) has a target one sigma t_q (`[plan]`: a fraction of the prior mass,
//! a length, a fraction of the prior's smallest principal moment). The plan minimises
//! `max_q σ_q / t_q`, the predicted sigma of the payload (loaded − tare: both runs' noise) of
//! the worst quantity relative to its target. Only the sensors' noise is predicted: the
//! systematic sources of the error budget depend on calibrations and are not a property of
//! the motion alone.
//!
//! **Prior.** The prediction needs the bodies (the noise of the accelerometer and gyro reaches
//! the equations through them, and the leg forces they take bound the motion): `[plan.payload]`
//! and `[plan.fixture]`, what the rig's owner knows before measuring — never a simulated
//! world's truth.

#![warn(missing_docs)]

pub mod motion;
pub mod predict;
pub mod search;

use control::trajectory::{FeasibilityLimits, Trajectory};
use estimator::{LegModel, ParameterVector};
use kinematics::Geometry;
use nalgebra::{SMatrix, Vector3};

use measure::report::Quantities;
pub use predict::{ChannelNoise, Conditioning};
use rig_description::config::{Config, ParamCount};
use rig_description::load::{ConfigError, LoadedConfig};
pub use search::{design, Plan, PlanError};

/// What a plan is computed from: the rig description's geometry, limits, datasheet and
/// estimator settings, and the prior.
#[derive(Clone, Debug)]
pub struct Planner {
    /// The platform design.
    pub geometry: Geometry,
    /// The legs as described (their mass and friction load the actuators whether or not the
    /// estimator compensates them).
    pub legs: LegModel,
    /// The estimator's conditioning and weights.
    pub conditioning: Conditioning,
    /// The datasheet's white noise per sample.
    pub noise: ChannelNoise,
    /// Stroke, leg speed and conditioning limits (`[excitation]`).
    pub feasibility: FeasibilityLimits,
    /// Largest |leg force| the plan may ask, N.
    pub max_force_n: f64,
    /// Largest acceleration of the payload's centre of mass, m/s².
    pub max_acceleration_m_s2: f64,
    /// Highest excitation frequency allowed, Hz.
    pub max_frequency_hz: f64,
    /// The payload's prior parameters.
    pub payload: ParameterVector,
    /// The fixture's (and plate's) prior parameters.
    pub fixture: ParameterVector,
    /// Target one sigma of each quantity ([`Quantities::NAMES`] order).
    pub targets: [f64; 10],
}

/// The predicted one sigma of the payload's quantities from the sensors' noise.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// One sigma of each quantity.
    pub sigma: Quantities,
    /// σ_q / t_q ([`Quantities::NAMES`] order).
    pub ratios: [f64; 10],
}

impl Prediction {
    /// The criterion: the largest ratio, and its quantity's index.
    pub fn worst(&self) -> (usize, f64) {
        self.ratios
            .iter()
            .copied()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (i, r)| {
                if r > best.1 {
                    (i, r)
                } else {
                    best
                }
            })
    }
}

/// The limit that binds a motion, or that a motion breaks.
#[derive(Clone, Debug, PartialEq)]
pub enum Binding {
    /// Stroke, leg speed or conditioning ([`Trajectory::check_feasibility`]), as it says.
    Kinematic(String),
    /// A leg's force, N, at time s.
    Force {
        /// |f| reached, N.
        force_n: f64,
        /// When, s.
        time_s: f64,
    },
    /// The payload's centre-of-mass acceleration, m/s², at time s.
    Acceleration {
        /// |a| reached, m/s².
        acceleration_m_s2: f64,
        /// When, s.
        time_s: f64,
    },
    /// The pose is singular somewhere.
    Singular,
    /// Nothing: the motion reached the search's largest rotation peak, rad.
    SearchLimit {
        /// That peak, rad.
        rotation_rad: f64,
    },
}

impl core::fmt::Display for Binding {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Kinematic(s) => write!(f, "{s}"),
            Self::Force { force_n, time_s } => {
                write!(f, "leg force {force_n:.0} N at {time_s:.2} s")
            }
            Self::Acceleration {
                acceleration_m_s2,
                time_s,
            } => write!(
                f,
                "payload acceleration {acceleration_m_s2:.2} m/s² at {time_s:.2} s"
            ),
            Self::Singular => write!(f, "a singular pose"),
            Self::SearchLimit { rotation_rad } => write!(
                f,
                "no limit: the search's largest rotation peak, {:.1}°",
                rotation_rad.to_degrees()
            ),
        }
    }
}

/// The extremes a motion reaches, each as a share of its limit (1 = at the limit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Usage {
    /// Largest |leg force| / limit.
    pub force: f64,
    /// Largest payload acceleration / limit.
    pub acceleration: f64,
    /// Largest leg speed / limit.
    pub leg_speed: f64,
    /// Largest use of the stroke less the margins, either end.
    pub stroke: f64,
}

/// One sigma of the accelerometer's vertical offset as a run measures it: its per-sample noise
/// `per_sample_m_s2` over √n, n the samples at rest before the excitation (the brake hold, the
/// settle ramp from the resting pose, about `control.settle_ramp_s` long, and the settle hold;
/// [`estimator::AccelerometerOffset`]). 0 without a known gravity, against which alone the
/// offset is measured.
fn accel_offset_sigma(config: &Config, per_sample_m_s2: f64) -> f64 {
    if config.estimator.local_gravity_m_s2.is_none_or(|g| g <= 0.0) {
        return 0.0;
    }
    let rest_s = config.run.brake_hold_s + config.control.settle_ramp_s + config.run.settle_s;
    per_sample_m_s2 / (rest_s * config.sensors.sample_rate_hz).max(1.0).sqrt()
}

impl Planner {
    /// The planner of a loaded rig description. Errors: a geometry that cannot be built, or
    /// `estimator.params = 6` (the plan predicts the ten-parameter fit).
    pub fn new(loaded: &LoadedConfig) -> Result<Self, ConfigError> {
        let config = &loaded.config;
        if config.estimator.params != ParamCount::Ten {
            return Err(ConfigError::single(loaded.issue(
                "estimator.params",
                "the plan predicts the ten-parameter fit: use params = 10 (or --params 10)",
            )));
        }
        let geometry = measure::setup::geometry(loaded)?;
        Ok(Self::of(config, geometry))
    }

    /// The planner of `config` on `geometry`. The conditioning, weights and IMU noise are the
    /// estimator's own settings ([`measure::setup::estimator_config`]).
    pub fn of(config: &Config, geometry: Geometry) -> Self {
        let plan = &config.plan;
        let payload = plan.payload.parameters();
        let fixture = plan.fixture.parameters();
        let smallest = payload
            .principal()
            .map_or(f64::NAN, |p| p.moments_kg_m2.min());
        let mut targets = [plan.target_mass_fraction * plan.payload.mass_kg; 10];
        for t in &mut targets[1..4] {
            *t = plan.target_com_m;
        }
        for t in &mut targets[4..] {
            *t = plan.target_inertia_fraction * smallest;
        }
        let estimator = measure::setup::estimator_config(
            config,
            &geometry,
            measure::setup::Measurement::Loaded,
            f64::NEG_INFINITY,
            f64::INFINITY,
        );
        let cell = &config.sensors.load_cell;
        Self {
            geometry,
            legs: config.legs.model(),
            conditioning: Conditioning {
                period_s: estimator.sample_period_s,
                cutoff_hz: config.estimator.cutoff_hz,
                equation_sigma: estimator.equation_sigma,
                lever_m: estimator.accelerometer_position_m,
                block_samples: estimator.covariance_half_block_samples,
                load_cell_drift: estimator.load_cell_drift,
            },
            noise: ChannelNoise {
                load_cell_n: cell.noise_n.hypot(cell.resolution_n / 12f64.sqrt()),
                gyro_rad_s: estimator.gyro_noise_rad_s,
                accel_m_s2: estimator.accel_noise_m_s2,
                accel_offset_m_s2: accel_offset_sigma(config, estimator.accel_noise_m_s2),
            },
            // The limits the controller checks every trajectory against before it moves, the
            // leg speed's at the plan's share of it.
            feasibility: {
                let mut f = measure::setup::controller_config(config).feasibility;
                f.max_leg_speed_m_s *= plan.speed_share;
                f
            },
            max_force_n: plan.force_share * config.control.max_force_n,
            max_acceleration_m_s2: plan.max_acceleration_m_s2,
            max_frequency_hz: plan.max_frequency_share * config.estimator.cutoff_hz,
            payload: payload.to_vector(),
            fixture: fixture.to_vector(),
            targets,
        }
    }

    /// The payload's predicted sigma when the loaded run follows `loaded` and the tare run
    /// `tare` (the payload is loaded − tare, so both runs' noise counts); `None` when a run
    /// does not determine all ten parameters.
    pub fn predict(&self, loaded: &Trajectory, tare: &Trajectory) -> Option<Prediction> {
        self.predict_until(loaded, tare, f64::INFINITY)
    }

    /// The payload's predicted sigma after the loaded run's first `until_s` seconds of
    /// `loaded` (its samples at t ≤ `until_s`; the tare run whole): the information of
    /// [`Self::predict`] accumulated up to that time, through the same code. `None` when the
    /// samples so far do not determine all ten parameters.
    pub fn predict_until(
        &self,
        loaded: &Trajectory,
        tare: &Trajectory,
        until_s: f64,
    ) -> Option<Prediction> {
        let period = self.conditioning.period_s;
        let total = self.payload + self.fixture;
        let run = |points: &[motion::MotionPoint], theta: &ParameterVector| {
            predict::covariance(
                points,
                theta,
                &self.geometry,
                &self.conditioning,
                &self.noise,
            )
        };
        let mut loaded_points = motion::sample(loaded, period);
        loaded_points.retain(|p| p.time_s <= until_s);
        let tare_points = motion::sample(tare, period);
        let cov: SMatrix<f64, 10, 10> =
            run(&loaded_points, &total)? + run(&tare_points, &self.fixture)?;
        let derived = estimator::uncertainty::derive(&self.payload, &cov)?;
        let sigma = Quantities {
            mass: cov[(0, 0)].max(0.0).sqrt(),
            com: derived.com_sigma_m.into(),
            inertia_com: core::array::from_fn(|r| {
                core::array::from_fn(|c| derived.inertia_com_sigma_kg_m2[(r, c)])
            }),
        };
        let flat = sigma.flat();
        let ratios = core::array::from_fn(|i| flat[i] / self.targets[i]);
        Some(Prediction { sigma, ratios })
    }

    /// The degrees of freedom the loaded run's residual windows will give each reported
    /// quantity on `loaded` ([`Quantities::NAMES`] order; the estimator scales each sigma by
    /// its ν/(ν − 2), and below [`measure::quality::HEAVY_TAIL_DEGREES_OF_FREEDOM`] the table
    /// of a measurement flags it); `None` when the run does not determine θ.
    pub fn predicted_degrees_of_freedom(&self, loaded: &Trajectory) -> Option<[f64; 10]> {
        let points = motion::sample(loaded, self.conditioning.period_s);
        predict::degrees_of_freedom(&points, &(self.payload + self.fixture), &self.conditioning)
    }

    /// [`Self::predict_until`] at each of `times_s`: the predicted sigma's course over the
    /// excitation, with `None` where the samples so far do not yet determine θ.
    pub fn predicted_course(
        &self,
        loaded: &Trajectory,
        tare: &Trajectory,
        times_s: &[f64],
    ) -> Vec<(f64, Option<Prediction>)> {
        times_s
            .iter()
            .map(|&t| (t, self.predict_until(loaded, tare, t)))
            .collect()
    }

    /// Checks `trajectory` with the body `theta` on the plate (the payload's centre of mass
    /// at `payload_com_m`) against every limit along its whole path: stroke, leg speed,
    /// conditioning (at the limits' own step), leg force and payload acceleration (every
    /// `step_s`). The usage of each limit, or the first one broken.
    pub fn check(
        &self,
        trajectory: &Trajectory,
        theta: &ParameterVector,
        payload_com_m: &Vector3<f64>,
        step_s: f64,
    ) -> Result<Usage, Binding> {
        let limits = FeasibilityLimits {
            step_s: step_s.max(self.feasibility.step_s),
            ..self.feasibility
        };
        let report = trajectory
            .check_feasibility(&self.geometry, &limits)
            .map_err(|e| Binding::Kinematic(e.to_string()))?;
        let stroke = self.geometry.stroke();
        let (low, high) = (
            stroke.min_length_m + limits.stroke_margin_m,
            stroke.max_length_m - limits.stroke_margin_m,
        );
        let mid = 0.5 * (low + high);
        let half = 0.5 * (high - low);
        let mut usage = Usage {
            leg_speed: report.max_speed_m_s.iter().fold(0.0f64, |m, v| m.max(*v))
                / limits.max_leg_speed_m_s,
            stroke: report
                .min_length_m
                .iter()
                .chain(report.max_length_m.iter())
                .fold(0.0f64, |m, l| m.max((l - mid).abs() / half)),
            ..Usage::default()
        };
        let points = motion::sample(trajectory, limits.step_s);
        for point in &points {
            let f = motion::leg_forces(&self.geometry, Some(&self.legs), theta, point)
                .ok_or(Binding::Singular)?;
            let force = f.amax();
            if force > self.max_force_n {
                return Err(Binding::Force {
                    force_n: force,
                    time_s: point.time_s,
                });
            }
            let a = motion::acceleration_at(point, payload_com_m).norm();
            if a > self.max_acceleration_m_s2 {
                return Err(Binding::Acceleration {
                    acceleration_m_s2: a,
                    time_s: point.time_s,
                });
            }
            usage.force = usage.force.max(force / self.max_force_n);
            usage.acceleration = usage.acceleration.max(a / self.max_acceleration_m_s2);
        }
        Ok(usage)
    }

    /// The payload's prior centre of mass in P, m.
    pub fn payload_com_m(&self) -> Vector3<f64> {
        let m = self.payload[0];
        Vector3::new(self.payload[1], self.payload[2], self.payload[3]) / m
    }
}

#[cfg(test)]
mod tests;
