//! The load cells' zero drift, fitted as a nuisance of the run.
//!
//! A load cell's zero moves over a run (creep, temperature): the datasheet gives the rate's
//! sigma, `zero_drift_n_per_min`. Left in, the drift of cell i adds δfᵢ(t) = rᵢ (t − t₀) to
//! its force, and through the leg map L (column i: the wrench of a unit force of leg i) it
//! adds L r (t − t₀) to the sample's equations. Over a run of length T its mean, L r T/2,
//! is a constant offset the fit absorbs into θ wherever the regressors cannot tell it from
//! the load (the weight, the horizontal moment); an hour of the datasheet's 0.4 N/min moves
//! the mass by kilograms. The offset at t₀ is the zero the tare takes out; the rate is not.
//!
//! **What tells the drift from the load.** A constant offset and θ's columns share their
//! mean, but a ramp grows with time while the excitation's columns do not. So the six rates
//! are fitted jointly with θ and the scores' constant offsets c
//! ([`crate::score::ScoreCovariance`]): each sample's weighted equations gain
//! Ψ = W L_c (t − t₀) r (L_c the conditioned leg map, t₀ the window's first sample), and the
//! normal equations of y = Φθ + c + Ψ r + e, with θ eliminated (θ = θ̂ − P S c − P S_r r),
//! read
//!
//! ```text
//! [F_cc  F_cr] [c]   [h_c]      F_cc = n𝟙 − SᵀPS,    F_cr = ΣΨ − SᵀPS_r,   F_rr = ΣΨᵀΨ − S_rᵀPS_r
//! [F_crᵀ F_rr] [r] = [h_r],     h_c = Y − Sᵀθ̂ + e,   h_r = ΣΨᵀy − S_rᵀθ̂
//! ```
//!
//! (S = ΣΦᵀ, S_r = ΣΦᵀΨ, Y = Σy over the weighted rows; e the gyro's ends, which c must not
//! take for its own). With c eliminated by F_cc's pseudo-inverse (directions θ absorbs carry
//! no offset of their own):
//!
//! ```text
//! G = F_rr − F_crᵀ F_cc⁺ F_cr,   r̂ = G⁻¹ (h_r − F_crᵀ F_cc⁺ h_c),   θ = θ̂ − Q S_r r̂
//! ```
//!
//! Q the map from the normal equations' b to θ (the corrected fit's gain): θ is linear in the
//! measurements, so θ̂ − Q S_r r̂ is exactly the fit of the measurements with the fitted drift
//! taken out, the cells' zeros held at their value at t₀. For white errors r̂ and θ̂ are
//! uncorrelated (the Schur complement's property), and the rate's own uncertainty adds
//! Q S_r G⁻¹ S_rᵀ Q to θ's covariance.

use crate::uncertainty::jacobi_eigen;
use nalgebra::{Matrix6, SMatrix, SVector, Vector6};

/// The drift rates fitted over the samples so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriftFit<const R: usize> {
    /// r̂, each cell's zero drift rate, N/s.
    pub rate_n_s: Vector6<f64>,
    /// G⁻¹ (a pseudo-inverse where the samples leave a rate undetermined): r̂'s covariance
    /// for errors of the configured equation sigmas, (N/s)².
    pub covariance: Matrix6<f64>,
    /// F_cr r̂: the drift's share of the offsets' right-hand side, which the scores' offset
    /// fit takes out before solving for c (weighted units).
    pub offset_share: SVector<f64, R>,
}

/// The load cells' drift a run's fit took out ([`crate::OnlineEstimator::load_cell_drift`]):
/// cell i's force read rᵢ (t − t₀) more than at t₀.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadCellDrift {
    /// r̂, each cell's zero drift rate, N/s.
    pub rate_n_s: Vector6<f64>,
    /// r̂'s covariance for errors of the configured equation sigmas, (N/s)².
    pub covariance: Matrix6<f64>,
    /// t₀, the time from which the drift is counted (the fit's first sample), s.
    pub start_s: f64,
}

