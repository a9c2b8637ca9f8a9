//! The log's run-level messages: what was run (`/run/metadata`), the estimator's exact settings
//! for each measurement (`/run/estimator`, enough to re-run it offline from `/sensors`), and the
//! simulator's ground truth (`/run/truth`, never read by the estimator).

use anyhow::{bail, Result};
use nalgebra::{Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::schema::{array, int, nullable, num, numbers, object, string, Schema};
use rig_description::calibration::CalibrationDocument;

/// `stewart.RunMetadata` on `/run/metadata`, written at the start, twice
/// ([`crate::run_log::RunLog::write_metadata`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunMetadata {
    /// `stewart-cli` version.
    pub tool_version: String,
    /// `simulate` or `rig`.
    pub command: String,
    /// `sim` or `rig`.
    pub backend: String,
    /// Rig description / scenario file as named by the user, or the embedded default.
    pub config_source: String,
    /// That file's text as read.
    pub config_text: String,
    /// The effective rig description (default merged with the file and the command line) as
    /// TOML: what `stewart estimate` takes its datasheet figures from, unless `--rig` says.
    pub config_toml: String,
    /// Seed of the simulated world (0 on a rig).
    pub seed: u64,
    /// Sensor grade of the simulated world (`none`, `realistic`, `harsh`), `rig` on a rig.
    pub noise: String,
    /// 10 or 6.
    pub params: u8,
    /// Nominal sample period, s.
    pub sample_period_s: f64,
    /// Unix time of the first sample, ns; MCAP log times are this plus the sample clock.
    pub start_unix_ns: u64,
    /// Measurements planned, in order (`tare`, `loaded`).
    pub runs: Vec<String>,
    /// Tare file used instead of a tare run, if any.
    pub tare_file: Option<String>,
    /// Base joints in B, m.
    pub base_joints_m: [[f64; 3]; 6],
    /// Plate joints in P, m.
    pub plate_joints_m: [[f64; 3]; 6],
    /// Shortest and longest leg, m.
    pub stroke_m: [f64; 2],
    /// The home pose's height when the rig description gives it (`platform.home_height_m`),
    /// m; `null`: the height whose mean leg length is mid-stroke.
    #[serde(default)]
    pub home_height_m: Option<f64>,
    /// The IMU calibration the measurement applied, as its file's TOML (`null`: none), so that
    /// `stewart estimate` re-runs it without the file.
    #[serde(default)]
    pub imu_calibration_toml: Option<String>,
    /// The load cells' gains the measurement applied, as their file's TOML (`null`: none).
    #[serde(default)]
    pub load_cell_calibration_toml: Option<String>,
}

impl RunMetadata {
    /// The metadata of a run of `command` on `backend` with the rig description `rig` and its
    /// platform `geometry`: the description (as given and as run), the parameter count, the
    /// joints and stroke, the calibrations applied, and the sample period the description
    /// gives. The run's own facts start empty (seed 0, `noise` [`UNKNOWN`], start time 0, no
    /// runs, no tare file): the caller sets what it knows.
    pub fn describing(
        rig: &rig_description::LoadedConfig,
        geometry: &kinematics::Geometry,
        command: &str,
        backend: &str,
    ) -> Self {
        let (base_joints_m, plate_joints_m) = measure::sequence::joints(geometry);
        let stroke = geometry.stroke();
        let config = &rig.config;
        Self {
            tool_version: env!("CARGO_PKG_VERSION").into(),
            command: command.into(),
            backend: backend.into(),
            config_source: rig.source.clone(),
            config_text: rig.text.clone(),
            config_toml: rig.effective_toml(),
            seed: 0,
            noise: UNKNOWN.into(),
            params: config.estimator.params.into(),
            sample_period_s: 1.0 / config.sensors.sample_rate_hz,
            start_unix_ns: 0,
            runs: Vec::new(),
            tare_file: None,
            base_joints_m,
            plate_joints_m,
            stroke_m: [stroke.min_length_m, stroke.max_length_m],
            home_height_m: geometry
                .home_is_given()
                .then_some(geometry.home_pose().position_m.z),
            imu_calibration_toml: config.calibration.imu_file.as_ref().map(|f| f.to_toml()),
            load_cell_calibration_toml: config
                .calibration
                .load_cells_file
                .as_ref()
                .map(|f| f.to_toml()),
        }
    }

