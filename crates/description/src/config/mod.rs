//! The rig description's schema: one struct per TOML table, units in the key names.
//!
//! The rig description is what a rig's owner can know and write down: the platform's geometry
//! and stroke, the sample rate, each sensor's datasheet figures and the IMU's mounting, the
//! control gains and safety limits, the excitation, the estimator's settings, the run's phases
//! and the link to the rig. It never holds anything about the simulated world (the true
//! payload, the actuator model, the seed): a scenario file may carry that too, in its `[world]`
//! table, which this schema leaves to the simulator's layer (see [`crate::load::LoadedConfig::section`]).
//!
//! Every table refuses unknown keys (`deny_unknown_fields`) so that a misspelt key or a key with
//! the wrong unit is an error, never a silently ignored setting. Ranges are checked in
//! [`crate::validate`]; loading and messages are in [`crate::load`]; the checks that need the
//! kinematics (singular design) in [`crate::derived`], the trajectory's in measure's `setup`.

use serde::{Deserialize, Serialize};

mod calibration;
mod certificate;
mod vehicle;

pub use calibration::CalibrationConfig;
pub use certificate::{CertificateConfig, Nominal};
pub use vehicle::{VehicleConfig, VehicleConvention, WheelContacts, WheelFrame, WheelProblem};

/// The rig description: the machine, its sensors' datasheets, the controller, the excitation,
/// the estimator, the run's phases and the link.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Joint layout and leg stroke.
    pub platform: PlatformConfig,
    /// Sample rate, the sensors' datasheet figures and the IMU's mounting.
    pub sensors: SensorsConfig,
    /// Leg position control and the safety supervisor's limits.
    pub control: ControlConfig,
    /// The motion that excites the payload's inertia.
    pub excitation: ExcitationConfig,
    /// The tare run's motion when it differs from the loaded run's: a `[tare_excitation]` table
    /// is laid over `[excitation]` (it needs only the keys that differ). Omitted: the tare run
    /// moves as the loaded run does, which cancels most of the legs' own dynamics in loaded −
    /// tare; a different motion does not, and shows what the error budget must cover.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tare_excitation: Option<ExcitationConfig>,
    /// The online estimator.
    pub estimator: EstimatorSection,
    /// Durations of the run's phases.
    pub run: RunConfig,
    /// The link to a rig (`stewart rig`, `stewart emulate`); optional, every key defaulted.
    #[serde(default)]
    pub rig: crate::link::RigLinkConfig,
    /// The legs' own mass properties, the load cells' place in them and the joints' friction;
    /// optional (omitted: massless, frictionless legs with the cells at the plate end).
    #[serde(default)]
    pub legs: LegsConfig,
    /// What `stewart plan` designs the excitation for: the payload and fixture as known before
    /// measuring, the targets and the margins; optional, every key defaulted.
    #[serde(default)]
    pub plan: PlanConfig,
    /// The calibrations the measurement applies; optional (omitted: none, the rig as
    /// described).
    #[serde(default)]
    pub calibration: CalibrationConfig,
    /// Where the payload, a vehicle, stands on the plate; optional (omitted: results in P
    /// only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<VehicleConfig>,
    /// The measurement's and the rig's identification for the certificate; optional.
    #[serde(default)]
    pub certificate: CertificateConfig,
}

/// A body as known before it is measured (a CAD model, a previous measurement, a weighing):
/// about its own centre of mass, in P axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyPrior {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in P, m.
    pub com_m: [f64; 3],
    /// Inertia tensor about the centre of mass, P axes, kg·m².
    pub inertia_com_kg_m2: [[f64; 3]; 3],
}

impl BodyPrior {
    /// The body's ten parameters about the P origin.
    pub fn parameters(&self) -> estimator::InertialParameters {
        estimator::InertialParameters::from_com(
            self.mass_kg,
            nalgebra::Vector3::from(self.com_m),
            nalgebra::Matrix3::from_fn(|r, c| self.inertia_com_kg_m2[r][c]),
        )
    }
}

