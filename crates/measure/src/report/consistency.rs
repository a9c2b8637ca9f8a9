//! The report's `consistency` section: the physical-consistency verdict on the payload's fitted
//! estimate and, when it fails, the projection the report gives instead
//! ([`estimator::projection`]: the nearest consistent parameters in the metric of the payload's
//! covariance).

use estimator::Estimate;
use serde::{Deserialize, Serialize};

use super::{principal_of, quantities, Principal, Quantities};

/// Physical-consistency verdict on the payload's fitted estimate, and its projection onto the
/// consistent set when it fails ([`estimator::projection::nearest_consistent`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Consistency {
    /// `"consistent"` or `"inconsistent"`: the verdict on the fitted estimate.
    pub verdict: String,
    /// What failed, if anything (mass not positive, J_C not positive definite, triangle
    /// inequality broken), and that the projection failed when it did.
    pub problems: Vec<String>,
    /// True when the report's `estimate` and `principal` are the projection of the fitted
    /// estimate onto the consistent set (the nearest consistent parameters in the metric of the
    /// covariance behind `sigma`), not the fit itself; the fit is in `raw`.
    #[serde(default)]
    pub projected: bool,
    /// Mahalanobis distance √((θ* − θ̂)ᵀ Σ⁻¹ (θ* − θ̂)) from the fit θ̂ to the projection θ*, in
    /// sigmas; `null` unless projected. Beyond about 4 (for ten parameters) the fit is further
    /// from every consistent body than its uncertainty explains.
    #[serde(default)]
    pub distance_sigma: Option<f64>,
    /// The fitted estimate before the projection; `null` unless projected.
    #[serde(default)]
    pub raw: Option<RawEstimate>,
}

/// The fitted estimate, as `estimate` and `principal` would have given it without projection.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RawEstimate {
    /// Mass, centre of mass and J_C of the fit (NaN, written `null`, where the mass is not
    /// positive).
    pub estimate: Quantities,
    /// Principal moments and axes of the fit's J_C.
    pub principal: Principal,
}

/// The consistency section of the payload's estimate, and the estimate the report gives: the
/// fit itself when it is consistent, else its projection onto the consistent set
/// ([`estimator::nearest_consistent`], in the metric of the payload's covariance) with the same
/// covariance, the fit kept in `raw`. When the projection fails (non-finite fit or
/// covariance) the fit is reported as it is and `problems` says so.
pub fn consistency_of(payload: &Estimate) -> (Consistency, Estimate) {
    let verdict = payload.consistency;
    let mut section = Consistency {
        verdict: if verdict.is_consistent() {
            "consistent".into()
        } else {
            "inconsistent".into()
        },
        problems: verdict
            .first_failure()
            .map(|f| vec![f.to_string()])
            .unwrap_or_default(),
        ..Consistency::default()
    };
    if verdict.is_consistent() {
        return (section, *payload);
    }
    match estimator::nearest_consistent(&payload.parameters.to_vector(), &payload.covariance) {
        Some(p) if p.projected => {
            let mut reported = Estimate::from_parameters(p.parameters, payload.covariance);
            reported.residual_rms = payload.residual_rms;
            reported.counts = payload.counts;
            reported.timing = payload.timing;
            section.projected = true;
            section.distance_sigma = Some(p.distance_sigma);
            section.raw = Some(RawEstimate {
                estimate: quantities(payload),
                principal: principal_of(payload),
            });
            (section, reported)
        }
        _ => {
            section
                .problems
                .push("it could not be projected onto the consistent set".into());
            (section, *payload)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::{InertialParameters, ParameterCovariance};
    use nalgebra::{Matrix3, Vector3};

    fn body(mass: f64, moments: [f64; 3]) -> InertialParameters {
        InertialParameters::from_com(
            mass,
            Vector3::new(0.1, -0.2, 0.4),
            Matrix3::from_diagonal(&Vector3::from(moments)),
        )
    }

    #[test]
    fn a_consistent_fit_is_reported_as_it_is() {
        let e = Estimate::from_parameters(
            body(10.0, [1.0, 2.0, 2.5]),
            ParameterCovariance::identity() * 1e-4,
        );
        let (section, reported) = consistency_of(&e);
        assert_eq!(section.verdict, "consistent");
        assert!(!section.projected && section.raw.is_none() && section.problems.is_empty());
        assert_eq!(reported, e);
    }

    #[test]
    fn a_broken_triangle_is_reported_projected_with_the_fit_kept() {
        let e = Estimate::from_parameters(
            body(10.0, [1.0, 1.0, 2.1]),
            ParameterCovariance::identity() * 1e-2,
        );
        let (section, reported) = consistency_of(&e);
        assert_eq!(section.verdict, "inconsistent");
        assert_eq!(
            section.problems,
            vec!["principal moments break the triangle inequality (A + B >= C)".to_string()]
        );
        assert!(section.projected);
        assert!(reported.consistency.is_consistent());
        let m = reported.principal_moments_kg_m2;
        assert!(m.x + m.y >= m.z - 1e-9, "{m}");
        let raw = section.raw.expect("the fit is kept");
        assert_eq!(raw.estimate, quantities(&e));
        assert_eq!(raw.principal, principal_of(&e));
        assert!((raw.principal.moments[2] - 2.1).abs() < 1e-12);
        // The reported estimate moved towards the triangle's bound: J_zz down.
        assert!(reported.inertia_com_kg_m2[(2, 2)] < 2.1 - 1e-3);
        let d = section.distance_sigma.expect("a distance");
        assert!(d > 0.0 && d < 10.0, "{d}");
        // The JSON round trip keeps every field.
        let text = serde_json::to_string(&section).expect("serialises");
        let back: Consistency = serde_json::from_str(&text).expect("parses");
        assert_eq!(back.projected, section.projected);
        assert_eq!(back.distance_sigma, section.distance_sigma);
        // A report written before the projection existed still parses.
        let old: Consistency =
            serde_json::from_str(r#"{"verdict": "consistent", "problems": []}"#).expect("old");
        assert!(!old.projected && old.raw.is_none());
    }

    #[test]
    fn a_fit_that_cannot_be_projected_says_so() {
        let mut cov = ParameterCovariance::identity();
        cov[(3, 3)] = f64::NAN;
        let e = Estimate::from_parameters(body(10.0, [1.0, 1.0, 2.1]), cov);
        let (section, reported) = consistency_of(&e);
        assert!(!section.projected);
        assert_eq!(section.problems.len(), 2);
        assert_eq!(reported.parameters, e.parameters);
    }
}
