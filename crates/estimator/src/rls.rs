//! Recursive least squares in Bierman's U-D factorised form, and a batch solver over the same
//! weighted normal equations.
//!
//! The vector form of the paper's Eq. 16–18 with the errata (forgetting factor λ):
//! K = P φ (λ𝟙 + φᵀ P φ)⁻¹, θ ← θ + K (y − φᵀ θ), P ← (𝟙 − K φᵀ) P / λ.
//! With rows already divided by their noise sigma (unit noise), this equals dividing P by λ
//! once per sample and then processing the rows one at a time as scalar updates with unit
//! noise. Each scalar update is done on the factors P = U D Uᵀ (U unit upper triangular, D
//! diagonal; G. J. Bierman, *Factorization Methods for Discrete Sequential Estimation*, 1977):
//! every new dⱼ is a product of positive numbers, so P stays symmetric positive definite by
//! construction, whatever the rounding, over any number of updates.

use crate::error::EstimatorError;
use nalgebra::{Cholesky, SMatrix, SVector};

/// Recursive least squares for `N` parameters, U-D factorised.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rls<const N: usize> {
    theta: SVector<f64, N>,
    u: SMatrix<f64, N, N>,
    d: SVector<f64, N>,
    forgetting: f64,
    max_variance: f64,
}

impl<const N: usize> Rls<N> {
    /// Starts from `initial` with a diagonal prior covariance `prior_variance` (P₀), and
    /// forgetting factor λ ∈ (0, 1]. No cap on the covariance (see [`Self::with_variance_cap`]).
    pub fn new(
        initial: SVector<f64, N>,
        prior_variance: SVector<f64, N>,
        forgetting: f64,
    ) -> Result<Self, EstimatorError> {
        if !(forgetting > 0.0 && forgetting <= 1.0) {
            return Err(EstimatorError::InvalidConfig(
                "forgetting_factor must be in (0, 1]",
            ));
        }
        if !prior_variance.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "prior variance must be positive and finite",
            ));
        }
        if !initial.iter().all(|v| v.is_finite()) {
            return Err(EstimatorError::InvalidConfig(
                "initial parameters must be finite",
            ));
        }
        Ok(Self {
            theta: initial,
            u: SMatrix::identity(),
            d: prior_variance,
            forgetting,
            max_variance: f64::INFINITY,
        })
    }

    /// Caps each dⱼ at `cap` when dividing by λ, so that with λ < 1 the covariance cannot wind
    /// up without bound while the excitation is poor (a bounded-covariance variant; with the
    /// cap at the prior variance the estimator is never less sure than it started).
    pub fn with_variance_cap(mut self, cap: f64) -> Self {
        if cap > 0.0 {
            self.max_variance = cap;
        }
        self
    }

    /// The current estimate θ.
    pub fn theta(&self) -> &SVector<f64, N> {
        &self.theta
    }

    /// The forgetting factor λ.
    pub fn forgetting(&self) -> f64 {
        self.forgetting
    }

    /// The factors (U, D) of P = U D Uᵀ.
    pub fn factors(&self) -> (&SMatrix<f64, N, N>, &SVector<f64, N>) {
        (&self.u, &self.d)
    }

    /// P = U D Uᵀ, each entry summed in the same order for (i, j) and (j, i), so the result is
    /// exactly symmetric.
    pub fn covariance(&self) -> SMatrix<f64, N, N> {
        let mut p = SMatrix::<f64, N, N>::zeros();
        // Column k of U adds u_ik d_k u_jk to each p_ij, i ≤ j ≤ k: over k ascending, every
        // entry's sum Σ_{k ≥ j} in the order of k, from contiguous columns; then the upper
        // triangle mirrored.
        // Column-major storage: chunk k of U is its column k, chunk j of P its column j.
        let n = N.max(1);
        for (k, (u_k, d_k)) in self.u.as_slice().chunks(n).zip(self.d.iter()).enumerate() {
            for (j, (p_j, u_jk)) in p
                .as_mut_slice()
                .chunks_mut(n)
                .zip(u_k)
                .enumerate()
                .take(k + 1)
            {
                for (p_ij, u_ik) in p_j.iter_mut().zip(u_k).take(j + 1) {
                    *p_ij += u_ik * d_k * u_jk;
                }
            }
        }
        p.fill_lower_triangle_with_upper_triangle();
        p
    }

    /// P v = U (D (Uᵀ v)) from the factors, without forming P (2N² products instead of
    /// N³/2 for P itself).
    pub fn covariance_times(&self, v: &SVector<f64, N>) -> SVector<f64, N> {
        let f = self.u.tr_mul(v).component_mul(&self.d);
        self.u * f
    }

    /// Starts a new sample: P ← P / λ (no-op for λ = 1).
    pub fn begin_sample(&mut self) {
        if self.forgetting < 1.0 {
            let cap = self.max_variance;
            self.d.apply(|v| *v = (*v / self.forgetting).min(cap));
        }
    }

    /// One scalar measurement y = φᵀθ + e with unit noise variance (Bierman's update).
    /// Returns the a-priori residual y − φᵀθ.
    pub fn update_row(&mut self, phi: &SVector<f64, N>, y: f64) -> f64 {
        let innovation = y - phi.dot(&self.theta);
        // f = Uᵀ φ, v = D f.
        let f = self.u.tr_mul(phi);
        let mut b = SVector::<f64, N>::zeros();
        let mut alpha = 1.0;
        for (j, ((fj, dj), mut u_col)) in f
            .iter()
            .zip(self.d.iter_mut())
            .zip(self.u.column_iter_mut())
            .enumerate()
        {
            let vj = *dj * fj;
            let beta = alpha;
            alpha += fj * vj;
            // d'ⱼ = dⱼ β/α: positive whenever dⱼ is.
            *dj *= beta / alpha;
            let lambda = -fj / beta;
            // Rows i < j of column j (contiguous), then bⱼ = vⱼ.
            for (uij, bi) in u_col
                .as_mut_slice()
                .iter_mut()
                .zip(b.as_mut_slice().iter_mut())
                .take(j)
            {
                let u_old = *uij;
                *uij = u_old + lambda * *bi;
                *bi += u_old * vj;
            }
            if let Some(bj) = b.get_mut(j) {
                *bj = vj;
            }
        }
        self.theta += b * (innovation / alpha);
        innovation
    }

    /// One sample of `R` weighted rows: begin_sample, then each row in turn.
    pub fn update<const R: usize>(&mut self, rows: &SMatrix<f64, R, N>, y: &SVector<f64, R>) {
        self.begin_sample();
        for (row, yr) in rows.row_iter().zip(y.iter()) {
            self.update_row(&row.transpose(), *yr);
        }
    }

    /// True when θ and both factors are finite.
    pub fn is_finite(&self) -> bool {
        // v · 0 is 0 for a finite v and NaN otherwise, so the sum is 0 exactly when every
        // entry is finite: one pass without a branch per entry (checked every sample).
        let poison = |s: &[f64]| s.iter().fold(0.0, |acc, v| acc + v * 0.0);
        poison(self.theta.as_slice()) + poison(self.d.as_slice()) + poison(self.u.as_slice()) == 0.0
    }
}

