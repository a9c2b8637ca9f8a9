//! The gyro's measured error, everything the estimate and its sigma do with it.
//!
//! The gyro's error n (its noise, and whatever else it reads beyond the plate's rate) reaches
//! every equation through ω̇, a derivative: the residual carries −ψ(ṅ)θ, ψ(v) the regressor
//! with ω̇ = v and every other signal zero
//! ([`RegressorSignals::angular_acceleration_error`]: J v, v × h, and m·(−v × r) through the
//! accelerometer's lever arm r). When the samples carry the rig's forward kinematics the error
//! is measured, n̂ = the gyro's rate less the kinematic rate of the pose, conditioned alike
//! ([`crate::conditioning::Conditioned::gyro_excess_rad_s`]), and so is its change over each
//! grid step, ṅ̂. From them, per sample (rows weighted as the fit's):
//!
//! - ψ(n̂) and Φᵀψ(n̂): the run's ends, Δ = Σ over the stretches of
//!   (Φᵀψ(n̂)_end − Φᵀψ(n̂)_start)/Δt, taken out of θ ([`ends`]), and the windows' slopes,
//!   E_k = Σ ẇ Φᵀψ(n̂), taken out of each window's score ([`WindowSums`]);
//! - Φᵀψ(ṅ̂): over the run Q̂ = Σ Φᵀψ(ṅ̂) ([`integral`]), taken out of the estimate the windows
//!   are scored at, θ_w ([`GyroError::scored_shift`]); over window k U_k = Σ w Φᵀψ(ṅ̂), the
//!   gyro's share of the window's score, kept apart from the other sensors' ([`WindowSums`]).
//!
//! Whether the error is measured is decided here once ([`is_measured`]); the windows and the
//! run's sums only record which samples carried the measurement.

pub mod ends;
pub mod integral;

use crate::regressor::RegressorSignals;
use ends::RateEnds;
use integral::RateIntegral;
use nalgebra::{SMatrix, SVector, Vector3};

/// Whether the gyro's error is measured against the kinematics and taken out: for a gyro the
/// rig describes as noisy (`gyro_noise_rad_s` > 0) only. Against an exact one the measured
/// excess is the kinematics' own error (a simulator's integrator, 3e-7 rad/s on the paper's
/// case), which the run's ends would amplify by 1/Δt at the first samples.
pub fn is_measured(gyro_noise_rad_s: f64) -> bool {
    gyro_noise_rad_s > 0.0
}

/// The signals of ψ(n̂) and ψ(ṅ̂) for one conditioned sample: the measured error and its
/// change as errors of ω̇ ([`RegressorSignals::angular_acceleration_error`], the
/// accelerometer at `lever_m`), each `None` where the conditioning gave none or the error is
/// not measured ([`is_measured`]).
#[inline]
pub fn signals(
    measured: bool,
    excess_rad_s: Option<Vector3<f64>>,
    change_rad_s2: Option<Vector3<f64>>,
    lever_m: &Vector3<f64>,
) -> (Option<RegressorSignals>, Option<RegressorSignals>) {
    let as_rate_error = |n: Vector3<f64>| RegressorSignals::angular_acceleration_error(&n, lever_m);
    (
        excess_rad_s.filter(|_| measured).map(as_rate_error),
        change_rad_s2.filter(|_| measured).map(as_rate_error),
    )
}

/// One sample's gyro-error rows ψ (the regressor's part linear in ω̇, at the gyro's measured
/// error) met with its weighted rows Φ: what [`crate::score::ScoreCovariance::add_sample`]
/// takes out of the windows' scores and keeps apart ([`WindowSums`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateErrorNormals<'a, const N: usize> {
    /// Φᵀ ψ(n̂), n̂ the gyro's measured error.
    pub rate: &'a SMatrix<f64, N, N>,
    /// Φᵀ ψ(ṅ̂), ṅ̂ the error's change over the last grid step, `None` where the conditioning
    /// gave none ([`crate::conditioning::Conditioned::gyro_excess_change_rad_s2`]).
    pub derivative: Option<&'a SMatrix<f64, N, N>>,
}

/// The run's sums of the gyro's measured error: its ends Δ ([`ends`]) and its integral Q̂
/// ([`integral`]), `R` equations per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroError<const N: usize, const R: usize> {
    ends: RateEnds<N, R>,
    integral: RateIntegral<N, R>,
}

impl<const N: usize, const R: usize> GyroError<N, R> {
    /// Nothing summed; samples `period_s` apart, forgetting factor λ as the fit's.
    pub fn new(period_s: f64, forgetting: f64) -> Self {
        Self {
            ends: RateEnds::new(period_s, forgetting),
            integral: RateIntegral::new(forgetting),
        }
    }

