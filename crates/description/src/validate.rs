//! Range checks on a deserialized [`Config`]: every value a physical meaning allows, nothing
//! else. Each problem is returned as (dotted key, what is wrong) so the loader can add the file
//! and line. Checks that need the kinematics (reachability, singularity) run later, before any
//! motion, in [`crate::derived::geometry`] and measure's `setup`.

use crate::config::{Config, ExcitationKind, MultisineConfig, ParamCount, SineConfig};
use crate::range::{ranges, Range};

/// Which keys of a rig description a command checks: those that act on what it does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Scope {
    /// Every key: a command that moves the platform or plans a motion.
    Everything,
    /// The keys an estimate from recorded data reads (`import`, `estimate`, `report`): the
    /// platform, the sensors, the legs, the estimator, the calibrations and the brake hold's
    /// length (the static weighing's longest rest). Not the controller, the excitation, the
    /// plan or the run's other phases: they act only on a rig or a simulation, and a foreign
    /// lab's description need not hold values for them that this tool would accept.
    Estimation,
}

impl Scope {
    /// Whether a problem at `key` (dotted) counts for this scope.
    pub fn covers(self, key: &str) -> bool {
        match self {
            Scope::Everything => true,
            Scope::Estimation => {
                let ignored = [
                    "control.",
                    "excitation.",
                    "tare_excitation.",
                    "plan.",
                    "run.",
                ];
                key == "run.brake_hold_s" || !ignored.iter().any(|p| key.starts_with(p))
            }
        }
    }
}

/// Collects problems as (dotted key, message); other layers (the simulated world) check their
/// own tables with it.
#[derive(Default)]
pub struct Problems(pub Vec<(String, String)>);

impl Problems {
    /// Adds a problem.
    pub fn push(&mut self, key: impl Into<String>, problem: impl Into<String>) {
        self.0.push((key.into(), problem.into()));
    }

    /// `value` must be finite and strictly positive.
    pub fn positive(&mut self, key: &str, value: f64) {
        if !(value.is_finite() && value > 0.0) {
            self.push(key, format!("must be positive and finite, got {value}"));
        }
    }

    /// `value` must be finite and not negative.
    pub fn non_negative(&mut self, key: &str, value: f64) {
        if !(value.is_finite() && value >= 0.0) {
            self.push(
                key,
                format!("must be zero or positive and finite, got {value}"),
            );
        }
    }

    /// `value` must lie in `range`.
    pub fn range(&mut self, key: &str, value: f64, range: &Range) {
        if let Some(problem) = range.problem(value) {
            self.push(key, problem);
        }
    }

    /// `value` must lie in `[lo, hi]`.
    pub fn within(&mut self, key: &str, value: f64, lo: f64, hi: f64, unit: &str) {
        if !(value.is_finite() && value >= lo && value <= hi) {
            self.push(
                key,
                format!("must be between {lo} and {hi} {unit}, got {value}"),
            );
        }
    }

    /// Each entry of `v` must be finite and within ±`limit`.
    pub fn finite3(&mut self, key: &str, v: &[f64; 3], limit: f64) {
        for (i, x) in v.iter().enumerate() {
            if !(x.is_finite() && x.abs() <= limit) {
                self.push(
                    format!("{key}[{i}]"),
                    format!("must be finite and within ±{limit}, got {x}"),
                );
            }
        }
    }
}