impl LoadCellDrift {
    /// δf(t) = r̂ (t − t₀): what the fit took off each cell's force at `time_s`, N.
    pub fn at(&self, time_s: f64) -> Vector6<f64> {
        self.rate_n_s * (time_s - self.start_s)
    }
}

/// The sums behind the drift fit, for `N` parameters and `R` equations per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroDrift<const N: usize, const R: usize> {
    /// t₀, the first sample's time, s.
    start_s: Option<f64>,
    /// S_r = Σ λ^age Φ_wᵀ Ψ.
    phi_psi: SMatrix<f64, N, 6>,
    /// Σ λ^age Ψ, the offsets' cross term.
    psi: SMatrix<f64, R, 6>,
    /// Σ λ^age Ψᵀ Ψ.
    psi_psi: Matrix6<f64>,
    /// Σ λ^age Ψᵀ y_w.
    psi_y: Vector6<f64>,
    /// Σ λ^age, the samples.
    samples: f64,
    forgetting: f64,
}

impl<const N: usize, const R: usize> ZeroDrift<N, R> {
    /// No samples yet; λ as the fit's.
    pub fn new(forgetting: f64) -> Self {
        Self {
            start_s: None,
            phi_psi: SMatrix::zeros(),
            psi: SMatrix::zeros(),
            psi_psi: SMatrix::zeros(),
            psi_y: SVector::zeros(),
            samples: 0.0,
            forgetting,
        }
    }

    /// Ψ = W L_c (t − t₀) of a sample at `time_s` whose weighted conditioned leg map is
    /// `weighted_map`; the first sample sets t₀.
    pub fn rows(&mut self, time_s: f64, weighted_map: &SMatrix<f64, R, 6>) -> SMatrix<f64, R, 6> {
        let start = *self.start_s.get_or_insert(time_s);
        weighted_map * (time_s - start)
    }

    /// Adds one sample's weighted rows Φ_w, weighted measurements y_w and drift rows Ψ.
    pub fn add(
        &mut self,
        rows: &SMatrix<f64, R, N>,
        y: &SVector<f64, R>,
        psi: &SMatrix<f64, R, 6>,
    ) {
        let l = self.forgetting;
        self.phi_psi = self.phi_psi * l + rows.tr_mul(psi);
        self.psi = self.psi * l + psi;
        self.psi_psi = self.psi_psi * l + psi.tr_mul(psi);
        self.psi_y = self.psi_y * l + psi.tr_mul(y);
        self.samples = self.samples * l + 1.0;
    }

    /// t₀, the first sample's time, s; `None` before it.
    pub fn start_s(&self) -> Option<f64> {
        self.start_s
    }

    /// S_r = Σ Φ_wᵀ Ψ: b's sensitivity to the six drift rates.
    pub fn sensitivity(&self) -> &SMatrix<f64, N, 6> {
        &self.phi_psi
    }

