//! The accelerometer's offset from the samples before the excitation.
//!
//! Before the fit window the plate rests on its brakes, ramps home and holds there: a stretch
//! that starts and ends at rest, so the plate's mean acceleration over it is Δv/T ≈ 0 however
//! it moved in between (and however a car on its suspension settled after loading). A window
//! that opens later in the excitation (a re-estimate of part of the run) still takes the stretch
//! up to the excitation's start (`EstimatorConfig::hold_end_s`): the motion between does not
//! end at rest, and its mean is not gravity's (measured, `estimate --window 5:8` on twelve
//! noise-only logs: mass mean z² 75 and rms error 0.55 kg with it averaged in, 2.2 and 0.11 kg
//! without). An ideal
//! accelerometer's mean reading over it is then the mean specific force of gravity alone,
//! `Rᵀ (0, 0, g)` in P axes (R the plate's orientation from forward kinematics, g the site's
//! gravity), and the mean reading less that is the accelerometer's offset:
//!
//! ```text
//! d = (1/n) Σ fₖ − g·ū',   ū' = (1/n) Σ Rₖᵀ ẑ,   ū = ū'/|ū'|,   b̂ = (d·ū) ū,   σ(b̂) = σ_f/√n
//! ```
//!
//! Only the component along gravity is taken: the mass needs only that one, and the
//! horizontal ones would take a tilt error of the forward kinematics and what is left of the
//! motion for a bias (measured: with them, the noise-only campaign's centre of mass x is off by
//! 24 µm, 6.9 standard errors of its mean; without, by 1.4 µm, 0.8).
//!
//! with σ_f the accelerometer's white noise per sample as its datasheet gives it (the readings'
//! own spread would be mostly the plate's motion, not noise). b̂ holds whatever is
//! constant in the vertical reading: the bias and the scale error's share of gravity (s·g).
//! Subtracting it from every sample in the window makes the reading at rest the site's gravity
//! exactly, so the
//! mass, which the fit draws mostly from the load cells against gravity, no longer carries the
//! accelerometer's offset: only g's own uncertainty (a gravity survey or map: about 1e-6 of g)
//! and σ(b̂). A scale error still scales the dynamic part of the reading.

use nalgebra::Vector3;

/// Fewest samples at rest for an offset.
pub const MIN_HOLD_SAMPLES: u32 = 20;

/// The accelerometer offset measured before the window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelerometerOffset {
    /// b̂, P axes, m/s²: along gravity, subtracted from every sample in the window.
    pub offset_m_s2: Vector3<f64>,
    /// One sigma of b̂ along gravity from the accelerometer's noise, σ_f/√n, m/s².
    pub sigma_m_s2: f64,
    /// Samples averaged.
    pub samples: u32,
}

/// Running mean of the readings before the window (an incremental mean, so that a long
/// stretch loses no precision to a large sum) and the sum of the expected directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoldAverage {
    count: u32,
    mean_m_s2: Vector3<f64>,
    /// Σ Rₖᵀ ẑ: the vertical in P axes.
    up_sum: Vector3<f64>,
}

impl Default for HoldAverage {
    fn default() -> Self {
        Self::new()
    }
}

impl HoldAverage {
    /// No samples yet.
    pub const fn new() -> Self {
        Self {
            count: 0,
            mean_m_s2: Vector3::new(0.0, 0.0, 0.0),
            up_sum: Vector3::new(0.0, 0.0, 0.0),
        }
    }

    /// Adds one reading: `accel_m_s2` in P axes and `up_in_p` = Rᵀ ẑ, the base's
    /// vertical in P axes. Non-finite readings are skipped.
    pub fn push(&mut self, accel_m_s2: &Vector3<f64>, up_in_p: &Vector3<f64>) {
        let finite = accel_m_s2
            .iter()
            .chain(up_in_p.iter())
            .all(|v| v.is_finite());
        if !finite || self.count == u32::MAX {
            return;
        }
        self.count += 1;
        self.mean_m_s2 += (accel_m_s2 - self.mean_m_s2) / f64::from(self.count);
        self.up_sum += up_in_p;
    }

