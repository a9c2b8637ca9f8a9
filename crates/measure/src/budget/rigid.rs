//! Does the rigid-body model explain the data? The residual of the budget's fit about the
//! run's estimate, r = y − Φ θ̂, should hold no more than the sensors' noise and the modelled
//! errors. Two figures:
//!
//! - `residual_ratio`: rms of the residual of the force rows (with six parameters, the torque
//!   rows about the centre of mass) over the rms that is expected of it: the datasheet noise
//!   ([`super::statistical`]) plus each modelled error's residual change at one sigma
//!   ([`super::perturb`], those smooth in the motion: [`super::perturb::Scalar::is_smooth`]),
//!   added as independent. About 1 or below for a rigid payload (θ̂ absorbs part of the
//!   errors); a body that moves on the plate (a car on its suspension) leaves its own motion's
//!   force, far above both. The errors' amplitudes are not fitted: a column made of the noisy
//!   data (a gain times the noisy force) would absorb the noise.
//! - `peak_hz`: the frequency of the largest peak of the residual's power spectrum (a direct
//!   Fourier sum at the entries' times, from 0.2 Hz to the lower of 20 Hz and the entries'
//!   Nyquist frequency, in steps of 1/(2T)).
//!
//! The check passes when the ratio is below [`RATIO_LIMIT`]. At most [`MAX_ROWS`] entries
//! (evenly strided) take part, to bound the memory of the error columns.
//!
//! A rig described as ideal (no noise, no tolerances: `configs/paper.toml`) predicts an rms
//! below 1e-4 of the rows' own: the budget fit's own numerical floor (its unfiltered derivative
//! of the 100 Hz record is coarser than the estimator's; on paper.toml its residual is 1.9 % of
//! the rows' rms). The check then has no scale to judge the residual by and is not made
//! (`None`), rather than flag a rigid payload at hundreds of "predicted" rms.

use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

use super::fit::Fit;

/// Largest residual ratio of a rigid payload.
pub const RATIO_LIMIT: f64 = 3.0;

/// Entries at most in the check.
pub const MAX_ROWS: usize = 4096;

/// The predicted rms, relative to the checked rows' own, below which the check is not made:
/// the budget fit's numerical floor (see the module docs).
pub const NUMERICAL_FLOOR: f64 = 1e-4;

/// The check's verdict.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RigidBody {
    /// The rigid-body model (with the modelled errors) explains the data.
    pub ok: bool,
    /// Residual rms over the noise's predicted rms.
    pub residual_ratio: f64,
    /// Frequency of the residual spectrum's largest peak, Hz.
    pub peak_hz: f64,
}

/// The entries of `fit` that take part (indices into `fit.idx`).
pub fn subset(fit: &Fit) -> Vec<usize> {
    let n = fit.idx.len();
    let step = n.div_ceil(MAX_ROWS).max(1);
    (0..n).step_by(step).collect()
}

/// The checked rows of a residual: the force rows, or with six parameters the torque rows
/// about the centre of mass.
fn checked_rows(six: bool) -> core::ops::Range<usize> {
    if six {
        3..6
    } else {
        0..3
    }
}

/// `peak_hz` of the check on `fit`'s residual at the entries `rows` (from [`subset`]) at the
/// entries' `times`: [`spectrum_peak`] of the checked rows. It needs neither the modelled
/// errors nor the noise, so it runs beside them ([`super::analyse`]).
pub fn residual_peak(fit: &Fit, rows: &[usize], times: &[f64], six: bool) -> f64 {
    if rows.len() < 10 {
        return f64::NAN;
    }
    let eq = checked_rows(six);
    let series: Vec<[f64; 3]> = rows
        .iter()
        .map(|&row| {
            let mut e = [0.0; 3];
            for (j, r) in eq.clone().enumerate() {
                e[j] = fit.r0[row][r];
            }
            e
        })
        .collect();
    let t: Vec<f64> = rows.iter().map(|&k| times[fit.idx[k]]).collect();
    spectrum_peak(&t, &series)
}

/// The check on `fit`'s residual at the entries `rows` (from [`subset`]), with the modelled
/// errors' residual changes `modes` (each at those entries), the noise's predicted variance
/// per entry `noise` (at every interior entry) and the residual spectrum's peak `peak_hz`
/// (from [`residual_peak`]).
pub fn check(
    fit: &Fit,
    rows: &[usize],
    modes: &[Vec<Vector6<f64>>],
    noise: &[Vector6<f64>],
    peak_hz: f64,
    six: bool,
) -> Option<RigidBody> {
    let eq = checked_rows(six);
    if rows.len() < 10 {
        return None;
    }
    let (mut sum_r, mut sum_v, mut sum_y) = (0.0, 0.0, 0.0);
    for (k, &row) in rows.iter().enumerate() {
        let y = fit.r0[row] + fit.phi[row] * fit.theta;
        for r in eq.clone() {
            let v = fit.r0[row][r];
            sum_r += v * v;
            sum_v += noise[row][r] + modes.iter().map(|m| m[k][r] * m[k][r]).sum::<f64>();
            sum_y += y[r] * y[r];
        }
    }
    if sum_v <= NUMERICAL_FLOOR * NUMERICAL_FLOOR * sum_y {
        return None;
    }
    let ratio = (sum_r / sum_v).sqrt();
    Some(RigidBody {
        ok: ratio.is_finite() && ratio < RATIO_LIMIT,
        residual_ratio: ratio,
        peak_hz,
    })
}