/// `[vehicle]`: one placement (the frame's origin and axes, or the wheels' contact points)
/// within the rig's reach, its tolerances and the wheel distances physical.
fn vehicle(p: &mut Problems, v: &crate::config::VehicleConfig) {
    let tolerance =
        |p: &mut Problems, key: &str, value: Option<f64>, hi: f64, unit: &str| match value {
            Some(t) => p.within(key, t, 0.0, hi, unit),
            None => p.push(key, format!("missing: one standard deviation, {unit}")),
        };
    // Keys the wheels' form derives, refused beside it.
    let derived = |p: &mut Problems, key: &str, given: bool| {
        if given {
            p.push(
                format!("vehicle.{key}"),
                "follows from vehicle.wheels_m: give the wheels' contact points or the frame's \
                 origin and orientation, not both",
            );
        }
    };
    match (&v.origin_m, &v.wheels_m) {
        (Some(_), Some(_)) => p.push(
            "vehicle.wheels_m",
            "the placement is given twice: as the frame's origin (vehicle.origin_m) and as the \
             wheels' contact points (vehicle.wheels_m); give one",
        ),
        (None, None) => p.push(
            "vehicle.origin_m",
            "missing: give V's origin in P (vehicle.origin_m, with orientation_deg) or the four \
             wheels' contact points (vehicle.wheels_m)",
        ),
        (Some(origin), None) => {
            p.finite3("vehicle.origin_m", origin, 10.0);
            p.finite3(
                "vehicle.orientation_deg",
                &v.orientation_deg.unwrap_or_default(),
                180.0,
            );
            tolerance(
                p,
                "vehicle.origin_tolerance_m",
                v.origin_tolerance_m,
                1.0,
                "m",
            );
            tolerance(
                p,
                "vehicle.orientation_tolerance_deg",
                v.orientation_tolerance_deg,
                10.0,
                "degrees",
            );
            if v.wheel_tolerance_m.is_some() {
                p.push(
                    "vehicle.wheel_tolerance_m",
                    "is the tolerance of vehicle.wheels_m, which is not given: give \
                     vehicle.origin_tolerance_m and vehicle.orientation_tolerance_deg",
                );
            }
        }
        (None, Some(wheels)) => {
            let names = ["front_left", "front_right", "rear_left", "rear_right"];
            let mut finite = true;
            for (name, point) in names.iter().zip(wheels.points()) {
                let before = p.0.len();
                p.finite3(&format!("vehicle.wheels_m.{name}"), &point, 10.0);
                finite &= p.0.len() == before;
            }
            tolerance(
                p,
                "vehicle.wheel_tolerance_m",
                v.wheel_tolerance_m,
                0.1,
                "m",
            );
            derived(p, "orientation_deg", v.orientation_deg.is_some());
            derived(p, "origin_tolerance_m", v.origin_tolerance_m.is_some());
            derived(
                p,
                "orientation_tolerance_deg",
                v.orientation_tolerance_deg.is_some(),
            );
            derived(p, "wheelbase_m", v.wheelbase_m.is_some());
            derived(p, "track_m", v.track_m.is_some());
            if finite {
                match wheels.frame() {
                    Err(problem) => p.push("vehicle.wheels_m", problem.describe()),
                    Ok(f) => {
                        for (key, d) in [("wheelbase", f.wheelbase_m), ("track", f.track_m)] {
                            if !(0.1..=20.0).contains(&d) {
                                p.push(
                                    "vehicle.wheels_m",
                                    format!(
                                        "the contact points give a {key} of {d:.4} m, outside \
                                         0.1 to 20 m: check the points' units (m) and labels"
                                    ),
                                );
                            }
                        }
                        // A car's four contact patches lie on one surface: a point far off
                        // the plane through the others is a typing or survey error.
                        let allowed = 0.01 + 3.0 * v.wheel_tolerance_m.unwrap_or(0.0);
                        if f.out_of_plane_m > allowed {
                            p.push(
                                "vehicle.wheels_m",
                                format!(
                                    "the four contact points are {:.1} mm off one plane (each, \
                                     alternately above and below it), more than the {:.1} mm a \
                                     surface and the survey's tolerance allow: check the \
                                     points' heights",
                                    1e3 * f.out_of_plane_m,
                                    1e3 * allowed
                                ),
                            );
                        }
                    }
                }
            }
        }
    }
    for (key, value) in [
        ("vehicle.wheelbase_m", v.wheelbase_m),
        ("vehicle.track_m", v.track_m),
    ] {
        if let Some(d) = value {
            p.within(key, d, 0.1, 20.0, "m");
        }
    }
}

/// An IMU channel's noise: exactly one of its density and its per-sample rms, each given as
/// (key, value, largest, unit), within [0, largest].
fn noise_form(
    p: &mut Problems,
    table: &str,
    density: (&str, Option<f64>, f64, &str),
    rms: (&str, Option<f64>, f64, &str),
) {
    match (density.1, rms.1) {
        (Some(_), Some(_)) => p.push(
            format!("{table}.{}", rms.0),
            format!(
                "the noise is given twice: as a density ({table}.{}) and per sample \
                 ({table}.{}); give one",
                density.0, rms.0
            ),
        ),
        (None, None) => p.push(
            format!("{table}.{}", density.0),
            format!(
                "missing: give the noise as a density ({table}.{}, Allan-deviation convention: \
                 one sample's sigma is it × √(sample rate)) or per sample ({table}.{})",
                density.0, rms.0
            ),
        ),
        _ => {}
    }
    for (key, value, largest, unit) in [density, rms] {
        if let Some(v) = value {
            p.within(&format!("{table}.{key}"), v, 0.0, largest, unit);
        }
    }
}

