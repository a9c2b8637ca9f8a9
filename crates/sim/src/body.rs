//! Inertial properties of the rigid bodies on the plate (fixture plate, payload).
//!
//! A body is given the way a user describes it: mass, centre of mass `c` in P and the inertia
//! tensor about the centre of mass `J_C` in P axes. The estimator works with the parameters about
//! the P origin, `m`, `h = m c` and `J_O = J_C + m(‖c‖²𝟙 − c cᵀ)` (parallel-axis theorem),
//! which add across bodies; the shared [`InertialParameters`] holds that form, and
//! [`InertialParameters::from_body`] takes a [`BodyProperties`] there.

use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Vector3};
use serde::{Deserialize, Serialize};
use stewart_types::{InertialParameters, RigidBody};

use crate::error::SimError;

/// Mass, centre of mass and inertia tensor of one rigid body, in P (the plate frame).
///
/// `inertia_com_kg_m2` is the tensor `J_C = ∫(‖r‖²𝟙 − r rᵀ) dm` about the centre of mass, so its
/// off-diagonal entries are minus the products of inertia. All three products may be non-zero.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyProperties {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in P, metres.
    pub com_m: [f64; 3],
    /// Inertia tensor about the centre of mass, in P axes, kg·m² (rows).
    pub inertia_com_kg_m2: [[f64; 3]; 3],
}

impl Default for BodyProperties {
    /// A 200 kg fixture plate, 1.6 m × 1.6 m × 0.06 m, resting with its underside on the P origin.
    fn default() -> Self {
        Self::cuboid(200.0, [0.0, 0.0, 0.03], [1.6, 1.6, 0.06])
    }
}

impl BodyProperties {
    /// A homogeneous box of the given mass and edge lengths, axes along P, centred on `com_m`:
    /// `J_xx = m (b² + c²) / 12` and cyclic.
    pub fn cuboid(mass_kg: f64, com_m: [f64; 3], size_m: [f64; 3]) -> Self {
        let [a, b, c] = size_m.map(|s| s * s);
        let k = mass_kg / 12.0;
        Self {
            mass_kg,
            com_m,
            inertia_com_kg_m2: [
                [k * (b + c), 0.0, 0.0],
                [0.0, k * (a + c), 0.0],
                [0.0, 0.0, k * (a + b)],
            ],
        }
    }

    /// Builds a body from principal moments and the rotation from principal axes into P:
    /// `J_C = Q diag(moments) Qᵀ`. Handy for tensors with all products of inertia non-zero.
    pub fn from_principal(
        mass_kg: f64,
        com_m: [f64; 3],
        moments_kg_m2: [f64; 3],
        principal_to_p: &Rotation3<f64>,
    ) -> Self {
        let q = principal_to_p.matrix();
        let j = q * Matrix3::from_diagonal(&Vector3::from(moments_kg_m2)) * q.transpose();
        let j = 0.5 * (j + j.transpose());
        Self {
            mass_kg,
            com_m,
            inertia_com_kg_m2: matrix_to_rows(&j),
        }
    }

    /// Centre of mass as a vector.
    pub fn com(&self) -> Vector3<f64> {
        Vector3::from(self.com_m)
    }

    /// Inertia tensor about the centre of mass as a matrix.
    pub fn inertia_com(&self) -> Matrix3<f64> {
        rows_to_matrix(&self.inertia_com_kg_m2)
    }

    /// Checks that the body is physical: positive finite mass, finite centre of mass, and a
    /// symmetric positive-definite tensor whose principal moments satisfy the triangle
    /// inequality `λᵢ ≤ λⱼ + λₖ` (no real mass distribution violates it).
    pub fn validate(&self, body: &'static str) -> Result<(), SimError> {
        let bad = |reason| Err(SimError::InvalidBody { body, reason });
        if !(self.mass_kg.is_finite() && self.mass_kg > 0.0) {
            return bad("mass_kg must be positive and finite");
        }
        if !self.com_m.iter().all(|v| v.is_finite()) {
            return bad("com_m must be finite");
        }
        let j = self.inertia_com();
        if !j.iter().all(|v| v.is_finite()) {
            return bad("inertia_com_kg_m2 must be finite");
        }
        let scale = j.trace().abs().max(f64::MIN_POSITIVE);
        if (j - j.transpose()).amax() > 1e-9 * scale {
            return bad("inertia_com_kg_m2 must be symmetric");
        }
        let (moments, _) = principal_axes(&j);
        if moments.iter().any(|&l| l <= 0.0) {
            return bad("inertia_com_kg_m2 must be positive definite");
        }
        let sum = moments.sum();
        if moments.iter().any(|&l| l > sum - l + 1e-9 * sum) {
            return bad("principal moments violate the triangle inequality");
        }
        Ok(())
    }
}