    /// What a log whose `/run/metadata` was lost to damage is read with: the platform and
    /// the sample period of the rig description `rig` (`stewart estimate --rig FILE`), the
    /// run's own facts unknown (`command`, `backend` and `noise` say `unknown`; no seed, no
    /// start time). `runs` is empty: what was planned is lost with the metadata, and the
    /// reader lists the measurements whose frames the log holds
    /// ([`crate::LogContents::or_metadata_of`], `ops::estimate::stream::tare_of_file`).
    /// Errors: `rig`'s platform is refused.
    pub fn of_rig(rig: &rig_description::LoadedConfig) -> Result<Self> {
        let geometry = measure::setup::geometry(rig)
            .map_err(|e| anyhow::anyhow!("the rig description's platform is refused: {e}"))?;
        Ok(Self::describing(rig, &geometry, UNKNOWN, UNKNOWN))
    }
}

/// What [`RunMetadata::of_rig`] says of a fact the lost metadata held.
pub const UNKNOWN: &str = "unknown";

fn joints(d: &'static str) -> Schema {
    array(numbers(3, ""), Some(6), d)
}

impl RunMetadata {
    /// JSON schema.
    pub fn schema() -> Schema {
        object(
            vec![
                ("tool_version", string("stewart-cli version")),
                ("command", string("simulate or rig")),
                ("backend", string("sim or rig")),
                (
                    "config_source",
                    string("scenario file, or the embedded default"),
                ),
                ("config_text", string("the scenario file's text as read")),
                (
                    "config_toml",
                    string("effective rig description (default + file + command line), TOML"),
                ),
                ("seed", int("seed of the simulated world (0 on a rig)")),
                (
                    "noise",
                    string("sensor grade of the simulated world (none, realistic, harsh), or rig"),
                ),
                ("params", int("10 or 6")),
                ("sample_period_s", num("nominal sample period, s")),
                (
                    "start_unix_ns",
                    int("Unix time of the first sample, ns; log time = this + sample clock"),
                ),
                (
                    "runs",
                    array(string(""), None, "measurements planned, in order"),
                ),
                (
                    "tare_file",
                    nullable(string("tare file used instead of a tare run")),
                ),
                ("base_joints_m", joints("base joints in B, m")),
                ("plate_joints_m", joints("plate joints in P, m")),
                ("stroke_m", numbers(2, "shortest and longest leg, m")),
                (
                    "home_height_m",
                    nullable(num("the home height given, m (null: mid-stroke)")),
                ),
                (
                    "imu_calibration_toml",
                    nullable(string("the IMU calibration applied, as its file's TOML")),
                ),
                (
                    "load_cell_calibration_toml",
                    nullable(string(
                        "the load cells' gains applied, as their file's TOML",
                    )),
                ),
            ],
            "What was run, with the configuration needed to run it again",
        )
    }
}

/// The estimator's settings for one measurement: every field of `estimator::EstimatorConfig`
/// except the geometry (in [`RunMetadata`]), plus how the pose fed to it was obtained.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorSettings {
    /// Measurement (`tare` or `loaded`).
    pub run: String,
    /// `full` (10) or `inertia_about_known_com` (the paper's 6).
    pub parameters: String,
    /// Known mass for the 6-parameter model, kg.
    pub known_mass_kg: Option<f64>,
    /// Known centre of mass for the 6-parameter model, in P, m.
    pub known_com_m: Option<[f64; 3]>,
    /// Nominal sample period, s.
    pub sample_period_s: f64,
    /// Low-pass cut-off, Hz (`null`: none).
    pub lowpass_cutoff_hz: Option<f64>,
    /// RLS forgetting factor.
    pub forgetting_factor: f64,
    /// Expected noise of each equation, [Fx, Fy, Fz] N, [τx, τy, τz] N·m.
    pub equation_sigma: [f64; 6],
    /// Prior one-sigma of every parameter.
    pub prior_sigma: f64,
    /// Accelerometer mounting point in P, m.
    pub accelerometer_position_m: [f64; 3],
    /// Samples before this backend time only warm the conditioning, s (`null`: −∞).
    pub window_start_s: Option<f64>,
    /// Samples after this backend time are ignored, s (`null`: +∞).
    pub window_end_s: Option<f64>,
    /// A longer step between samples restarts the conditioning, s.
    pub max_gap_s: f64,
    /// Largest relative error of the nominal sample rate the timestamps may show before the
    /// conditioning takes the measured period ([`estimator::timebase`]); a log without it was
    /// estimated with the estimator's default, 1e-4.
    #[serde(default = "default_max_rate_error")]
    pub max_rate_error: f64,
    /// Samples per half-block of the covariance estimate's residual windows (a log
    /// that names it `covariance_block_samples` estimates too).
    #[serde(alias = "covariance_block_samples")]
    pub covariance_half_block_samples: u32,
    /// Gyro white noise per sample for the errors-in-variables correction, rad/s (0: off).
    #[serde(default)]
    pub gyro_noise_rad_s: f64,
    /// Accelerometer white noise per sample for that correction, m/s² (0: off).
    #[serde(default)]
    pub accel_noise_m_s2: f64,
    /// Forward kinematics tolerance, m. The pose of each sample is the FK of its measured leg
    /// lengths, warm-started from the previous sample's solution, the first sample of the run
    /// from the geometry's home pose.
    pub fk_tolerance_m: f64,
    /// Forward kinematics iteration limit.
    pub fk_max_iterations: u32,
    /// Forward kinematics: largest accepted jump from the warm start, m.
    pub fk_max_jump_m: f64,
    /// Forward kinematics: largest accepted rotation from the warm start, rad.
    pub fk_max_jump_rad: f64,
    /// The legs the estimator compensated (`[legs]` figures; `null`: none).
    #[serde(default)]
    pub legs: Option<rig_description::config::LegsConfig>,
    /// The site's gravity that the readings before the window are held against for the
    /// accelerometer's offset, m/s² (0: no offset measured).
    #[serde(default)]
    pub local_gravity_m_s2: f64,
}