/// Every range problem in `config`, as (dotted key, what is wrong). Empty when all is well.
pub fn validate(config: &Config) -> Vec<(String, String)> {
    let mut p = Problems::default();
    p.positive("calibration.max_age_days", config.calibration.max_age_days);
    if let Some(m) = config.calibration.reference_mass_kg {
        p.positive("calibration.reference_mass_kg", m);
    }
    p.non_negative(
        "calibration.reference_mass_tolerance_kg",
        config.calibration.reference_mass_tolerance_kg,
    );

    let pl = &config.platform;
    match (&pl.base_joints_m, &pl.plate_joints_m) {
        (Some(base), Some(plate)) => {
            // A joint tens of metres out is a typo (millimetres for metres), not a rig.
            for (name, points) in [("base_joints_m", base), ("plate_joints_m", plate)] {
                for (i, point) in points.iter().enumerate() {
                    p.finite3(&format!("platform.{name}[{i}]"), point, 50.0);
                }
            }
        }
        (Some(_), None) | (None, Some(_)) => {
            let missing = if pl.base_joints_m.is_none() {
                "base_joints_m"
            } else {
                "plate_joints_m"
            };
            p.push(
                format!("platform.{missing}"),
                "the platform's joints are given by points: give both platform.base_joints_m \
                 (six points in B) and platform.plate_joints_m (six points in P), leg i joining \
                 base joint i to plate joint i",
            );
        }
        (None, None) => {
            let radii = [
                ("platform.base_radius_m", pl.base_radius_m),
                ("platform.plate_radius_m", pl.plate_radius_m),
                (
                    "platform.base_pair_separation_deg",
                    pl.base_pair_separation_deg,
                ),
                (
                    "platform.plate_pair_separation_deg",
                    pl.plate_pair_separation_deg,
                ),
            ];
            for (key, value) in radii {
                match value {
                    None => p.push(
                        key,
                        "missing: the radii form needs both radii and both pair separations \
                         (or give the joints as platform.base_joints_m and platform.plate_joints_m)",
                    ),
                    Some(v) if key.ends_with("_deg") => p.within(key, v, 0.5, 119.5, "degrees"),
                    Some(v) => p.positive(key, v),
                }
            }
        }
    }
    p.positive("platform.min_leg_length_m", pl.min_leg_length_m);
    p.positive("platform.max_leg_length_m", pl.max_leg_length_m);
    if pl.max_leg_length_m <= pl.min_leg_length_m {
        p.push(
            "platform.max_leg_length_m",
            format!(
                "must be greater than platform.min_leg_length_m ({} m), got {} m",
                pl.min_leg_length_m, pl.max_leg_length_m
            ),
        );
    }

    let s = &config.sensors;
    p.within(
        "sensors.sample_rate_hz",
        s.sample_rate_hz,
        100.0,
        20_000.0,
        "Hz",
    );
    p.non_negative("sensors.encoder.noise_m", s.encoder.noise_m);
    p.non_negative("sensors.encoder.resolution_m", s.encoder.resolution_m);
    p.non_negative("sensors.load_cell.noise_n", s.load_cell.noise_n);
    p.non_negative("sensors.load_cell.zero_offset_n", s.load_cell.zero_offset_n);
    p.non_negative("sensors.load_cell.resolution_n", s.load_cell.resolution_n);
    noise_form(
        &mut p,
        "sensors.gyro",
        (
            "noise_density_rad_s_sqrt_hz",
            s.gyro.noise_density_rad_s_sqrt_hz,
            0.1,
            "rad/s/√Hz",
        ),
        ("noise_rms_rad_s", s.gyro.noise_rms_rad_s, 10.0, "rad/s"),
    );
    p.within(
        "sensors.gyro.bias_rad_s",
        s.gyro.bias_rad_s,
        0.0,
        1.0,
        "rad/s",
    );
    noise_form(
        &mut p,
        "sensors.accelerometer",
        (
            "noise_density_m_s2_sqrt_hz",
            s.accelerometer.noise_density_m_s2_sqrt_hz,
            10.0,
            "m/s²/√Hz",
        ),
        (
            "noise_rms_m_s2",
            s.accelerometer.noise_rms_m_s2,
            100.0,
            "m/s²",
        ),
    );
    p.within(
        "sensors.accelerometer.bias_m_s2",
        s.accelerometer.bias_m_s2,
        0.0,
        1.0,
        "m/s²",
    );
    p.finite3("sensors.imu.position_m", &s.imu.position_m, 10.0);
    p.finite3("sensors.imu.orientation_deg", &s.imu.orientation_deg, 180.0);
    for (k, n) in config.certificate.nominal.iter().enumerate() {
        let key = |field: &str| format!("certificate.nominal[{k}].{field}");
        if !crate::quantities::Quantities::NAMES.contains(&n.quantity.as_str()) {
            p.push(
                key("quantity"),
                format!(
                    "unknown quantity {:?}: one of {}",
                    n.quantity,
                    crate::quantities::Quantities::NAMES.join(", ")
                ),
            );
        }
        if !n.value.is_finite() {
            p.push(key("value"), format!("must be finite, got {}", n.value));
        }
        p.positive(&key("tolerance"), n.tolerance);
    }
    if let Some(v) = &config.vehicle {
        vehicle(&mut p, v);
    }
    for (key, _, value) in config.certificate.fields() {
        if let Some(text) = value {
            if text.chars().count() > 200 || text.chars().any(char::is_control) {
                p.push(
                    format!("certificate.{key}"),
                    "must be one line of at most 200 characters",
                );
            }
        }
    }
    datasheet_tolerances(&mut p, config);
    legs(&mut p, &config.legs);
    plan(&mut p, &config.plan);
    tare_excitation(&mut p, config);

    let c = &config.control;
    p.positive("control.kp_n_per_m", c.kp_n_per_m);
    p.non_negative("control.ki_n_per_m_s", c.ki_n_per_m_s);
    p.non_negative("control.kd_n_s_per_m", c.kd_n_s_per_m);
    p.non_negative("control.derivative_filter_s", c.derivative_filter_s);
    p.positive("control.max_force_n", c.max_force_n);
    p.positive("control.max_measured_force_n", c.max_measured_force_n);
    p.positive("control.max_leg_speed_m_s", c.max_leg_speed_m_s);
    p.non_negative("control.leg_length_margin_m", c.leg_length_margin_m);
    p.positive("control.max_sample_gap_s", c.max_sample_gap_s);
    p.positive("control.settle_ramp_s", c.settle_ramp_s);
    p.non_negative("control.park_hold_s", c.park_hold_s);

    let nyquist = s.sample_rate_hz / 2.0;
    let e = &config.excitation;
    p.positive("excitation.fade_s", e.fade_s);
    if let Some(f) = e.fade_out_s {
        p.positive("excitation.fade_out_s", f);
    }
    p.non_negative("excitation.stroke_margin_m", e.stroke_margin_m);
    p.positive("excitation.max_leg_speed_m_s", e.max_leg_speed_m_s);
    if e.max_leg_speed_m_s > c.max_leg_speed_m_s {
        p.push(
            "excitation.max_leg_speed_m_s",
            format!(
                "must not exceed control.max_leg_speed_m_s ({} m/s), or tracking overshoot trips the supervisor; got {} m/s",
                c.max_leg_speed_m_s, e.max_leg_speed_m_s
            ),
        );
    }
    p.within(
        "excitation.min_inverse_condition",
        e.min_inverse_condition,
        0.0,
        1.0,
        "",
    );
    let f_max = nyquist / 10.0;
    match e.kind {
        ExcitationKind::Multisine => multisine(&mut p, &e.multisine, f_max),
        ExcitationKind::Sines => {
            if e.sines.is_empty() {
                p.push(
                    "excitation.sines",
                    "needs at least one [[excitation.sines]] component when kind = \"sines\"",
                );
            }
            for (i, sine) in e.sines.iter().enumerate() {
                sine_component(&mut p, i, sine, f_max);
            }
        }
    }

    let est = &config.estimator;
    p.range(
        "estimator.cutoff_hz",
        est.cutoff_hz,
        &ranges::cutoff_hz(s.sample_rate_hz),
    );
    let highest = highest_excitation_hz(config);
    if highest.is_finite() && est.cutoff_hz.is_finite() && est.cutoff_hz < 2.0 * highest {
        p.push(
            "estimator.cutoff_hz",
            format!(
                "must be at least twice the excitation's highest frequency ({highest:.3} Hz), got {} Hz: \
                 the low-pass would remove the motion it is meant to measure",
                est.cutoff_hz
            ),
        );
    }
    p.range(
        "estimator.forgetting_factor",
        est.forgetting_factor,
        &ranges::FORGETTING_FACTOR,
    );
    p.positive("estimator.force_sigma_n", est.force_sigma_n);
    p.positive("estimator.torque_sigma_nm", est.torque_sigma_nm);
    p.within("estimator.prior_sigma", est.prior_sigma, 1e-6, 1e12, "");
    if let Some(g) = est.local_gravity_m_s2.filter(|g| *g != 0.0) {
        p.within("estimator.local_gravity_m_s2", g, 9.7, 9.9, "m/s²");
    }
    if est.params == ParamCount::Six {
        known(
            &mut p,
            "known_payload",
            est.known_payload_mass_kg,
            est.known_payload_com_m,
        );
        known(
            &mut p,
            "known_fixture",
            est.known_fixture_mass_kg,
            est.known_fixture_com_m,
        );
    }

    let r = &config.run;
    p.within("run.brake_hold_s", r.brake_hold_s, 0.0, 60.0, "s");
    p.within("run.settle_s", r.settle_s, 0.0, 600.0, "s");
    p.range("run.duration_s", r.duration_s, &ranges::RUN_DURATION_S);
    p.range(
        "run.tare_duration_s",
        r.tare_duration_s,
        &ranges::RUN_DURATION_S,
    );
    p.within("run.park_s", r.park_s, 0.01, 600.0, "s");
    for (key, d) in [
        ("run.duration_s", r.duration_s),
        ("run.tare_duration_s", r.tare_duration_s),
    ] {
        let fades = e.fade_s + e.fade_out();
        if d.is_finite() && d < fades {
            p.push(
                key,
                format!(
                    "must be at least the fade-in and fade-out together (excitation.fade_s and \
                     excitation.fade_out_s: {fades} s), got {d} s"
                ),
            );
        }
    }
    // The `[rig]` table is checked whatever the command: a description `stewart rig` refuses
    // is refused by `simulate` and `emulate` too, at its own line, not first on the rig.
    for (key, problem) in config.rig.problems() {
        p.push(key, problem);
    }
    p.0
}

