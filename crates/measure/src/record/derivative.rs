//! The record's signals: the rate products, zero-phase derivatives on the record's grid, and
//! the record's regular stretches.

use nalgebra::{SVector, Vector3, Vector6};

/// The six entries of ω ωᵀ in the regressor's order [xx, yy, zz, xy, xz, yz].
pub fn products(w: &Vector3<f64>) -> Vector6<f64> {
    estimator::regressor::rate_products(w)
}

/// Fourth-order central first derivative at `i`,
/// ẋ ≈ (x₋₂ − 8x₋₁ + 8x₊₁ − x₊₂)/(12h): zero-phase, error ≈ h⁴x⁽⁵⁾/30 (5e-6 relative at
/// 1.8 Hz and h = 10 ms). `i` must have two neighbours on each side.
pub fn d1<const N: usize>(x: &[SVector<f64, N>], i: usize, h: f64) -> SVector<f64, N> {
    (x[i - 2] - x[i - 1] * 8.0 + x[i + 1] * 8.0 - x[i + 2]) / (12.0 * h)
}

/// Fourth-order central second derivative at `i`,
/// ẍ ≈ (−x₋₂ + 16x₋₁ − 30x₀ + 16x₊₁ − x₊₂)/(12h²).
pub fn d2<const N: usize>(x: &[SVector<f64, N>], i: usize, h: f64) -> SVector<f64, N> {
    (-x[i - 2] + x[i - 1] * 16.0 - x[i] * 30.0 + x[i + 1] * 16.0 - x[i + 2]) / (12.0 * h * h)
}

/// Σ w² of [`d1`]'s weights times h²: a white sequence of variance v gives a derivative of
/// variance v · this / h².
pub const D1_NOISE_GAIN: f64 = 130.0 / 144.0;

/// The indices with two neighbours on each side within a regular stretch of `times` (steps
/// within ±40 % of the median step), with that stretch's local step.
pub fn interior(times: &[f64]) -> (Vec<usize>, f64) {
    let n = times.len();
    if n < 5 {
        return (Vec::new(), f64::NAN);
    }
    let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(|a, b| a.total_cmp(b));
    let h = steps[steps.len() / 2];
    if !(h.is_finite() && h > 0.0) {
        return (Vec::new(), f64::NAN);
    }
    let regular = |k: usize| {
        let s = times[k + 1] - times[k];
        (0.6 * h..=1.4 * h).contains(&s)
    };
    let idx = (2..n - 2)
        .filter(|&i| (i - 2..i + 2).all(regular))
        .collect();
    (idx, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the analytic derivatives of a sine at the excitation's top frequency.
    #[test]
    fn derivatives_match_a_sine() {
        let h = 0.01;
        let w = 2.0 * core::f64::consts::PI * 1.8;
        let x: Vec<SVector<f64, 1>> = (0..50)
            .map(|k| SVector::from([(w * k as f64 * h).sin()]))
            .collect();
        for i in 2..48 {
            let t = i as f64 * h;
            assert!((d1(&x, i, h)[0] - w * (w * t).cos()).abs() < 1e-4 * w);
            assert!((d2(&x, i, h)[0] + w * w * (w * t).sin()).abs() < 1e-4 * w * w);
        }
    }

    #[test]
    fn interior_skips_gaps() {
        let mut t: Vec<f64> = (0..20).map(|k| k as f64 * 0.01).collect();
        for v in t.iter_mut().skip(10) {
            *v += 0.05;
        }
        let (idx, h) = interior(&t);
        assert!((h - 0.01).abs() < 1e-12);
        assert!(!idx.contains(&8) && !idx.contains(&9) && !idx.contains(&10));
        assert!(idx.contains(&7) && idx.contains(&12));
        assert_eq!(idx.first(), Some(&2));
        assert_eq!(idx.last(), Some(&17));
    }
}