/// Batch least squares over the same weighted normal equations: A = Σ λ^(n−k) φₖ φₖᵀ + λⁿ P₀⁻¹,
/// b = Σ λ^(n−k) φₖ yₖ + λⁿ P₀⁻¹ θ₀, θ = A⁻¹ b (Cholesky). With the same prior and rows it
/// gives the RLS estimate up to rounding; without a prior it is ordinary weighted least squares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalEquations<const N: usize> {
    a: SMatrix<f64, N, N>,
    b: SVector<f64, N>,
    forgetting: f64,
    rows: u64,
}

impl<const N: usize> NormalEquations<N> {
    /// Empty equations (no prior), forgetting factor λ ∈ (0, 1].
    pub fn new(forgetting: f64) -> Result<Self, EstimatorError> {
        if !(forgetting > 0.0 && forgetting <= 1.0) {
            return Err(EstimatorError::InvalidConfig(
                "forgetting_factor must be in (0, 1]",
            ));
        }
        Ok(Self {
            a: SMatrix::zeros(),
            b: SVector::zeros(),
            forgetting,
            rows: 0,
        })
    }

    /// Adds the prior of an [`Rls`] started with the same `initial` and `prior_variance`.
    pub fn add_prior(&mut self, initial: &SVector<f64, N>, prior_variance: &SVector<f64, N>) {
        for (i, ((mut a_col, b_i), (variance, initial_i))) in self
            .a
            .column_iter_mut()
            .zip(self.b.iter_mut())
            .zip(prior_variance.iter().zip(initial.iter()))
            .enumerate()
        {
            let w = 1.0 / variance;
            // Column i's diagonal entry: the one after its first i.
            for a_ii in a_col.iter_mut().skip(i).take(1) {
                *a_ii += w;
            }
            *b_i += w * initial_i;
        }
    }

    /// Starts a new sample: everything so far is discounted by λ.
    pub fn begin_sample(&mut self) {
        if self.forgetting < 1.0 {
            self.a *= self.forgetting;
            self.b *= self.forgetting;
        }
    }

    /// Adds one weighted row.
    pub fn add_row(&mut self, phi: &SVector<f64, N>, y: f64) {
        self.a += phi * phi.transpose();
        self.b += phi * y;
        self.rows += 1;
    }