/// The excitation's highest frequency, Hz (NaN when it has none).
fn highest_excitation_hz(config: &Config) -> f64 {
    let e = &config.excitation;
    match e.kind {
        ExcitationKind::Multisine => {
            let m = &e.multisine;
            let excited = m
                .peak_translation_m
                .iter()
                .chain(&m.peak_rotation_deg)
                .filter(|a| **a > 0.0)
                .count();
            m.base_frequency_hz * (excited as f64) * f64::from(m.harmonics_per_axis)
        }
        ExcitationKind::Sines => e
            .sines
            .iter()
            .map(|s| s.frequency_hz)
            .fold(f64::NAN, f64::max),
    }
}

fn multisine(p: &mut Problems, m: &MultisineConfig, f_max: f64) {
    let k = "excitation.multisine";
    p.positive(&format!("{k}.base_frequency_hz"), m.base_frequency_hz);
    if m.harmonics_per_axis == 0 {
        p.push(format!("{k}.harmonics_per_axis"), "must be at least 1");
    }
    let excited = m
        .peak_translation_m
        .iter()
        .chain(&m.peak_rotation_deg)
        .filter(|a| **a > 0.0)
        .count();
    if excited == 0 {
        p.push(
            format!("{k}.peak_rotation_deg"),
            "every peak is zero: nothing would move",
        );
    }
    let total = excited as u64 * u64::from(m.harmonics_per_axis);
    if total > control::trajectory::MAX_COMPONENTS as u64 {
        p.push(
            format!("{k}.harmonics_per_axis"),
            format!(
                "{excited} excited axes × {} harmonics = {total} components, more than the {} a trajectory holds",
                m.harmonics_per_axis,
                control::trajectory::MAX_COMPONENTS
            ),
        );
    }
    let highest = m.base_frequency_hz * total as f64;
    if highest.is_finite() && highest > f_max {
        p.push(
            format!("{k}.base_frequency_hz"),
            format!(
                "the highest harmonic ({highest} Hz) must be at most {f_max} Hz (a tenth of the Nyquist rate)"
            ),
        );
    }
    for (i, a) in m.peak_translation_m.iter().enumerate() {
        if !(a.is_finite() && *a >= 0.0 && *a <= 1.0) {
            p.push(
                format!("{k}.peak_translation_m[{i}]"),
                format!("must be between 0 and 1 m, got {a}"),
            );
        }
    }
    for (i, a) in m.peak_rotation_deg.iter().enumerate() {
        if !(a.is_finite() && *a >= 0.0 && *a <= 30.0) {
            p.push(
                format!("{k}.peak_rotation_deg[{i}]"),
                format!("must be between 0 and 30 degrees, got {a}"),
            );
        }
    }
}

