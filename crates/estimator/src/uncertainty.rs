//! Honest uncertainty: the small-sample factors and the own-fit correction of the residuals'
//! covariance ([`crate::score`] measures it), and its first-order propagation to the centre
//! of mass, the tensor about it and the principal moments.

use nalgebra::{Const, DimMin, Matrix3, SMatrix, SVector, Vector3};
use stewart_types::{parallel_axis, Principal, TENSOR_ENTRIES};

/// C' = G⁻¹ D G C Gᵀ D G⁻ᵀ with D = diag(`roots`): C's quantities' covariance G C Gᵀ scaled
/// entry (i, j) by dᵢ dⱼ, taken back to θ. `None` when G is singular or the result not finite.
pub(crate) fn scale_in_basis<const N: usize>(
    c: &SMatrix<f64, N, N>,
    basis: &SMatrix<f64, N, N>,
    roots: &SVector<f64, N>,
) -> Option<SMatrix<f64, N, N>>
where
    Const<N>: DimMin<Const<N>, Output = Const<N>>,
{
    // t = G⁻¹ D G by one LU solve.
    let t = basis
        .lu()
        .solve(&(SMatrix::<f64, N, N>::from_diagonal(roots) * basis))?;
    let scaled = t * c * t.transpose();
    let scaled = (scaled + scaled.transpose()) * 0.5;
    scaled.iter().all(|v| v.is_finite()).then_some(scaled)
}

/// Largest leverage [`own_fit_correction`] corrects for: ½, the second of equal windows'. A
/// window whose leverage in some direction exceeds it taught the fit more there than every
/// window before it together — the fit before it was the prior's in that direction, as in the
/// first window, which does not count — and its score there carries the prior's and the still
/// moving estimate's error, which the correction would multiply (measured: uncapped, the
/// default excitation's 5 s noise-only campaign reported sigmas 25–600 times the spread).
pub const MAX_LEVERAGE: f64 = 0.5;

/// (𝟙 − A P)^(-1/2) for a window's information A (the window's rows' Σ φ φᵀ) and the fit's P
/// after the window (P⁻¹ ⊇ A): the score g = b − A θ at the fit after the window has
/// Var g = V − A P V − V P A + A Cov(θ) A, i.e. (𝟙 − A P) V for white equation errors (V = A,
/// Cov θ = P), so (𝟙 − A P)^(-1/2) g has the variance of the errors' own score, A, again:
/// the windows' counterpart of the HC2 leverage correction, whose leverage is the window's share
/// A P of the information so far (1/k for the k-th of equal windows; near 1 in a direction
/// the window is the first to determine). Evaluated on the unit-diagonal scaling of P
/// (D = diag P^½: 𝟙 − A P = D⁻¹ (𝟙 − Ã P̃) D with P̃ = D⁻¹ P D⁻¹, Ã = D A D) as
/// P̃^(-½) (𝟙 − H)^(-½) P̃^½ with H = P̃^½ Ã P̃^½ symmetric, its eigenvalues clamped to
/// [0, [`MAX_LEVERAGE`]]. The identity when P is not positive definite or the result not
/// finite.
pub fn own_fit_correction<const N: usize>(
    a: &SMatrix<f64, N, N>,
    p: &SMatrix<f64, N, N>,
) -> SMatrix<f64, N, N> {
    let identity = SMatrix::<f64, N, N>::identity();
    let d = p.diagonal();
    if !d.iter().all(|v| v.is_finite() && *v > 0.0) {
        return identity;
    }
    let d = SMatrix::<f64, N, N>::from_diagonal(&d.map(libm::sqrt));
    let d_inverse = SMatrix::<f64, N, N>::from_diagonal(&p.diagonal().map(|v| 1.0 / libm::sqrt(v)));
    let scaled_p = d_inverse * p * d_inverse;
    let scaled_a = d * a * d;
    let (values, vectors) = jacobi_eigen((scaled_p + scaled_p.transpose()) * 0.5);
    if !values.iter().all(|v| *v > 0.0) {
        return identity;
    }
    let root = |power: f64| {
        let diag = values.map(|v| libm::pow(v, power));
        vectors * SMatrix::<f64, N, N>::from_diagonal(&diag) * vectors.transpose()
    };
    let (half, inverse_half) = (root(0.5), root(-0.5));
    let h = half * scaled_a * half;
    let (h_values, h_vectors) = jacobi_eigen((h + h.transpose()) * 0.5);
    let factors = h_values.map(|v| 1.0 / libm::sqrt(1.0 - v.clamp(0.0, MAX_LEVERAGE)));
    let middle = h_vectors * SMatrix::<f64, N, N>::from_diagonal(&factors) * h_vectors.transpose();
    let t = d_inverse * inverse_half * middle * half * d;
    if t.iter().all(|v| v.is_finite()) {
        t
    } else {
        identity
    }
}