    /// Adds one sample: its weighted rows Φ, its weighted ψ(n̂) (`rate_rows`) and ψ(ṅ̂)
    /// (`change_rows`) where measured, and whether the conditioning started a new stretch
    /// with it ([`RateEnds::add`]). Returns Φᵀψ(n̂) and Φᵀψ(ṅ̂), formed once for the run's
    /// sums and the windows'.
    #[inline]
    pub fn add(
        &mut self,
        rows: &SMatrix<f64, R, N>,
        rate_rows: Option<&SMatrix<f64, R, N>>,
        change_rows: Option<&SMatrix<f64, R, N>>,
        starts_stretch: bool,
    ) -> (Option<SMatrix<f64, N, N>>, Option<SMatrix<f64, N, N>>) {
        let derivative = match change_rows {
            Some(change) => Some(self.integral.add(rows, change)),
            None => {
                self.integral.skip();
                None
            }
        };
        let rate = match rate_rows {
            Some(psi) => {
                let rate = rows.tr_mul(psi);
                self.ends.add(&rate, psi, starts_stretch);
                Some(rate)
            }
            None => {
                self.ends.interrupt();
                None
            }
        };
        (rate, derivative)
    }

    /// Δ of the run's ends, taken out of θ: (A − n C − Δ) θ = b ([`ends`]).
    pub fn delta(&self) -> SMatrix<f64, N, N> {
        self.ends.delta()
    }

    /// The ends' share of the residuals' sum at θ ([`RateEnds::residual_sum`]).
    pub fn residual_sum(&self, theta: &SVector<f64, N>) -> SVector<f64, R> {
        self.ends.residual_sum(theta)
    }

    /// K of the equations of θ_w, the estimate the windows are scored at,
    /// (A − K) θ_w = b with K = n C − n_u C_ω̇ + Q̂: `noise` is n C (the fit's noise moment
    /// times its samples), `rate_moment` C_ω̇, which the measured Q̂ carries in expectation
    /// over its n_u samples ([`integral`]). `None` where no sample's change was measured.
    pub fn scored_shift(
        &self,
        noise: &SMatrix<f64, N, N>,
        rate_moment: &SMatrix<f64, N, N>,
    ) -> Option<SMatrix<f64, N, N>> {
        if self.integral.weight() <= 0.0 {
            return None;
        }
        Some((noise - rate_moment * self.integral.weight()) + self.integral.sum())
    }
}

/// A window's sums of the gyro's measured error, each sample weighted by the window (w) or
/// its slope (ẇ) and aged by λ: E = Σ ẇ Φᵀψ(n̂), U = Σ w Φᵀψ(ṅ̂) and n_u = Σ w over the
/// samples U covers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowSums<const N: usize> {
    e: SMatrix<f64, N, N>,
    u: SMatrix<f64, N, N>,
    n_u: f64,
}

impl<const N: usize> WindowSums<N> {
    /// Nothing summed.
    pub fn zeros() -> Self {
        Self {
            e: SMatrix::zeros(),
            u: SMatrix::zeros(),
            n_u: 0.0,
        }
    }

    /// Ages the sums by `factor`.
    pub fn age(&mut self, factor: f64) {
        self.e *= factor;
        self.u *= factor;
        self.n_u *= factor;
    }

    /// `self` aged by `factor`, plus `later`.
    pub fn aged_plus(&self, factor: f64, later: &Self) -> Self {
        Self {
            e: self.e * factor + later.e,
            u: self.u * factor + later.u,
            n_u: self.n_u * factor + later.n_u,
        }
    }

    /// Adds one sample to the rising window's sums and the falling one's, at weights
    /// (`rise`, `fall`); the slopes are `slope_scale` times (fall, −rise)
    /// ([`crate::window::slope_scale`]).
    #[inline]
    pub fn add(
        rising: &mut Self,
        falling: &mut Self,
        products: &RateErrorNormals<'_, N>,
        (rise, fall): (f64, f64),
        slope_scale: f64,
    ) {
        rising.e += products.rate * (slope_scale * fall);
        falling.e -= products.rate * (slope_scale * rise);
        if let Some(derivative) = products.derivative {
            rising.u += derivative * rise;
            falling.u += derivative * fall;
            rising.n_u += rise;
            falling.n_u += fall;
        }
    }

    /// The window's score, split: (g_o, g_ω) at the estimate `theta`, from the window's
    /// b and its information `a` (A − n C), `own_fit` the own-fit correction T.
    ///
    /// Where the window's samples carried the gyro's measured change (n_u > 0), its measured
    /// share U − n_u C_ω̇ (less the derivative noise's own second moment, `rate_moment`)
    /// splits off: g_ω = −(U − n_u C_ω̇ + E) θ, the rest g_o = T (b − (A − U + n_u C_ω̇) θ);
    /// otherwise the gyro's noise is the fit's like any other, only its slopes' share taken
    /// out, g_o = T (b − (A + E) θ), g_ω = 0.
    #[inline]
    pub fn scores(
        &self,
        b: &SVector<f64, N>,
        a: &SMatrix<f64, N, N>,
        own_fit: &SMatrix<f64, N, N>,
        theta: &SVector<f64, N>,
        rate_moment: &SMatrix<f64, N, N>,
    ) -> (SVector<f64, N>, SVector<f64, N>) {
        if self.n_u > 0.0 {
            let u = self.u - rate_moment * self.n_u;
            (own_fit * (b - (a - u) * theta), -(u + self.e) * theta)
        } else {
            (own_fit * (b - (a + self.e) * theta), SVector::zeros())
        }
    }
}
