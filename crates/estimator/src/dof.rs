//! Effective degrees of freedom of the window-sandwich variance, direction by direction.
//!
//! The sandwich's variance of one quantity q = cᵀθ is a quadratic form in the windows' scores
//! along w = P c: with uₖ = wᵀ gₖ, V̂ ∝ Σ uₖ² ([`crate::score`]). Were the windows alike, V̂
//! would carry about G/1.2 degrees of freedom (consecutive windows share a half-block); but
//! an excitation does not spread its information evenly — the fades carry little, a sine's
//! phase decides what each short window sees — so a few windows can make most of V̂ in one
//! direction and few in another, and the standardised error e/σ̂ is then Student-t with far
//! fewer degrees of freedom than the window count says (measured on a planned 2 s
//! excitation, 8 counted windows: σ̂² of J_C xx spread over the runs as χ² with 3.7 degrees of
//! freedom, against the 7 assumed, and mean z² 2.8).
//!
//! Satterthwaite's approximation with model-based weights (Bell & McCaffrey 2002; Imbens &
//! Kolesár 2016, "Robust standard errors in small samples", the BM degrees of freedom): the
//! scores have variances aₖ = wᵀ Vₖ w (Vₖ what the own-fit corrected score's covariance is
//! for white equation errors) and consecutive ones the covariances cₖ = wᵀ Cₖ w (Cₖ from
//! their shared half-block), the rest independent, so with Λ their tridiagonal covariance
//! E V̂ = tr Λ = Σ aₖ and Var V̂ = 2 tr(Λ²) = 2 (Σ aₖ² + 2 Σ cₖ²), and matching a scaled χ²_ν
//! gives
//!
//! ν = (Σ aₖ)² / (Σ aₖ² + 2 Σ cₖ²).
//!
//! Since w is known only when the covariance is asked for (P at the end of the run), the
//! windows' matrices are kept as the second moments of their packed upper triangles
//! (aₖ = vₖ · x(w), x(w) the packed w wᵀ with off-diagonal entries doubled), so that ν is
//! exact for any direction at any time: Σ vₖ, Σ vₖ vₖᵀ and Σ sₖ sₖᵀ (sₖ the packed Cₖ).

use nalgebra::{SMatrix, SVector};

/// Entries of a packed upper triangle of a symmetric matrix of up to ten rows (the full
/// model's parameters): 10·11/2.
pub const PACKED: usize = 55;

/// Entries of the packed upper triangle of a symmetric PACKED × PACKED matrix: 55·56/2. The
/// second moments are kept so (12 KB each instead of 24): a debug build holds several copies
/// of the estimator's state on the stack.
const PACKED_SQUARE: usize = PACKED * (PACKED + 1) / 2;

/// The windows' score covariances as far as the degrees of freedom need them (see the module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfBlockInformation<const N: usize> {
    /// Σ λ^(2·age) vₖ.
    sum: SVector<f64, PACKED>,
    /// Σ λ^(4·age) vₖ vₖᵀ, its packed upper triangle.
    square: SVector<f64, PACKED_SQUARE>,
    /// Σ λ^(4·age) sₖ sₖᵀ, its packed upper triangle.
    shared: SVector<f64, PACKED_SQUARE>,
}

impl<const N: usize> Default for HalfBlockInformation<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HalfBlockInformation<N> {
    /// Compile-time check that N × N fits the packed storage.
    pub const FITS: () = assert!(N * (N + 1) / 2 <= PACKED, "N must be at most 10");

    /// No windows yet.
    pub fn new() -> Self {
        let () = Self::FITS;
        Self {
            sum: SVector::zeros(),
            square: SVector::zeros(),
            shared: SVector::zeros(),
        }
    }

    /// Adds one counted window: `variance`, Vₖ, the matrix of its score's variance along any
    /// direction, and `with_previous`, Cₖ, that of its covariance with the window before
    /// (`None` for the first that counts). `decay` is λ^(2B) for half-blocks of B samples (1
    /// without forgetting), the factor by which the sandwich ages each window.
    pub fn add(
        &mut self,
        variance: &SMatrix<f64, N, N>,
        with_previous: Option<&SMatrix<f64, N, N>>,
        decay: f64,
    ) {
        let v = pack(variance);
        let c = with_previous.map_or_else(SVector::zeros, pack);
        if !(v.iter().all(|x| x.is_finite()) && c.iter().all(|x| x.is_finite())) {
            return;
        }
        let decay_squared = decay * decay;
        self.sum.axpy(1.0, &v, decay);
        if decay_squared != 1.0 {
            self.square *= decay_squared;
            self.shared *= decay_squared;
        }
        let mut k = 0;
        for (i, (vi, ci)) in v.iter().zip(c.iter()).enumerate() {
            for (vj, cj) in v.iter().zip(c.iter()).skip(i) {
                if let (Some(sq), Some(sh)) = (self.square.get_mut(k), self.shared.get_mut(k)) {
                    *sq += vi * vj;
                    *sh += ci * cj;
                }
                k += 1;
            }
        }
    }