/// Fewest residual windows whose scores count (the first window of a run does not) for the
/// covariance to be measured: G ≥ 6, i.e. ν = G − 1 ≥ 5 degrees of freedom (a little fewer
/// for the overlapping windows, [`crate::dof`]). Why: the
/// standardised error z = e/σ̂ of a variance estimated with ν degrees of freedom is Student-t;
/// [`student_factor`] makes E(z²) = 1 for any ν > 2, but z² has a finite variance only for
/// ν > 4, so below that a single run's z, or a campaign's mean z², says nothing reliable (one
/// heavy-tailed run dominates it). With the factor, ±2σ covers 95.1 % at ν = 5 and 95.0–95.4 %
/// for every larger ν (Gaussian: 95.4 %).
pub const MIN_COVARIANCE_WINDOWS: u32 = 6;

/// (n−1)/(n−N−R) for n rows in all and `fitted` = N + R parameters and offsets fitted: the
/// rows' share of the cluster-robust CR1 correction. Its windows' share, G/(G−1) for scores at
/// one fitted θ that sum to zero, does not apply: the window scores are taken along the run
/// and corrected for their own fit ([`own_fit_correction`]), and what the windows miss is
/// the run's information outside them, which [`crate::score::ScoreCovariance::covariance`]
/// restores quantity by quantity (`crate::score`'s synthetic tests: mean z² within
/// [0.9, 1.1] at 8–18 windows). Infinite unless n > N + R.
pub fn fitted_rows_factor(rows: f64, fitted: f64) -> f64 {
    if rows > fitted {
        (rows - 1.0) / (rows - fitted)
    } else {
        f64::INFINITY
    }
}

/// ν/(ν−2) for a variance estimated with ν degrees of freedom: an unbiased σ̂² = σ² χ²_ν/ν,
/// independent of the error e ~ N(0, σ²), makes e/σ̂ Student-t with ν degrees of freedom and
/// E[(e/σ̂)²] = ν/(ν−2), so σ̂² scaled by this has mean z² 1 (measured, 20 runs at 2–3 s of
/// excitation: mean z² 3–4 without it). 1 for ν → ∞; below ν = [`MIN_DEGREES_OF_FREEDOM`]
/// it is taken at that ν (z² has no finite mean at ν ≤ 2): a quantity whose variance rests
/// on fewer degrees of freedom is reported with that factor, not refused.
pub fn student_factor(nu: f64) -> f64 {
    let nu = if nu.is_nan() {
        MIN_DEGREES_OF_FREEDOM
    } else {
        nu.max(MIN_DEGREES_OF_FREEDOM)
    };
    nu / (nu - 2.0)
}

/// The degrees of freedom at which [`student_factor`] stops: 3 (factor 3). Below it the
/// standardised error's square has no finite mean (ν ≤ 2) or nearly none, whatever the
/// factor.
pub const MIN_DEGREES_OF_FREEDOM: f64 = 3.0;