impl EstimatorSettings {
    /// JSON schema (`stewart.EstimatorSettings` on `/run/estimator`).
    pub fn schema() -> Schema {
        object(
            vec![
                ("run", string("tare or loaded")),
                ("parameters", string("full or inertia_about_known_com")),
                (
                    "known_mass_kg",
                    nullable(num("known mass (6-parameter model), kg")),
                ),
                (
                    "known_com_m",
                    nullable(numbers(3, "known centre of mass (6-parameter model), P, m")),
                ),
                ("sample_period_s", num("s")),
                ("lowpass_cutoff_hz", nullable(num("Hz; null = no filter"))),
                ("forgetting_factor", num("RLS lambda")),
                (
                    "equation_sigma",
                    numbers(6, "Fx, Fy, Fz (N), τx, τy, τz (N·m)"),
                ),
                ("prior_sigma", num("prior sigma of every parameter, SI")),
                ("accelerometer_position_m", numbers(3, "P, m")),
                (
                    "window_start_s",
                    nullable(num("backend time, s; null = -inf")),
                ),
                (
                    "window_end_s",
                    nullable(num("backend time, s; null = +inf")),
                ),
                ("max_gap_s", num("s")),
                (
                    "max_rate_error",
                    num("largest relative sample-rate error before the measured period is used"),
                ),
                ("covariance_half_block_samples", int("")),
                (
                    "gyro_noise_rad_s",
                    num("gyro noise per sample for the errors-in-variables correction, rad/s; 0 = off"),
                ),
                (
                    "accel_noise_m_s2",
                    num("accelerometer noise per sample for that correction, m/s^2; 0 = off"),
                ),
                ("fk_tolerance_m", num("forward kinematics tolerance, m")),
                (
                    "fk_max_iterations",
                    int("forward kinematics iteration limit"),
                ),
                (
                    "fk_max_jump_m",
                    num("largest accepted FK jump from the warm start, m"),
                ),
                (
                    "fk_max_jump_rad",
                    num("largest accepted FK rotation from the warm start, rad"),
                ),
                ("legs", nullable(legs_schema())),
                (
                    "local_gravity_m_s2",
                    num("the site's gravity for the accelerometer's offset at rest, m/s^2; 0 = off"),
                ),
            ],
            "Estimator settings of one measurement: enough to re-run it from /sensors",
        )
    }

