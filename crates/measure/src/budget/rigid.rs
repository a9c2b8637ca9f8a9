//! Does the rigid-body model explain the data? The record's fit residual, once the rigid body
//! and every modelled error (each elementary error's residual change, [`super::perturb`], at a
//! free amplitude) are fitted out, should be the sensors' noise alone. Two figures:
//!
//! - `residual_ratio`: rms of what is left of the equations' residual (the force rows with ten
//!   parameters, the torque rows about the centre of mass with six), over the rms the datasheet
//!   noise predicts for them ([`super::statistical`]), corrected for the fitted columns
//!   (N/(N − p)); the prediction has a floor of 1e-4 of the rows' own rms (the fit's numerical
//!   floor, for ideal sensors). About 1 for a rigid payload; a body that moves on the plate
//!   (a car on its suspension) leaves its own motion's force, far above the noise.
//! - `peak_hz`: the frequency of the largest peak of the left residual's power spectrum
//!   (a direct Fourier sum at the entries' times, from 0.2 Hz to the lower of 20 Hz and the
//!   entries' Nyquist frequency, in steps of 1/(2T)).
//!
//! The check passes when the ratio is below [`RATIO_LIMIT`]. At most [`MAX_ROWS`] entries
//! (evenly strided) take part, to bound the memory of the error columns.

use nalgebra::{DMatrix, DVector, Vector6};
use serde::{Deserialize, Serialize};

use super::fit::Fit;

/// Largest residual ratio of a rigid payload.
pub const RATIO_LIMIT: f64 = 3.0;

/// Entries at most in the check.
pub const MAX_ROWS: usize = 4096;

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

/// The check on `fit`'s residual at the entries `rows` (from [`subset`]), with the error
/// columns `modes` (each a residual change at those entries), the noise's predicted variance
/// per entry `noise` (at every interior entry) and the entries' `times`.
pub fn check(
    fit: &Fit,
    rows: &[usize],
    modes: &[Vec<Vector6<f64>>],
    noise: &[Vector6<f64>],
    times: &[f64],
    six: bool,
) -> Option<RigidBody> {
    let eq = if six { 3..6 } else { 0..3 };
    let sw: Vector6<f64> = fit.weights.map(f64::sqrt);
    let active: Vec<usize> = (0..10)
        .filter(|&p| fit.phi.iter().any(|phi| phi.column(p).iter().any(|v| *v != 0.0)))
        .collect();
    let live: Vec<&Vec<Vector6<f64>>> = modes
        .iter()
        .filter(|m| m.iter().any(|v| v.iter().any(|x| *x != 0.0)))
        .collect();
    let cols = active.len() + live.len();
    let n_rows = rows.len() * 6;
    if rows.len() < 10 || n_rows <= cols {
        return None;
    }
    let mut x = DMatrix::<f64>::zeros(n_rows, cols);
    let mut y = DVector::<f64>::zeros(n_rows);
    for (k, &row) in rows.iter().enumerate() {
        for r in 0..6 {
            let at = 6 * k + r;
            y[at] = sw[r] * fit.r0[row][r];
            for (c, &p) in active.iter().enumerate() {
                x[(at, c)] = sw[r] * fit.phi[row][(r, p)];
            }
            for (c, m) in live.iter().enumerate() {
                x[(at, active.len() + c)] = sw[r] * m[k][r];
            }
        }
    }
    // Columns scaled to unit norm, a tiny ridge for collinear ones.
    let scale: Vec<f64> = (0..cols)
        .map(|c| {
            let n = x.column(c).norm();
            if n > 0.0 {
                1.0 / n
            } else {
                0.0
            }
        })
        .collect();
    for (c, s) in scale.iter().enumerate() {
        x.column_mut(c).scale_mut(*s);
    }
    let mut a = x.tr_mul(&x);
    for c in 0..cols {
        a[(c, c)] += 1e-10;
    }
    let beta = a.cholesky()?.solve(&x.tr_mul(&y));
    let left = &y - &x * beta;
    // Unweighted residual of the check's rows, and the predicted noise.
    let (mut sum_r, mut sum_v, mut sum_y) = (0.0, 0.0, 0.0);
    let mut series = Vec::with_capacity(rows.len());
    for (k, &row) in rows.iter().enumerate() {
        let mut e = [0.0; 3];
        for (j, r) in eq.clone().enumerate() {
            let v = if sw[r] > 0.0 { left[6 * k + r] / sw[r] } else { 0.0 };
            e[j] = v;
            sum_r += v * v;
            sum_v += noise[row][r];
            let yr = fit.r0[row][r] + (fit.phi[row] * fit.theta)[r];
            sum_y += yr * yr;
        }
        series.push(e);
    }
    let floor = 1e-8 * sum_y;
    let dof = n_rows as f64 / (n_rows - cols) as f64;
    let ratio = (sum_r * dof / (sum_v + floor)).sqrt();
    let t: Vec<f64> = rows.iter().map(|&k| times[fit.idx[k]]).collect();
    let peak_hz = spectrum_peak(&t, &series);
    Some(RigidBody {
        ok: ratio.is_finite() && ratio < RATIO_LIMIT,
        residual_ratio: ratio,
        peak_hz,
    })
}

/// The frequency of the largest peak of Σ_rows |Σₖ eₖ e^(−2πi f tₖ)|² (see the module docs).
pub fn spectrum_peak(t: &[f64], e: &[[f64; 3]]) -> f64 {
    let (Some(first), Some(last)) = (t.first(), t.last()) else {
        return f64::NAN;
    };
    let span = last - first;
    if !(span > 0.0) || t.len() < 4 {
        return f64::NAN;
    }
    let dt = span / (t.len() - 1) as f64;
    let top = 20.0f64.min(0.5 / dt);
    let df = 0.5 / span;
    let mut best = (f64::NAN, -1.0);
    let mut f = 0.2;
    while f <= top {
        let w = 2.0 * core::f64::consts::PI * f;
        let (mut re, mut im) = ([0.0; 3], [0.0; 3]);
        for (tk, ek) in t.iter().zip(e) {
            let (s, c) = (w * (tk - first)).sin_cos();
            for r in 0..3 {
                re[r] += ek[r] * c;
                im[r] -= ek[r] * s;
            }
        }
        let p: f64 = (0..3).map(|r| re[r] * re[r] + im[r] * im[r]).sum();
        if p > best.1 {
            best = (f, p);
        }
        f += df;
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
}