    /// Samples so far.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// b̂ and its sigma against gravity `gravity_m_s2` with white noise `noise_m_s2` per
    /// sample (the module docs' formula; a noise that is not positive counts as 0); `None`
    /// with fewer than [`MIN_HOLD_SAMPLES`] samples or a gravity that is not positive.
    pub fn offset(&self, gravity_m_s2: f64, noise_m_s2: f64) -> Option<AccelerometerOffset> {
        if self.count < MIN_HOLD_SAMPLES || !(gravity_m_s2.is_finite() && gravity_m_s2 > 0.0) {
            return None;
        }
        let n = f64::from(self.count);
        let expected = self.up_sum * (gravity_m_s2 / n);
        let sigma = if noise_m_s2.is_finite() && noise_m_s2 > 0.0 {
            noise_m_s2 / libm::sqrt(n)
        } else {
            0.0
        };
        let up = self.up_sum / n;
        let up = up / up.norm();
        if !up.iter().all(|v| v.is_finite()) {
            return None;
        }
        Some(AccelerometerOffset {
            offset_m_s2: up * (self.mean_m_s2 - expected).dot(&up),
            sigma_m_s2: sigma,
            samples: self.count,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_rest_gives_the_bias_and_the_noise_over_root_n() {
        let mut hold = HoldAverage::new();
        let up = Vector3::z();
        let bias = Vector3::new(1e-3, -2e-3, 3e-3);
        // Alternating ±s on every axis: the mean is the bias exactly.
        let s = 0.01;
        for k in 0..100 {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let f = Vector3::new(0.0, 0.0, 9.81) + bias + Vector3::repeat(sign * s);
            hold.push(&f, &up);
        }
        let o = hold.offset(9.81, 0.02).unwrap();
        // The vertical part of the bias alone.
        let vertical = Vector3::new(0.0, 0.0, bias.z);
        assert!(
            (o.offset_m_s2 - vertical).amax() < 1e-15,
            "{:?}",
            o.offset_m_s2
        );
        assert!((o.sigma_m_s2 - 0.002).abs() < 1e-15);
        assert_eq!(o.samples, 100);
        assert_eq!(hold.offset(9.81, 0.0).unwrap().sigma_m_s2, 0.0);
    }

    #[test]
    fn a_tilted_rest_expects_gravity_along_the_tilted_vertical() {
        // Pitched by β: the base's vertical in P axes is (−sin β, 0, cos β).
        let beta: f64 = 0.03;
        let up = Vector3::new(-libm::sin(beta), 0.0, libm::cos(beta));
        let g = 9.79;
        let mut hold = HoldAverage::new();
        for _ in 0..MIN_HOLD_SAMPLES {
            hold.push(&(up * g), &up);
        }
        let o = hold.offset(g, 0.0).unwrap();
        assert!(o.offset_m_s2.amax() < 1e-15, "{:?}", o.offset_m_s2);
        // A bias along the tilted vertical is found; one across it is not taken.
        let mut biased = HoldAverage::new();
        let across = Vector3::new(libm::cos(beta), 0.0, libm::sin(beta)) * 3e-3;
        for _ in 0..MIN_HOLD_SAMPLES {
            biased.push(&(up * (g + 2e-3) + across), &up);
        }
        let o = biased.offset(g, 0.0).unwrap();
        assert!(
            (o.offset_m_s2 - up * 2e-3).amax() < 1e-12,
            "{:?}",
            o.offset_m_s2
        );
    }

    #[test]
    fn too_few_samples_or_no_gravity_give_no_offset() {
        let mut hold = HoldAverage::new();
        for _ in 0..MIN_HOLD_SAMPLES - 1 {
            hold.push(&Vector3::z(), &Vector3::z());
        }
        assert_eq!(hold.offset(9.81, 0.0), None);
        hold.push(&Vector3::new(f64::NAN, 0.0, 0.0), &Vector3::z());
        assert_eq!(
            hold.count(),
            MIN_HOLD_SAMPLES - 1,
            "a NaN reading is skipped"
        );
        hold.push(&Vector3::z(), &Vector3::z());
        assert!(hold.offset(9.81, 0.0).is_some());
        assert_eq!(hold.offset(0.0, 0.0), None);
        assert_eq!(hold.offset(f64::NAN, 0.0), None);
    }
}