    /// Captures `config` (and the FK options) for measurement `run`.
    pub fn from_config(
        run: &str,
        c: &estimator::EstimatorConfig,
        fk: &kinematics::FkOptions,
    ) -> Self {
        let (parameters, known_mass_kg, known_com_m) = match c.parameters {
            estimator::ParameterSet::Full => ("full", None, None),
            estimator::ParameterSet::InertiaAboutKnownCom { mass_kg, com_m } => (
                "inertia_about_known_com",
                Some(mass_kg),
                Some([com_m.x, com_m.y, com_m.z]),
            ),
        };
        let finite = |v: f64| v.is_finite().then_some(v);
        Self {
            run: run.into(),
            parameters: parameters.into(),
            known_mass_kg,
            known_com_m,
            sample_period_s: c.sample_period_s,
            lowpass_cutoff_hz: c.lowpass_cutoff_hz,
            forgetting_factor: c.forgetting_factor,
            equation_sigma: c.equation_sigma.into(),
            prior_sigma: c.prior_sigma,
            accelerometer_position_m: c.accelerometer_position_m.into(),
            window_start_s: finite(c.window_start_s),
            window_end_s: finite(c.window_end_s),
            max_gap_s: c.max_gap_s,
            max_rate_error: c.max_rate_error,
            covariance_half_block_samples: c.covariance_half_block_samples,
            gyro_noise_rad_s: c.gyro_noise_rad_s,
            accel_noise_m_s2: c.accel_noise_m_s2,
            fk_tolerance_m: fk.tolerance_m,
            fk_max_iterations: fk.max_iterations,
            fk_max_jump_m: fk.max_jump_m,
            fk_max_jump_rad: fk.max_jump_rad,
            legs: c
                .legs
                .as_ref()
                .map(rig_description::config::LegsConfig::from_model),
            local_gravity_m_s2: c.local_gravity_m_s2,
        }
    }

    /// Rebuilds the estimator configuration for `geometry` (inverse of [`Self::from_config`]).
    pub fn to_config(
        &self,
        geometry: kinematics::Geometry,
    ) -> Result<(estimator::EstimatorConfig, kinematics::FkOptions)> {
        let parameters = match (&self.parameters[..], self.known_mass_kg, self.known_com_m) {
            ("full", _, _) => estimator::ParameterSet::Full,
            ("inertia_about_known_com", Some(m), Some(c)) => {
                estimator::ParameterSet::InertiaAboutKnownCom {
                    mass_kg: m,
                    com_m: Vector3::from(c),
                }
            }
            (other, _, _) => bail!("unknown or incomplete parameter set `{other}`"),
        };
        let mut c = estimator::EstimatorConfig::new(geometry, self.sample_period_s);
        c.lowpass_cutoff_hz = self.lowpass_cutoff_hz;
        c.forgetting_factor = self.forgetting_factor;
        c.parameters = parameters;
        c.equation_sigma = Vector6::from(self.equation_sigma);
        c.prior_sigma = self.prior_sigma;
        c.accelerometer_position_m = Vector3::from(self.accelerometer_position_m);
        c.window_start_s = self.window_start_s.unwrap_or(f64::NEG_INFINITY);
        c.window_end_s = self.window_end_s.unwrap_or(f64::INFINITY);
        c.max_gap_s = self.max_gap_s;
        c.max_rate_error = self.max_rate_error;
        c.covariance_half_block_samples = self.covariance_half_block_samples;
        c.gyro_noise_rad_s = self.gyro_noise_rad_s;
        c.accel_noise_m_s2 = self.accel_noise_m_s2;
        c.legs = self.legs.as_ref().map(|l| l.model());
        c.local_gravity_m_s2 = self.local_gravity_m_s2;
        let fk = kinematics::FkOptions {
            tolerance_m: self.fk_tolerance_m,
            max_iterations: self.fk_max_iterations,
            max_jump_m: self.fk_max_jump_m,
            max_jump_rad: self.fk_max_jump_rad,
        };
        Ok((c, fk))
    }
}

/// The `[legs]` table as the log carries it.
/// `max_rate_error` of a log that does not record it: the estimator's default then.
fn default_max_rate_error() -> f64 {
    estimator::DEFAULT_MAX_RATE_ERROR
}

fn legs_schema() -> Schema {
    object(
        vec![
            ("load_cell_end", string("plate or base")),
            ("cylinder_mass_kg", num("kg")),
            ("cylinder_com_from_base_m", num("m")),
            (
                "cylinder_inertia_kg_m2",
                num("transverse, about its centre of mass, kg m^2"),
            ),
            ("rod_mass_kg", num("kg")),
            ("rod_com_from_plate_m", num("m")),
            (
                "rod_inertia_kg_m2",
                num("transverse, about its centre of mass, kg m^2"),
            ),
            ("joint_coulomb_torque_nm", num("N m")),
            ("joint_viscous_nm_s_per_rad", num("N m s/rad")),
            ("mass_tolerance", num("relative, one sigma")),
            ("com_tolerance_m", num("m, one sigma")),
            ("inertia_tolerance", num("relative, one sigma")),
            ("friction_tolerance", num("relative, one sigma")),
        ],
        "The legs the estimator compensated (rig description's [legs])",
    )
}

