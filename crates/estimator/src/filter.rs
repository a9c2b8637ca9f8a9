//! A second-order Butterworth low-pass, applied channel by channel with one set of
//! coefficients so that every channel sees the same gain and delay.

use crate::error::EstimatorError;
use nalgebra::SVector;

/// Coefficients of a direct-form-II-transposed biquad with unit gain at DC.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Biquad {
    b0: f64,
    b1: f64,
    b2: f64,
    a1: f64,
    a2: f64,
}

impl Biquad {
    /// Butterworth low-pass (Q = 1/√2) at `cutoff_hz`, discretised by the bilinear transform
    /// with the cut-off prewarped: K = tan(π f_c T), b = K²(1, 2, 1)/n,
    /// a = (2(K² − 1), 1 − √2 K + K²)/n, n = 1 + √2 K + K².
    pub fn butterworth(cutoff_hz: f64, sample_period_s: f64) -> Result<Self, EstimatorError> {
        if !(sample_period_s.is_finite() && sample_period_s > 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "sample_period_s must be positive and finite",
            ));
        }
        let nyquist_hz = 0.5 / sample_period_s;
        if !(cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < 0.9 * nyquist_hz) {
            return Err(EstimatorError::InvalidConfig(
                "lowpass_cutoff_hz must be positive and below 0.9 of the Nyquist frequency",
            ));
        }
        let k = libm::tan(core::f64::consts::PI * cutoff_hz * sample_period_s);
        let sqrt2 = core::f64::consts::SQRT_2;
        let n = 1.0 + sqrt2 * k + k * k;
        let b0 = k * k / n;
        Ok(Self {
            b0,
            b1: 2.0 * b0,
            b2: b0,
            a1: 2.0 * (k * k - 1.0) / n,
            a2: (1.0 - sqrt2 * k + k * k) / n,
        })
    }

    /// The identity filter (y = x): used when no low-pass is configured.
    pub fn identity() -> Self {
        Self {
            b0: 1.0,
            b1: 0.0,
            b2: 0.0,
            a1: 0.0,
            a2: 0.0,
        }
    }

    /// |p|² of the poles, a₂ (the product of the two poles, equal to the squared radius of a
    /// complex pair, as a Butterworth low-pass has): the start transient decays as |p|ⁿ.
    pub fn pole_radius_squared(&self) -> f64 {
        self.a2
    }
}

/// The biquad applied to `C` channels at once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowPass<const C: usize> {
    coefficients: Biquad,
    s1: SVector<f64, C>,
    s2: SVector<f64, C>,
}

impl<const C: usize> LowPass<C> {
    /// A filter with zero state.
    pub fn new(coefficients: Biquad) -> Self {
        Self {
            coefficients,
            s1: SVector::zeros(),
            s2: SVector::zeros(),
        }
    }

    /// Sets the state as if `x` had been the input forever (output = x, no start transient).
    /// Holding every channel at its first value keeps linear relations between channels exact
    /// through the start, since the held history obeys them too.
    pub fn reset_to(&mut self, x: &SVector<f64, C>) {
        let c = &self.coefficients;
        self.s2 = x * (c.b2 - c.a2);
        self.s1 = x * (c.b1 - c.a1) + self.s2;
    }

    /// One step: y = b0 x + s1; s1 ← b1 x − a1 y + s2; s2 ← b2 x − a2 y.
    pub fn step(&mut self, x: &SVector<f64, C>) -> SVector<f64, C> {
        let c = self.coefficients;
        let y = x * c.b0 + self.s1;
        self.s1 = x * c.b1 - y * c.a1 + self.s2;
        self.s2 = x * c.b2 - y * c.a2;
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_dc_gain_and_minus_3_db_at_cutoff() {
        let t = 1e-3;
        let fc = 20.0;
        let q = Biquad::butterworth(fc, t).unwrap();
        // DC: settle on a constant.
        let mut f = LowPass::<1>::new(q);
        let mut y = 0.0;
        for _ in 0..5000 {
            y = f.step(&SVector::from_element(2.0))[0];
        }
        assert!((y - 2.0).abs() < 1e-12);
        // Sine at the cut-off: amplitude 1/√2 in steady state.
        let mut f = LowPass::<1>::new(q);
        let mut peak: f64 = 0.0;
        for k in 0..20_000 {
            let x = (2.0 * core::f64::consts::PI * fc * k as f64 * t).sin();
            let y = f.step(&SVector::from_element(x))[0];
            if k > 10_000 {
                peak = peak.max(y.abs());
            }
        }
        assert!(
            (peak - core::f64::consts::FRAC_1_SQRT_2).abs() < 2e-3,
            "{peak}"
        );
    }

    #[test]
    fn reset_to_holds_a_constant_without_transient() {
        let q = Biquad::butterworth(5.0, 1e-3).unwrap();
        let mut f = LowPass::<2>::new(q);
        let x = SVector::<f64, 2>::new(3.0, -1.5);
        f.reset_to(&x);
        for _ in 0..10 {
            assert!((f.step(&x) - x).norm() < 1e-13);
        }
    }

    #[test]
    fn rejects_cutoffs_beyond_nyquist() {
        assert!(Biquad::butterworth(500.0, 1e-3).is_err());
        assert!(Biquad::butterworth(0.0, 1e-3).is_err());
        assert!(Biquad::butterworth(f64::NAN, 1e-3).is_err());
        assert!(Biquad::butterworth(10.0, -1.0).is_err());
    }
}
