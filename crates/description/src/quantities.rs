//! The ten quantities a measurement reports, in the order every table, report and plan target
//! uses: mass, centre of mass, J_C (the inertia tensor about the centre of mass).

use estimator::Estimate;
use serde::{Deserialize, Serialize};

/// Mass, centre of mass and inertia about the centre of mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quantities {
    /// kg.
    pub mass: f64,
    /// Centre of mass in P, m.
    pub com: [f64; 3],
    /// J_C in P axes, kg·m².
    pub inertia_com: [[f64; 3]; 3],
}

impl Quantities {
    /// Names of the entries of [`Self::flat`], as the tables print them.
    pub const NAMES: [&'static str; 10] = [
        "mass", "com x", "com y", "com z", "J_C xx", "J_C yy", "J_C zz", "J_C xy", "J_C xz",
        "J_C yz",
    ];

    /// [m, c_x, c_y, c_z, J_xx, J_yy, J_zz, J_xy, J_xz, J_yz].
    pub fn flat(&self) -> [f64; 10] {
        let (c, j) = (self.com, self.inertia_com);
        [
            self.mass, c[0], c[1], c[2], j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2],
        ]
    }

    /// The inverse of [`Self::flat`] (J_C symmetric).
    pub fn from_flat(q: &[f64; 10]) -> Self {
        let (xx, yy, zz, xy, xz, yz) = (q[4], q[5], q[6], q[7], q[8], q[9]);
        Self {
            mass: q[0],
            com: [q[1], q[2], q[3]],
            inertia_com: [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]],
        }
    }
}

/// Principal moments (ascending) and axes (row k is the unit axis of moment k, in P).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Principal {
    /// kg·m², ascending.
    pub moments: [f64; 3],
    /// Row k: the unit axis (in P) of `moments[k]`.
    pub axes: [[f64; 3]; 3],
}

fn rows(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    core::array::from_fn(|r| core::array::from_fn(|c| m[(r, c)]))
}

/// Mass, centre of mass and J_C of an estimate.
pub fn quantities(e: &Estimate) -> Quantities {
    Quantities {
        mass: e.parameters.mass_kg,
        com: e.com_m.into(),
        inertia_com: rows(&e.inertia_com_kg_m2),
    }
}

/// One sigma of each entry of [`quantities`].
pub fn sigmas(e: &Estimate) -> Quantities {
    Quantities {
        mass: e.mass_sigma_kg,
        com: e.com_sigma_m.into(),
        inertia_com: rows(&e.inertia_com_sigma_kg_m2),
    }
}

/// Principal moments and axes of an estimate, as the report gives them.
pub fn principal_of(e: &Estimate) -> Principal {
    let axes = e.principal_axes;
    Principal {
        moments: e.principal_moments_kg_m2.into(),
        axes: core::array::from_fn(|k| core::array::from_fn(|r| axes[(r, k)])),
    }
}

/// The decision on one nominal value ([`conformity`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Verdict {
    /// The measured value lies within the tolerance by at least the expanded uncertainty.
    Conforms,
    /// The measured value lies outside the tolerance by more than the expanded uncertainty.
    DoesNotConform,
    /// Neither: the expanded uncertainty straddles a tolerance limit, so no statement of
    /// conformity can be made at 95 %.
    Undecided,
}

impl Verdict {
    /// In words, as the certificate states it.
    pub fn describe(self) -> &'static str {
        match self {
            Verdict::Conforms => "conforms",
            Verdict::DoesNotConform => "does not conform",
            Verdict::Undecided => "no statement possible",
        }
    }
}

/// A statement of conformity with one nominal value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Conformity {
    /// The quantity ([`Quantities::NAMES`]).
    pub quantity: String,
    /// The nominal value and the tolerance, SI.
    pub nominal: f64,
    /// ± this around the nominal value, SI.
    pub tolerance: f64,
    /// The measured value, SI.
    pub measured: f64,
    /// U = 2σ, the expanded uncertainty (k = 2, about 95 %), SI.
    pub expanded_uncertainty: f64,
    /// The decision.
    pub verdict: Verdict,
}

/// The decision rule, in words, as the certificate states it.
pub const DECISION_RULE: &str = "guarded acceptance with the guard band equal to the expanded \
    uncertainty U (k = 2, about 95 %; ILAC-G8:09/2019, ISO/IEC 17025 §7.1.3): conforms when \
    |measured − nominal| ≤ tolerance − U, does not conform when |measured − nominal| > \
    tolerance + U, otherwise no statement is possible; the probability of a false acceptance \
    is then below 2.5 %";

/// Conformity with each of `nominal` of the values `estimate` with sigmas `sigma`, by
/// [`DECISION_RULE`]; a nominal whose quantity is not one of [`Quantities::NAMES`] is left out
/// (validation refuses it).
pub fn conformity(
    nominal: &[crate::config::Nominal],
    estimate: &Quantities,
    sigma: &Quantities,
) -> Vec<Conformity> {
    let (x, s) = (estimate.flat(), sigma.flat());
    nominal
        .iter()
        .filter_map(|n| {
            let k = Quantities::NAMES.iter().position(|q| *q == n.quantity)?;
            let u = 2.0 * s[k];
            let off = (x[k] - n.value).abs();
            let verdict = if off <= n.tolerance - u {
                Verdict::Conforms
            } else if off > n.tolerance + u {
                Verdict::DoesNotConform
            } else {
                Verdict::Undecided
            };
            Some(Conformity {
                quantity: n.quantity.clone(),
                nominal: n.value,
                tolerance: n.tolerance,
                measured: x[k],
                expanded_uncertainty: u,
                verdict,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Nominal;

    /// The rule's three outcomes on a mass of 1500 ± 0.5 kg (σ; U = 1 kg) against 1497 kg
    /// nominal: a tolerance of 5 kg conforms (3 + 1 ≤ 5), 1.5 kg does not (3 > 1.5 + 1), and
    /// 2.5 kg leaves no statement (2.5 − 1 < 3 ≤ 2.5 + 1); an unknown quantity is left out.
    #[test]
    fn the_guard_band_is_the_expanded_uncertainty() {
        let estimate = Quantities {
            mass: 1500.0,
            ..Quantities::default()
        };
        let sigma = Quantities {
            mass: 0.5,
            ..Quantities::default()
        };
        let nominal = |tolerance: f64| Nominal {
            quantity: "mass".into(),
            value: 1497.0,
            tolerance,
        };
        let unknown = Nominal {
            quantity: "weight".into(),
            ..nominal(1.0)
        };
        let c = conformity(
            &[nominal(5.0), nominal(1.5), nominal(2.5), unknown],
            &estimate,
            &sigma,
        );
        let verdicts: Vec<_> = c.iter().map(|c| c.verdict).collect();
        assert_eq!(
            verdicts,
            [
                Verdict::Conforms,
                Verdict::DoesNotConform,
                Verdict::Undecided
            ]
        );
        assert_eq!(c[0].expanded_uncertainty, 1.0);
        // On the limits: exactly tolerance − U conforms, exactly tolerance + U is undecided.
        let edge = conformity(&[nominal(4.0), nominal(2.0)], &estimate, &sigma);
        assert_eq!(edge[0].verdict, Verdict::Conforms);
        assert_eq!(edge[1].verdict, Verdict::Undecided);
    }
}