/// A body's true properties, both ways.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyTruth {
    /// kg.
    pub mass_kg: f64,
    /// Centre of mass in P, m.
    pub com_m: [f64; 3],
    /// J_C, P axes, kg·m².
    pub inertia_com_kg_m2: [[f64; 3]; 3],
    /// θ about the P origin.
    pub theta: [f64; 10],
}

impl BodyTruth {
    fn schema(d: &'static str) -> Schema {
        object(
            vec![
                ("mass_kg", num("kg")),
                ("com_m", numbers(3, "P, m")),
                (
                    "inertia_com_kg_m2",
                    array(numbers(3, ""), Some(3), "J_C, P axes, kg·m²"),
                ),
                ("theta", numbers(10, "about the P origin, P axes")),
            ],
            d,
        )
    }
}

/// `stewart.Truth` on `/run/truth` (simulation only).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthMsg {
    /// The plate and fixture.
    pub fixture: BodyTruth,
    /// The payload.
    pub payload: BodyTruth,
    /// The whole simulated world (`[world]`: bodies, actuators, seed) as TOML.
    #[serde(default)]
    pub world_toml: String,
}

impl TruthMsg {
    /// JSON schema.
    pub fn schema() -> Schema {
        object(
            vec![
                ("fixture", BodyTruth::schema("plate and fixture")),
                ("payload", BodyTruth::schema("the payload")),
                (
                    "world_toml",
                    string("the simulated world ([world]: bodies, actuators, seed) as TOML"),
                ),
            ],
            "The simulator's ground truth; never read by the estimator",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every estimator setting survives the log (JSON) and comes back as the same
    /// configuration, which `stewart estimate` needs to reproduce a run.
    #[test]
    fn estimator_settings_round_trip_through_json() {
        let geometry = kinematics::Geometry::from_radii(
            1.5,
            1.2,
            0.3,
            0.3,
            kinematics::StrokeLimits {
                min_length_m: 1.6,
                max_length_m: 2.4,
            },
        )
        .unwrap();
        let mut c = estimator::EstimatorConfig::new(geometry, 1e-3);
        c.lowpass_cutoff_hz = Some(17.25);
        c.forgetting_factor = 0.999_9;
        c.equation_sigma = Vector6::new(1.0, 2.0, 3.0, 0.1, 0.2, 0.3);
        c.prior_sigma = 3e3;
        c.accelerometer_position_m = Vector3::new(0.01, -0.02, 0.1);
        c.window_start_s = 1.234;
        c.window_end_s = 61.234;
        c.max_gap_s = 0.0123;
        c.max_rate_error = 2.5e-4;
        c.gyro_noise_rad_s = 1.7e-4;
        c.accel_noise_m_s2 = 2.3e-3;
        c.covariance_half_block_samples = 321;
        c.legs = Some(estimator::LegModel {
            cell_end: estimator::CellEnd::Base,
            cylinder_mass_kg: 28.5,
            cylinder_com_from_base_m: 0.45,
            cylinder_inertia_kg_m2: 2.75,
            rod_mass_kg: 12.25,
            rod_com_from_plate_m: 0.5,
            rod_inertia_kg_m2: 1.125,
            joint_coulomb_torque_nm: 0.75,
            joint_viscous_nm_s_per_rad: 5.5,
        });
        c.parameters = estimator::ParameterSet::InertiaAboutKnownCom {
            mass_kg: 1900.0,
            com_m: Vector3::new(0.1, 0.2, 0.45),
        };
        let fk = kinematics::FkOptions::default();
        let s = EstimatorSettings::from_config("loaded", &c, &fk);
        let json = serde_json::to_value(&s).unwrap();
        EstimatorSettings::schema().check(&json).unwrap();
        let back: EstimatorSettings = serde_json::from_value(json.clone()).unwrap();
        let (c2, fk2) = back.to_config(geometry).unwrap();
        assert_eq!(c2, c);
        assert_eq!(fk2, fk);
        // A log naming the half-block length `covariance_block_samples` keeps its length.
        let mut old = json;
        let samples = old["covariance_half_block_samples"].take();
        let object = old.as_object_mut().unwrap();
        object.remove("covariance_half_block_samples");
        object.insert("covariance_block_samples".into(), samples);
        let back: EstimatorSettings = serde_json::from_value(old).unwrap();
        assert_eq!(back.covariance_half_block_samples, 321);
    }
}