/// `[plan]`: the excitation design's prior, targets and margins (measure's `plan`). The plan
/// minimises the largest ratio of a quantity's predicted sigma to its target.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlanConfig {
    /// The payload as known beforehand (`[plan.payload]`).
    pub payload: BodyPrior,
    /// The plate with the empty fixture as known beforehand (`[plan.fixture]`).
    pub fixture: BodyPrior,
    /// Target one sigma of the payload's mass, as a fraction of it.
    pub target_mass_fraction: f64,
    /// Target one sigma of each coordinate of the centre of mass, m.
    pub target_com_m: f64,
    /// Target one sigma of each entry of J_C, as a fraction of its smallest principal moment.
    pub target_inertia_fraction: f64,
    /// Leg forces stay below this share of `control.max_force_n` along the planned path.
    pub force_share: f64,
    /// Leg speeds stay below this share of `excitation.max_leg_speed_m_s`: room for the legs'
    /// tracking lag and the measured speed's noise below the supervisor's limit.
    pub speed_share: f64,
    /// The payload's centre of mass accelerates at most this much, m/s² (what its tie-downs
    /// allow).
    pub max_acceleration_m_s2: f64,
    /// The highest excitation frequency stays below this share of `estimator.cutoff_hz`, so
    /// that the low-pass passes the motion undistorted.
    pub max_frequency_share: f64,
}

impl Default for PlanConfig {
    /// The default scenario's car and fixture as a CAD model gives them (inertia within about
    /// 10 %, products of inertia unknown), a vehicle-dynamics lab's targets (0.01 %, 0.1 mm,
    /// 0.05 %), 80 % of the force limit, 90 % of the speed limit, half a g, and 0.4 of the
    /// cut-off.
    fn default() -> Self {
        Self {
            payload: BodyPrior {
                mass_kg: 1500.0,
                com_m: [0.15, -0.08, 0.5],
                inertia_com_kg_m2: [[550.0, 0.0, 0.0], [0.0, 2300.0, 0.0], [0.0, 0.0, 2500.0]],
            },
            fixture: BodyPrior {
                mass_kg: 400.0,
                com_m: [0.0, 0.0, 0.05],
                inertia_com_kg_m2: [[240.0, 0.0, 0.0], [0.0, 240.0, 0.0], [0.0, 0.0, 450.0]],
            },
            target_mass_fraction: 1e-4,
            target_com_m: 1e-4,
            target_inertia_fraction: 5e-4,
            force_share: 0.8,
            speed_share: 0.9,
            max_acceleration_m_s2: 4.9,
            max_frequency_share: 0.4,
        }
    }
}

/// Which end of each leg its load cell sits at.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LoadCellEnd {
    /// Between the rod and the plate joint: the cell reads the axial force the leg applies to
    /// the plate.
    #[default]
    Plate,
    /// Between the cylinder and the base joint: the cell reads the axial force at the base,
    /// which includes the leg's own weight and inertia along its axis.
    Base,
}

/// `[legs]`: each leg is two rigid bodies, a cylinder turning about the base joint and a rod
/// fixed to the plate joint's side of the actuator, both slender and symmetric about the leg's
/// axis. Their weight and inertia reach the joints with components across the leg that a
/// single-axis load cell does not see (and, with the cell at the base end, along it too).
/// Joint friction: Coulomb and viscous torque at every universal (base) and spherical (plate)
/// joint, against the joint's relative rotation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LegsConfig {
    /// Where the load cell sits.
    pub load_cell_end: LoadCellEnd,
    /// Mass of the cylinder (the part that turns about the base joint), kg.
    pub cylinder_mass_kg: f64,
    /// Distance of the cylinder's centre of mass from the base joint centre, m.
    pub cylinder_com_from_base_m: f64,
    /// Moment of inertia of the cylinder about a transverse axis through its centre of mass,
    /// kg·m².
    pub cylinder_inertia_kg_m2: f64,
    /// Mass of the rod (the part that slides out to the plate joint), kg.
    pub rod_mass_kg: f64,
    /// Distance of the rod's centre of mass from the plate joint centre, m.
    pub rod_com_from_plate_m: f64,
    /// Moment of inertia of the rod about a transverse axis through its centre of mass, kg·m².
    pub rod_inertia_kg_m2: f64,
    /// Coulomb friction torque of each joint, N·m.
    pub joint_coulomb_torque_nm: f64,
    /// Viscous friction of each joint, N·m per rad/s of relative rotation.
    pub joint_viscous_nm_s_per_rad: f64,
    /// How far the built legs' masses may lie from these figures, one relative standard
    /// deviation (the same for cylinder and rod, all legs alike).
    pub mass_tolerance: f64,
    /// How far their centres of mass may lie from these figures, one standard deviation, m.
    pub com_tolerance_m: f64,
    /// How far their transverse inertias may lie from these figures, one relative standard
    /// deviation.
    pub inertia_tolerance: f64,
    /// How far the joints' friction (Coulomb and viscous alike) may lie from these figures, one
    /// relative standard deviation.
    pub friction_tolerance: f64,
}

