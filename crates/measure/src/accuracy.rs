//! Accuracy statistics of a set of measurements of one payload whose truth is known (a
//! campaign of simulated runs): per parameter of the payload (mass, centre of mass, J_C),
//!
//! - **mean error** `ē = mean(x̂ − x)`: the bias, to be read against `spread/√N`;
//! - **spread**: the sample standard deviation of the estimates over the runs (`N − 1`);
//! - **largest error** `max |x̂ − x|`, against the acceptance: mass 0.2 %, centre of mass
//!   1 mm, diagonal of J_C 0.5 %, off-diagonal 0.5 % of the smallest principal moment;
//! - **mean z²** `mean(((x̂ − x)/σ̂)²)` with σ̂ each run's reported sigma: 1 when the sigmas are
//!   honest, below when they are pessimistic, above when optimistic (for N runs its own
//!   sampling spread is about `√(2/N)`);
//! - **share within 2σ**: the fraction of runs with `|x̂ − x| ≤ 2σ̂` (95.4 % for honest
//!   Gaussian errors).

use nalgebra::{Matrix3, SymmetricEigen};
use serde::Serialize;

use crate::report::{Quantities, Report};

/// One parameter of the payload: name, unit, accessor.
struct Parameter {
    name: &'static str,
    unit: &'static str,
    get: fn(&Quantities) -> f64,
    kind: Kind,
}

/// Which acceptance applies (mass 0.2 %, centre of mass 1 mm, J_C 0.5 %: docs/accuracy.md).
#[derive(Clone, Copy)]
enum Kind {
    Mass,
    Com,
    Diagonal,
    OffDiagonal,
}

const PARAMETERS: [Parameter; 10] = [
    Parameter {
        name: "mass",
        unit: "kg",
        get: |q| q.mass,
        kind: Kind::Mass,
    },
    Parameter {
        name: "com x",
        unit: "m",
        get: |q| q.com[0],
        kind: Kind::Com,
    },
    Parameter {
        name: "com y",
        unit: "m",
        get: |q| q.com[1],
        kind: Kind::Com,
    },
    Parameter {
        name: "com z",
        unit: "m",
        get: |q| q.com[2],
        kind: Kind::Com,
    },
    Parameter {
        name: "J_C xx",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][0],
        kind: Kind::Diagonal,
    },
    Parameter {
        name: "J_C yy",
        unit: "kg·m²",
        get: |q| q.inertia_com[1][1],
        kind: Kind::Diagonal,
    },
    Parameter {
        name: "J_C zz",
        unit: "kg·m²",
        get: |q| q.inertia_com[2][2],
        kind: Kind::Diagonal,
    },
    Parameter {
        name: "J_C xy",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][1],
        kind: Kind::OffDiagonal,
    },
    Parameter {
        name: "J_C xz",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][2],
        kind: Kind::OffDiagonal,
    },
    Parameter {
        name: "J_C yz",
        unit: "kg·m²",
        get: |q| q.inertia_com[1][2],
        kind: Kind::OffDiagonal,
    },
];

/// Issue 4's acceptance for one parameter of a body whose truth is `truth`.
fn acceptance(kind: Kind, value: f64, truth: &Quantities) -> f64 {
    match kind {
        Kind::Mass => 0.002 * value.abs(),
        Kind::Com => 1e-3,
        Kind::Diagonal => 0.005 * value.abs(),
        Kind::OffDiagonal => {
            let j = Matrix3::from_fn(|r, c| truth.inertia_com[r][c]);
            let smallest = SymmetricEigen::new(j).eigenvalues.min();
            0.005 * smallest
        }
    }
}

/// Campaign statistics of one parameter (errors are estimate − truth, in the parameter's unit).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParameterStats {
    /// `mass`, `com x`, …, `J_C yz`.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Ground truth (the same in every run).
    pub truth: f64,
    /// Mean error over the runs (the bias).
    pub mean_error: f64,
    /// Sample standard deviation of the estimates over the runs.
    pub spread: f64,
    /// `mean_error / (spread/√N)`: how many standard errors the bias is (|·| > 3 is a real
    /// bias); null with fewer than two runs or no spread (identical runs, as without noise).
    pub mean_error_in_standard_errors: Option<f64>,
    /// Largest |error|.
    pub max_abs_error: f64,
    /// Mean of the reported sigmas.
    pub mean_sigma: f64,
    /// Mean of (error/σ)²; null when a sigma is zero (e.g. mass and centre of mass with
    /// `params = 6`, which are given, not estimated).
    pub mean_z2: Option<f64>,
    /// Share of runs with |error| ≤ 2σ.
    pub within_2_sigma: f64,
    /// Issue 4's acceptance for |error|.
    pub acceptance: f64,
    /// `max_abs_error ≤ acceptance`.
    pub within_acceptance: bool,
}

