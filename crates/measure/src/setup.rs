//! Turning a validated [`Config`] into the cores' settings, with the checks that need the
//! kinematics — a singular or unbuildable design, a trajectory that leaves the stroke, moves a
//! leg too fast or passes near a singularity — all before anything moves. Every refusal names
//! the file, the key and what is wrong.

use control::controller::ControllerConfig;
use control::pid::{AntiWindup, PidConfig};
use control::supervisor::SupervisorConfig;
use control::trajectory::{
    Axis, FeasibilityLimits, MultiSineConfig, SineComponent, Spectrum, Trajectory,
};
use control::ControlError;
use kinematics::{FkOptions, Geometry};
use nalgebra::{Vector3, Vector6};
pub use rig_description::derived::{accelerometer_position, geometry};

use rig_description::config::{AxisName, Config, ExcitationKind, ParamCount, SpectrumConfig};
use rig_description::load::{ConfigError, ConfigIssue, LoadedConfig};

/// The tare run's excitation (`[tare_excitation]` when given, else `[excitation]`;
/// `run.tare_duration_s` long), refusals said of those keys.
pub fn tare_trajectory(
    loaded: &LoadedConfig,
    geometry: &Geometry,
) -> Result<Trajectory, ConfigError> {
    let duration_s = loaded.config.run.tare_duration_s;
    let own = loaded.config.tare_excitation.as_ref();
    let result = match own {
        Some(tare) => {
            let mut moved = loaded.clone();
            moved.config.excitation = tare.clone();
            trajectory(&moved, geometry, duration_s)
        }
        None => trajectory(loaded, geometry, duration_s),
    };
    result.map_err(|mut e| {
        for issue in &mut e.issues {
            if issue.key == "run.duration_s" {
                issue.key = "run.tare_duration_s".into();
            } else if let Some(rest) = issue.key.strip_prefix("excitation") {
                if own.is_some() {
                    issue.key = format!("tare_excitation{rest}");
                }
            }
        }
        e
    })
}

/// The excitation of the loaded (or tare) run, lasting `duration_s` including the fades,
/// about the geometry's home pose.
pub fn trajectory(
    loaded: &LoadedConfig,
    geometry: &Geometry,
    duration_s: f64,
) -> Result<Trajectory, ConfigError> {
    let e = &loaded.config.excitation;
    let home = geometry.home_pose();
    let result = match e.kind {
        ExcitationKind::Multisine => {
            let m = &e.multisine;
            let t = m.peak_translation_m;
            let r = m.peak_rotation_deg.map(f64::to_radians);
            Trajectory::multisine(
                home,
                &MultiSineConfig {
                    base_frequency_hz: m.base_frequency_hz,
                    harmonics_per_axis: m.harmonics_per_axis as usize,
                    peak_amplitudes: [t[0], t[1], t[2], r[0], r[1], r[2]],
                    duration_s,
                    fade_in_s: e.fade_s,
                    fade_out_s: e.fade_out(),
                    spectrum: match m.spectrum {
                        SpectrumConfig::FlatPosition => Spectrum::FlatPosition,
                        SpectrumConfig::FlatVelocity => Spectrum::FlatVelocity,
                    },
                },
            )
        }
        ExcitationKind::Sines => {
            let components: Vec<SineComponent> = e
                .sines
                .iter()
                .map(|s| SineComponent {
                    axis: match s.axis {
                        AxisName::X => Axis::X,
                        AxisName::Y => Axis::Y,
                        AxisName::Z => Axis::Z,
                        AxisName::Roll => Axis::Roll,
                        AxisName::Pitch => Axis::Pitch,
                        AxisName::Yaw => Axis::Yaw,
                    },
                    amplitude: match (s.amplitude_deg, s.amplitude_m) {
                        (Some(d), _) => d.to_radians(),
                        (None, Some(m)) => m,
                        (None, None) => 0.0,
                    },
                    frequency_hz: s.frequency_hz,
                    phase_rad: s.phase_deg.to_radians(),
                })
                .collect();
            Trajectory::new(home, &components, duration_s, e.fade_s, e.fade_out())
        }
    };
    result.map_err(|err| ConfigError::single(trajectory_issue(loaded, &err)))
}

