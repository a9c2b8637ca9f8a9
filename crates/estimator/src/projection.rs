//! The nearest physically consistent parameters to an estimate, in the metric of its covariance.
//!
//! **The consistent set.** With θ = [m, h, J_O] the pseudo-inertia matrix
//!
//! ```text
//!        ⎡ Σ   h ⎤        Σ = ∫ r rᵀ dm = ½ tr(J_O) 𝟙 − J_O
//! J(θ) = ⎢       ⎥ ,
//!        ⎣ hᵀ  m ⎦        J_O = tr(Σ) 𝟙 − Σ
//! ```
//!
//! is linear in θ and one-to-one (ten parameters, ten entries of a symmetric 4×4). J ≻ 0 holds
//! exactly when m > 0 and the second moment about the centre of mass Σ_C = Σ − h hᵀ/m (J's
//! Schur complement) is positive definite; Σ_C's eigenvalues are σᵢ = ½(J_j + J_k − J_i) of
//! J_C's principal moments Jᵢ, and Jᵢ = σ_j + σ_k, so J ≻ 0 implies every rule of
//! [`InertialParameters::consistency`] (m > 0, J_C ≻ 0, A + B ≥ C), and those rules imply
//! J ⪰ 0 (Wensing, Kim & Slotine 2017: the LMI form of physical consistency). The set
//! {θ : J(θ) ⪰ 0} is therefore a closed convex cone, and projecting onto it has one answer.
//!
//! **The projection** solves
//!
//! ```text
//! θ* = argmin ½ (θ − θ̂)ᵀ P⁻¹ (θ − θ̂)   subject to   J(θ) ⪰ ε T
//! ```
//!
//! with P the estimate's covariance and T = m_ref · diag(ℓ², ℓ², ℓ², 1) a reference body of
//! the estimate's own mass and size (m_ref = max(|m̂|, σ_m), ℓ² = |tr J_O|/(6 m_ref)); the
//! margin ε = 1e-9 keeps the answer strictly inside, so that it passes the consistency check
//! in floating point (m ≥ ε m_ref, Σ_C ⪰ ε m_ref ℓ² 𝟙). In whitened coordinates θ = θ̂ + L z,
//! P = L Lᵀ (L = V Λ^½ from P's eigen-decomposition, eigenvalues floored at 1e-12 of the
//! largest so that a parameter known exactly stays put), the objective is ½‖z‖² and the
//! problem is a small semidefinite program. It is solved by the log-det barrier method
//! (Boyd & Vandenberghe, *Convex Optimization*, §11.3): for t = t₀, 10 t₀, … minimise
//!
//! ```text
//! φ_t(z) = t · ½‖z‖² − log det G(z),     G(z) = J(θ̂ + L z) − ε T,
//! ∇φ_t = t z − g,   gₖ = tr(G⁻¹ Bₖ),   ∇²φ_t = t 𝟙 + H,   Hₖₗ = tr(G⁻¹ Bₖ G⁻¹ Bₗ),
//! ```
//!
//! (Bₖ = J(L eₖ)) by damped Newton steps with a backtracking line search that keeps G ≻ 0.
//! After centring at t the objective is within 4/t of the optimum (4 = the barrier's degree),
//! so the iteration stops once 4/t ≤ 1e-8 (1 + ½‖z‖²): ½d² is exact to 1e-8 of itself (or
//! absolutely, below one). It starts from θ̂'s pseudo-inertia with its eigenvalues raised to a
//! small positive floor (in the units of T), at t₀ = 4/(½‖z₀‖²); every iterate is strictly
//! consistent. H is formed as the Gram matrix of Cₖ = Λ⁻¹ Bₖ Λ⁻ᵀ (G = Λ Λᵀ) and the Newton
//! system solved through its eigen-decomposition, which keeps the step finite and downhill
//! when G is nearly singular.
//!
//! Fixed-size nalgebra, no allocation, no panic: a non-finite estimate or a covariance with no
//! positive finite eigenvalue gives `None`.

use crate::estimate::ParameterCovariance;
use nalgebra::{Cholesky, Matrix3, Matrix4, SMatrix, SVector, SymmetricEigen, Vector3};
use stewart_types::{InertialParameters, ParameterVector, PARAMETER_COUNT};

const N: usize = PARAMETER_COUNT;

/// Relative margin ε of the projection's target set J(θ) ⪰ ε T.
pub const CONSISTENCY_MARGIN: f64 = 1e-9;

