//! The statistical part's split: of the estimator's covariance (noise of every channel),
//! the share the lost frames cost and the share the sampling jitter adds.
//!
//! - **Frame loss**: the covariance of n used samples scales as 1/n, so had the `lost` frames
//!   arrived it would be Σ·used/(used + lost); the lost frames cost Σ·lost/(used + lost).
//! - **Timestamp jitter**: a frame sampled δt off its grid place reads ω(t + δt) ≈ ω + ω̇ δt
//!   and f(t + δt) ≈ f + ḟ δt, so a jitter of one sigma σ_j acts to first order as gyro-like
//!   noise of size |ω̇ₖ|σ_j on each rate axis k, |ḟᵢ|σ_j on each load cell and |ȧₖ|σ_j on each
//!   accelerometer axis (treated as independent between channels; the common δt of a frame's
//!   channels is not modelled). Its share is predicted on the record: each noise source,
//!   datasheet noise and jitter alike, is propagated through the budget's own fit as white
//!   noise of the record's entries (variance per raw sample / samples averaged; the rate's
//!   through the derivative's noise gain), Cov = A⁻¹ (Σ Φᵀ W V W Φ) A⁻¹, and the jitter's
//!   share is the mean over the estimated parameters of Cov_jitter/(Cov_noise + Cov_jitter).
//!   The rate products' share of the rate noise is left out (the derivative's gain, ~1/h,
//!   dominates). The estimator's covariance is then split by that one scalar share, so the
//!   three parts stay positive semi-definite and add up to it exactly.

use nalgebra::{SMatrix, Vector3, Vector6};

use super::fit::{Data, Fit};
use super::Figures;
use crate::record::derivative::{d1, D1_NOISE_GAIN};
use estimator::regressor::RegressorSignals;

/// What [`predict`] gives.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    /// The jitter's share of the statistical variance, 0 to 1.
    pub jitter_share: f64,
    /// The datasheet noise's predicted variance of each interior entry's equations (the
    /// mode's rows, unweighted), for the rigid-body check.
    pub noise_variance: Vec<Vector6<f64>>,
}

/// The per-entry covariance of the equations from independent noise on the rate's
/// derivative (`var_wd` per axis), the specific force (`var_a`) and the leg forces (`var_f`).
fn equation_covariance(
    data: &Data,
    fit: &Fit,
    i: usize,
    var_wd: &Vector3<f64>,
    var_a: &Vector3<f64>,
    var_f: &Vector6<f64>,
) -> SMatrix<f64, 6, 6> {
    let model = &data.model;
    let r = model.lever_m;
    let mut v = SMatrix::<f64, 6, 6>::zeros();
    for k in 0..3 {
        let e = Vector3::ith(k, 1.0);
        let gw = model.regressor(&RegressorSignals::angular_acceleration_error(&e, &r)) * fit.theta;
        let ga = model.regressor(&RegressorSignals {
            specific_force_m_s2: e,
            ..RegressorSignals::default()
        }) * fit.theta;
        v += gw * gw.transpose() * var_wd[k] + ga * ga.transpose() * var_a[k];
    }
    let pose = &data.poses[i];
    for leg in 0..6 {
        let mut f = Vector6::zeros();
        f[leg] = 1.0;
        let w = model.geometry.wrench_in_platform(pose, &f);
        let col = model.map_wrench(&estimator::wrench::to_vector(&w));
        v += col * col.transpose() * var_f[leg];
    }
    v
}

/// The jitter's share and the noise's predicted equation variance on `data`'s fit.
pub fn predict(data: &Data, fit: &Fit, figures: &Figures) -> Prediction {
    let s = &figures.sensors;
    let (sg, sa, sf, sj) = (
        s.gyro_noise_rad_s(),
        s.accel_noise_m_s2(),
        s.load_cell.noise_n,
        s.timing.sampling_jitter_s,
    );
    let h = fit.h;
    let gain = D1_NOISE_GAIN / (h * h);
    let gyro = data.gyro();
    let acc: Vec<Vector3<f64>> = data.entries.iter().map(|e| e.accel_m_s2).collect();
    let forces: Vec<Vector6<f64>> = data.entries.iter().map(|e| e.leg_forces_n).collect();
    let w = SMatrix::<f64, 6, 6>::from_diagonal(&fit.weights);
    let mut b_noise = SMatrix::<f64, 10, 10>::zeros();
    let mut b_jit = SMatrix::<f64, 10, 10>::zeros();
    let mut noise_variance = Vec::with_capacity(fit.idx.len());
    for (k, &i) in fit.idx.iter().enumerate() {
        let n = data.entries[i].samples.max(1) as f64;
        let v_noise = equation_covariance(
            data,
            fit,
            i,
            &Vector3::from_element(sg * sg / n * gain),
            &Vector3::from_element(sa * sa / n),
            &Vector6::from_element(sf * sf / n),
        );
        let wd = data.signals(&gyro, i, h).angular_acceleration_rad_s2;
        let ad = d1(&acc, i, h);
        let fd = d1(&forces, i, h);
        let j2 = sj * sj / n;
        let v_jit = equation_covariance(
            data,
            fit,
            i,
            &wd.map(|x| x * x * j2 * gain),
            &ad.map(|x| x * x * j2),
            &fd.map(|x| x * x * j2),
        );
        let phi = &fit.phi[k];
        b_noise += phi.transpose() * w * v_noise * w * phi;
        b_jit += phi.transpose() * w * v_jit * w * phi;
        noise_variance.push(v_noise.diagonal());
    }
    let c_noise = fit.a_inv * b_noise * fit.a_inv;
    let c_jit = fit.a_inv * b_jit * fit.a_inv;
    let active = data.model.mode.active();
    let count = active.len() as f64;
    let share = active
        .map(|p| {
            let t = c_noise[(p, p)] + c_jit[(p, p)];
            if t > 0.0 {
                c_jit[(p, p)] / t
            } else {
                0.0
            }
        })
        .sum::<f64>()
        / count;
    Prediction {
        jitter_share: if share.is_finite() {
            share.clamp(0.0, 1.0)
        } else {
            0.0
        },
        noise_variance,
    }
}