/// Eigenvalues and eigenvectors (columns) of a small symmetric matrix by cyclic Jacobi
/// rotations (nalgebra's `SymmetricEigen` needs a dimension it can subtract from, which a
/// generic `R` is not). Converges quadratically; 30 sweeps are far more than a 6×6 needs.
pub(crate) fn jacobi_eigen<const R: usize>(
    mut a: SMatrix<f64, R, R>,
) -> (SVector<f64, R>, SMatrix<f64, R, R>) {
    let mut v = SMatrix::<f64, R, R>::identity();
    for _ in 0..30 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for (i, row) in a.row_iter().enumerate() {
            for (j, aij) in row.iter().enumerate() {
                if j == i {
                    diag += aij * aij;
                } else if j > i {
                    off += aij * aij;
                }
            }
        }
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..R {
            for q in (p + 1)..R {
                // p < q < R: both entries exist, so the `else` is never taken.
                let (Some(apq), Some((app, aqq))) = (
                    a.get((p, q)).copied(),
                    pair(a.diagonal().iter().copied(), p, q),
                ) else {
                    continue;
                };
                if apq == 0.0 {
                    continue;
                }
                // The rotation that zeroes a[p][q] (Golub & Van Loan, Alg. 8.4.1).
                let tau = (aqq - app) / (2.0 * apq);
                let t = if tau >= 0.0 {
                    1.0 / (tau + libm::sqrt(1.0 + tau * tau))
                } else {
                    -1.0 / (-tau + libm::sqrt(1.0 + tau * tau))
                };
                let c = 1.0 / libm::sqrt(1.0 + t * t);
                let s = t * c;
                // Columns p and q of A, then its rows p and q, then V's columns p and q (each
                // pair exists for p < q < R).
                if let Some((col_p, col_q)) = pair(a.column_iter_mut(), p, q) {
                    rotate(col_p.into_iter(), col_q.into_iter(), c, s);
                }
                if let Some((row_p, row_q)) = pair(a.row_iter_mut(), p, q) {
                    rotate(row_p.into_iter(), row_q.into_iter(), c, s);
                }
                if let Some((col_p, col_q)) = pair(v.column_iter_mut(), p, q) {
                    rotate(col_p.into_iter(), col_q.into_iter(), c, s);
                }
            }
        }
    }
    (a.diagonal(), v)
}

/// Items p and q (p < q) of `items`; `None` when q ≤ p or there are not q + 1 items.
fn pair<T>(items: impl Iterator<Item = T>, p: usize, q: usize) -> Option<(T, T)> {
    let gap = q.checked_sub(p)?.checked_sub(1)?;
    let mut rest = items.skip(p);
    let first = rest.next()?;
    let second = rest.nth(gap)?;
    Some((first, second))
}

/// The plane rotation of two rows or columns x, y: x ← c x − s y, y ← s x + c y, entry by entry.
fn rotate<'a>(
    x: impl Iterator<Item = &'a mut f64>,
    y: impl Iterator<Item = &'a mut f64>,
    c: f64,
    s: f64,
) {
    for (xk, yk) in x.zip(y) {
        let (x0, y0) = (*xk, *yk);
        *xk = c * x0 - s * y0;
        *yk = s * x0 + c * y0;
    }
}

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
    let [m, hx, hy, hz, ..]: [f64; 10] = (*theta).into();
    let h = Vector3::new(hx, hy, hz);
    let dm = parallel_axis(&h) / (m * m);
    let delta = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
    // Row i, column j: row 0 is m's, rows 1–3 c's, rows 4–9 J_C's entries (TENSOR_ENTRIES).
    SMatrix::<f64, 10, 10>::from_fn(|i, j| match i {
        0 => delta(i, j),
        1..=3 => {
            if j == 0 {
                -component(&h, i - 1) / (m * m)
            } else if j == i {
                1.0 / m
            } else {
                0.0
            }
        }
        _ => match TENSOR_ENTRIES.iter().find(|(row, _, _)| *row == i) {
            Some(&(row, r, c)) => {
                if j == row {
                    1.0
                } else if j == 0 {
                    entry(&dm, r, c)
                } else if (1..=3).contains(&j) {
                    let k = j - 1;
                    let d = 2.0 * component(&h, k) * delta(r, c)
                        - delta(k, r) * component(&h, c)
                        - component(&h, r) * delta(k, c);
                    -d / m
                } else {
                    0.0
                }
            }
            None => 0.0,
        },
    })
}

/// vᵢ for i < 3 (an axis of TENSOR_ENTRIES or of a loop over three); NaN for any other i, so
/// that a wrong index poisons the result rather than passing for a zero.
fn component(v: &Vector3<f64>, i: usize) -> f64 {
    v.get(i).copied().unwrap_or(f64::NAN)
}

