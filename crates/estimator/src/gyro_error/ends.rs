//! The gyro's error at the ends of the run, where the derivative leaves it.
//!
//! The gyro's error n reaches the equations through ω̇, a derivative: every residual carries
//! −ψ(ṅ)θ, ψ(v) the regressor with ω̇ = v and every other signal zero (J v, v × h, and
//! m·(−v × r) through the accelerometer's lever arm r). Over a stretch of conditioned samples
//! Δt apart, summation by parts turns the fit's score of it into
//!
//! ```text
//! −Σ φ ψ(ṅ)θ = −[φ ψ(n)θ]_start^end / Δt + Σ φ̇ ψ(n)θ
//! ```
//!
//! The second sum is the error's share in the run's middle, which the residual windows measure
//! ([`crate::score`]). The bracket is the error at the stretch's two ends: it does not grow with
//! the run, so it matters in short ones, above all for a parameter whose regressor column
//! barely changes. For the first moment h, whose column is gravity, it is J (n_end − n_start)
//! / (g T) (measured, noise-only world, 2 s: the whole spread of c_x, about 2e-5 m), and no
//! window's spread can show it: each window sees only its own slopes.
//!
//! When the samples carry the rig's forward kinematics, and the rig's description gives its
//! gyro a noise (against an exact gyro the measured excess is only the kinematics' own error),
//! the bracket is measured (n̂, the gyro's
//! rate less the kinematic rate: [`crate::conditioning::Conditioned::gyro_excess_rad_s`]) and is
//! taken out of the estimate instead: the normal equations A θ = b become (A − Δ) θ = b with
//! Δ = Σ over the conditioning's unbroken stretches of (Φ_endᵀ ψ(n̂_end) − Φ_startᵀ ψ(n̂_start))
//! / Δt (rows weighted as the fit's). Only two instants per stretch enter, where the plate
//! rests at the excitation's start and end, so what the kinematics get wrong in motion (a
//! joint's survey error, about 1e-4 of the rate) hardly reaches it. A constant gyro bias, which
//! does not reach ω̇ at all, cancels between the two ends of a stretch that starts and ends at
//! the same pose.

use nalgebra::{SMatrix, SVector};

/// One sample's Φᵀψ(n̂) and ψ(n̂), or sums of them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ends<const N: usize, const R: usize> {
    normal: SMatrix<f64, N, N>,
    rows: SMatrix<f64, R, N>,
}

impl<const N: usize, const R: usize> Ends<N, R> {
    fn zeros() -> Self {
        Self {
            normal: SMatrix::zeros(),
            rows: SMatrix::zeros(),
        }
    }

    fn scaled(&self, factor: f64) -> Self {
        Self {
            normal: self.normal * factor,
            rows: self.rows * factor,
        }
    }

    fn plus(&self, other: &Self, factor: f64) -> Self {
        Self {
            normal: self.normal + other.normal * factor,
            rows: self.rows + other.rows * factor,
        }
    }
}

/// Σ over the conditioning's stretches of Φᵀψ(n̂) (the normal equations' Δ) and of ψ(n̂) (the
/// residuals' sum) at the stretch's end less at its start, divided by the sample period
/// (module docs); `R` equations per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateEnds<const N: usize, const R: usize> {
    /// Σ (end − start) over the stretches the conditioning broke off, aged by λ.
    closed: Ends<N, R>,
    /// At the start of the stretch in progress, aged by λ.
    start: Ends<N, R>,
    /// At the latest sample.
    latest: Ends<N, R>,
    /// Whether a stretch is in progress.
    open: bool,
    forgetting: f64,
    inv_period: f64,
}

impl<const N: usize, const R: usize> RateEnds<N, R> {
    /// No stretch yet; samples `period_s` apart, forgetting factor λ as the fit's.
    pub fn new(period_s: f64, forgetting: f64) -> Self {
        Self {
            closed: Ends::zeros(),
            start: Ends::zeros(),
            latest: Ends::zeros(),
            open: false,
            forgetting,
            inv_period: if period_s > 0.0 { 1.0 / period_s } else { 0.0 },
        }
    }

    /// Adds one sample's Φᵀψ(n̂) (`normal`, weighted rows) and gyro-error rows ψ(n̂).
    /// `starts_stretch`: the conditioning started afresh before this sample (its first output,
    /// or the first after a restart), which closes the stretch in progress at its latest
    /// sample.
    pub fn add(
        &mut self,
        normal: &SMatrix<f64, N, N>,
        psi: &SMatrix<f64, R, N>,
        starts_stretch: bool,
    ) {
        let sample = Ends {
            normal: *normal,
            rows: *psi,
        };
        if self.forgetting < 1.0 {
            self.closed = self.closed.scaled(self.forgetting);
            self.start = self.start.scaled(self.forgetting);
        }
        if starts_stretch || !self.open {
            if self.open {
                // The latest sample is one period old now.
                self.closed = self
                    .closed
                    .plus(&self.latest, self.forgetting)
                    .plus(&self.start, -1.0);
            }
            self.start = sample;
            self.open = true;
        }
        self.latest = sample;
    }

    /// A sample without the kinematics: the stretch in progress ends at the sample before.
    pub fn interrupt(&mut self) {
        if self.open {
            self.closed = self.closed.plus(&self.latest, 1.0).plus(&self.start, -1.0);
            self.open = false;
        }
        if self.forgetting < 1.0 {
            self.closed = self.closed.scaled(self.forgetting);
        }
    }

    fn total(&self) -> Ends<N, R> {
        let open = if self.open {
            self.latest.plus(&self.start, -1.0)
        } else {
            Ends::zeros()
        };
        self.closed.plus(&open, 1.0).scaled(self.inv_period)
    }

    /// Δ of the normal equations (A − Δ) θ = b: zero until a stretch has two ends.
    pub fn delta(&self) -> SMatrix<f64, N, N> {
        self.total().normal
    }

    /// The bracket's share of the residuals' sum at θ, Σ r ∋ −[ψ(n̂)θ] / Δt: this, added to
    /// Σ r, takes it out (weighted equations).
    pub fn residual_sum(&self, theta: &SVector<f64, N>) -> SVector<f64, R> {
        self.total().rows * theta
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    /// One stretch: the latest less the first; a restart closes it at its latest sample and
    /// opens another.
    #[test]
    fn delta_is_each_stretchs_end_less_its_start() {
        let mut ends = RateEnds::<2, 2>::new(0.5, 1.0);
        let one = Matrix2::identity();
        let theta = nalgebra::Vector2::new(1.0, -2.0);
        assert_eq!(ends.delta(), Matrix2::zeros());
        ends.add(&one, &one, true);
        ends.add(&(one * 4.0), &(one * 4.0), false);
        ends.add(&(one * 3.0), &(one * 3.0), false);
        assert_eq!(ends.delta(), one * 4.0); // (3 − 1) / 0.5
        assert_eq!(ends.residual_sum(&theta), theta * 4.0);
        ends.add(&(one * 10.0), &(one * 10.0), true);
        ends.add(&(one * 22.0), &(one * 11.0), false);
        // (2 + (22 − 10)) / 0.5 for Φᵀψ, (2 + 1) / 0.5 for ψ.
        assert_eq!(ends.delta(), one * 28.0);
        assert_eq!(ends.residual_sum(&theta), theta * 6.0);
        ends.interrupt();
        ends.add(&(one * 7.0), &(one * 7.0), false);
        assert_eq!(ends.residual_sum(&theta), theta * 6.0);
    }
}