/// The key of the excitation's amplitudes, for messages.
fn amplitude_key(config: &Config) -> &'static str {
    match config.excitation.kind {
        ExcitationKind::Multisine => "excitation.multisine",
        ExcitationKind::Sines => "excitation.sines",
    }
}

fn trajectory_issue(loaded: &LoadedConfig, e: &ControlError) -> ConfigIssue {
    let amplitudes = amplitude_key(&loaded.config);
    let (key, problem) = match e {
        ControlError::StrokeViolation { .. } => (
            amplitudes,
            format!(
                "unreachable trajectory: {e} (platform stroke {}–{} m less excitation.stroke_margin_m): \
                 lower the amplitudes",
                loaded.config.platform.min_leg_length_m, loaded.config.platform.max_leg_length_m
            ),
        ),
        ControlError::LegSpeedViolation { .. } => (
            amplitudes,
            format!(
                "trajectory too fast for excitation.max_leg_speed_m_s: {e}: lower the amplitudes or frequencies"
            ),
        ),
        ControlError::ConditioningViolation { .. } => (
            amplitudes,
            format!(
                "the trajectory passes too close to a singular pose (excitation.min_inverse_condition): {e}"
            ),
        ),
        ControlError::TooManyComponents { .. } => (amplitudes, e.to_string()),
        ControlError::InvalidConfig { parameter, reason } => {
            let key = match *parameter {
                p if p.contains("fade") => "excitation.fade_s",
                p if p.contains("duration") => "run.duration_s",
                _ => amplitudes,
            };
            (key, format!("{parameter} {reason}"))
        }
        _ => (amplitudes, e.to_string()),
    };
    loaded.issue(key, problem)
}

/// The controller's settings. `feedforward_n` is filled in per run from the braked static load.
pub fn controller_config(config: &Config) -> ControllerConfig {
    let c = &config.control;
    let e = &config.excitation;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let pid = PidConfig {
        kp: c.kp_n_per_m,
        ki: c.ki_n_per_m_s,
        kd: c.kd_n_s_per_m,
        derivative_filter_s: c.derivative_filter_s,
        output_min_n: -c.max_force_n,
        output_max_n: c.max_force_n,
        anti_windup: AntiWindup::BackCalculation {
            tracking_time_s: 0.02,
        },
    };
    let supervisor = SupervisorConfig {
        leg_length_margin_m: c.leg_length_margin_m,
        max_leg_speed_m_s: c.max_leg_speed_m_s,
        max_command_force_n: c.max_force_n,
        max_measured_force_n: c.max_measured_force_n,
        max_sample_gap_s: c.max_sample_gap_s,
        max_sensor_age_s: c.max_sample_gap_s,
        ..SupervisorConfig::default()
    };
    ControllerConfig {
        sample_period_s: period_s,
        settle_ramp_s: c.settle_ramp_s,
        settle_s: config.run.settle_s,
        park_s: config.run.park_s,
        park_hold_s: c.park_hold_s,
        pid,
        feedforward_n: [0.0; 6],
        supervisor,
        feasibility: FeasibilityLimits {
            stroke_margin_m: e.stroke_margin_m,
            max_leg_speed_m_s: e.max_leg_speed_m_s,
            min_inverse_condition: e.min_inverse_condition,
            step_s: period_s.min(1e-3),
        },
        fk: FkOptions::default(),
        ..ControllerConfig::default()
    }
}