/// Floor of P's eigenvalues, relative to the largest.
const EIGEN_FLOOR: f64 = 1e-12;

/// The barrier's degree: G is 4×4.
const BARRIER_DEGREE: f64 = 4.0;

/// Relative accuracy of ½d² at which the barrier method stops.
const ACCURACY: f64 = 1e-8;

/// Newton steps allowed in all (a step costs a few microseconds).
const MAX_NEWTON_STEPS: usize = 5000;

/// The nearest consistent parameters to an estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// θ*: the input itself when it was consistent, else the projection.
    pub parameters: InertialParameters,
    /// True when the input was inconsistent and θ* differs from it.
    pub projected: bool,
    /// Mahalanobis distance d = √((θ* − θ̂)ᵀ P⁻¹ (θ* − θ̂)) from the estimate, in sigmas
    /// (0 when not projected).
    pub distance_sigma: f64,
    /// True when the barrier method reached its accuracy (4/t ≤ 1e-8 (1 + ½d²)); θ* is
    /// consistent either way.
    pub converged: bool,
}

/// Pseudo-inertia J(θ) = [Σ h; hᵀ m], Σ = ½ tr(J_O) 𝟙 − J_O (linear in θ).
pub fn pseudo_inertia(theta: &ParameterVector) -> Matrix4<f64> {
    let p = InertialParameters::from_vector(theta);
    let j = p.inertia_origin_kg_m2;
    let sigma = Matrix3::identity() * (0.5 * j.trace()) - j;
    let h = p.first_moment_kg_m;
    let mut out = Matrix4::zeros();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    out.fixed_view_mut::<3, 1>(0, 3).copy_from(&h);
    out.fixed_view_mut::<1, 3>(3, 0).copy_from(&h.transpose());
    out.m44 = p.mass_kg;
    out
}

/// θ of a pseudo-inertia matrix (its symmetric part): m = J₃₃, h = J₀..₃,₃,
/// J_O = tr(Σ) 𝟙 − Σ. The inverse of [`pseudo_inertia`].
pub fn from_pseudo_inertia(j: &Matrix4<f64>) -> ParameterVector {
    let s = (j + j.transpose()) * 0.5;
    let sigma: Matrix3<f64> = s.fixed_view::<3, 3>(0, 0).into_owned();
    let h: Vector3<f64> = s.fixed_view::<3, 1>(0, 3).into_owned();
    InertialParameters {
        mass_kg: s.m44,
        first_moment_kg_m: h,
        inertia_origin_kg_m2: Matrix3::identity() * sigma.trace() - sigma,
    }
    .to_vector()
}

/// The parameters nearest to `theta` in the metric of `covariance` among those whose
/// pseudo-inertia is at least ε T (module docs): `theta` unchanged when it passes
/// [`InertialParameters::consistency`]. `None` when `theta` is not finite or `covariance` has no
/// positive finite eigenvalue.
pub fn nearest_consistent(
    theta: &ParameterVector,
    covariance: &ParameterCovariance,
) -> Option<Projection> {
    if !theta.iter().all(|v| v.is_finite()) {
        return None;
    }
    let input = InertialParameters::from_vector(theta);
    if input.consistency().is_consistent() {
        return Some(Projection {
            parameters: input,
            projected: false,
            distance_sigma: 0.0,
            converged: true,
        });
    }
    let (l, l_inv) = square_root(covariance)?;
    let t_ref = reference_body(theta, covariance);
    let g0 = pseudo_inertia(theta) - t_ref * CONSISTENCY_MARGIN;
    // Bₖ = J(L eₖ): how G moves with each whitened coordinate.
    let columns: [[f64; N]; N] = l.into();
    let basis: [Matrix4<f64>; N] = columns.map(|lk| pseudo_inertia(&ParameterVector::from(lk)));
    let z0 = start(theta, &t_ref, &l_inv)?;
    let problem = Barrier { g0, basis };
    let (z, converged) = problem.solve(z0)?;
    let moved = theta + l * z;
    let parameters = InertialParameters::from_vector(&moved);
    if !parameters.consistency().is_consistent() {
        return None;
    }
    Some(Projection {
        parameters,
        projected: true,
        distance_sigma: z.norm(),
        converged,
    })
}

