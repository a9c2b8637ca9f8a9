//! The simulated world: what `stewart simulate`, `emulate` and `bench` put behind the rig
//! description —
//! the true fixture and payload, the actuator model, the physics step and the seed of every
//! random draw — read from a scenario file's `[world]` table, and the simulator built from it.
//!
//! The simulated sensors draw their errors from the rig description's datasheet
//! (`[sensors.*]`): the estimator and the simulator read the same figures, as a real rig's
//! sensors are what their datasheet says to within its sigmas. The estimator never sees this
//! module's truth.

use serde::{Deserialize, Serialize};

use rig_description::load::{ConfigError, LoadedConfig, WORLD_TABLE};
use rig_description::quantities::Quantities;
use rig_description::sources::ErrorSource;
use rig_description::validate::Problems;

use crate::NoisePreset;

/// A rigid body's inertial properties, given the way a datasheet or CAD gives them: mass, centre
/// of mass in P, inertia tensor about the centre of mass in P axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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

impl BodyConfig {
    /// As the simulator's body description.
    pub fn to_sim(self) -> crate::BodyProperties {
        crate::BodyProperties {
            mass_kg: self.mass_kg,
            com_m: self.com_m,
            inertia_com_kg_m2: self.inertia_com_kg_m2,
        }
    }

    /// As the report's quantities (the truth column).
    pub fn quantities(self) -> Quantities {
        Quantities {
            mass: self.mass_kg,
            com: self.com_m,
            inertia_com: self.inertia_com_kg_m2,
        }
    }
}

/// The most physics substeps per sample (`world.physics_substeps`). The lowest sample rate
/// the rig description admits (100 Hz) needs 10 for the 1 ms step; 64 leaves room for a finer
/// step, while each substep costs a whole physics step per sample, so a count like 10⁹ would
/// run a single sample for hours.
pub const MAX_PHYSICS_SUBSTEPS: u32 = 64;

/// The `[world]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Seed of every random draw (sensor errors and noise); `--seed` overrides it.
    pub seed: u64,
    /// Physics substeps per sample (substep ≤ 1 ms), 1 to [`MAX_PHYSICS_SUBSTEPS`].
    pub physics_substeps: u32,
    /// The plate and the fixture that holds the payload (always on the platform).
    pub fixture: BodyConfig,
    /// The body to be measured.
    pub payload: BodyConfig,
    /// The reference body of the load cells' calibration (`stewart simulate
    /// --calibrate-load-cells`), put on in place of the payload; its mass is the rig
    /// description's `calibration.reference_mass_kg` to within its tolerance, its centre of mass
    /// and inertia unknown to the estimator. Omitted: [`default_reference`].
    #[serde(default = "default_reference")]
    pub reference: BodyConfig,
    /// The actuators between command and leg force.
    pub actuator: crate::ActuatorConfig,
    /// Which of a real rig's error sources the simulated rig has.
    #[serde(default)]
    pub imperfections: crate::Imperfections,
    /// The payload as a car body on its suspension (off by default).
    #[serde(default)]
    pub suspension: crate::SuspensionConfig,
}

/// The default reference body: a 1000 kg steel block of 1.2 × 0.8 × 0.13 m, its centre of mass
/// 0.2 m above the plate and a little off its centre (a real weight is never placed exactly).
pub fn default_reference() -> BodyConfig {
    BodyConfig {
        mass_kg: 1000.0,
        com_m: [0.04, -0.03, 0.2],
        inertia_com_kg_m2: [[54.7, 0.0, 0.0], [0.0, 121.4, 0.0], [0.0, 0.0, 173.3]],
    }
}

/// A rig description with the simulated world behind it.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The rig description (its datasheet scaled by the grade).
    pub loaded: LoadedConfig,
    /// The simulated world.
    pub world: World,
    /// The sensors' grade: the rig description's datasheet as written (`realistic`), scaled
    /// to ideal (`none`) or ten times worse (`harsh`), and the joints' tolerance
    /// (`platform.joint_position_tolerance_m`) with it. Both the rig description the estimator
    /// reads and the simulated rig follow it, so the estimator knows what it is given.
    pub noise: NoisePreset,
}