/// Principal moments and axes of a symmetric tensor: `J = Q diag(λ) Qᵀ` with `Q` a proper
/// rotation (columns are the principal axes, determinant +1), as rapier's mass properties need.
pub(crate) fn principal_axes(j: &Matrix3<f64>) -> (Vector3<f64>, Rotation3<f64>) {
    let sym = 0.5 * (j + j.transpose());
    let eig = SymmetricEigen::new(sym);
    let mut q = eig.eigenvectors;
    if q.determinant() < 0.0 {
        q.column_mut(2).neg_mut();
    }
    (eig.eigenvalues, Rotation3::from_matrix_unchecked(q))
}

impl RigidBody for BodyProperties {
    fn mass(&self) -> f64 {
        self.mass_kg
    }

    fn com(&self) -> Vector3<f64> {
        BodyProperties::com(self)
    }

    fn inertia_com(&self) -> Matrix3<f64> {
        BodyProperties::inertia_com(self)
    }
}

impl BodyProperties {
    /// Back from parameters about the P origin to mass, centre of mass and tensor about the
    /// centre of mass: `c = h / m`, `J_C = J_O − m(‖c‖²𝟙 − c cᵀ)`. `None` unless `m` is positive
    /// and finite.
    pub fn from_parameters(p: &InertialParameters) -> Option<Self> {
        Some(Self {
            mass_kg: p.mass_kg,
            com_m: p.com_m()?.into(),
            inertia_com_kg_m2: matrix_to_rows(&p.inertia_com_kg_m2()?),
        })
    }
}

pub(crate) fn rows_to_matrix(rows: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| rows[r][c])
}

pub(crate) fn matrix_to_rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| m[(r, c)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted() -> BodyProperties {
        let q = Rotation3::from_euler_angles(0.3, -0.5, 0.8);
        BodyProperties::from_principal(1500.0, [0.2, -0.1, 0.5], [500.0, 2200.0, 2400.0], &q)
    }

    #[test]
    fn from_principal_has_all_products_and_round_trips() {
        let b = tilted();
        let j = b.inertia_com();
        assert!(j[(0, 1)].abs() > 10.0 && j[(0, 2)].abs() > 10.0 && j[(1, 2)].abs() > 10.0);
        let (moments, q) = principal_axes(&j);
        let mut sorted = [moments.x, moments.y, moments.z];
        sorted.sort_by(f64::total_cmp);
        for (got, want) in sorted.iter().zip([500.0, 2200.0, 2400.0]) {
            assert!((got - want).abs() < 1e-9 * want);
        }
        let back = q.matrix() * Matrix3::from_diagonal(&moments) * q.matrix().transpose();
        assert!((back - j).amax() < 1e-9);
        assert!((q.matrix().determinant() - 1.0).abs() < 1e-12);
        b.validate("payload").unwrap();
    }

    #[test]
    fn parallel_axis_round_trip_and_addition() {
        let a = InertialParameters::from_body(&tilted());
        let b = InertialParameters::from_body(&BodyProperties::default());
        let back = BodyProperties::from_parameters(&a).unwrap();
        let orig = tilted();
        assert!((back.com() - orig.com()).amax() < 1e-12);
        assert!((back.inertia_com() - orig.inertia_com()).amax() < 1e-9);
        // A point mass at c has J_O = m(‖c‖²𝟙 − c cᵀ): Jxy = −m cx cy.
        let p = InertialParameters::from_body(&BodyProperties {
            mass_kg: 2.0,
            com_m: [1.0, 2.0, 3.0],
            inertia_com_kg_m2: [[0.0; 3]; 3],
        });
        assert_eq!(
            p.theta(),
            [2.0, 2.0, 4.0, 6.0, 26.0, 20.0, 10.0, -4.0, -6.0, -12.0]
        );
        let s = a + b;
        for (k, v) in s.theta().iter().enumerate() {
            assert!((v - a.theta()[k] - b.theta()[k]).abs() < 1e-9);
        }
    }

    #[test]
    fn validation_refuses_unphysical_bodies() {
        let mut b = tilted();
        b.mass_kg = 0.0;
        assert!(b.validate("payload").is_err());
        let mut b = tilted();
        b.inertia_com_kg_m2[0][1] += 1.0;
        assert!(b.validate("payload").is_err());
        // Moments 1, 1, 3 violate 3 ≤ 1 + 1.
        let b =
            BodyProperties::from_principal(1.0, [0.0; 3], [1.0, 1.0, 3.0], &Rotation3::identity());
        assert!(b.validate("payload").is_err());
        let mut b = tilted();
        b.com_m[2] = f64::NAN;
        assert!(b.validate("payload").is_err());
    }
}
