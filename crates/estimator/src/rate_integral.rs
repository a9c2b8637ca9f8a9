//! The gyro's measured error over the whole run, as the normal equations meet it.
//!
//! The gyro's error n reaches every equation through ω̇, a derivative: the residual carries
//! −ψ(ṅ)θ, ψ(v) the regressor with ω̇ = v and every other signal zero ([`crate::rate_ends`]).
//! Summed into the normal equations it is Q θ with Q = Σ Φᵀ ψ(ṅ): the fit solves
//! (A − Q) θ = b rather than A θ = b, so its estimate carries P Q θ of the gyro's error.
//! That error is mostly in J (the gyro's derivative noise meets J's column ω̇ directly) and
//! is one draw shared by the whole run.
//!
//! When the samples carry the rig's forward kinematics the error is measured, n̂ = the gyro's
//! rate less the kinematic rate of the pose ([`crate::conditioning::Conditioned::gyro_excess_rad_s`]),
//! and so is Q: this module sums Φₜᵀ ψ(ṅ̂ₜ) with ṅ̂ₜ = (n̂ₜ − n̂ₜ₋₁)/Δt over the
//! conditioning's unbroken stretches. It is not used for the estimate, which keeps the
//! gyro's rate (what the legs' compliance does to the pose would otherwise enter J): only the
//! residual windows ([`crate::score`]) are scored at the estimate with Q taken out.
//!
//! Q also carries the noise's own second moment, E[Φᵀψ(ṅ)] = C_ω̇ per sample, the
//! derivative-noise part of the noise moment that the fit already takes out; [`Self::weight`]
//! counts the samples it covers, so the caller takes C_ω̇ out once.

use nalgebra::SMatrix;

/// Σ λ^(age) Φₜᵀ ψ(ṅ̂ₜ) over the samples whose gyro error was measured (module docs); `R`
/// equations per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateIntegral<const N: usize, const R: usize> {
    sum: SMatrix<f64, N, N>,
    /// Σ λ^(age) over the samples in the sum.
    weight: f64,
    /// The latest sample's ψ(n̂), while its stretch goes on.
    previous: Option<SMatrix<f64, R, N>>,
    forgetting: f64,
    inv_period: f64,
}

impl<const N: usize, const R: usize> RateIntegral<N, R> {
    /// Nothing summed; samples `period_s` apart, forgetting factor λ as the fit's.
    pub fn new(period_s: f64, forgetting: f64) -> Self {
        Self {
            sum: SMatrix::zeros(),
            weight: 0.0,
            previous: None,
            forgetting,
            inv_period: if period_s > 0.0 { 1.0 / period_s } else { 0.0 },
        }
    }

    /// Adds one sample: its (weighted) rows Φ and gyro-error rows ψ(n̂). Returns the sample's
    /// Φᵀ ψ(ṅ̂), `None` for the first sample of a stretch (`starts_stretch`, or after
    /// [`Self::interrupt`]), which has no sample before it to difference with.
    pub fn add(
        &mut self,
        rows: &SMatrix<f64, R, N>,
        psi: &SMatrix<f64, R, N>,
        starts_stretch: bool,
    ) -> Option<SMatrix<f64, N, N>> {
        if self.forgetting < 1.0 {
            self.sum *= self.forgetting;
            self.weight *= self.forgetting;
        }
        let before = self.previous.replace(*psi).filter(|_| !starts_stretch)?;
        let derivative = rows.tr_mul(&(psi - before)) * self.inv_period;
        self.sum += derivative;
        self.weight += 1.0;
        Some(derivative)
    }

    /// A sample without the kinematics: the next measured one starts a stretch.
    pub fn interrupt(&mut self) {
        self.previous = None;
    }

    /// Q = Σ λ^(age) Φᵀ ψ(ṅ̂).
    pub fn sum(&self) -> &SMatrix<f64, N, N> {
        &self.sum
    }

    /// Σ λ^(age) over the samples Q covers: the multiple of C_ω̇ it carries in expectation.
    pub fn weight(&self) -> f64 {
        self.weight
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp n̂ₜ = k t Δt under constant rows sums to Φᵀψ(k) per differenced sample, and a
    /// stretch's first sample (a restart, or the first after an interruption) adds nothing:
    /// the jump across a break is not a derivative.
    #[test]
    fn a_ramp_sums_its_slope_and_breaks_do_not_count() {
        let period = 1e-3;
        let rows = SMatrix::<f64, 2, 2>::new(1.0, 2.0, 0.5, -1.0);
        let slope = SMatrix::<f64, 2, 2>::new(0.3, 0.0, 0.0, -0.2);
        let mut q = RateIntegral::<2, 2>::new(period, 1.0);
        for t in 0..10 {
            q.add(&rows, &(slope * (t as f64 * period)), t == 0);
        }
        let expected = rows.tr_mul(&slope) * 9.0;
        assert!((q.sum() - expected).norm() < 1e-12 * expected.norm());
        assert_eq!(q.weight(), 9.0);
        // A restart far away on the ramp, then an interruption: two first samples.
        q.add(&rows, &(slope * 5.0), true);
        q.interrupt();
        assert_eq!(q.add(&rows, &(slope * 7.0), false), None);
        assert!((q.sum() - expected).norm() < 1e-12 * expected.norm());
        assert_eq!(q.weight(), 9.0);
    }

    /// With forgetting, earlier samples count λ^(age), the weight alike.
    #[test]
    fn forgetting_ages_the_sum_and_its_weight() {
        let rows = SMatrix::<f64, 1, 1>::new(1.0);
        let mut q = RateIntegral::<1, 1>::new(1.0, 0.5);
        for t in 0..3 {
            q.add(&rows, &SMatrix::<f64, 1, 1>::new(t as f64), t == 0);
        }
        // Two unit slopes, the first aged once.
        assert!((q.sum()[(0, 0)] - 1.5).abs() < 1e-15);
        assert!((q.weight() - 1.5).abs() < 1e-15);
    }
}
