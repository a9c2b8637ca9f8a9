//! The gyro's measured error over the whole run, as the normal equations meet it.
//!
//! The gyro's error n reaches every equation through ω̇, a derivative: the residual carries
//! −ψ(ṅ)θ, ψ(v) the regressor with ω̇ = v and every other signal zero ([`crate::gyro_error::ends`]).
//! Summed into the normal equations it is Q θ with Q = Σ Φᵀ ψ(ṅ): the fit solves
//! (A − Q) θ = b rather than A θ = b, so its estimate carries P Q θ of the gyro's error.
//! That error is mostly in J (the gyro's derivative noise meets J's column ω̇ directly) and
//! is one draw shared by the whole run.
//!
//! When the samples carry the rig's forward kinematics the error is measured, n̂ = the gyro's
//! rate less the kinematic rate of the pose, and so is its change over each grid step, ṅ̂
//! ([`crate::conditioning::Conditioned::gyro_excess_change_rad_s2`]: the samples a bridged gap
//! filled in count as steps, so a lost frame does not stretch one difference over two). This
//! module sums Φₜᵀ ψ(ṅ̂ₜ) into Q̂. It is not used for the estimate, which keeps the gyro's rate
//! (what the legs' compliance does to the pose would otherwise enter J): only the residual
//! windows ([`crate::score`]) are scored at the estimate with Q̂ taken out.
//!
//! Q̂ also carries the noise's own second moment, E[Φᵀψ(ṅ)] = C_ω̇ per sample, the
//! derivative-noise part of the noise moment that the fit already takes out; [`RateIntegral::weight`]
//! counts the samples it covers, so the caller takes C_ω̇ out once.

use nalgebra::SMatrix;

/// Σ λ^(age) Φₜᵀ ψ(ṅ̂ₜ) over the samples whose gyro error was measured (module docs); `R`
/// equations per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateIntegral<const N: usize, const R: usize> {
    sum: SMatrix<f64, N, N>,
    /// Σ λ^(age) over the samples in the sum.
    weight: f64,
    forgetting: f64,
}

impl<const N: usize, const R: usize> RateIntegral<N, R> {
    /// Nothing summed; forgetting factor λ as the fit's.
    pub fn new(forgetting: f64) -> Self {
        Self {
            sum: SMatrix::zeros(),
            weight: 0.0,
            forgetting,
        }
    }

    /// Adds one sample: its (weighted) rows Φ and the rows ψ(ṅ̂) of its gyro error's change
    /// (weighted alike). Returns the sample's Φᵀ ψ(ṅ̂).
    pub fn add(
        &mut self,
        rows: &SMatrix<f64, R, N>,
        change_rows: &SMatrix<f64, R, N>,
    ) -> SMatrix<f64, N, N> {
        let product = rows.tr_mul(change_rows);
        self.sum = self.sum * self.forgetting + product;
        self.weight = self.weight * self.forgetting + 1.0;
        product
    }

    /// A sample without a measured change (no pose, or the first after a start): ages the
    /// sums as a sample does.
    pub fn skip(&mut self) {
        self.sum *= self.forgetting;
        self.weight *= self.forgetting;
    }

    /// Q̂ = Σ λ^(age) Φᵀ ψ(ṅ̂).
    pub fn sum(&self) -> &SMatrix<f64, N, N> {
        &self.sum
    }

    /// Σ λ^(age) over the samples Q̂ covers: the multiple of C_ω̇ it carries in expectation.
    pub fn weight(&self) -> f64 {
        self.weight
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each sample adds Φᵀψ and counts once; a skipped sample adds nothing.
    #[test]
    fn samples_add_their_products_and_skips_do_not() {
        let rows = SMatrix::<f64, 2, 2>::new(1.0, 2.0, 0.5, -1.0);
        let change = SMatrix::<f64, 2, 2>::new(0.3, 0.0, 0.0, -0.2);
        let mut q = RateIntegral::<2, 2>::new(1.0);
        for _ in 0..9 {
            assert_eq!(q.add(&rows, &change), rows.tr_mul(&change));
        }
        q.skip();
        let expected = rows.tr_mul(&change) * 9.0;
        assert!((q.sum() - expected).norm() < 1e-12 * expected.norm());
        assert_eq!(q.weight(), 9.0);
    }

    /// With forgetting, earlier samples count λ^(age), skipped ones age the rest alike.
    #[test]
    fn forgetting_ages_the_sum_and_its_weight() {
        let rows = SMatrix::<f64, 1, 1>::new(1.0);
        let mut q = RateIntegral::<1, 1>::new(0.5);
        q.add(&rows, &SMatrix::<f64, 1, 1>::new(1.0));
        q.skip();
        q.add(&rows, &SMatrix::<f64, 1, 1>::new(1.0));
        // The first aged twice, the second not at all.
        assert!((q.sum()[(0, 0)] - 1.25).abs() < 1e-15);
        assert!((q.weight() - 1.25).abs() < 1e-15);
    }
}