impl LegsConfig {
    /// The estimator's model of these legs ([`estimator::legs`]).
    pub fn model(&self) -> estimator::LegModel {
        estimator::LegModel {
            cell_end: match self.load_cell_end {
                LoadCellEnd::Plate => estimator::CellEnd::Plate,
                LoadCellEnd::Base => estimator::CellEnd::Base,
            },
            cylinder_mass_kg: self.cylinder_mass_kg,
            cylinder_com_from_base_m: self.cylinder_com_from_base_m,
            cylinder_inertia_kg_m2: self.cylinder_inertia_kg_m2,
            rod_mass_kg: self.rod_mass_kg,
            rod_com_from_plate_m: self.rod_com_from_plate_m,
            rod_inertia_kg_m2: self.rod_inertia_kg_m2,
            joint_coulomb_torque_nm: self.joint_coulomb_torque_nm,
            joint_viscous_nm_s_per_rad: self.joint_viscous_nm_s_per_rad,
        }
    }

    /// The figures of an estimator's leg model (tolerances zero): [`Self::model`]'s inverse.
    pub fn from_model(m: &estimator::LegModel) -> Self {
        Self {
            load_cell_end: match m.cell_end {
                estimator::CellEnd::Plate => LoadCellEnd::Plate,
                estimator::CellEnd::Base => LoadCellEnd::Base,
            },
            cylinder_mass_kg: m.cylinder_mass_kg,
            cylinder_com_from_base_m: m.cylinder_com_from_base_m,
            cylinder_inertia_kg_m2: m.cylinder_inertia_kg_m2,
            rod_mass_kg: m.rod_mass_kg,
            rod_com_from_plate_m: m.rod_com_from_plate_m,
            rod_inertia_kg_m2: m.rod_inertia_kg_m2,
            joint_coulomb_torque_nm: m.joint_coulomb_torque_nm,
            joint_viscous_nm_s_per_rad: m.joint_viscous_nm_s_per_rad,
            ..Self::default()
        }
    }

    /// True when the legs have mass or the joints friction: something for the cells to miss.
    pub fn matter(&self) -> bool {
        self.cylinder_mass_kg > 0.0
            || self.rod_mass_kg > 0.0
            || self.cylinder_inertia_kg_m2 > 0.0
            || self.rod_inertia_kg_m2 > 0.0
            || self.joint_coulomb_torque_nm > 0.0
            || self.joint_viscous_nm_s_per_rad > 0.0
    }
}

impl Default for LegsConfig {
    /// Massless, frictionless legs with the load cells at the plate end.
    fn default() -> Self {
        Self {
            load_cell_end: LoadCellEnd::Plate,
            cylinder_mass_kg: 0.0,
            cylinder_com_from_base_m: 0.0,
            cylinder_inertia_kg_m2: 0.0,
            rod_mass_kg: 0.0,
            rod_com_from_plate_m: 0.0,
            rod_inertia_kg_m2: 0.0,
            joint_coulomb_torque_nm: 0.0,
            joint_viscous_nm_s_per_rad: 0.0,
            mass_tolerance: 0.0,
            com_tolerance_m: 0.0,
            inertia_tolerance: 0.0,
            friction_tolerance: 0.0,
        }
    }
}