/// Builds the controller for one `measurement`'s run, refusing (with the key) a configuration
/// or trajectory the control crate rejects — including the whole-trajectory feasibility check
/// and, with `control.inertial_feedforward`, whether the legs can drive the load as the rig
/// description gives it ([`feedforward_load`]) along the trajectory
/// ([`control::Controller::check_load_forces`]) — before anything is contacted or moves.
pub fn controller(
    loaded: &LoadedConfig,
    geometry: &Geometry,
    trajectory: Trajectory,
    measurement: Measurement,
) -> Result<control::controller::Controller, ConfigError> {
    let config = controller_config(&loaded.config);
    let controller =
        control::controller::Controller::new(*geometry, trajectory, config).map_err(|e| {
            let issue = match e {
                ControlError::InvalidConfig { parameter, reason } => {
                    let key = if parameter.starts_with("feasibility") {
                        "excitation"
                    } else {
                        "control"
                    };
                    loaded.issue(key, format!("{parameter} {reason}"))
                }
                other => trajectory_issue(loaded, &other),
            };
            ConfigError::single(issue)
        })?;
    // A run too short for a measured sigma is refused here, before its motion.
    let estimator = estimator_config(&loaded.config, geometry, measurement, 0.0, 0.0);
    crate::quality::check_excitation(
        measurement.name(),
        controller.trajectory().duration_s(),
        estimator.sample_period_s,
        estimator.covariance_half_block_samples,
    )
    .map_err(|e| {
        let key = match measurement {
            Measurement::Tare => "run.tare_duration_s",
            Measurement::Loaded => "run.duration_s",
        };
        ConfigError::single(loaded.issue(key, format!("refused before motion: {e}")))
    })?;
    // The loops must hold the braked load as the description gives it. Checked here, before
    // the log and the brake hold, so that such a rig is refused with nothing run; the hold's
    // measured forces are checked again when they are read.
    if let Some(load) = described_load(&loaded.config, measurement) {
        controller.check_hold(&load).map_err(|e| {
            ConfigError::single(loaded.issue(
                "control.ki_n_per_m_s",
                format!("refused before motion ({} run): {e}", measurement.name()),
            ))
        })?;
    }
    if let Some(load) = feedforward_load(&loaded.config, measurement, None) {
        controller.check_load_forces(&load).map_err(|e| {
            ConfigError::single(loaded.issue(
                amplitude_key(&loaded.config),
                format!("refused before motion ({} run): {e}", measurement.name()),
            ))
        })?;
    }
    Ok(controller)
}

/// One sigma of the accelerometer's bias, m/s²: the rig description's datasheet figure
/// (`sensors.accelerometer.bias_m_s2`). Zero for ideal sensors.
pub fn accel_bias_sigma(config: &Config) -> f64 {
    config.sensors.accelerometer.bias_m_s2
}

/// One sigma of each load cell's zero offset, N: the rig description's datasheet figure
/// (`sensors.load_cell.zero_offset_n`). Zero for ideal sensors.
pub fn load_cell_bias_sigma(config: &Config) -> f64 {
    config.sensors.load_cell.zero_offset_n
}

/// Whether the estimator fits the load cells' zero drift (`estimator::drift`): whenever their
/// datasheet gives one (`sensors.load_cell.zero_drift_n_per_min` > 0), since over a long run
/// the drift's mean moves the mass by more than the run's noise.
pub fn fits_load_cell_drift(config: &Config) -> bool {
    config.sensors.load_cell.zero_drift_n_per_min > 0.0
}

/// The tick of one `measurement` run by `controller` (checked beforehand): the frame-to-sample
/// rule with the controller's forward-kinematics options and the IMU's mounting, and the
/// estimator's settings, its fit window not yet open.
pub fn tick(
    config: &Config,
    geometry: &Geometry,
    measurement: Measurement,
    controller: control::controller::Controller,
) -> Result<crate::tick::Tick, estimator::EstimatorError> {
    let feed = crate::feed::Feed::new(*geometry, controller.config().fk, &config.sensors.imu)
        .aligned(
            config.calibration.imu_alignment(),
            1.0 / config.sensors.sample_rate_hz,
        )
        .with_load_cell_gains(config.calibration.load_cell_gains());
    let excitation_s = controller.trajectory().duration_s();
    let mut estimator = estimator_config(
        config,
        geometry,
        measurement,
        f64::NEG_INFINITY,
        f64::INFINITY,
    );
    // A short excitation gets blocks short enough for a measured sigma (the log records them).
    estimator.covariance_half_block_samples = crate::quality::half_block_samples_for(
        estimator.covariance_half_block_samples,
        excitation_s,
        estimator.sample_period_s,
    );
    crate::tick::Tick::new(controller, feed, estimator, excitation_s)
}

/// Which measurement an estimator is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measurement {
    /// The empty fixture.
    Tare,
    /// Fixture plus payload.
    Loaded,
}

impl Measurement {
    /// `"tare"` or `"loaded"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tare => "tare",
            Self::Loaded => "loaded",
        }
    }
}