/// Mᵣ꜀ for r, c < 3, NaN otherwise (as [`component`]).
fn entry(m: &Matrix3<f64>, r: usize, c: usize) -> f64 {
    m.get((r, c)).copied().unwrap_or(f64::NAN)
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
    let [m, hx, hy, hz, ..]: [f64; 10] = (*theta).into();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let g = derived_jacobian(theta);
    let cov = g * covariance * g.transpose();
    let h = Vector3::new(hx, hy, hz);
    let c = h / m;
    let jo = stewart_types::InertialParameters::from_vector(theta).inertia_origin_kg_m2;
    let jc = jo - parallel_axis(&h) / m;
    // The sigmas in θ's layout; from_vector places J_C's entries where TENSOR_ENTRIES says.
    let sigma = cov.diagonal().map(sqrt_nonneg);
    let [_, sx, sy, sz, ..]: [f64; 10] = sigma.into();
    let jc_sigma = stewart_types::InertialParameters::from_vector(&sigma).inertia_origin_kg_m2;
    Some(Derived {
        com_m: c,
        com_sigma_m: Vector3::new(sx, sy, sz),
        inertia_com_kg_m2: jc,
        inertia_com_sigma_kg_m2: jc_sigma,
        covariance: cov,
    })
}

/// Gradient of v_aᵀ J v_b with respect to the six tensor entries [xx, yy, zz, xy, xz, yz].
fn bilinear_gradient(va: &Vector3<f64>, vb: &Vector3<f64>) -> SVector<f64, 6> {
    SVector::<f64, 6>::from(TENSOR_ENTRIES.map(|(_, r, c)| {
        if r == c {
            component(va, r) * component(vb, c)
        } else {
            component(va, r) * component(vb, c) + component(va, c) * component(vb, r)
        }
    }))
}