/// The frequency of the largest peak of Σ_rows |Σₖ eₖ e^(−2πi f tₖ)|² (see the module docs).
///
/// The frequencies are the grid f_j = f₀ + j Δf, so each sample's phasor steps from one
/// frequency to the next by one complex product, e^(−iω_{j+1}τ) = e^(−iω_jτ) e^(−iΔωτ): two
/// `sin_cos` a sample instead of one a sample and frequency. Over the grid's few thousand
/// steps the products drift from unit modulus by about j ε ≈ 1e-12, far below what moves a peak.
pub fn spectrum_peak(t: &[f64], e: &[[f64; 3]]) -> f64 {
    let (Some(first), Some(last)) = (t.first(), t.last()) else {
        return f64::NAN;
    };
    let span = last - first;
    if span.is_nan() || span <= 0.0 || t.len() < 4 {
        return f64::NAN;
    }
    let dt = span / (t.len() - 1) as f64;
    let (lowest, top, df) = (0.2, 20.0f64.min(0.5 / dt), 0.5 / span);
    if top < lowest {
        return f64::NAN;
    }
    let count = ((top - lowest) / df).floor() as usize + 1;
    let tau = 2.0 * core::f64::consts::PI;
    // Σₖ eₖ e^(−iω_j τₖ) per frequency j and row: (re, im) for the three rows.
    let mut sums = vec![[0.0f64; 6]; count];
    for (tk, ek) in t.iter().zip(e) {
        let phase = tk - first;
        let (s0, c0) = (tau * lowest * phase).sin_cos();
        let (ds, dc) = (tau * df * phase).sin_cos();
        let (mut c, mut s) = (c0, s0);
        for sum in sums.iter_mut() {
            for r in 0..3 {
                sum[r] += ek[r] * c;
                sum[3 + r] -= ek[r] * s;
            }
            (c, s) = (c * dc - s * ds, s * dc + c * ds);
        }
    }
    let mut best = (f64::NAN, -1.0);
    for (j, sum) in sums.iter().enumerate() {
        let p: f64 = sum.iter().map(|v| v * v).sum();
        if p > best.1 {
            best = (lowest + j as f64 * df, p);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spectrum_peak_is_at_the_sines_frequency() {
        let t: Vec<f64> = (0..3000).map(|k| k as f64 * 0.01).collect();
        let e: Vec<[f64; 3]> = t
            .iter()
            .map(|t| {
                let s = (2.0 * core::f64::consts::PI * 1.3 * t).sin();
                [0.1 * s, 0.0, s]
            })
            .collect();
        let f = spectrum_peak(&t, &e);
        assert!((f - 1.3).abs() < 0.02, "{f}");
    }

    #[test]
    fn the_phasor_recurrence_finds_the_direct_sums_peak_on_irregular_times() {
        // Times with gaps and jitter (lost frames, block means), two sines of which the
        // weaker is the lower: the peak must be the stronger one's grid point, as a direct
        // Σ e^(−iωτ) with one sin_cos per sample and frequency finds it.
        let t: Vec<f64> = (0..4000)
            .filter(|k| k % 97 != 0)
            .map(|k| k as f64 * 0.01 + 1e-4 * ((k * 7919) % 13) as f64)
            .collect();
        let e: Vec<[f64; 3]> = t
            .iter()
            .map(|t| {
                let w = 2.0 * core::f64::consts::PI;
                [0.3 * (w * 1.3 * t).sin(), 0.0, (w * 4.7 * t + 0.4).sin()]
            })
            .collect();
        let (first, span) = (t[0], t[t.len() - 1] - t[0]);
        let df = 0.5 / span;
        let mut direct = (0.0, -1.0);
        for j in 0..((20.0 - 0.2) / df) as usize {
            let f = 0.2 + j as f64 * df;
            let (mut re, mut im) = ([0.0; 3], [0.0; 3]);
            for (tk, ek) in t.iter().zip(&e) {
                let (s, c) = (2.0 * core::f64::consts::PI * f * (tk - first)).sin_cos();
                for r in 0..3 {
                    re[r] += ek[r] * c;
                    im[r] -= ek[r] * s;
                }
            }
            let p: f64 = (0..3).map(|r| re[r] * re[r] + im[r] * im[r]).sum();
            if p > direct.1 {
                direct = (f, p);
            }
        }
        let f = spectrum_peak(&t, &e);
        assert!((f - direct.0).abs() < 1e-9, "{f} against {}", direct.0);
        assert!((f - 4.7).abs() < 0.02, "{f}");
    }
}