    /// The counted windows' summed score variance along w for white equation errors,
    /// Σ aₖ = Σ wᵀ Vₖ w: what the sandwich's middle expects to see of the run's information
    /// along w (module docs). `None` before any window or for a non-finite sum.
    pub fn covered_variance(&self, w: &SVector<f64, N>) -> Option<f64> {
        let covered = self.sum.dot(&pack_outer(w));
        covered.is_finite().then_some(covered)
    }

    /// ν of the sandwich's variance along w = P c (see the module docs); `None` before any
    /// window, for a zero or non-finite direction, or when the sums give no positive ν.
    pub fn degrees_of_freedom(&self, w: &SVector<f64, N>) -> Option<f64> {
        let x = pack_outer(w);
        let mean = self.sum.dot(&x);
        let square = packed_quadratic(&self.square, &x);
        let shared = packed_quadratic(&self.shared, &x);
        let spread = square + 2.0 * shared;
        let nu = mean * mean / spread;
        (mean > 0.0 && spread > 0.0 && nu.is_finite()).then_some(nu)
    }
}

/// xᵀ Q x for a symmetric Q given by its packed upper triangle (row by row).
fn packed_quadratic(q: &SVector<f64, PACKED_SQUARE>, x: &SVector<f64, PACKED>) -> f64 {
    let mut sum = 0.0;
    let mut k = 0;
    for (i, xi) in x.iter().enumerate() {
        for (j, xj) in x.iter().enumerate().skip(i) {
            let weight = if i == j { 1.0 } else { 2.0 };
            sum += weight * q.get(k).copied().unwrap_or(0.0) * xi * xj;
            k += 1;
        }
    }
    sum
}

/// Index of entry (i, j), i ≤ j < N, in the packed upper triangle (row by row).
fn packed_index<const N: usize>(i: usize, j: usize) -> usize {
    i * N - i * i.saturating_sub(1) / 2 - i + j
}

/// The packed upper triangle of a symmetric matrix (its lower triangle is not read).
fn pack<const N: usize>(a: &SMatrix<f64, N, N>) -> SVector<f64, PACKED> {
    let mut v = SVector::<f64, PACKED>::zeros();
    for j in 0..N {
        for i in 0..=j {
            if let (Some(dst), Some(src)) = (v.get_mut(packed_index::<N>(i, j)), a.get((i, j))) {
                *dst = *src;
            }
        }
    }
    v
}