fn sine_component(p: &mut Problems, i: usize, s: &SineConfig, f_max: f64) {
    let k = format!("excitation.sines[{i}]");
    match (s.axis.is_rotation(), s.amplitude_deg, s.amplitude_m) {
        (true, Some(a), None) => {
            if !(a.is_finite() && a.abs() <= 30.0) {
                p.push(
                    format!("{k}.amplitude_deg"),
                    format!("must be within ±30 degrees, got {a}"),
                );
            }
        }
        (false, None, Some(a)) => {
            if !(a.is_finite() && a.abs() <= 1.0) {
                p.push(
                    format!("{k}.amplitude_m"),
                    format!("must be within ±1 m, got {a}"),
                );
            }
        }
        (true, _, Some(_)) => p.push(
            format!("{k}.amplitude_m"),
            "wrong unit: a rotation axis takes `amplitude_deg`",
        ),
        (false, Some(_), _) => p.push(
            format!("{k}.amplitude_deg"),
            "wrong unit: a translation axis takes `amplitude_m`",
        ),
        (rot, None, None) => p.push(
            k.clone(),
            format!(
                "missing `{}`",
                if rot { "amplitude_deg" } else { "amplitude_m" }
            ),
        ),
    }
    if !(s.frequency_hz.is_finite() && s.frequency_hz > 0.0 && s.frequency_hz <= f_max) {
        p.push(
            format!("{k}.frequency_hz"),
            format!(
                "must be above 0 and at most {f_max} Hz (a tenth of the Nyquist rate), got {}",
                s.frequency_hz
            ),
        );
    }
    if !s.phase_deg.is_finite() {
        p.push(format!("{k}.phase_deg"), "must be finite");
    }
}