/// Statistics of `reports` (all with the same truth). `None` without reports or truth.
pub fn statistics(reports: &[Report]) -> Option<Vec<ParameterStats>> {
    let truth = reports.first()?.truth?;
    let n = reports.len() as f64;
    let rows = PARAMETERS.iter().map(|p| {
        let t = (p.get)(&truth);
        let estimates: Vec<f64> = reports.iter().map(|r| (p.get)(&r.estimate)).collect();
        let sigmas: Vec<f64> = reports.iter().map(|r| (p.get)(&r.sigma)).collect();
        let errors: Vec<f64> = estimates.iter().map(|e| e - t).collect();
        let mean_error = errors.iter().sum::<f64>() / n;
        let mean_estimate = estimates.iter().sum::<f64>() / n;
        let spread = if reports.len() > 1 {
            (estimates
                .iter()
                .map(|e| (e - mean_estimate).powi(2))
                .sum::<f64>()
                / (n - 1.0))
                .sqrt()
        } else {
            0.0
        };
        let standard_error = spread / n.sqrt();
        let honest_sigmas = sigmas.iter().all(|s| s.is_finite() && *s > 0.0);
        let mean_z2 = honest_sigmas.then(|| {
            errors
                .iter()
                .zip(&sigmas)
                .map(|(e, s)| (e / s).powi(2))
                .sum::<f64>()
                / n
        });
        let within = errors
            .iter()
            .zip(&sigmas)
            .filter(|(e, s)| e.abs() <= 2.0 * **s)
            .count() as f64
            / n;
        let max_abs_error = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        let limit = acceptance(p.kind, t, &truth);
        ParameterStats {
            name: p.name.into(),
            unit: p.unit.into(),
            truth: t,
            mean_error,
            spread,
            // A spread at rounding level (identical runs, e.g. without noise) gives no
            // standard error to compare the bias with.
            mean_error_in_standard_errors: (reports.len() > 1
                && spread > 1e-9 * t.abs().max(mean_estimate.abs()))
            .then(|| mean_error / standard_error),
            max_abs_error,
            mean_sigma: sigmas.iter().sum::<f64>() / n,
            mean_z2,
            within_2_sigma: within,
            acceptance: limit,
            within_acceptance: max_abs_error <= limit,
        }
    });
    Some(rows.collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(mass: f64, com_x: f64, jxy: f64) -> Quantities {
        Quantities {
            mass,
            com: [com_x, 0.0, 0.5],
            inertia_com: [[600.0, jxy, 0.0], [jxy, 2500.0, 0.0], [0.0, 0.0, 2700.0]],
        }
    }

    fn report(estimate: Quantities, sigma: Quantities, truth: Quantities) -> Report {
        Report {
            estimate,
            sigma,
            truth: Some(truth),
            ..Report::default()
        }
    }

    #[test]
    fn statistics_by_hand() {
        let truth = body(1500.0, 0.125, -25.0);
        let sigma = body(1.0, 1e-3, 0.5);
        // Mass errors +1, −1, +3 (σ = 1): mean 1, z² mean (1+1+9)/3, two of three within 2σ.
        let reports = [
            report(body(1501.0, 0.125, -25.0), sigma, truth),
            report(body(1499.0, 0.125, -25.0), sigma, truth),
            report(body(1503.0, 0.125, -21.0), sigma, truth),
        ];
        let s = statistics(&reports).unwrap();
        let mass = &s[0];
        assert_eq!(mass.name, "mass");
        assert!((mass.mean_error - 1.0).abs() < 1e-12);
        assert!((mass.spread - 2.0).abs() < 1e-12); // estimates 1501, 1499, 1503
        assert!((mass.max_abs_error - 3.0).abs() < 1e-12);
        assert!((mass.mean_z2.unwrap() - 11.0 / 3.0).abs() < 1e-12);
        assert!((mass.within_2_sigma - 2.0 / 3.0).abs() < 1e-12);
        assert!((mass.acceptance - 3.0).abs() < 1e-12); // 0.2 % of 1500 kg
        assert!(mass.within_acceptance);
        let se = 2.0 / 3f64.sqrt();
        assert!((mass.mean_error_in_standard_errors.unwrap() - 1.0 / se).abs() < 1e-12);
        // Off-diagonal acceptance: 0.5 % of the smallest principal moment.
        let xy = &s[7];
        assert_eq!(xy.name, "J_C xy");
        let smallest: f64 = SymmetricEigen::new(Matrix3::new(
            600.0, -25.0, 0.0, -25.0, 2500.0, 0.0, 0.0, 0.0, 2700.0,
        ))
        .eigenvalues
        .min();
        assert!((xy.acceptance - 0.005 * smallest).abs() < 1e-12);
        assert!((xy.max_abs_error - 4.0).abs() < 1e-12);
        assert!(!xy.within_acceptance); // 4 kg·m² > 0.5 % of ≈ 599.7 = 3.0
                                        // Com: 1 mm, no error at all.
        assert_eq!(s[1].acceptance, 1e-3);
        assert_eq!(s[1].max_abs_error, 0.0);
        assert_eq!(s[1].mean_error_in_standard_errors, None);
    }

    #[test]
    fn zero_sigma_gives_no_z2_and_no_truth_gives_no_statistics() {
        let truth = body(1500.0, 0.1, -25.0);
        let mut sigma = body(1.0, 1e-3, 0.5);
        sigma.mass = 0.0;
        let s = statistics(&[report(truth, sigma, truth)]).unwrap();
        assert_eq!(s[0].mean_z2, None);
        assert_eq!(s[4].mean_z2, Some(0.0));
        let mut r = report(truth, sigma, truth);
        r.truth = None;
        assert!(statistics(&[r]).is_none());
        assert!(statistics(&[]).is_none());
    }
}