impl Scenario {
    /// The world of `loaded` with `seed` and `noise` applied, checked.
    pub fn new(
        mut loaded: LoadedConfig,
        seed: Option<u64>,
        noise: Option<NoisePreset>,
    ) -> Result<Self, ConfigError> {
        let mut world: World = loaded.section(WORLD_TABLE)?;
        if let Some(s) = seed {
            world.seed = s;
        }
        let noise = noise.unwrap_or(NoisePreset::Realistic);
        loaded.config.sensors = loaded.config.sensors.scaled(noise.scale());
        // The grade is the whole rig's: the joints' tolerance follows the sensors'.
        loaded.config.platform.joint_position_tolerance_m *= noise.scale();
        let legs = &mut loaded.config.legs;
        legs.mass_tolerance *= noise.scale();
        legs.com_tolerance_m *= noise.scale();
        legs.inertia_tolerance *= noise.scale();
        legs.friction_tolerance *= noise.scale();
        let problems = validate(&world, loaded.config.sensors.sample_rate_hz);
        if !problems.is_empty() {
            return Err(ConfigError {
                issues: problems
                    .into_iter()
                    .map(|(key, problem)| loaded.issue(&key, problem))
                    .collect(),
            });
        }
        Ok(Self {
            loaded,
            world,
            noise,
        })
    }

    /// The simulator's settings: the world's physics and actuators, sensors drawing from the
    /// rig description's datasheet, each error source's figures zero when
    /// `[world.imperfections]` switches it off (`noise`: white noise, quantisation and the gyro's
    /// bias; `load_cell_offset`: zero offset and drift, per minute in the description, per
    /// second here; `imu_misalignment`: the axes' rotation and both scale errors).
    pub fn sim_config(&self) -> crate::SimConfig {
        let s = &self.loaded.config.sensors;
        let on = |source: ErrorSource, figure: f64| {
            if self.world.imperfections.is_on(source) {
                figure
            } else {
                0.0
            }
        };
        let noise = |figure| on(ErrorSource::Noise, figure);
        let sensors = crate::SensorConfig {
            leg_length: crate::LegLengthSensorConfig {
                noise_sigma_m: noise(s.encoder.noise_m),
                resolution_m: noise(s.encoder.resolution_m),
            },
            load_cell: crate::LoadCellConfig {
                noise_sigma_n: noise(s.load_cell.noise_n),
                bias_sigma_n: on(ErrorSource::LoadCellOffset, s.load_cell.zero_offset_n),
                resolution_n: noise(s.load_cell.resolution_n),
                gain_sigma: on(ErrorSource::LoadCellScale, s.load_cell.gain_error),
                transverse_sigma: on(
                    ErrorSource::LoadCellCrosstalk,
                    s.load_cell.transverse_sensitivity,
                ),
                drift_sigma_n_s: on(
                    ErrorSource::LoadCellOffset,
                    s.load_cell.zero_drift_n_per_min / 60.0,
                ),
            },
            gyro: crate::GyroConfig {
                noise_density_rad_s_sqrt_hz: noise(s.gyro_density_rad_s_sqrt_hz()),
                bias_sigma_rad_s: noise(s.gyro.bias_rad_s),
                scale_sigma: on(ErrorSource::ImuMisalignment, s.gyro.scale_error),
            },
            accelerometer: crate::AccelerometerConfig {
                noise_density_m_s2_sqrt_hz: noise(s.accel_density_m_s2_sqrt_hz()),
                bias_sigma_m_s2: on(ErrorSource::AccelBias, s.accelerometer.bias_m_s2),
                scale_sigma: on(ErrorSource::ImuMisalignment, s.accelerometer.scale_error),
                mount_m: s.imu.position_m,
                mount_sigma_m: on(ErrorSource::ImuLeverArm, s.imu.position_tolerance_m),
            },
            imu: crate::ImuAxesConfig {
                orientation_deg: s.imu.orientation_deg,
                misalignment_sigma_deg: on(ErrorSource::ImuMisalignment, s.imu.misalignment_deg),
            },
            timing: crate::TimingConfig {
                imu_skew_sigma_s: on(ErrorSource::TimeSkew, s.timing.imu_skew_s),
                jitter_sigma_s: on(ErrorSource::TimestampJitter, s.timing.sampling_jitter_s),
                frame_loss: on(ErrorSource::FrameLoss, s.timing.frame_loss),
            },
        };
        let legs = self.built_legs();
        crate::SimConfig {
            sample_rate_hz: s.sample_rate_hz,
            substeps: self.world.physics_substeps,
            actuator: self.world.actuator,
            sensors,
            legs,
            suspension: self.world.suspension,
            ..crate::SimConfig::default()
        }
    }

