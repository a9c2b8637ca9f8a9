//! Honest uncertainty: the covariance of the estimate from P and the residuals, and its first-
//! order propagation to the centre of mass, the tensor about it and the principal moments.
//!
//! Why not simply σ̂²·P? The low-pass makes the equation errors of neighbouring samples
//! correlated (over roughly 1/f_c), and the gyro noise reaches ω̇ through a derivative, so the
//! error spectrum is far from white. σ̂²·P would understate the spread several-fold. Instead the
//! residual scores are summed over blocks longer than the correlation time and their spread
//! gives a sandwich (batch-means, cluster-robust) covariance, Cov = P·M·P with
//! M = Σ_blocks g gᵀ, g = Σ_(rows in block) φ r — valid whatever the noise colour, provided the
//! blocks are long compared with it.

use crate::params::{parallel_axis, Principal, TENSOR_ENTRIES};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Block-summed residual scores of an exponentially weighted least-squares fit.
///
/// Each block keeps b = Σ φ y and A = Σ φ φᵀ, so that its score is taken at the estimate of
/// the block's end, g = b − A θ, rather than at the estimates of its samples: the estimate
/// still moving at the start of a run would otherwise inflate the scores of the first blocks
/// many times over. The first block, where the prior still shapes θ, is left out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScoreCovariance<const N: usize> {
    /// Σ λ^(age) φ y over the block in progress.
    block_b: SVector<f64, N>,
    /// Σ λ^(age) φ φᵀ over the block in progress (upper triangle only).
    block_a: SMatrix<f64, N, N>,
    /// M = Σ λ^(2·age) (g gᵀ + ½(g g₋ᵀ + g₋ gᵀ)) over finished blocks (g₋: the block before).
    sum: SMatrix<f64, N, N>,
    /// Score of the last finished block, aged by one block.
    previous: SVector<f64, N>,
    /// Effective number of finished blocks, Σ λ^(2·age).
    blocks: f64,
    /// Effective number of rows, Σ λ^(age).
    rows: f64,
    in_block: u32,
    finished: u64,
    block_samples: u32,
    forgetting: f64,
    block_decay: f64,
}

impl<const N: usize> ScoreCovariance<N> {
    /// Blocks of `block_samples` samples (≥ 1); forgetting factor λ as the fit's.
    pub fn new(block_samples: u32, forgetting: f64) -> Self {
        let block_samples = block_samples.max(1);
        Self {
            block_b: SVector::zeros(),
            block_a: SMatrix::zeros(),
            sum: SMatrix::zeros(),
            previous: SVector::zeros(),
            blocks: 0.0,
            rows: 0.0,
            in_block: 0,
            finished: 0,
            block_samples,
            forgetting,
            block_decay: libm::pow(forgetting, 2.0 * block_samples as f64),
        }
    }

    /// Adds one sample's weighted rows and weighted measurements; `theta` is the estimate after
    /// the sample, used when the sample closes a block.
    pub fn add<const R: usize>(
        &mut self,
        rows: &SMatrix<f64, R, N>,
        y: &SVector<f64, R>,
        theta: &SVector<f64, N>,
    ) {
        if self.forgetting < 1.0 {
            self.block_b *= self.forgetting;
            self.block_a *= self.forgetting;
        }
        self.block_b += rows.tr_mul(y);
        for r in 0..R {
            for i in 0..N {
                let ri = rows[(r, i)];
                if ri != 0.0 {
                    for j in i..N {
                        self.block_a[(i, j)] += ri * rows[(r, j)];
                    }
                }
            }
        }
        self.rows = self.rows * self.forgetting + R as f64;
        self.in_block += 1;
        if self.in_block >= self.block_samples {
            self.close_block(theta);
        }
    }

    fn close_block(&mut self, theta: &SVector<f64, N>) {
        if self.finished > 0 {
            // g = b − A θ with A symmetric, stored as its upper triangle.
            let mut g = self.block_b;
            for i in 0..N {
                let mut s = 0.0;
                for j in 0..N {
                    let a = if j >= i {
                        self.block_a[(i, j)]
                    } else {
                        self.block_a[(j, i)]
                    };
                    s += a * theta[j];
                }
                g[i] -= s;
            }
            // Bartlett weight ½ on the neighbouring blocks' cross terms (Newey–West at lag one):
            // a derivative's noise telescopes, so neighbours' scores anticorrelate; slow noise
            // makes them correlate. Either way the pair terms keep M positive semi-definite.
            let cross = g * self.previous.transpose() * 0.5;
            self.sum = self.sum * self.block_decay + g * g.transpose() + cross + cross.transpose();
            self.blocks = self.blocks * self.block_decay + 1.0;
            self.previous = g * libm::pow(self.forgetting, self.block_samples as f64);
        }
        self.finished += 1;
        self.block_b = SVector::zeros();
        self.block_a = SMatrix::zeros();
        self.in_block = 0;
    }