/// The load of the leg loops' inverse-dynamics feed-forward ([`control::Controller::set_load`])
/// for one `measurement`, from what the rig's owner knows: the tare run's is the plate with the
/// empty fixture (`[plan.fixture]`); a loaded run's is the fixture as the tare measured it
/// (`tare`, when there is one: the owner's own data) or as `[plan.fixture]` gives it, plus
/// `[plan.payload]`. `None` when `control.inertial_feedforward` is off, or the sum is not a
/// body with positive mass.
pub fn feedforward_load(
    config: &Config,
    measurement: Measurement,
    tare: Option<&estimator::InertialParameters>,
) -> Option<estimator::InertialParameters> {
    if !config.control.inertial_feedforward {
        return None;
    }
    let fixture = tare
        .filter(|t| t.is_finite() && t.mass_kg > 0.0)
        .copied()
        .unwrap_or_else(|| config.plan.fixture.parameters());
    let load = match measurement {
        Measurement::Tare => config.plan.fixture.parameters(),
        Measurement::Loaded => fixture + config.plan.payload.parameters(),
    };
    (load.is_finite() && load.mass_kg > 0.0).then_some(load)
}

/// The load the legs carry in one `measurement` as the rig description gives it: the plate
/// with the empty fixture (`[plan.fixture]`), plus `[plan.payload]` for a loaded run; `None`
/// when that is not a body with positive mass (a description without the prior).
pub fn described_load(
    config: &Config,
    measurement: Measurement,
) -> Option<estimator::InertialParameters> {
    let fixture = config.plan.fixture.parameters();
    let load = match measurement {
        Measurement::Tare => fixture,
        Measurement::Loaded => fixture + config.plan.payload.parameters(),
    };
    (load.is_finite() && load.mass_kg > 0.0).then_some(load)
}

/// The legs the estimator compensates: the rig description's `[legs]` when
/// `estimator.compensate_legs` is set and the legs have mass or friction.
pub fn leg_model(config: &Config) -> Option<estimator::LegModel> {
    (config.estimator.compensate_legs && config.legs.matter()).then(|| config.legs.model())
}