    /// The legs as built from the rig description's `[legs]`. The estimator compensates the
    /// described legs, so what it cannot know is how far the built ones differ: with the
    /// `leg_dynamics` source on, each mass and inertia is scaled by 1 + N(0, σ²) (σ the
    /// `mass_tolerance`, `inertia_tolerance`) and each centre of mass moved by N(0, σ²)
    /// (`com_tolerance_m`), all six legs alike (one drawing), drawn from the seed's
    /// `leg_dynamics` stream in the order cylinder mass, centre, inertia, rod mass, centre,
    /// inertia; with `joint_friction` on, the Coulomb and viscous figures are scaled alike
    /// from the `joint_friction` stream (`friction_tolerance`). A source off leaves its figures
    /// as described. Figures stay non-negative.
    pub fn built_legs(&self) -> rig_description::config::LegsConfig {
        use crate::streams::{normal, stream};
        let described = self.loaded.config.legs;
        let mut legs = described;
        let seed = self.world.seed;
        let imperfections = &self.world.imperfections;
        if imperfections.leg_dynamics {
            let mut rng = stream(seed, ErrorSource::LegDynamics);
            let mut scaled = |x: f64, tol: f64| (x * (1.0 + normal(&mut rng, tol))).max(0.0);
            legs.cylinder_mass_kg = scaled(described.cylinder_mass_kg, described.mass_tolerance);
            let d = scaled(1.0, described.com_tolerance_m) - 1.0;
            legs.cylinder_com_from_base_m = (described.cylinder_com_from_base_m + d).max(0.0);
            legs.cylinder_inertia_kg_m2 = scaled(
                described.cylinder_inertia_kg_m2,
                described.inertia_tolerance,
            );
            legs.rod_mass_kg = scaled(described.rod_mass_kg, described.mass_tolerance);
            let d = scaled(1.0, described.com_tolerance_m) - 1.0;
            legs.rod_com_from_plate_m = (described.rod_com_from_plate_m + d).max(0.0);
            legs.rod_inertia_kg_m2 =
                scaled(described.rod_inertia_kg_m2, described.inertia_tolerance);
        }
        if imperfections.joint_friction {
            let mut rng = stream(seed, ErrorSource::JointFriction);
            let k = (1.0 + normal(&mut rng, described.friction_tolerance)).max(0.0);
            legs.joint_coulomb_torque_nm = described.joint_coulomb_torque_nm * k;
            let k = (1.0 + normal(&mut rng, described.friction_tolerance)).max(0.0);
            legs.joint_viscous_nm_s_per_rad = described.joint_viscous_nm_s_per_rad * k;
        }
        legs
    }

    /// The rig as built from the `described` geometry: with the `geometry` source on, each of
    /// the 12 joints moved by `N(0, σ²)` per coordinate, `σ` = `platform.joint_position_tolerance_m`
    /// (default 0.2 mm: a welded and machined frame surveyed with a laser tracker), drawn from
    /// the seed's `geometry` stream (base joints 0–5, then plate joints 0–5, x, y, z each);
    /// the stroke limits are the described ones. Otherwise `described` itself. The simulator
    /// runs on the built rig, the controller and the estimator on the described one.
    pub fn built_geometry(
        &self,
        described: &kinematics::Geometry,
    ) -> Result<kinematics::Geometry, ConfigError> {
        let sigma = self.loaded.config.platform.joint_position_tolerance_m;
        if !self.world.imperfections.geometry || sigma == 0.0 {
            return Ok(*described);
        }
        let mut rng = crate::streams::stream(self.world.seed, ErrorSource::Geometry);
        let mut moved = |joints: &[nalgebra::Vector3<f64>; 6]| {
            joints.map(|p| {
                p + nalgebra::Vector3::from_fn(|_, _| crate::streams::normal(&mut rng, sigma))
            })
        };
        let base = moved(described.base_joints_m());
        let plate = moved(described.plate_joints_m());
        described.with_joints(base, plate).map_err(|e| {
            ConfigError::single(self.loaded.issue(
                "platform.joint_position_tolerance_m",
                format!(
                    "the rig built with this tolerance (seed {}) is refused: {e}",
                    self.world.seed
                ),
            ))
        })
    }

    /// The simulator on the rig built from `geometry` ([`Self::built_geometry`]) with the
    /// payload on or off, refused (naming the key) when the simulator does not accept the world.
    pub fn simulator(
        &self,
        geometry: kinematics::Geometry,
        payload_on: bool,
    ) -> Result<crate::Simulator, ConfigError> {
        crate::Simulator::new(
            self.built_geometry(&geometry)?,
            self.world.fixture.to_sim(),
            payload_on.then(|| self.world.payload.to_sim()),
            &self.sim_config(),
            self.world.seed,
        )
        .map_err(|e| ConfigError::single(self.sim_issue(&e)))
    }