fn known(p: &mut Problems, prefix: &str, mass: Option<f64>, com: Option<[f64; 3]>) {
    let mk = format!("estimator.{prefix}_mass_kg");
    let ck = format!("estimator.{prefix}_com_m");
    match mass {
        Some(m) => p.positive(&mk, m),
        None => p.push(
            mk,
            "required when estimator.params = 6 (the paper's model needs the mass known beforehand)",
        ),
    }
    match com {
        Some(c) => p.finite3(&ck, &c, 10.0),
        None => p.push(
            ck,
            "required when estimator.params = 6 (the paper's model needs the centre of mass known beforehand)",
        ),
    }
}

/// The rig's tolerances and the sensors' systematic figures (one standard deviation each).
fn datasheet_tolerances(p: &mut Problems, config: &Config) {
    let s = &config.sensors;
    p.within(
        "platform.joint_position_tolerance_m",
        config.platform.joint_position_tolerance_m,
        0.0,
        0.01,
        "m",
    );
    let lc = &s.load_cell;
    p.within(
        "sensors.load_cell.gain_error",
        lc.gain_error,
        0.0,
        0.1,
        "(relative)",
    );
    p.within(
        "sensors.load_cell.transverse_sensitivity",
        lc.transverse_sensitivity,
        0.0,
        0.1,
        "(relative)",
    );
    p.non_negative(
        "sensors.load_cell.zero_drift_n_per_min",
        lc.zero_drift_n_per_min,
    );
    p.within(
        "sensors.gyro.scale_error",
        s.gyro.scale_error,
        0.0,
        0.1,
        "(relative)",
    );
    p.within(
        "sensors.accelerometer.scale_error",
        s.accelerometer.scale_error,
        0.0,
        0.1,
        "(relative)",
    );
    p.within(
        "sensors.imu.misalignment_deg",
        s.imu.misalignment_deg,
        0.0,
        5.0,
        "degrees",
    );
    p.within(
        "sensors.imu.position_tolerance_m",
        s.imu.position_tolerance_m,
        0.0,
        0.1,
        "m",
    );
    let t = &s.timing;
    let period_s = 1.0 / s.sample_rate_hz.max(1.0);
    p.within(
        "sensors.timing.imu_skew_s",
        t.imu_skew_s,
        0.0,
        period_s,
        "s",
    );
    p.within(
        "sensors.timing.sampling_jitter_s",
        t.sampling_jitter_s,
        0.0,
        0.25 * period_s,
        "s",
    );
    p.within(
        "sensors.timing.frame_loss",
        t.frame_loss,
        0.0,
        0.5,
        "(share)",
    );
}

