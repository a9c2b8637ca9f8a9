//! The scenario file's schema: one struct per TOML table, units in the key names.
//!
//! Every table refuses unknown keys (`deny_unknown_fields`) so that a misspelt key or a key with
//! the wrong unit is an error, never a silently ignored setting. Ranges are checked in
//! [`crate::validate`]; loading and messages are in [`crate::config_load`].

use serde::{Deserialize, Serialize};

/// A whole scenario: the machine, the bodies on it, the sensors, the controller, the excitation,
/// the estimator and the run's phases.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Joint layout and leg stroke.
    pub platform: PlatformConfig,
    /// The plate and the fixture that holds the payload (always on the platform).
    pub fixture: BodyConfig,
    /// The body to be measured (a car).
    pub payload: BodyConfig,
    /// The actuators between command and leg force.
    pub actuator: ActuatorConfig,
    /// Sensor quality and rates.
    pub sensors: SensorsConfig,
    /// Leg position control and the safety supervisor's limits.
    pub control: ControlConfig,
    /// The motion that excites the payload's inertia.
    pub excitation: ExcitationConfig,
    /// The online estimator.
    pub estimator: EstimatorConfig,
    /// Durations of the run's phases and the random seed.
    pub run: RunConfig,
}

/// A 6-6 platform with joints in three pairs on each circle (ERRATA Eq. 1–2: the plate's pairs
/// turned 60° against the base's).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlatformConfig {
    /// Radius of the base joint circle, metres.
    pub base_radius_m: f64,
    /// Radius of the plate joint circle, metres.
    pub plate_radius_m: f64,
    /// Angle between the two joints of a pair on the base, degrees.
    pub base_pair_separation_deg: f64,
    /// Angle between the two joints of a pair on the plate, degrees.
    pub plate_pair_separation_deg: f64,
    /// Shortest leg (joint centre to joint centre), metres.
    pub min_leg_length_m: f64,
    /// Longest leg, metres.
    pub max_leg_length_m: f64,
}

/// A rigid body's inertial properties, given the way a datasheet or CAD gives them: mass, centre
/// of mass in P, inertia tensor about the centre of mass in P axes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyConfig {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in the platform frame P, metres.
    pub com_m: [f64; 3],
    /// Inertia tensor J_C about the centre of mass, P axes, kg·m² (symmetric; off-diagonal
    /// entries are minus the products of inertia).
    pub inertia_com_kg_m2: [[f64; 3]; 3],
}

/// Actuator dynamics between force command and applied force.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorConfig {
    /// Bandwidth of the first-order force lag, Hz.
    pub bandwidth_hz: f64,
    /// Force saturation, N (each direction).
    pub max_force_n: f64,
    /// Viscous friction inside the actuator, N·s/m.
    pub viscous_friction_n_s_per_m: f64,
    /// Coulomb friction inside the actuator, N.
    pub coulomb_friction_n: f64,
}

/// Sensor noise level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoisePreset {
    /// Ideal sensors.
    None,
    /// Industrial grade: load cells ~0.02 % of 20 kN, encoders ~1 µm, tactical-grade IMU.
    Realistic,
    /// About ten times worse than realistic.
    Harsh,
}

impl NoisePreset {
    /// The preset's name as written in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Realistic => "realistic",
            Self::Harsh => "harsh",
        }
    }
}

/// Sensors on the platform.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsConfig {
    /// Noise preset (overridden by `--noise`).
    pub noise: NoisePreset,
    /// Sampling (and control loop) rate, Hz.
    pub sample_rate_hz: f64,
    /// Accelerometer mounting point in P, metres.
    pub imu_position_m: [f64; 3],
}

/// Leg position control (a PID per leg on leg length) and the supervisor's limits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlConfig {
    /// Proportional gain, N/m.
    pub kp_n_per_m: f64,
    /// Integral gain, N/(m·s).
    pub ki_n_per_m_s: f64,
    /// Derivative gain, N·s/m.
    pub kd_n_s_per_m: f64,
    /// The supervisor faults when a leg's tracking error exceeds this, metres.
    pub max_tracking_error_m: f64,
    /// The supervisor faults when a leg moves faster than this, m/s.
    pub max_leg_speed_m_s: f64,
    /// Force command limit per leg, N.
    pub max_force_n: f64,
}

/// One rotational or translational axis of the excitation: a sum of sines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisExcitation {
    /// Amplitude of each component (degrees for roll/pitch/yaw, metres for x/y/z).
    pub amplitudes: Vec<f64>,
    /// Frequency of each component, Hz.
    pub frequencies_hz: Vec<f64>,
    /// Phase of each component, degrees.
    #[serde(default)]
    pub phases_deg: Vec<f64>,
}

/// The excitation trajectory about the home pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExcitationConfig {
    /// Time to fade the motion in and out, s.
    pub ramp_s: f64,
    /// Roll α about x, components in degrees.
    pub roll_deg: AxisExcitation,
    /// Pitch β about y, degrees.
    pub pitch_deg: AxisExcitation,
    /// Yaw γ about z, degrees.
    pub yaw_deg: AxisExcitation,
    /// Translation along x, metres.
    pub x_m: AxisExcitation,
    /// Translation along y, metres.
    pub y_m: AxisExcitation,
    /// Translation along z, metres.
    pub z_m: AxisExcitation,
}

/// Which parameters are identified.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub enum ParamCount {
    /// m, m·c and J_O: the full rigid-body model.
    Ten,
    /// The paper's model: J_O only, centre of mass assumed at the P origin.
    Six,
}

impl TryFrom<u8> for ParamCount {
    type Error = String;
    fn try_from(v: u8) -> Result<Self, String> {
        match v {
            10 => Ok(Self::Ten),
            6 => Ok(Self::Six),
            other => Err(format!("must be 10 or 6, got {other}")),
        }
    }
}

impl From<ParamCount> for u8 {
    fn from(p: ParamCount) -> u8 {
        match p {
            ParamCount::Ten => 10,
            ParamCount::Six => 6,
        }
    }
}

/// The online estimator's settings (all of them are logged so `stewart estimate` can re-run it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorConfig {
    /// 10 (full model) or 6 (the paper's: J_O only).
    pub params: ParamCount,
    /// Cut-off of the low-pass filter applied alike to both sides of the equations, Hz.
    pub cutoff_hz: f64,
    /// RLS forgetting factor λ (1 = none).
    pub forgetting_factor: f64,
}

/// The run's phases.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Hold at home before each measurement, s.
    pub settle_s: f64,
    /// Excitation length of the loaded run, s (overridden by `--duration`).
    pub duration_s: f64,
    /// Excitation length of the tare run (empty fixture), s.
    pub tare_duration_s: f64,
    /// Time allowed to return home and stop, s.
    pub park_s: f64,
    /// Seed of every random number in the simulation (overridden by `--seed`).
    pub seed: u64,
}