/// One sigma of the principal moments (λₖ = vₖᵀ J vₖ, so ∂λₖ = vₖᵀ ∂J vₖ) and of the direction
/// of each principal axis, rad (axis k turns towards axis l by vₗᵀ ∂J vₖ / (λₖ − λₗ)); an axis
/// whose moment is repeated has an infinite sigma. `inertia_covariance` is the 6×6 covariance
/// of J_C's entries.
pub fn principal_sigma(
    principal: &Principal,
    inertia_covariance: &SMatrix<f64, 6, 6>,
) -> (Vector3<f64>, Vector3<f64>) {
    let axes: [[f64; 3]; 3] = principal.axes.into();
    let axes = axes.map(Vector3::from);
    let lam: [f64; 3] = principal.moments_kg_m2.into();
    let variance = |g: &SVector<f64, 6>| (g.transpose() * inertia_covariance * g).x;
    let mut moments = Vector3::zeros();
    let mut angles = Vector3::zeros();
    for (k, ((moment, angle), (axis_k, lam_k))) in moments
        .iter_mut()
        .zip(angles.iter_mut())
        .zip(axes.iter().zip(lam))
        .enumerate()
    {
        let gk = bilinear_gradient(axis_k, axis_k);
        *moment = sqrt_nonneg(variance(&gk));
        let mut var = 0.0;
        for (l, (axis_l, lam_l)) in axes.iter().zip(lam).enumerate() {
            if l != k {
                let gl = bilinear_gradient(axis_l, axis_k);
                let gap = lam_k - lam_l;
                var += variance(&gl) / (gap * gap);
            }
        }
        *angle = libm::sqrt(var);
    }
    (moments, angles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use stewart_types::InertialParameters;

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
    fn jacobi_eigen_reconstructs_the_matrix() {
        let b = SMatrix::<f64, 4, 4>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 - 1.5);
        let a = b * b.transpose() + SMatrix::<f64, 4, 4>::identity() * 1e-3;
        let (values, vectors) = jacobi_eigen(a);
        let back = vectors * SMatrix::<f64, 4, 4>::from_diagonal(&values) * vectors.transpose();
        assert!((back - a).norm() < 1e-12 * a.norm());
        assert!((vectors.transpose() * vectors - SMatrix::<f64, 4, 4>::identity()).norm() < 1e-12);
    }

    /// The correction against its closed form for a running mean (one parameter, k equal
    /// windows of information a: leverage a P = 1/k, so (1 − 1/k)^(-1/2), and √2 for a window
    /// that taught the fit more than the windows before it together), and for a matrix case
    /// its defining property T² (𝟙 − A P) = 𝟙.
    #[test]
    fn own_fit_correction_is_the_inverse_root_of_one_less_the_leverage() {
        for k in [2.0, 3.0, 10.0, 100.0, 1.5, 1.0001] {
            let a = SMatrix::<f64, 1, 1>::new(4.0);
            let p = SMatrix::<f64, 1, 1>::new(1.0 / (4.0 * k));
            let t = own_fit_correction(&a, &p)[(0, 0)];
            let leverage = (1.0 / k).min(MAX_LEVERAGE);
            let expected = 1.0 / libm::sqrt(1.0 - leverage);
            assert!((t - expected).abs() < 1e-12, "k = {k}: {t}");
        }
        // Three parameters of very different scales, the block one of four unequal ones.
        let scale = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::new(1e-3, 1.0, 1e3));
        let block = |x: f64| {
            let m = SMatrix::<f64, 3, 3>::new(2.0, 0.3, -0.1, 0.3, 1.0 + x, 0.2, -0.1, 0.2, 0.5);
            scale * m * m.transpose() * scale
        };
        let a = block(0.7);
        let total = a + block(0.0) + block(-0.4) + block(1.5);
        let p = total.try_inverse().unwrap();
        let t = own_fit_correction(&a, &p);
        let residual =
            t * t * (SMatrix::<f64, 3, 3>::identity() - a * p) - SMatrix::<f64, 3, 3>::identity();
        assert!(residual.norm() < 1e-9, "{residual}");
    }

    /// Scaling in a basis: unit roots give C back; the quantities' covariance G C' Gᵀ is
    /// G C Gᵀ with entry (i, j) scaled by dᵢ dⱼ; a singular basis gives None.
    #[test]
    fn scaling_in_the_quantities_basis_scales_their_covariance() {
        let l = SMatrix::<f64, 3, 3>::new(2.0, 0.0, 0.0, 0.5, 1.0, 0.0, -0.3, 0.2, 0.7);
        let c = l * l.transpose();
        let g = SMatrix::<f64, 3, 3>::new(1.0, 0.2, 0.0, 0.0, 3.0, -1.0, 0.5, 0.0, 2.0);
        let same = scale_in_basis(&c, &g, &SVector::from_element(1.0)).unwrap();
        assert!((same - c).norm() < 1e-12 * c.norm());
        let d = SVector::<f64, 3>::new(1.5, 1.0, 0.8);
        let scaled = scale_in_basis(&c, &g, &d).unwrap();
        let q = g * c * g.transpose();
        let q2 = g * scaled * g.transpose();
        for i in 0..3 {
            for j in 0..3 {
                assert!((q2[(i, j)] - q[(i, j)] * d[i] * d[j]).abs() < 1e-10 * q.norm());
            }
        }
        let singular = SMatrix::<f64, 3, 3>::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
        assert_eq!(scale_in_basis(&c, &singular, &d), None);
    }

    #[test]
    fn small_sample_factors_by_hand() {
        // n = 300 rows, 3 fitted: 299/297; ν = 5: 5/3.
        assert!((fitted_rows_factor(300.0, 3.0) - 299.0 / 297.0).abs() < 1e-15);
        assert!((student_factor(5.0) - 5.0 / 3.0).abs() < 1e-15);
        // ν ≤ 2 has no finite mean z²: the factor stops at MIN_DEGREES_OF_FREEDOM (3/1);
        // many rows and degrees of freedom tend to 1; no more rows than fitted is infinite.
        assert_eq!(student_factor(2.0), 3.0);
        assert_eq!(student_factor(f64::NAN), 3.0);
        assert!((fitted_rows_factor(1e9, 3.0) * student_factor(1e6) - 1.0).abs() < 1e-5);
        assert_eq!(fitted_rows_factor(3.0, 3.0), f64::INFINITY);
    }
}
