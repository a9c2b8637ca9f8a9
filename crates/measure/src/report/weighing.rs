//! The report's `static_weighing` section: the brake holds' static weighing of the payload
//! (loaded run less tare, [`crate::weigh::payload`]) and of the tare, and its check against
//! the dynamic fit.

use serde::{Deserialize, Serialize};

use crate::weigh::{payload, StaticWeighing, Weighed};

/// Differences between the dynamic fit and the static weighing beyond this many combined
/// sigmas are warned about.
pub const CHECK_LIMIT_SIGMA: f64 = 4.0;

/// The dynamic fit against the static weighing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WeighingCheck {
    /// (dynamic − static) / √(σ_dynamic² + σ_static²) of mass, c_x, c_y. The two share the
    /// load cells' gains, so the combined sigma, which ignores that correlation, is the larger
    /// bound.
    pub z: [f64; 3],
    /// The largest |z|.
    pub largest_abs_z: f64,
    /// [`CHECK_LIMIT_SIGMA`].
    pub limit_sigma: f64,
    /// Every |z| within the limit.
    pub agrees: bool,
}

/// The report's static weighing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StaticWeighingReport {
    /// The payload: the loaded run's hold less the tare's.
    pub payload: Weighed,
    /// The tare (fixture and plate) alone.
    pub tare: Weighed,
    /// The dynamic fit's payload against `payload`; absent when the fit does not estimate the
    /// mass and centre of mass (the paper's six-parameter model takes them as given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<WeighingCheck>,
}

/// The section of the loaded run's weighing `loaded` and the tare's `tare`, with the dynamic
/// fit's total θ `loaded_theta` and tare θ `tare_theta` (their h_z/m give each run's centre of
/// mass height, which one level pose cannot, see [`crate::weigh`]), checked against the
/// dynamic payload's mass and c_x, c_y with their sigmas, `dynamic` = `Some((values,
/// sigmas))`; `None` when the fit does not estimate them (no check).
pub fn section(
    loaded: &StaticWeighing,
    tare: &StaticWeighing,
    loaded_theta: &[f64; 10],
    tare_theta: &[f64; 10],
    dynamic: Option<([f64; 3], [f64; 3])>,
) -> StaticWeighingReport {
    let height = |t: &[f64; 10]| if t[0] > 0.0 { t[3] / t[0] } else { 0.0 };
    let p = payload(loaded, height(loaded_theta), tare, height(tare_theta));
    let weighed = [p.mass_kg, p.com_xy_m[0], p.com_xy_m[1]];
    let sigma = [p.sigma_mass_kg, p.sigma_com_xy_m[0], p.sigma_com_xy_m[1]];
    let check = dynamic.map(|(values, dynamic_sigma)| {
        let z: [f64; 3] =
            core::array::from_fn(|k| (values[k] - weighed[k]) / dynamic_sigma[k].hypot(sigma[k]));
        WeighingCheck {
            z,
            largest_abs_z: z.iter().fold(0.0f64, |a, v| a.max(v.abs())),
            limit_sigma: CHECK_LIMIT_SIGMA,
            agrees: z.iter().all(|v| v.abs() <= CHECK_LIMIT_SIGMA),
        }
    });
    StaticWeighingReport {
        payload: p,
        tare: tare.weighed(height(tare_theta)),
        check,
    }
}

impl StaticWeighingReport {
    /// The warning when the dynamic fit and the static weighing disagree beyond
    /// [`CHECK_LIMIT_SIGMA`]; `None` when they agree.
    pub fn warning(&self) -> Option<String> {
        let check = self.check.as_ref().filter(|c| !c.agrees)?;
        let [m, x, y] = check.z;
        Some(format!(
            "the dynamic fit and the static weighing of the brake holds disagree: mass {m:+.1} σ, \
             c_x {x:+.1} σ, c_y {y:+.1} σ (limit {:.0} σ); static mass {:.3} ± {:.3} kg, c_x \
             {:.2} ± {:.2} mm, c_y {:.2} ± {:.2} mm",
            check.limit_sigma,
            self.payload.mass_kg,
            self.payload.sigma_mass_kg,
            self.payload.com_xy_m[0] * 1e3,
            self.payload.sigma_com_xy_m[0] * 1e3,
            self.payload.com_xy_m[1] * 1e3,
            self.payload.sigma_com_xy_m[1] * 1e3,
        ))
    }
}

/// Why a report gives no static prior.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PriorError {
    /// Not one measurement's report.
    #[error(transparent)]
    Text(#[from] super::ReportTextError),
    /// Its `static_weighing` section is missing or unreadable.
    #[error("the report has no static_weighing section to take the prior from{0}")]
    NoWeighing(String),
}

/// The `static_weighing` section of a report file's `text`.
pub fn static_weighing_of(text: &str) -> Result<StaticWeighingReport, PriorError> {
    let value = super::one_measurement(text)?;
    let section = value
        .get("static_weighing")
        .ok_or_else(|| PriorError::NoWeighing(String::new()))?;
    serde_json::from_value(section.clone()).map_err(|e| PriorError::NoWeighing(format!(": {e}")))
}