/// A 6-6 platform: leg i joins base joint i (in B) to plate joint i (in P), given either as
/// the surveyed points (`base_joints_m`, `plate_joints_m`) or by the shorthand of three joint
/// pairs on each circle (the two radii and pair separations,
/// [`kinematics::Geometry::from_radii`]: the plate's pairs turned 60° against the base's; the
/// seed paper's Eq. 1–2 as printed put equal joint angles on both circles, which is
/// architecturally singular). A file gives one form: its points replace the embedded
/// default's radii.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlatformConfig {
    /// Radius of the base joint circle, metres (the radii form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_radius_m: Option<f64>,
    /// Radius of the plate joint circle, metres (the radii form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plate_radius_m: Option<f64>,
    /// Angle between the two joints of a pair on the base, degrees (the radii form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_pair_separation_deg: Option<f64>,
    /// Angle between the two joints of a pair on the plate, degrees (the radii form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plate_pair_separation_deg: Option<f64>,
    /// The base joints' centres bᵢ in B, metres, leg i's first (the points form; a survey's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_joints_m: Option<[[f64; 3]; 6]>,
    /// The plate joints' centres pᵢ in P, metres, leg i's second (the points form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plate_joints_m: Option<[[f64; 3]; 6]>,
    /// Shortest leg (joint centre to joint centre), metres.
    pub min_leg_length_m: f64,
    /// Longest leg, metres.
    pub max_leg_length_m: f64,
    /// The home pose's height: P's origin above B's, metres, the plate level and centred, as
    /// the rig's owner measures it (omitted: the height whose mean leg length is mid-stroke).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home_height_m: Option<f64>,
    /// How far each built joint centre may lie from where this table puts it, one standard
    /// deviation per coordinate, metres (0: built exactly).
    #[serde(default)]
    pub joint_position_tolerance_m: f64,
}

impl PlatformConfig {
    /// The base's and the plate's joint-circle radii, m: the radii form's, or for surveyed
    /// points each body's mean joint distance from its z axis (the circles a drawing of the
    /// rig shows). `None` when neither form is complete.
    pub fn joint_radii_m(&self) -> Option<(f64, f64)> {
        let mean =
            |points: &[[f64; 3]; 6]| points.iter().map(|p| p[0].hypot(p[1])).sum::<f64>() / 6.0;
        match (&self.base_joints_m, &self.plate_joints_m) {
            (Some(base), Some(plate)) => Some((mean(base), mean(plate))),
            _ => Some((self.base_radius_m?, self.plate_radius_m?)),
        }
    }
}

/// The `[platform]` keys of the radii form, which a file giving the joints' points replaces.
pub const RADII_KEYS: [&str; 4] = [
    "base_radius_m",
    "plate_radius_m",
    "base_pair_separation_deg",
    "plate_pair_separation_deg",
];

/// The `[platform]` keys of the points form.
pub const JOINT_KEYS: [&str; 2] = ["base_joints_m", "plate_joints_m"];

impl ExcitationConfig {
    /// The fade-out time, s.
    pub fn fade_out(&self) -> f64 {
        self.fade_out_s.unwrap_or(self.fade_s)
    }
}

/// The sensors on the platform as their datasheets and the rig's build describe them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsConfig {
    /// Sampling (and control loop) rate, Hz.
    pub sample_rate_hz: f64,
    /// The leg-length encoders.
    pub encoder: EncoderDatasheet,
    /// The load cell in each leg.
    pub load_cell: LoadCellDatasheet,
    /// The gyroscope.
    pub gyro: GyroDatasheet,
    /// The accelerometer.
    pub accelerometer: AccelerometerDatasheet,
    /// Where the IMU (gyroscope and accelerometer) sits on the plate and how it is turned.
    pub imu: ImuMounting,
    /// How the channels are timed: skew between the IMU and the rest, jitter, lost frames.
    #[serde(default)]
    pub timing: TimingDatasheet,
}

/// `[sensors.timing]`: how well the channels of one frame describe one instant, and how many
/// frames arrive.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TimingDatasheet {
    /// One standard deviation of the constant delay of the IMU's channels against the load
    /// cells and encoders, s (positive: the IMU reports an older instant).
    pub imu_skew_s: f64,
    /// One standard deviation of each frame's sampling instant about its nominal place on the
    /// sample grid, s.
    pub sampling_jitter_s: f64,
    /// Expected share of frames lost between the sensors and the host (0 to 0.5).
    pub frame_loss: f64,
}

/// Leg-length encoders (joint centre to joint centre).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderDatasheet {
    /// White noise, one standard deviation, m.
    pub noise_m: f64,
    /// Resolution (quantisation step), m; 0 = continuous.
    pub resolution_m: f64,
}