/// The estimator's settings for one measurement whose excitation runs over backend times
/// `[window_start_s, window_end_s]`. With `params = 6` the known mass and centre of mass are
/// the fixture's (tare) or the fixture's plus the payload's (loaded), from the `known_*` keys —
/// what an operator weighed beforehand, never the simulator's truth.
pub fn estimator_config(
    config: &Config,
    geometry: &Geometry,
    measurement: Measurement,
    window_start_s: f64,
    window_end_s: f64,
) -> estimator::EstimatorConfig {
    let est = &config.estimator;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let mut c = estimator::EstimatorConfig::new(*geometry, period_s);
    c.lowpass_cutoff_hz = Some(est.cutoff_hz);
    c.forgetting_factor = est.forgetting_factor;
    c.equation_sigma = Vector6::new(
        est.force_sigma_n,
        est.force_sigma_n,
        est.force_sigma_n,
        est.torque_sigma_nm,
        est.torque_sigma_nm,
        est.torque_sigma_nm,
    );
    c.prior_sigma = est.prior_sigma;
    // What the IMU's datasheet says, per sample: density × √(sample rate).
    c.gyro_noise_rad_s = config.sensors.gyro_noise_rad_s();
    c.accel_noise_m_s2 = config.sensors.accel_noise_m_s2();
    c.accelerometer_position_m = accelerometer_position(config);
    // The load cells' offset sensitivity is kept when their datasheet gives an offset, and
    // their zero drift is fitted when it gives a drift (`estimator::drift`).
    c.leg_force_offsets = load_cell_bias_sigma(config) > 0.0;
    c.load_cell_drift = fits_load_cell_drift(config);
    c.window_start_s = window_start_s;
    c.window_end_s = window_end_s;
    c.legs = leg_model(config);
    c.local_gravity_m_s2 = est.local_gravity_m_s2.unwrap_or(0.0);
    if est.params == ParamCount::Six {
        let fm = est.known_fixture_mass_kg.unwrap_or(0.0);
        let fc = Vector3::from(est.known_fixture_com_m.unwrap_or_default());
        let (mass_kg, com_m) = match measurement {
            Measurement::Tare => (fm, fc),
            Measurement::Loaded => {
                let pm = est.known_payload_mass_kg.unwrap_or(0.0);
                let pc = Vector3::from(est.known_payload_com_m.unwrap_or_default());
                let m = fm + pm;
                (m, (fc * fm + pc * pm) / m)
            }
        };
        c.parameters = estimator::ParameterSet::InertiaAboutKnownCom { mass_kg, com_m };
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use rig_description::load::{load, load_str};

    #[test]
    fn default_config_passes_preflight() {
        let loaded = load(None).unwrap();
        let g = geometry(&loaded).unwrap();
        let t = trajectory(&loaded, &g, loaded.config.run.duration_s).unwrap();
        controller(&loaded, &g, t, Measurement::Loaded).unwrap();
    }

    #[test]
    fn a_tare_excitation_table_moves_the_tare_run_its_own_way() {
        let g = geometry(&load(None).unwrap()).unwrap();
        let same = load(None).unwrap();
        let text = "[tare_excitation]\nkind = \"multisine\"\n\n[tare_excitation.multisine]\nbase_frequency_hz = 0.13\n";
        let own = load_str(text, "tare.toml").unwrap();
        let tare = own.config.tare_excitation.as_ref().unwrap();
        // Laid over [excitation]: only the frequency differs.
        assert_eq!(tare.multisine.base_frequency_hz, 0.13);
        assert_eq!(tare.fade_s, own.config.excitation.fade_s);
        let at = |loaded: &LoadedConfig, t: f64| {
            tare_trajectory(loaded, &g)
                .unwrap()
                .sample(t)
                .pose
                .position_m
        };
        assert_eq!(
            at(&same, 7.3),
            trajectory(&same, &g, 30.0)
                .unwrap()
                .sample(7.3)
                .pose
                .position_m
        );
        assert!((at(&own, 7.3) - at(&same, 7.3)).norm() > 1e-4);
        // Its refusals name its own keys.
        let bad = "[tare_excitation]\nfade_s = -1.0\n";
        let err = load_str(bad, "bad.toml").unwrap_err();
        assert_eq!(err.issues[0].key, "tare_excitation.fade_s", "{err}");
        assert_eq!(err.issues[0].line, Some(2));
    }

    #[test]
    fn singular_design_is_refused_naming_the_platform() {
        let text =
            "[platform]\nbase_pair_separation_deg = 60.0\nplate_pair_separation_deg = 60.0\n";
        let loaded = load_str(text, "bad.toml").unwrap();
        let err = geometry(&loaded).unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.file, "bad.toml");
        assert_eq!(issue.key, "platform");
        assert_eq!(issue.line, Some(1));
        assert!(issue.problem.contains("singular"), "{issue}");
    }

    #[test]
    fn unreachable_trajectory_is_refused_naming_the_amplitudes() {
        let text = "[excitation.multisine]\npeak_translation_m = [0.3, 0.3, 0.3]\n\n[excitation]\nkind = \"multisine\"\n";
        let loaded = load_str(text, "far.toml").unwrap();
        let g = geometry(&loaded).unwrap();
        let t = trajectory(&loaded, &g, 20.0).unwrap();
        let err = controller(&loaded, &g, t, Measurement::Loaded).unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.key, "excitation.multisine");
        assert_eq!(issue.line, Some(1));
        assert!(
            issue.problem.contains("stroke") || issue.problem.contains("fast"),
            "{issue}"
        );
    }

    #[test]
    fn six_parameter_known_values_combine_fixture_and_payload() {
        let loaded = load_str("[estimator]\nparams = 6\n", "six.toml").unwrap();
        let g = geometry(&loaded).unwrap();
        let c = estimator_config(&loaded.config, &g, Measurement::Loaded, 0.0, 1.0);
        let est = &loaded.config.estimator;
        match c.parameters {
            estimator::ParameterSet::InertiaAboutKnownCom { mass_kg, com_m } => {
                let (fm, pm) = (
                    est.known_fixture_mass_kg.unwrap(),
                    est.known_payload_mass_kg.unwrap(),
                );
                assert_eq!(mass_kg, fm + pm);
                let pc = est.known_payload_com_m.unwrap();
                let fc = est.known_fixture_com_m.unwrap();
                assert!((com_m.z * (fm + pm) - (fc[2] * fm + pc[2] * pm)).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
    }
}