/// L and L⁻¹ with P = L Lᵀ, L = V Λ^½ from P's symmetric eigen-decomposition, eigenvalues
/// floored at [`EIGEN_FLOOR`] of the largest.
fn square_root(
    covariance: &ParameterCovariance,
) -> Option<(SMatrix<f64, N, N>, SMatrix<f64, N, N>)> {
    if !covariance.iter().all(|v| v.is_finite()) {
        return None;
    }
    let sym = (covariance + covariance.transpose()) * 0.5;
    let eig = SymmetricEigen::try_new(sym, f64::EPSILON, 1000)?;
    let largest = eig.eigenvalues.max();
    if !(largest > 0.0 && largest.is_finite()) {
        return None;
    }
    let root = eig
        .eigenvalues
        .map(|v| libm::sqrt(v.max(largest * EIGEN_FLOOR)));
    let l = eig.eigenvectors * SMatrix::<f64, N, N>::from_diagonal(&root);
    let l_inv =
        SMatrix::<f64, N, N>::from_diagonal(&root.map(|r| 1.0 / r)) * eig.eigenvectors.transpose();
    Some((l, l_inv))
}

/// T = m_ref · diag(ℓ², ℓ², ℓ², 1): a body of the estimate's mass and size, the yardstick of the
/// margin and of the start.
fn reference_body(theta: &ParameterVector, covariance: &ParameterCovariance) -> Matrix4<f64> {
    let [mass_variance, ..]: [f64; N] = covariance.diagonal().into();
    let [m, _, _, _, jxx, jyy, jzz, ..]: [f64; N] = (*theta).into();
    let mass_sigma = libm::sqrt(mass_variance.max(0.0));
    let m_ref = m.abs().max(mass_sigma).max(f64::MIN_POSITIVE);
    let trace = (jxx + jyy + jzz).abs();
    let mut l2 = trace / (6.0 * m_ref);
    if !(l2 > 0.0 && l2.is_finite()) {
        l2 = 1.0;
    }
    Matrix4::from_diagonal(&nalgebra::Vector4::new(l2, l2, l2, 1.0)) * m_ref
}

/// A strictly feasible start near θ̂: J(θ̂) scaled by the reference body, Ĵ_s = T^-½ J(θ̂) T^-½,
/// with its eigenvalues raised to at least 2ε + 1e-6 of the largest magnitude (the nearest
/// such matrix in the Frobenius norm of the scaled entries), mapped back to θ₀;
/// z₀ = L⁻¹ (θ₀ − θ̂).
fn start(
    theta: &ParameterVector,
    t_ref: &Matrix4<f64>,
    l_inv: &SMatrix<f64, N, N>,
) -> Option<SVector<f64, N>> {
    // T is diagonal and positive.
    let s = t_ref.diagonal().map(|v| 1.0 / libm::sqrt(v));
    let s_inv = t_ref.diagonal().map(libm::sqrt);
    let scaled = Matrix4::from_diagonal(&s) * pseudo_inertia(theta) * Matrix4::from_diagonal(&s);
    let eig = SymmetricEigen::try_new(scaled, f64::EPSILON, 1000)?;
    let largest = eig.eigenvalues.amax();
    if !largest.is_finite() {
        return None;
    }
    let floor = 2.0 * CONSISTENCY_MARGIN + 1e-6 * largest;
    let raised = eig.eigenvalues.map(|v| v.max(floor));
    let repaired =
        eig.eigenvectors * Matrix4::from_diagonal(&raised) * eig.eigenvectors.transpose();
    let j0 = Matrix4::from_diagonal(&s_inv) * repaired * Matrix4::from_diagonal(&s_inv);
    Some(l_inv * (from_pseudo_inertia(&j0) - theta))
}

/// G(z) = G₀ + Σ zₖ Bₖ and the barrier problem over it.
struct Barrier {
    g0: Matrix4<f64>,
    basis: [Matrix4<f64>; N],
}

impl Barrier {
    fn g(&self, z: &SVector<f64, N>) -> Matrix4<f64> {
        self.basis
            .iter()
            .zip(z.iter())
            .fold(self.g0, |acc, (b, zk)| acc + b * *zk)
    }

    /// φ_t(z) = t ½‖z‖² − log det G(z); `None` when G(z) is not positive definite.
    fn value(&self, t: f64, z: &SVector<f64, N>) -> Option<f64> {
        let c = Cholesky::new(self.g(z))?;
        let l = c.l_dirty();
        let mut log_det = 0.0;
        for d in l.diagonal().iter().copied() {
            if !(d > 0.0 && d.is_finite()) {
                return None;
            }
            log_det += 2.0 * libm::log(d);
        }
        Some(t * 0.5 * z.norm_squared() - log_det)
    }