/// The axial load cells.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellDatasheet {
    /// White noise, one standard deviation, N.
    pub noise_n: f64,
    /// One standard deviation of each cell's zero offset left after its calibration, N. Its
    /// effect enters the reported sigma as a systematic part (measure's `systematic`).
    pub zero_offset_n: f64,
    /// Resolution (quantisation step), N; 0 = continuous.
    pub resolution_n: f64,
    /// One standard deviation of each cell's gain (sensitivity) error left after its
    /// calibration, relative (5e-4 = 0.05 %).
    #[serde(default)]
    pub gain_error: f64,
    /// One standard deviation of each cell's transverse sensitivity: its reading per newton of
    /// force across its axis, in each of the two transverse directions.
    #[serde(default)]
    pub transverse_sensitivity: f64,
    /// One standard deviation of each cell's zero drift rate over a run, N per minute.
    #[serde(default)]
    pub zero_drift_n_per_min: f64,
}

/// The gyroscope.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroDatasheet {
    /// Rate noise density (angle random walk N), rad/s/√Hz, in the Allan-deviation convention
    /// (IEEE Std 952): the rate averaged over τ has deviation N/√τ, so one sample's is
    /// N √(sample rate). A datasheet density meant over a Nyquist-limited band (σ = N √(fs/2))
    /// is given as [`Self::noise_rms_rad_s`] instead. One of the two.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_density_rad_s_sqrt_hz: Option<f64>,
    /// The noise of one sample, one standard deviation, rad/s (a datasheet's rms noise at this
    /// sample rate, or the readings' spread at rest). One of this and the density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_rms_rad_s: Option<f64>,
    /// One standard deviation of each axis' constant bias (bias stability), rad/s.
    pub bias_rad_s: f64,
    /// One standard deviation of each axis' scale-factor error, relative.
    #[serde(default)]
    pub scale_error: f64,
}

/// The accelerometer, reading specific force `a − g`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelerometerDatasheet {
    /// Noise density (velocity random walk), m/s²/√Hz, in the Allan-deviation convention as
    /// the gyro's ([`GyroDatasheet::noise_density_rad_s_sqrt_hz`]): one sample's deviation is
    /// this × √(sample rate). One of this and [`Self::noise_rms_m_s2`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_density_m_s2_sqrt_hz: Option<f64>,
    /// The noise of one sample, one standard deviation, m/s². One of this and the density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_rms_m_s2: Option<f64>,
    /// One standard deviation of each axis' constant bias, m/s². Its effect does not cancel
    /// with the tare (it is proportional to the mass on the plate) and enters the reported
    /// sigma as a systematic part (measure's `systematic`).
    pub bias_m_s2: f64,
    /// One standard deviation of each axis' scale-factor error, relative.
    #[serde(default)]
    pub scale_error: f64,
}

/// The IMU's mounting on the plate (`Default`: at the P origin, axes along P's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuMounting {
    /// The accelerometer's position in P, m.
    pub position_m: [f64; 3],
    /// The IMU's axes against P as roll, pitch, yaw, degrees: a vector v given in the IMU's
    /// axes is `R v` in P with `R = Rx(roll) Ry(pitch) Rz(yaw)` (the pose convention).
    pub orientation_deg: [f64; 3],
    /// One standard deviation of the IMU's mounting rotation about each of P's axes against
    /// `orientation_deg`, as left by its alignment, degrees.
    #[serde(default)]
    pub misalignment_deg: f64,
    /// One standard deviation of each coordinate of the accelerometer's position against
    /// `position_m` (the lever arm's uncertainty), m.
    #[serde(default)]
    pub position_tolerance_m: f64,
}

impl ImuMounting {
    /// The rotation from the IMU's axes into P.
    pub fn rotation(&self) -> nalgebra::Rotation3<f64> {
        let [r, p, y] = self.orientation_deg.map(f64::to_radians);
        nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::x_axis(), r)
            * nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), p)
            * nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), y)
    }
}