/// The plan's prior must be a physical body, its targets and margins positive.
fn plan(p: &mut Problems, c: &crate::config::PlanConfig) {
    for (name, body) in [("payload", &c.payload), ("fixture", &c.fixture)] {
        p.positive(&format!("plan.{name}.mass_kg"), body.mass_kg);
        p.finite3(&format!("plan.{name}.com_m"), &body.com_m, 10.0);
        if !body.parameters().consistency().is_consistent() {
            p.push(
                format!("plan.{name}.inertia_com_kg_m2"),
                "must be symmetric, positive definite and meet the triangle inequality (a body's tensor)",
            );
        }
    }
    p.positive("plan.target_mass_fraction", c.target_mass_fraction);
    p.positive("plan.target_com_m", c.target_com_m);
    p.positive("plan.target_inertia_fraction", c.target_inertia_fraction);
    p.within(
        "plan.force_share",
        c.force_share,
        0.01,
        1.0,
        "of control.max_force_n",
    );
    p.within(
        "plan.speed_share",
        c.speed_share,
        0.01,
        1.0,
        "of excitation.max_leg_speed_m_s",
    );
    p.positive("plan.max_acceleration_m_s2", c.max_acceleration_m_s2);
    p.within(
        "plan.max_frequency_share",
        c.max_frequency_share,
        0.01,
        1.0,
        "of estimator.cutoff_hz",
    );
}

/// The legs' mass properties must describe bodies that fit between the joints.
fn legs(p: &mut Problems, l: &crate::config::LegsConfig) {
    p.non_negative("legs.cylinder_mass_kg", l.cylinder_mass_kg);
    p.non_negative("legs.cylinder_com_from_base_m", l.cylinder_com_from_base_m);
    p.non_negative("legs.cylinder_inertia_kg_m2", l.cylinder_inertia_kg_m2);
    p.non_negative("legs.rod_mass_kg", l.rod_mass_kg);
    p.non_negative("legs.rod_com_from_plate_m", l.rod_com_from_plate_m);
    p.non_negative("legs.rod_inertia_kg_m2", l.rod_inertia_kg_m2);
    p.non_negative("legs.joint_coulomb_torque_nm", l.joint_coulomb_torque_nm);
    p.non_negative(
        "legs.joint_viscous_nm_s_per_rad",
        l.joint_viscous_nm_s_per_rad,
    );
    p.non_negative("legs.mass_tolerance", l.mass_tolerance);
    p.non_negative("legs.com_tolerance_m", l.com_tolerance_m);
    p.non_negative("legs.inertia_tolerance", l.inertia_tolerance);
    p.non_negative("legs.friction_tolerance", l.friction_tolerance);
}

/// The tare run's own excitation passes the same checks as the loaded run's, said of its keys.
fn tare_excitation(p: &mut Problems, config: &Config) {
    let Some(tare) = &config.tare_excitation else {
        return;
    };
    let mut c = config.clone();
    c.excitation = tare.clone();
    c.tare_excitation = None;
    c.run.duration_s = c.run.tare_duration_s;
    for (key, problem) in validate(&c) {
        if let Some(rest) = key.strip_prefix("excitation") {
            p.push(format!("tare_excitation{rest}"), problem);
        } else if key == "run.duration_s" {
            p.push("run.tare_duration_s", problem);
        }
    }
}