    /// Gradient of φ_t at z and the barrier's Hessian H (φ_t's is t 𝟙 + H); `None` when G(z) is
    /// not positive definite.
    fn derivatives(
        &self,
        t: f64,
        z: &SVector<f64, N>,
    ) -> Option<(SVector<f64, N>, SMatrix<f64, N, N>)> {
        // With G = Λ Λᵀ, Cₖ = Λ⁻¹ Bₖ Λ⁻ᵀ: gₖ = tr Cₖ and Hₖₗ = ⟨Cₖ, Cₗ⟩ (a Gram matrix, so
        // positive semidefinite in floating point too, unlike tr(G⁻¹Bₖ G⁻¹Bₗ) formed directly).
        let lambda_inv = Cholesky::new(self.g(z))?
            .l()
            .solve_lower_triangular(&Matrix4::identity())?;
        let c: [Matrix4<f64>; N] = self
            .basis
            .map(|bk| lambda_inv * bk * lambda_inv.transpose());
        let grad = z * t - SVector::<f64, N>::from(c.map(|ck| ck.trace()));
        // Column l holds ⟨Cₖ, Cₗ⟩ for k = 0…N−1 (nalgebra's arrays are column-major).
        let gram = SMatrix::<f64, N, N>::from(c.map(|cl| c.map(|ck| ck.dot(&cl))));
        Some((grad, gram))
    }

    /// The barrier method from a strictly feasible z₀: (z*, converged); `None` if z₀ is not
    /// feasible. Every iterate is feasible, so a numerical failure on the way returns the last
    /// one, not converged.
    fn solve(&self, z0: SVector<f64, N>) -> Option<(SVector<f64, N>, bool)> {
        let mut z = z0;
        self.value(1.0, &z)?;
        // Start where the duality gap 4/t is the start's own distance ½‖z₀‖²: a smaller t
        // wastes steps, a larger one presses the first centre against the boundary, where G
        // is too ill-conditioned for the Newton step.
        let mut t = BARRIER_DEGREE / (0.5 * z.norm_squared()).max(f64::MIN_POSITIVE);
        let mut steps = 0;
        loop {
            // Centre: damped Newton on φ_t until the decrement is negligible.
            loop {
                if steps >= MAX_NEWTON_STEPS {
                    return Some((z, false));
                }
                steps += 1;
                let Some((grad, gram)) = self.derivatives(t, &z) else {
                    return Some((z, false));
                };
                // (t 𝟙 + H)⁻¹ through H's eigen-decomposition: near the boundary H's entries
                // dwarf t, and a Cholesky factor of t 𝟙 + H would lose t to rounding.
                let Some(eig) = SymmetricEigen::try_new(gram, f64::EPSILON, 1000) else {
                    return Some((z, false));
                };
                let v = eig.eigenvectors;
                let scale = eig.eigenvalues.map(|e| 1.0 / (e.max(0.0) + t));
                let step = -(v * (v.transpose() * grad).component_mul(&scale));
                let decrement = -grad.dot(&step);
                if !decrement.is_finite() {
                    return Some((z, false));
                }
                // For a self-concordant φ_t, φ_t − min φ_t ≤ λ² once λ² is small: 1e-9 of φ_t
                // is 1e-9/t of ½d², far inside the accuracy asked for.
                if decrement * 0.5 <= 1e-9 {
                    break;
                }
                let Some(here) = self.value(t, &z) else {
                    return Some((z, false));
                };
                let mut s = 1.0;
                let mut moved = false;
                for _ in 0..60 {
                    let trial = z + step * s;
                    if let Some(v) = self.value(t, &trial) {
                        if v < here && v <= here - 0.25 * s * decrement {
                            z = trial;
                            moved = true;
                            break;
                        }
                    }
                    s *= 0.5;
                }
                if !moved {
                    break;
                }
            }
            if BARRIER_DEGREE / t <= ACCURACY * (1.0 + 0.5 * z.norm_squared()) {
                return Some((z, true));
            }
            t *= 10.0;
        }
    }
}

#[cfg(test)]
#[path = "projection_tests.rs"]
mod tests;