impl SensorsConfig {
    /// Every datasheet figure times `k` (0: ideal sensors; the IMU's nominal mounting is kept,
    /// its tolerances scaled; the frame loss capped at 0.5).
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            sample_rate_hz: self.sample_rate_hz,
            encoder: EncoderDatasheet {
                noise_m: k * self.encoder.noise_m,
                resolution_m: k * self.encoder.resolution_m,
            },
            load_cell: LoadCellDatasheet {
                noise_n: k * self.load_cell.noise_n,
                zero_offset_n: k * self.load_cell.zero_offset_n,
                resolution_n: k * self.load_cell.resolution_n,
                gain_error: k * self.load_cell.gain_error,
                transverse_sensitivity: k * self.load_cell.transverse_sensitivity,
                zero_drift_n_per_min: k * self.load_cell.zero_drift_n_per_min,
            },
            gyro: GyroDatasheet {
                noise_density_rad_s_sqrt_hz: self.gyro.noise_density_rad_s_sqrt_hz.map(|d| k * d),
                noise_rms_rad_s: self.gyro.noise_rms_rad_s.map(|r| k * r),
                bias_rad_s: k * self.gyro.bias_rad_s,
                scale_error: k * self.gyro.scale_error,
            },
            accelerometer: AccelerometerDatasheet {
                noise_density_m_s2_sqrt_hz: self
                    .accelerometer
                    .noise_density_m_s2_sqrt_hz
                    .map(|d| k * d),
                noise_rms_m_s2: self.accelerometer.noise_rms_m_s2.map(|r| k * r),
                bias_m_s2: k * self.accelerometer.bias_m_s2,
                scale_error: k * self.accelerometer.scale_error,
            },
            imu: ImuMounting {
                misalignment_deg: k * self.imu.misalignment_deg,
                position_tolerance_m: k * self.imu.position_tolerance_m,
                ..self.imu
            },
            timing: TimingDatasheet {
                imu_skew_s: k * self.timing.imu_skew_s,
                sampling_jitter_s: k * self.timing.sampling_jitter_s,
                frame_loss: (k * self.timing.frame_loss).min(0.5),
            },
        }
    }

    /// Per-sample gyro noise, rad/s: the rms given, else density × √(sample rate).
    pub fn gyro_noise_rad_s(&self) -> f64 {
        per_sample(
            self.gyro.noise_rms_rad_s,
            self.gyro.noise_density_rad_s_sqrt_hz,
            self.sample_rate_hz,
        )
    }

    /// Per-sample accelerometer noise, m/s²: the rms given, else density × √(sample rate).
    pub fn accel_noise_m_s2(&self) -> f64 {
        per_sample(
            self.accelerometer.noise_rms_m_s2,
            self.accelerometer.noise_density_m_s2_sqrt_hz,
            self.sample_rate_hz,
        )
    }

    /// The gyro's noise density, rad/s/√Hz: the density given, else the rms ÷ √(sample rate)
    /// (what a simulated gyro sampled at this rate must have for that rms).
    pub fn gyro_density_rad_s_sqrt_hz(&self) -> f64 {
        density(
            self.gyro.noise_rms_rad_s,
            self.gyro.noise_density_rad_s_sqrt_hz,
            self.sample_rate_hz,
        )
    }

    /// The accelerometer's noise density, m/s²/√Hz, as [`Self::gyro_density_rad_s_sqrt_hz`].
    pub fn accel_density_m_s2_sqrt_hz(&self) -> f64 {
        density(
            self.accelerometer.noise_rms_m_s2,
            self.accelerometer.noise_density_m_s2_sqrt_hz,
            self.sample_rate_hz,
        )
    }

    /// Whether the description leaves anything of the IMU's alignment for a calibration to
    /// measure ([`crate::calibration::imu`]): its axes (`imu.misalignment_deg`), the gyro's
    /// scales (`gyro.scale_error`), its position (`imu.position_tolerance_m`) or its delay
    /// (`timing.imu_skew_s`). With all four 0 the description declares the alignment known
    /// exactly, and a calibration could only add its own noise (the noise-only world's centre
    /// of mass x: spread 0.040 mm with a calibration per run, 0.008 mm without; docs/plan.md).
    pub fn imu_alignment_uncertain(&self) -> bool {
        self.imu.misalignment_deg > 0.0
            || self.gyro.scale_error > 0.0
            || self.imu.position_tolerance_m > 0.0
            || self.timing.imu_skew_s > 0.0
    }
}

