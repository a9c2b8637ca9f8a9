//! Range checks on a deserialized [`Config`]: every value a physical meaning allows, nothing
//! else. Each problem is returned as (dotted key, what is wrong) so the loader can add the file
//! and line. Checks that need the kinematics (reachability, singularity) run later, before any
//! motion, in [`crate::preflight`].

use crate::config::{AxisExcitation, BodyConfig, Config};

/// Collects problems as (dotted key, message).
#[derive(Default)]
struct Problems(Vec<(String, String)>);

impl Problems {
    fn push(&mut self, key: impl Into<String>, problem: impl Into<String>) {
        self.0.push((key.into(), problem.into()));
    }

    /// `value` must be finite and strictly positive.
    fn positive(&mut self, key: &str, value: f64) {
        if !(value.is_finite() && value > 0.0) {
            self.push(key, format!("must be positive and finite, got {value}"));
        }
    }

    /// `value` must be finite and not negative.
    fn non_negative(&mut self, key: &str, value: f64) {
        if !(value.is_finite() && value >= 0.0) {
            self.push(
                key,
                format!("must be zero or positive and finite, got {value}"),
            );
        }
    }

    /// `value` must lie in `[lo, hi]`.
    fn within(&mut self, key: &str, value: f64, lo: f64, hi: f64, unit: &str) {
        if !(value.is_finite() && value >= lo && value <= hi) {
            self.push(
                key,
                format!("must be between {lo} and {hi} {unit}, got {value}"),
            );
        }
    }

    fn finite3(&mut self, key: &str, v: &[f64; 3], limit: f64) {
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

/// Every range problem in `config`, as (dotted key, what is wrong). Empty when all is well.
pub fn validate(config: &Config) -> Vec<(String, String)> {
    let mut p = Problems::default();

    let pl = &config.platform;
    p.positive("platform.base_radius_m", pl.base_radius_m);
    p.positive("platform.plate_radius_m", pl.plate_radius_m);
    p.within(
        "platform.base_pair_separation_deg",
        pl.base_pair_separation_deg,
        0.5,
        119.5,
        "degrees",
    );
    p.within(
        "platform.plate_pair_separation_deg",
        pl.plate_pair_separation_deg,
        0.5,
        119.5,
        "degrees",
    );
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

    body(&mut p, "fixture", &config.fixture);
    body(&mut p, "payload", &config.payload);

    let a = &config.actuator;
    p.within("actuator.bandwidth_hz", a.bandwidth_hz, 0.1, 10_000.0, "Hz");
    p.positive("actuator.max_force_n", a.max_force_n);
    p.non_negative(
        "actuator.viscous_friction_n_s_per_m",
        a.viscous_friction_n_s_per_m,
    );
    p.non_negative("actuator.coulomb_friction_n", a.coulomb_friction_n);

    let s = &config.sensors;
    p.within(
        "sensors.sample_rate_hz",
        s.sample_rate_hz,
        100.0,
        20_000.0,
        "Hz",
    );
    p.finite3("sensors.imu_position_m", &s.imu_position_m, 10.0);

    let c = &config.control;
    p.positive("control.kp_n_per_m", c.kp_n_per_m);
    p.non_negative("control.ki_n_per_m_s", c.ki_n_per_m_s);
    p.non_negative("control.kd_n_s_per_m", c.kd_n_s_per_m);
    p.positive("control.max_tracking_error_m", c.max_tracking_error_m);
    p.positive("control.max_leg_speed_m_s", c.max_leg_speed_m_s);
    p.positive("control.max_force_n", c.max_force_n);

    let nyquist = s.sample_rate_hz / 2.0;
    let e = &config.excitation;
    p.non_negative("excitation.ramp_s", e.ramp_s);
    let axes: [(&str, &AxisExcitation, f64); 6] = [
        ("excitation.roll_deg", &e.roll_deg, 30.0),
        ("excitation.pitch_deg", &e.pitch_deg, 30.0),
        ("excitation.yaw_deg", &e.yaw_deg, 30.0),
        ("excitation.x_m", &e.x_m, 1.0),
        ("excitation.y_m", &e.y_m, 1.0),
        ("excitation.z_m", &e.z_m, 1.0),
    ];
    for (key, axis, limit) in axes {
        excitation_axis(&mut p, key, axis, limit, nyquist / 10.0);
    }

    let est = &config.estimator;
    p.within(
        "estimator.cutoff_hz",
        est.cutoff_hz,
        0.1,
        nyquist * 0.8,
        "Hz (below 80 % of half the sample rate)",
    );
    p.within(
        "estimator.forgetting_factor",
        est.forgetting_factor,
        0.9,
        1.0,
        "",
    );

    let r = &config.run;
    p.within("run.settle_s", r.settle_s, 0.0, 600.0, "s");
    p.within("run.duration_s", r.duration_s, 0.01, 36_000.0, "s");
    p.within(
        "run.tare_duration_s",
        r.tare_duration_s,
        0.01,
        36_000.0,
        "s",
    );
    p.within("run.park_s", r.park_s, 0.0, 600.0, "s");
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
    let _ = lo;
}

fn excitation_axis(p: &mut Problems, key: &str, axis: &AxisExcitation, limit: f64, f_max: f64) {
    if axis.amplitudes.len() != axis.frequencies_hz.len() {
        p.push(
            format!("{key}.frequencies_hz"),
            format!(
                "needs one frequency per amplitude: {} amplitudes, {} frequencies",
                axis.amplitudes.len(),
                axis.frequencies_hz.len()
            ),
        );
    }
    if !axis.phases_deg.is_empty() && axis.phases_deg.len() != axis.amplitudes.len() {
        p.push(
            format!("{key}.phases_deg"),
            format!(
                "needs one phase per amplitude (or none): {} amplitudes, {} phases",
                axis.amplitudes.len(),
                axis.phases_deg.len()
            ),
        );
    }
    let total: f64 = axis.amplitudes.iter().map(|a| a.abs()).sum();
    for (i, a) in axis.amplitudes.iter().enumerate() {
        if !a.is_finite() {
            p.push(
                format!("{key}.amplitudes[{i}]"),
                format!("must be finite, got {a}"),
            );
        }
    }
    if total > limit {
        p.push(
            format!("{key}.amplitudes"),
            format!("the amplitudes add up to {total}, more than the limit {limit}"),
        );
    }
    for (i, f) in axis.frequencies_hz.iter().enumerate() {
        if !(f.is_finite() && *f > 0.0 && *f <= f_max) {
            p.push(
                format!("{key}.frequencies_hz[{i}]"),
                format!(
                    "must be above 0 and at most {f_max} Hz (a tenth of the Nyquist rate), got {f}"
                ),
            );
        }
    }
    for (i, ph) in axis.phases_deg.iter().enumerate() {
        if !ph.is_finite() {
            p.push(
                format!("{key}.phases_deg[{i}]"),
                format!("must be finite, got {ph}"),
            );
        }
    }
}