/// x(w) such that pack(A) · x(w) = wᵀ A w: wᵢ² on the diagonal, 2 wᵢ wⱼ off it.
fn pack_outer<const N: usize>(w: &SVector<f64, N>) -> SVector<f64, PACKED> {
    let mut x = SVector::<f64, PACKED>::zeros();
    for (j, wj) in w.iter().enumerate() {
        for (i, wi) in w.iter().enumerate().take(j + 1) {
            if let Some(dst) = x.get_mut(packed_index::<N>(i, j)) {
                *dst = if i == j { wi * wj } else { 2.0 * wi * wj };
            }
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_is_a_bijection_onto_the_first_entries() {
        let mut seen = [false; PACKED];
        for j in 0..10 {
            for i in 0..=j {
                let k = packed_index::<10>(i, j);
                assert!(!seen[k], "({i}, {j}) collides");
                seen[k] = true;
            }
        }
        assert!(seen.iter().all(|s| *s));
        let six: std::vec::Vec<usize> = (0..6)
            .flat_map(|j| (0..=j).map(move |i| packed_index::<6>(i, j)))
            .collect();
        assert_eq!(six.iter().max(), Some(&20));
    }

    #[test]
    fn packed_quadratic_form_is_w_a_w() {
        let a = SMatrix::<f64, 4, 4>::from_fn(|i, j| 1.0 + (i * j) as f64 + (i + j) as f64 * 0.5);
        let w = SVector::<f64, 4>::new(0.3, -1.2, 2.0, 0.7);
        let direct = w.dot(&(a * w));
        assert!((pack(&a).dot(&pack_outer(&w)) - direct).abs() < 1e-12 * direct.abs());
    }

    /// The packed second moments give the quadratic forms of the full ones.
    #[test]
    fn packed_second_moments_give_the_full_quadratic_forms() {
        let mut info = HalfBlockInformation::<3>::new();
        let windows = [
            SMatrix::<f64, 3, 3>::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0),
            SMatrix::<f64, 3, 3>::new(1.0, -0.3, 0.2, -0.3, 5.0, 0.1, 0.2, 0.1, 0.7),
            SMatrix::<f64, 3, 3>::new(2.0, 0.4, -0.6, 0.4, 1.0, 0.0, -0.6, 0.0, 3.0),
        ];
        let shared = [
            SMatrix::<f64, 3, 3>::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.0, 0.0, 0.0, 0.3),
            SMatrix::<f64, 3, 3>::new(0.2, 0.0, 0.1, 0.0, 0.9, -0.2, 0.1, -0.2, 0.6),
        ];
        let w = SVector::<f64, 3>::new(0.7, -1.1, 0.4);
        let a: std::vec::Vec<f64> = windows.iter().map(|b| w.dot(&(b * w))).collect();
        let c: std::vec::Vec<f64> = shared.iter().map(|b| w.dot(&(b * w))).collect();
        info.add(&windows[0], None, 0.9);
        info.add(&windows[1], Some(&shared[0]), 0.9);
        info.add(&windows[2], Some(&shared[1]), 0.9);
        // Ages: the last window 1, the one before 0.9, the first 0.81 (λ^(2B) = 0.9).
        let mean = 0.81 * a[0] + 0.9 * a[1] + a[2];
        let square = 0.81 * 0.81 * a[0] * a[0] + 0.81 * a[1] * a[1] + a[2] * a[2];
        let covariance = 0.81 * c[0] * c[0] + c[1] * c[1];
        let expected = mean * mean / (square + 2.0 * covariance);
        let nu = info.degrees_of_freedom(&w).unwrap();
        assert!(
            (nu - expected).abs() < 1e-9 * expected,
            "{nu} against {expected}"
        );
    }

    /// G equal windows whose neighbours correlate by ρ: ν = G² / (G + 2 (G − 1) ρ²) whatever
    /// the direction (ρ = 1/π for the sine windows: about G/1.2).
    #[test]
    fn equal_windows_give_their_count_less_the_overlap() {
        let mut info = HalfBlockInformation::<3>::new();
        let a = SMatrix::<f64, 3, 3>::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0);
        let rho = 1.0 / core::f64::consts::PI;
        info.add(&a, None, 1.0);
        for _ in 1..8 {
            info.add(&a, Some(&(a * rho)), 1.0);
        }
        let expected = 64.0 / (8.0 + 14.0 * rho * rho);
        for w in [
            SVector::<f64, 3>::new(1.0, 0.0, 0.0),
            SVector::<f64, 3>::new(0.2, -0.7, 1.3),
        ] {
            let nu = info.degrees_of_freedom(&w).unwrap();
            assert!((nu - expected).abs() < 1e-9, "{nu} against {expected}");
        }
    }

    /// One window holding nearly all the information along w: about one degree of freedom,
    /// however many windows there are; along a direction every window sees alike, the count.
    #[test]
    fn one_dominant_window_leaves_about_one_degree_of_freedom() {
        let mut info = HalfBlockInformation::<2>::new();
        for k in 0..20 {
            let x = if k == 7 { 1000.0 } else { 1.0 };
            info.add(&SMatrix::<f64, 2, 2>::new(x, 0.0, 0.0, 1.0), None, 1.0);
        }
        let along = info
            .degrees_of_freedom(&SVector::<f64, 2>::new(1.0, 0.0))
            .unwrap();
        assert!((1.0..1.05).contains(&along), "{along}");
        let across = info
            .degrees_of_freedom(&SVector::<f64, 2>::new(0.0, 1.0))
            .unwrap();
        assert!((across - 20.0).abs() < 1e-9, "{across}");
    }

    #[test]
    fn no_windows_or_no_direction_give_none() {
        let mut info = HalfBlockInformation::<2>::new();
        assert_eq!(
            info.degrees_of_freedom(&SVector::<f64, 2>::new(1.0, 0.0)),
            None
        );
        info.add(&SMatrix::<f64, 2, 2>::identity(), None, 1.0);
        assert_eq!(info.degrees_of_freedom(&SVector::zeros()), None);
        assert_eq!(
            info.degrees_of_freedom(&SVector::<f64, 2>::new(f64::NAN, 0.0)),
            None
        );
        info.add(
            &SMatrix::<f64, 2, 2>::from_element(f64::INFINITY),
            None,
            1.0,
        );
        assert!(info
            .degrees_of_freedom(&SVector::<f64, 2>::new(1.0, 0.0))
            .is_some());
    }
}