/// Leg position control (a PID per leg on leg length) and the supervisor's limits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlConfig {
    /// Proportional gain, N/m.
    pub kp_n_per_m: f64,
    /// Integral gain, N/(m·s).
    pub ki_n_per_m_s: f64,
    /// Derivative gain (on the measurement), N·s/m.
    pub kd_n_s_per_m: f64,
    /// Time constant of the derivative's low-pass filter, s.
    pub derivative_filter_s: f64,
    /// Force command limit per leg (PID clamp and supervisor gate), N.
    pub max_force_n: f64,
    /// The supervisor faults when a load cell reads more than this, N.
    pub max_measured_force_n: f64,
    /// The supervisor faults when a leg moves faster than this, m/s.
    pub max_leg_speed_m_s: f64,
    /// The supervisor faults when a measured leg leaves the stroke by more than this, m.
    pub leg_length_margin_m: f64,
    /// The supervisor faults on a gap between samples longer than this, s.
    pub max_sample_gap_s: f64,
    /// Shortest ramp from the resting pose to home before the settle hold, s.
    pub settle_ramp_s: f64,
    /// Hold at home after the park ramp before braking, s.
    pub park_hold_s: f64,
    /// Add the inverse-dynamics feed-forward of the plate's load to the leg loops
    /// ([`control::Controller::set_load`]): the tare run's load is `[plan.fixture]`, a loaded
    /// run's the tare's estimate (or `[plan.fixture]`) plus `[plan.payload]`. Without it the
    /// loops find the load's inertial forces from their tracking error, and under a heavy
    /// payload the plate translates and turns where it was not commanded (docs/plan.md).
    #[serde(default = "default_true")]
    pub inertial_feedforward: bool,
}

/// Which excitation to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExcitationKind {
    /// A periodic multi-sine on all six axes (`[excitation.multisine]`).
    Multisine,
    /// Explicit sine components (`[[excitation.sines]]`), e.g. the paper's Eq. 8.
    Sines,
}

/// How a multi-sine shares an axis's amplitude among its harmonics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpectrumConfig {
    /// Equal amplitudes.
    FlatPosition,
    /// Amplitudes ∝ 1/frequency: equal velocity per harmonic.
    FlatVelocity,
}

/// `[excitation.multisine]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MultisineConfig {
    /// Base frequency f₀, Hz: the signal repeats every 1/f₀.
    pub base_frequency_hz: f64,
    /// Harmonics per excited axis.
    pub harmonics_per_axis: u32,
    /// Peak excursion along x, y, z, m (0 leaves the axis still).
    pub peak_translation_m: [f64; 3],
    /// Peak roll, pitch, yaw, degrees.
    pub peak_rotation_deg: [f64; 3],
    /// How amplitude is shared among harmonics.
    pub spectrum: SpectrumConfig,
}

/// A pose coordinate of the excitation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisName {
    /// Translation along x.
    X,
    /// Translation along y.
    Y,
    /// Translation along z.
    Z,
    /// Roll α.
    Roll,
    /// Pitch β.
    Pitch,
    /// Yaw γ.
    Yaw,
}

impl AxisName {
    /// True for roll, pitch and yaw.
    pub fn is_rotation(self) -> bool {
        matches!(self, Self::Roll | Self::Pitch | Self::Yaw)
    }
}

/// One `[[excitation.sines]]` component: `amplitude · sin(2π f t + phase)` on one axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SineConfig {
    /// The coordinate it moves.
    pub axis: AxisName,
    /// Amplitude for roll/pitch/yaw, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude_deg: Option<f64>,
    /// Amplitude for x/y/z, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude_m: Option<f64>,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Phase, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

/// The excitation trajectory about the home pose, and the limits it must meet before any
/// motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExcitationConfig {
    /// `multisine` or `sines`.
    pub kind: ExcitationKind,
    /// Fade in (and out, unless `fade_out_s` is given) with a C² window, s; part of the
    /// excitation time.
    pub fade_s: f64,
    /// Fade out, s (omitted: `fade_s`). A short fade-in starts the motion at once; the fade-out
    /// must still be long enough to bring the legs to rest within their speed limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fade_out_s: Option<f64>,
    /// Every leg must stay this far inside its stroke, m.
    pub stroke_margin_m: f64,
    /// Largest leg speed the trajectory may ask for, m/s (keep below
    /// `control.max_leg_speed_m_s`).
    pub max_leg_speed_m_s: f64,
    /// Smallest inverse condition number of the Jacobian along the trajectory.
    pub min_inverse_condition: f64,
    /// The multi-sine (used when `kind = "multisine"`).
    pub multisine: MultisineConfig,
    /// The sine components (used when `kind = "sines"`).
    #[serde(default)]
    pub sines: Vec<SineConfig>,
}