    /// Adds one sample of `R` weighted rows (after `begin_sample`).
    pub fn add<const R: usize>(&mut self, rows: &SMatrix<f64, R, N>, y: &SVector<f64, R>) {
        self.begin_sample();
        self.a += rows.transpose() * rows;
        self.b += rows.transpose() * y;
        self.rows += R as u64;
    }

    /// Number of rows added.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The information matrix A.
    pub fn information(&self) -> &SMatrix<f64, N, N> {
        &self.a
    }

    /// θ = A⁻¹ b; [`EstimatorError::Singular`] when A is not positive definite.
    pub fn solve(&self) -> Result<SVector<f64, N>, EstimatorError> {
        let chol = Cholesky::new(self.a).ok_or(EstimatorError::Singular)?;
        let x = chol.solve(&self.b);
        if x.iter().all(|v| v.is_finite()) {
            Ok(x)
        } else {
            Err(EstimatorError::Singular)
        }
    }

    /// A⁻¹, the covariance of θ under unit-variance row noise.
    pub fn covariance(&self) -> Result<SMatrix<f64, N, N>, EstimatorError> {
        let chol = Cholesky::new(self.a).ok_or(EstimatorError::Singular)?;
        Ok(chol.inverse())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    /// One non-finite entry anywhere (θ, D or U; NaN or either infinity) makes the state
    /// non-finite, and huge finite entries do not.
    #[test]
    fn is_finite_finds_any_non_finite_entry() {
        let fresh = Rls::<4>::new(SVector::zeros(), SVector::from_element(1e300), 1.0).unwrap();
        assert!(fresh.is_finite());
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for k in 0..4 {
                let mut r = fresh;
                r.theta[k] = bad;
                assert!(!r.is_finite(), "θ[{k}] = {bad}");
                let mut r = fresh;
                r.d[k] = bad;
                assert!(!r.is_finite(), "d[{k}] = {bad}");
            }
            for k in 0..16 {
                let mut r = fresh;
                r.u[k] = bad;
                assert!(!r.is_finite(), "u[{k}] = {bad}");
            }
        }
    }

    fn random_rows(rng: &mut StdRng) -> SMatrix<f64, 6, 10> {
        SMatrix::from_fn(|_, _| rng.random_range(-1.0..1.0))
    }

    #[test]
    fn rls_equals_batch_with_the_same_prior() {
        for lambda in [1.0, 0.98] {
            let mut rng = StdRng::seed_from_u64(5);
            let theta0 = SVector::<f64, 10>::zeros();
            let prior = SVector::<f64, 10>::from_element(1e2);
            let mut rls = Rls::new(theta0, prior, lambda).unwrap();
            let mut batch = NormalEquations::new(lambda).unwrap();
            batch.add_prior(&theta0, &prior);
            let truth = SVector::<f64, 10>::from_fn(|i, _| i as f64 - 3.0);
            for _ in 0..300 {
                let rows = random_rows(&mut rng);
                let noise = SVector::<f64, 6>::from_fn(|_, _| rng.random_range(-0.1..0.1));
                let y = rows * truth + noise;
                rls.update(&rows, &y);
                batch.add(&rows, &y);
            }
            let b = batch.solve().unwrap();
            assert!((rls.theta() - b).norm() < 1e-10 * b.norm(), "λ={lambda}");
            let pb = batch.covariance().unwrap();
            assert!((rls.covariance() - pb).norm() < 1e-10 * pb.norm());
        }
    }

    #[test]
    fn covariance_is_exactly_symmetric() {
        let mut rng = StdRng::seed_from_u64(9);
        let mut rls = Rls::<10>::new(SVector::zeros(), SVector::from_element(1e6), 1.0).unwrap();
        for _ in 0..50 {
            let rows = random_rows(&mut rng);
            rls.update(&rows, &SVector::<f64, 6>::zeros());
        }
        let p = rls.covariance();
        assert_eq!(p, p.transpose());
    }

    #[test]
    fn rejects_bad_settings_and_detects_singular_batches() {
        let z = SVector::<f64, 3>::zeros();
        assert!(Rls::new(z, SVector::from_element(1.0), 0.0).is_err());
        assert!(Rls::new(z, SVector::from_element(1.0), 1.5).is_err());
        assert!(Rls::new(z, SVector::from_element(-1.0), 1.0).is_err());
        assert!(Rls::new(z, SVector::from_element(f64::NAN), 1.0).is_err());
        let mut n = NormalEquations::<3>::new(1.0).unwrap();
        n.add_row(&SVector::<f64, 3>::new(1.0, 0.0, 0.0), 1.0);
        assert_eq!(n.solve(), Err(EstimatorError::Singular));
    }
}