    /// Effective number of finished blocks that count.
    pub fn blocks(&self) -> f64 {
        self.blocks
    }

    /// Covariance of θ given the fit's P: the sandwich P M P with the small-sample factor
    /// G/(G−1)·(n−1)/(n−N) (G blocks, n rows), combined with P (what the configured noise
    /// sigmas predict) as if P were worth two blocks: weight G/(G+2) on the sandwich. P alone
    /// before two blocks count. The configured sigmas thus matter only at the start; a wrong
    /// guess does not bias the reported sigmas of a long run.
    pub fn covariance(&self, p: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
        let g = self.blocks;
        let n = self.rows;
        let nf = N as f64;
        if g < 2.0 || n <= nf + 1.0 {
            return *p;
        }
        let correction = g / (g - 1.0) * (n - 1.0) / (n - nf);
        let sandwich = p * self.sum * p * correction;
        let w = g / (g + PRIOR_BLOCKS);
        let c = sandwich * w + p * (1.0 - w);
        (c + c.transpose()) * 0.5
    }
}

/// Weight of the configured-noise covariance P, in blocks.
const PRIOR_BLOCKS: f64 = 2.0;

/// Derived quantities with their one-sigma uncertainties, propagated to first order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derived {
    /// Centre of mass c = h/m, m.
    pub com_m: Vector3<f64>,
    /// One sigma of c, m.
    pub com_sigma_m: Vector3<f64>,
    /// J_C = J_O − (‖h‖²𝟙 − h hᵀ)/m, kg·m².
    pub inertia_com_kg_m2: Matrix3<f64>,
    /// One sigma of each entry of J_C, kg·m².
    pub inertia_com_sigma_kg_m2: Matrix3<f64>,
    /// Covariance of d = [m, c, J_C entries] (θ's order), G Cov Gᵀ.
    pub covariance: SMatrix<f64, 10, 10>,
}

/// Jacobian G = ∂[m, c, J_C entries]/∂θ at θ (m ≠ 0):
/// ∂c/∂m = −h/m², ∂c/∂h = 𝟙/m; ∂J_C/∂m = (‖h‖²𝟙 − h hᵀ)/m², ∂J_C/∂hₖ = −(2hₖ𝟙 − eₖhᵀ − h eₖᵀ)/m,
/// ∂J_C/∂J_O = 𝟙.
pub fn derived_jacobian(theta: &SVector<f64, 10>) -> SMatrix<f64, 10, 10> {
    let m = theta[0];
    let h = Vector3::new(theta[1], theta[2], theta[3]);
    let mut g = SMatrix::<f64, 10, 10>::zeros();
    g[(0, 0)] = 1.0;
    for i in 0..3 {
        g[(1 + i, 0)] = -h[i] / (m * m);
        g[(1 + i, 1 + i)] = 1.0 / m;
    }
    let dm = parallel_axis(&h) / (m * m);
    for (row, r, c) in TENSOR_ENTRIES {
        g[(row, row)] = 1.0;
        g[(row, 0)] = dm[(r, c)];
        for k in 0..3 {
            let delta = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
            let d = 2.0 * h[k] * delta(r, c) - delta(k, r) * h[c] - h[r] * delta(k, c);
            g[(row, 1 + k)] = -d / m;
        }
    }
    g
}

/// √v with rounding-level negatives read as 0; NaN stays NaN, so that a broken covariance can
/// never pass for a converged one.
pub(crate) fn sqrt_nonneg(v: f64) -> f64 {
    if v.is_nan() {
        f64::NAN
    } else {
        libm::sqrt(v.max(0.0))
    }
}

/// Propagates θ's covariance to c and J_C; `None` unless m is positive.
pub fn derive(theta: &SVector<f64, 10>, covariance: &SMatrix<f64, 10, 10>) -> Option<Derived> {
    let m = theta[0];
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let g = derived_jacobian(theta);
    let cov = g * covariance * g.transpose();
    let h = Vector3::new(theta[1], theta[2], theta[3]);
    let c = h / m;
    let jo = crate::params::InertialParameters::from_vector(theta).inertia_origin_kg_m2;
    let jc = jo - parallel_axis(&h) / m;
    let mut jc_sigma = Matrix3::zeros();
    for (row, r, col) in TENSOR_ENTRIES {
        let s = sqrt_nonneg(cov[(row, row)]);
        jc_sigma[(r, col)] = s;
        jc_sigma[(col, r)] = s;
    }
    Some(Derived {
        com_m: c,
        com_sigma_m: Vector3::new(
            sqrt_nonneg(cov[(1, 1)]),
            sqrt_nonneg(cov[(2, 2)]),
            sqrt_nonneg(cov[(3, 3)]),
        ),
        inertia_com_kg_m2: jc,
        inertia_com_sigma_kg_m2: jc_sigma,
        covariance: cov,
    })
}