/// Which parameters are identified.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub enum ParamCount {
    /// m, m·c and J_O: the full rigid-body model.
    Ten,
    /// The paper's model: the tensor about a known centre of mass.
    Six,
}

impl ParamCount {
    /// Indices of θ the model estimates: all ten, or the six of the tensor (m and h given).
    /// The report's quantities ([`crate::quantities::Quantities::flat`]) share the order: mass and
    /// centre of mass first, then J_C's entries.
    pub fn estimated(self) -> core::ops::Range<usize> {
        match self {
            Self::Ten => 0..10,
            Self::Six => 4..10,
        }
    }

    /// Whether quantity `k` (θ's order, or the report's) is given rather than estimated.
    pub fn given(self, k: usize) -> bool {
        !self.estimated().contains(&k)
    }
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

/// The online estimator's settings (all of them are logged so the estimate can be re-run).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorSection {
    /// 10 (full model) or 6 (the paper's: the tensor about a known centre of mass).
    pub params: ParamCount,
    /// Cut-off of the low-pass filter applied alike to both sides of the equations, Hz.
    pub cutoff_hz: f64,
    /// RLS forgetting factor λ (1 = none).
    pub forgetting_factor: f64,
    /// Expected noise of each force equation after filtering, N (sets the row weights).
    pub force_sigma_n: f64,
    /// Expected noise of each torque equation after filtering, N·m.
    pub torque_sigma_nm: f64,
    /// Prior one-sigma of every parameter about zero (SI units; large = uninformative).
    pub prior_sigma: f64,
    /// Known payload mass for `params = 6` (weighed beforehand), kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_payload_mass_kg: Option<f64>,
    /// Known payload centre of mass in P for `params = 6`, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_payload_com_m: Option<[f64; 3]>,
    /// Known fixture (plate) mass for `params = 6`, kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_fixture_mass_kg: Option<f64>,
    /// Known fixture centre of mass in P for `params = 6`, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub known_fixture_com_m: Option<[f64; 3]>,
    /// Add what the load cells do not see of the legs' mass and the joints' friction
    /// (`[legs]`) to the measured wrench ([`estimator::legs`]); the error budget then counts
    /// the `[legs]` tolerances instead of the legs' whole effect.
    #[serde(default = "default_true")]
    pub compensate_legs: bool,
    /// The site's gravity, m/s²: the accelerometer's offset is measured on the brake hold
    /// against it and subtracted ([`estimator::hold`]). Left out or 0: no hold calibration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub local_gravity_m_s2: Option<f64>,
}

fn default_true() -> bool {
    true
}

/// The run's phases.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Braked hold before each measurement, while the static load is read for the feed-forward,
    /// s.
    pub brake_hold_s: f64,
    /// Hold at home (after the ramp from rest) before the excitation, s.
    pub settle_s: f64,
    /// Excitation length of the loaded run including the fades, s (overridden by
    /// `--duration`).
    pub duration_s: f64,
    /// Excitation length of the tare run (empty fixture), s.
    pub tare_duration_s: f64,
    /// Ramp back home after the excitation, s.
    pub park_s: f64,
}

/// One sample's noise from an rms (taken as it is) or a density (× √rate); 0 with neither.
fn per_sample(rms: Option<f64>, density: Option<f64>, rate_hz: f64) -> f64 {
    match (rms, density) {
        (Some(r), _) => r,
        (None, Some(d)) => d * rate_hz.sqrt(),
        (None, None) => 0.0,
    }
}

/// A density from an rms (÷ √rate) or as it is; 0 with neither.
fn density(rms: Option<f64>, density: Option<f64>, rate_hz: f64) -> f64 {
    match (rms, density) {
        (_, Some(d)) => d,
        (Some(r), None) => r / rate_hz.sqrt(),
        (None, None) => 0.0,
    }
}