    /// Maps a simulator refusal to the key it names.
    fn sim_issue(&self, e: &crate::SimError) -> rig_description::ConfigIssue {
        let loaded = &self.loaded;
        match e {
            crate::SimError::InvalidConfig {
                field,
                reason,
                value,
            } => {
                let key = if let Some(rest) = field.strip_prefix("actuator.") {
                    format!("world.actuator.{rest}")
                } else if *field == "substeps" {
                    "world.physics_substeps".to_string()
                } else if let Some(rest) = field.strip_prefix("suspension.") {
                    format!("world.suspension.{rest}")
                } else if field.starts_with("legs.") {
                    field.to_string()
                } else if field.starts_with("sensors.") {
                    "sensors".to_string()
                } else {
                    "platform".to_string()
                };
                loaded.issue(
                    &key,
                    format!("refused by the simulator: {reason} (value {value})"),
                )
            }
            crate::SimError::InvalidBody { body, reason } => {
                let key = if *body == "fixture" {
                    "world.fixture"
                } else {
                    "world.payload"
                };
                loaded.issue(key, format!("refused by the simulator: {reason}"))
            }
            other => loaded.issue("platform", format!("refused by the simulator: {other}")),
        }
    }

    /// The world as TOML, for the log.
    pub fn world_toml(&self) -> String {
        toml::to_string(&self.world).unwrap_or_default()
    }
}

/// Range problems of the world, as (dotted key, what is wrong).
fn validate(world: &World, sample_rate_hz: f64) -> Vec<(String, String)> {
    let mut p = Problems::default();
    body(&mut p, "world.fixture", &world.fixture);
    body(&mut p, "world.payload", &world.payload);
    body(&mut p, "world.reference", &world.reference);
    if let Err(e) = world.actuator.validate() {
        match e {
            crate::SimError::InvalidConfig {
                field,
                value,
                reason,
            } => p.push(format!("world.{field}"), format!("{reason}, got {value}")),
            other => p.push("world.actuator", other.to_string()),
        }
    }
    let substeps = world.physics_substeps;
    let substep_s = 1.0 / (sample_rate_hz * f64::from(substeps.max(1)));
    if substeps == 0 || substep_s > 1e-3 * (1.0 + 1e-12) || substeps > MAX_PHYSICS_SUBSTEPS {
        p.push(
            "world.physics_substeps",
            format!(
                "must be between 1 and {MAX_PHYSICS_SUBSTEPS} and make the physics step 1/(sensors.sample_rate_hz·physics_substeps) at most 1 ms, got {substeps}"
            ),
        );
    }
    p.0
}

/// Checks a body's mass, centre of mass and inertia tensor for physical consistency.
fn body(p: &mut Problems, section: &str, b: &BodyConfig) {
    p.positive(&format!("{section}.mass_kg"), b.mass_kg);
    p.finite3(&format!("{section}.com_m"), &b.com_m, 10.0);
    let key = format!("{section}.inertia_com_kg_m2");
    let j = &b.inertia_com_kg_m2;
    let mut finite = true;
    for (r, row) in j.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            if !v.is_finite() {
                p.push(
                    format!("{key}[{r}][{c}]"),
                    format!("must be finite, got {v}"),
                );
                finite = false;
            }
        }
    }
    if !finite {
        return;
    }
    let scale = j[0][0]
        .abs()
        .max(j[1][1].abs())
        .max(j[2][2].abs())
        .max(1e-12);
    for (r, c) in [(0, 1), (0, 2), (1, 2)] {
        if (j[r][c] - j[c][r]).abs() > 1e-9 * scale {
            p.push(
                format!("{key}[{r}][{c}]"),
                format!(
                    "the tensor must be symmetric: [{r}][{c}] = {} but [{c}][{r}] = {}",
                    j[r][c], j[c][r]
                ),
            );
            return;
        }
    }
    let m = nalgebra::Matrix3::from_fn(|r, c| j[r][c]);
    let eig = m.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if lo <= 0.0 {
        p.push(
            key,
            format!("must be positive definite (principal moments {eig:?} kg·m²)"),
        );
        return;
    }
    // A real body's principal moments obey the triangle inequality I1 + I2 ≥ I3.
    let sum = eig.sum();
    if 2.0 * hi > sum * (1.0 + 1e-9) {
        p.push(
            key,
            format!(
                "is not a physical body: principal moments {:.4}, {:.4}, {:.4} kg·m² break \
                 the triangle inequality (the largest must not exceed the sum of the others)",
                eig[0], eig[1], eig[2]
            ),
        );
    }
}

#[cfg(test)]
mod tests;