/// Gradient of v_aᵀ J v_b with respect to the six tensor entries [xx, yy, zz, xy, xz, yz].
fn bilinear_gradient(va: &Vector3<f64>, vb: &Vector3<f64>) -> SVector<f64, 6> {
    let mut g = SVector::<f64, 6>::zeros();
    for (k, (_, r, c)) in TENSOR_ENTRIES.iter().enumerate() {
        g[k] = if r == c {
            va[*r] * vb[*c]
        } else {
            va[*r] * vb[*c] + va[*c] * vb[*r]
        };
    }
    g
}

/// One sigma of the principal moments (λₖ = vₖᵀ J vₖ, so ∂λₖ = vₖᵀ ∂J vₖ) and of the direction
/// of each principal axis, rad (axis k turns towards axis l by vₗᵀ ∂J vₖ / (λₖ − λₗ)); an axis
/// whose moment is repeated has an infinite sigma. `inertia_covariance` is the 6×6 covariance
/// of J_C's entries.
pub fn principal_sigma(
    principal: &Principal,
    inertia_covariance: &SMatrix<f64, 6, 6>,
) -> (Vector3<f64>, Vector3<f64>) {
    let axis = |k: usize| -> Vector3<f64> { principal.axes.column(k).into_owned() };
    let lam = principal.moments_kg_m2;
    let mut moments = Vector3::zeros();
    let mut angles = Vector3::zeros();
    for k in 0..3 {
        let gk = bilinear_gradient(&axis(k), &axis(k));
        moments[k] = sqrt_nonneg((gk.transpose() * inertia_covariance * gk)[(0, 0)]);
        let mut var = 0.0;
        for l in 0..3 {
            if l != k {
                let gl = bilinear_gradient(&axis(l), &axis(k));
                let gap = lam[k] - lam[l];
                var += (gl.transpose() * inertia_covariance * gl)[(0, 0)] / (gap * gap);
            }
        }
        angles[k] = libm::sqrt(var);
    }
    (moments, angles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::InertialParameters;

    fn derived_vector(theta: &SVector<f64, 10>) -> SVector<f64, 10> {
        let p = InertialParameters::from_vector(theta);
        let c = p.com_m().unwrap();
        let jc = p.inertia_com_kg_m2().unwrap();
        let mut d = SVector::<f64, 10>::zeros();
        d[0] = p.mass_kg;
        d.fixed_rows_mut::<3>(1).copy_from(&c);
        for (k, r, col) in TENSOR_ENTRIES {
            d[k] = jc[(r, col)];
        }
        d
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let theta = InertialParameters::from_com(
            3.0,
            Vector3::new(0.2, -0.4, 0.7),
            Matrix3::new(1.0, 0.1, -0.2, 0.1, 2.0, 0.3, -0.2, 0.3, 2.5),
        )
        .to_vector();
        let g = derived_jacobian(&theta);
        for j in 0..10 {
            let h = 1e-6;
            let mut tp = theta;
            let mut tm = theta;
            tp[j] += h;
            tm[j] -= h;
            let col = (derived_vector(&tp) - derived_vector(&tm)) / (2.0 * h);
            assert!(
                (col - g.column(j)).norm() < 1e-7,
                "column {j}: {col} vs {}",
                g.column(j)
            );
        }
    }

    #[test]
    fn score_covariance_falls_back_to_p_until_blocks_exist() {
        let mut s = ScoreCovariance::<2>::new(10, 1.0);
        let p = SMatrix::<f64, 2, 2>::identity() * 0.5;
        assert_eq!(s.covariance(&p), p);
        let rows = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
        let theta = SVector::<f64, 2>::zeros();
        for k in 0..1000 {
            let y = SVector::<f64, 1>::new(if k % 2 == 0 { 1.0 } else { -1.0 });
            s.add(&rows, &y, &theta);
        }
        // Alternating residuals cancel in every block: no spread in the first parameter.
        assert!((s.blocks() - 99.0).abs() < 1e-12);
        let c = s.covariance(&p);
        assert!(c[(0, 0)] < 0.03 * p[(0, 0)]);
    }
}