    /// The joint fit's r̂ (the module's docs) at the fit's θ̂ and P (without the drift), from
    /// S = ΣΦ_wᵀ and Y = Σy_w over the same samples (`totals`) and the gyro's ends `ends`.
    /// `None` before any rate is determined (G zero or not finite).
    pub fn fit(
        &self,
        theta: &SVector<f64, N>,
        p: &SMatrix<f64, N, N>,
        totals: &(SMatrix<f64, N, R>, SVector<f64, R>),
        ends: &SVector<f64, R>,
    ) -> Option<DriftFit<R>> {
        let (s, y) = totals;
        let n = self.samples;
        if n <= 0.0 {
            return None;
        }
        let ps = p * s;
        let f_cc = SMatrix::<f64, R, R>::identity() * n - s.tr_mul(&ps);
        let f_cc = (f_cc + f_cc.transpose()) * 0.5;
        let f_cr = self.psi - ps.tr_mul(&self.phi_psi);
        let f_rr = self.psi_psi - self.phi_psi.tr_mul(&(p * self.phi_psi));
        let h_c = y - s.tr_mul(theta) + ends;
        let h_r = self.psi_y - self.phi_psi.tr_mul(theta);
        // F_cc⁺ by its eigenvectors, as the scores' offset fit takes it.
        let (values, vectors) = jacobi_eigen(f_cc);
        let mut pinv = SMatrix::<f64, R, R>::zeros();
        for (value, v) in values.iter().zip(vectors.column_iter()) {
            if *value > 1e-9 * n {
                pinv += v * v.transpose() / *value;
            }
        }
        let g = f_rr - f_cr.tr_mul(&(pinv * f_cr));
        let g = (g + g.transpose()) * 0.5;
        // G⁻¹ on the rates the samples determine: a map that reaches fewer equations than
        // cells (the paper's three torque rows) leaves the rest at zero.
        let (values, vectors) = jacobi_eigen(g);
        let largest = values.iter().fold(0.0f64, |m, v| m.max(*v));
        if !(largest > 0.0 && largest.is_finite()) {
            return None;
        }
        let mut covariance = Matrix6::<f64>::zeros();
        for (value, v) in values.iter().zip(vectors.column_iter()) {
            if *value > 1e-9 * largest {
                covariance += v * v.transpose() / *value;
            }
        }
        let rate_n_s = covariance * (h_r - f_cr.tr_mul(&(pinv * h_c)));
        let offset_share = f_cr * rate_n_s;
        let finite = rate_n_s
            .iter()
            .chain(covariance.iter())
            .all(|v| v.is_finite());
        finite.then_some(DriftFit {
            rate_n_s,
            covariance,
            offset_share,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{SMatrix, SVector};

    /// A one-equation fit y = φθ + c + r t with a periodic column φ: r̂ is the ramp put in,
    /// whatever the constant, and θ̂ − Q S_r r̂ is the fit of the measurements less the ramp.
    #[test]
    fn the_fitted_rate_is_the_ramp_put_in_whatever_the_constant() {
        let mut d = ZeroDrift::<1, 1>::new(1.0);
        let (theta_true, c_true, rate_true) = (2.0, 0.7, 0.01);
        let mut a = 0.0;
        let mut b = 0.0;
        let mut b_less_ramp = 0.0;
        let mut s = SMatrix::<f64, 1, 1>::zeros();
        let mut y_sum = SVector::<f64, 1>::zeros();
        let map = SMatrix::<f64, 1, 6>::from_row_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        for k in 0..2000 {
            let t = k as f64 * 0.01;
            let phi = SMatrix::<f64, 1, 1>::new(1.0 + 0.5 * (3.0 * t).sin());
            let psi = d.rows(t, &map);
            let y = phi * theta_true + SVector::<f64, 1>::new(c_true + rate_true * t);
            d.add(&phi, &y, &psi);
            a += phi[0] * phi[0];
            b += phi[0] * y[0];
            b_less_ramp += phi[0] * (y[0] - rate_true * t);
            s += phi.transpose();
            y_sum += y;
        }
        let p = SMatrix::<f64, 1, 1>::new(1.0 / a);
        let theta = SVector::<f64, 1>::new(b / a);
        let fit = d.fit(&theta, &p, &(s, y_sum), &SVector::zeros());
        let Some(fit) = fit else {
            panic!("the drift is determined");
        };
        assert!(
            (fit.rate_n_s[0] - rate_true).abs() < 1e-9,
            "{}",
            fit.rate_n_s[0]
        );
        let corrected = theta[0] - p[0] * d.sensitivity()[0] * fit.rate_n_s[0];
        assert!((theta[0] - theta_true).abs() > 1e-2, "the ramp moves θ̂");
        assert!((corrected - b_less_ramp / a).abs() < 1e-9, "{corrected}");
        // The cells the map does not reach keep a zero rate.
        assert!(fit.rate_n_s.iter().skip(1).all(|r| *r == 0.0));
    }
}