/// Lays a static weighing over the plan's prior (`[plan.payload]`, `[plan.fixture]`): their
/// masses and c_x, c_y become the weighed ones; c_z and the inertia stay the described prior's
/// (one level pose does not see them).
pub fn apply_prior(plan: &mut rig_description::config::PlanConfig, w: &StaticWeighingReport) {
    let set = |body: &mut rig_description::config::BodyPrior, weighed: &Weighed| {
        if weighed.mass_kg.is_finite() && weighed.mass_kg > 0.0 {
            body.mass_kg = weighed.mass_kg;
            body.com_m[0] = weighed.com_xy_m[0];
            body.com_m[1] = weighed.com_xy_m[1];
        }
    };
    set(&mut plan.payload, &w.payload);
    set(&mut plan.fixture, &w.tare);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::Report;

    fn weighing(m: f64, hx: f64, hy: f64, noise: f64) -> StaticWeighing {
        StaticWeighing {
            samples: 500,
            time_s: 0.25,
            gravity_m_s2: 9.80665,
            up_in_p: [0.0, 0.0, 1.0],
            values: [m, hx, hy],
            noise_covariance: [[noise, 0.0, 0.0], [0.0, noise, 0.0], [0.0, 0.0, noise]],
            ..StaticWeighing::default()
        }
    }

    /// A report written without the section reads, and one with it round-trips.
    #[test]
    fn reports_with_and_without_the_section_read() {
        let plain = Report::default();
        let text = plain.to_json();
        assert!(!text.contains("static_weighing"));
        let back: Report = serde_json::from_str(&text).expect("reads");
        assert_eq!(back.static_weighing, None);
        let mut with = Report::default();
        let (l, t) = (
            weighing(1900.0, 225.0, -120.0, 0.01),
            weighing(400.0, 0.0, 0.0, 0.01),
        );
        let theta = |m: f64| [m, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        with.static_weighing = Some(section(
            &l,
            &t,
            &theta(1900.0),
            &theta(400.0),
            Some(([1500.0, 0.15, -0.08], [0.3, 2e-4, 2e-4])),
        ));
        let back: Report = serde_json::from_str(&with.to_json()).expect("reads");
        assert_eq!(back.static_weighing, with.static_weighing);
        let s = back.static_weighing.expect("section");
        assert!((s.payload.mass_kg - 1500.0).abs() < 1e-9);
        assert!((s.payload.com_xy_m[0] - 0.15).abs() < 1e-12);
        assert!(s.check.is_some_and(|c| c.agrees) && s.warning().is_none());
        let prior = static_weighing_of(&with.to_json()).expect("a prior");
        let mut plan = rig_description::config::PlanConfig::default();
        apply_prior(&mut plan, &prior);
        assert_eq!(plan.payload.mass_kg, s.payload.mass_kg);
        assert_eq!(plan.fixture.mass_kg, 400.0);
        assert!(static_weighing_of(&Report::default().to_json()).is_err());
    }

    /// A dynamic fit 5 combined sigmas off the weighing is warned about, naming the quantity.
    #[test]
    fn a_disagreement_beyond_four_sigma_warns() {
        let (l, t) = (
            weighing(1900.0, 0.0, 0.0, 0.01),
            weighing(400.0, 0.0, 0.0, 0.01),
        );
        let theta = |m: f64| [m, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        // σ_static of the mass: √0.02; σ_dynamic 0.1: combined √0.03.
        let off = 5.0 * 0.03f64.sqrt();
        let s = section(
            &l,
            &t,
            &theta(1900.0),
            &theta(400.0),
            Some(([1500.0 + off, 0.0, 0.0], [0.1, 1e-4, 1e-4])),
        );
        let check = s.check.expect("a check");
        assert!((check.z[0] - 5.0).abs() < 1e-9, "{check:?}");
        assert!(!check.agrees);
        let w = s.warning().expect("a warning");
        assert!(w.contains("mass +5.0 σ"), "{w}");
    }

    /// Regression, configs/paper.toml: a fit that takes the mass and centre of mass as given,
    /// with zero sigma, is not checked against the weighing (against which it would read 3e5 σ
    /// off), and its report still reads.
    #[test]
    fn a_fit_with_the_mass_given_is_not_checked_against_the_weighing() {
        let (l, t) = (
            weighing(1900.0, 0.0, 0.0, 1e-12),
            weighing(400.0, 0.0, 0.0, 1e-12),
        );
        let theta = |m: f64| [m, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        let s = section(&l, &t, &theta(1900.0), &theta(400.0), None);
        assert_eq!(s.check, None);
        assert_eq!(s.warning(), None);
        let report = Report {
            static_weighing: Some(s),
            ..Report::default()
        };
        let text = report.to_json();
        assert!(!text.contains("\"check\""), "{text}");
        let back: Report = serde_json::from_str(&text).expect("reads");
        assert_eq!(back.static_weighing, report.static_weighing);
    }
}
