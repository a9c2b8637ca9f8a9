//! The time base of the conditioning: every sample's place on the uniform grid of the sample
//! period, and a check of the timestamps against that grid.
//!
//! The conditioning's stencil and low-pass assume equal steps: fed the timestamps themselves,
//! a lost frame or a late one leaves the derivative stencil's taps unbalanced around it, so the
//! gyro's white noise, which the balanced taps cancel at low frequency, leaks through the
//! low-pass into ω̇ (measured: 1 % of frames lost made σ(J_C) four times larger), and
//! timestamp jitter turns into an error of the derivative's scale. So every sample gets a grid
//! index k and the time t = t₀ + k·T:
//!
//! - from the frames' **sequence counter** when they carry one: k = s − s₀, so a frame that
//!   comes late keeps its place and a gap in the counter is a lost frame;
//! - otherwise from the **timestamps**: k advances by the step rounded to whole periods,
//!   round((tₙ − tₙ₋₁)/T), at least one (exact while jitter stays under a quarter period).
//!
//! A counter that does not count (it stands still or runs backwards before it ever advanced)
//! is ignored from then on and the timestamps place the samples.
//!
//! **Jitter and drift.** The deviations dₖ = tₖ − t₀ − k·T of the timestamps from the grid are
//! fitted by a line dₖ = a + b·k (running least squares, Welford's co-moments): the spread of
//! dₖ about it is the timestamp jitter, and b/T the relative error of the nominal rate. When
//! that error exceeds the stated tolerance (and its own uncertainty thrice over, so that jitter
//! alone cannot trip it), the sampling clock does not run at the nominal rate: from then on the
//! grid's step is the measured period T + b, which the derivative stencil then uses (the
//! low-pass keeps its coefficients; a cut-off off by the same small fraction changes nothing,
//! being applied alike to every channel).

/// Samples before the rate check may trip: the fitted slope needs a span to mean anything.
const RATE_CHECK_MIN_SAMPLES: f64 = 100.0;

/// What the time base measured; see the [module docs](self).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    /// Samples placed on the grid (accepted by the conditioning).
    pub samples: u64,
    /// The frames' sequence counter placed the samples (false: their timestamps did).
    pub from_sequence: bool,
    /// Root-mean-square spread of the timestamps about the fitted line t = t₀ + a + (T + b)·k,
    /// s: the timestamp jitter (0 before three samples).
    pub jitter_rms_s: f64,
    /// Largest deviation of a timestamp from the line fitted up to it, s (from the hundredth
    /// sample on: the first lines are too short to tell jitter from slope).
    pub jitter_max_s: f64,
    /// Relative error of the nominal rate measured by the timestamps, b/T (positive: the
    /// samples come slower than nominal).
    pub rate_error: f64,
    /// One-sigma uncertainty of `rate_error` from the jitter.
    pub rate_error_sigma: f64,
    /// The period the conditioning's derivative uses, s: the nominal one, or the measured one
    /// once `rate_exceeded`.
    pub period_s: f64,
    /// The timestamps ran off the nominal rate by more than the tolerance: the measured period
    /// is in use.
    pub rate_exceeded: bool,
}

/// The counter's verdict so far.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Counter {
    /// Not yet seen advancing.
    Unknown,
    /// Advanced by at least one between samples: it places them.
    Counting,
    /// Stood still or ran back before it advanced: the timestamps place the samples.
    Ignored,
}

/// A sample's place, worked out before anything changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Place {
    /// Grid index.
    pub index: u64,
    /// Grid steps since the previous sample (0 for the first).
    pub step: u64,
    counter: Counter,
}

/// The grid and the timestamps' fit. Plain `Copy` data, no heap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TimeBase {
    nominal_s: f64,
    tolerance: f64,
    counter: Counter,
    /// Time and counter of the first sample, and the last sample's index, time and counter.
    first: Option<(f64, Option<u64>)>,
    last_index: u64,
    last_time_s: f64,
    last_sequence: Option<u64>,
    // Welford's running means and co-moments of (k, d).
    n: f64,
    mean_k: f64,
    mean_d: f64,
    ckk: f64,
    ckd: f64,
    cdd: f64,
    jitter_max_s: f64,
    rate_exceeded: bool,
}

impl TimeBase {
    /// A grid of `nominal_s` (positive, checked by the caller) whose rate check trips beyond a
    /// relative error of `tolerance`.
    pub fn new(nominal_s: f64, tolerance: f64) -> Self {
        Self {
            nominal_s,
            tolerance,
            counter: Counter::Unknown,
            first: None,
            last_index: 0,
            last_time_s: 0.0,
            last_sequence: None,
            n: 0.0,
            mean_k: 0.0,
            mean_d: 0.0,
            ckk: 0.0,
            ckd: 0.0,
            cdd: 0.0,
            jitter_max_s: 0.0,
            rate_exceeded: false,
        }
    }

    /// The grid's step in use, s.
    pub fn period_s(&self) -> f64 {
        if self.rate_exceeded {
            self.nominal_s + self.slope()
        } else {
            self.nominal_s
        }
    }

    fn slope(&self) -> f64 {
        if self.ckk > 0.0 {
            self.ckd / self.ckk
        } else {
            0.0
        }
    }

    /// Where a sample at `time_s` with counter `sequence` goes; `None` when its time does not
    /// increase (or the counter, once counting, does not). Changes nothing.
    pub fn place(&self, time_s: f64, sequence: Option<u64>) -> Option<Place> {
        let Some(_) = self.first else {
            let counter = match sequence {
                Some(_) => Counter::Unknown,
                None => Counter::Ignored,
            };
            return Some(Place {
                index: 0,
                step: 0,
                counter,
            });
        };
        let dt = time_s - self.last_time_s;
        if dt.is_nan() || dt <= 0.0 {
            return None;
        }
        let mut counter = self.counter;
        let by_counter = match (counter, sequence, self.last_sequence) {
            (Counter::Ignored, ..) | (_, None, _) | (_, _, None) => None,
            (_, Some(s), Some(last)) if s > last => {
                counter = Counter::Counting;
                Some(s - last)
            }
            (Counter::Counting, Some(_), Some(_)) => return None,
            (Counter::Unknown, Some(_), Some(_)) => {
                counter = Counter::Ignored;
                None
            }
        };
        if sequence.is_none() {
            counter = Counter::Ignored;
        }
        let step = match by_counter {
            Some(step) => step,
            None => {
                let steps = libm::round(dt / self.period_s());
                // Far beyond any gap that is bridged: the conditioning restarts either way.
                if steps.is_finite() && steps < 1e15 {
                    (steps as u64).max(1)
                } else {
                    u64::MAX / 4
                }
            }
        };
        Some(Place {
            index: self.last_index.saturating_add(step),
            step,
            counter,
        })
    }

    /// Takes the sample at `place` (from [`Self::place`] with the same time and counter).
    pub fn commit(&mut self, place: Place, time_s: f64, sequence: Option<u64>) {
        self.counter = place.counter;
        let (t0, _) = *self.first.get_or_insert((time_s, sequence));
        self.last_index = place.index;
        self.last_time_s = time_s;
        self.last_sequence = sequence;
        let k = place.index as f64;
        let d = time_s - t0 - k * self.nominal_s;
        if self.n >= RATE_CHECK_MIN_SAMPLES {
            let predicted = self.mean_d + self.slope() * (k - self.mean_k);
            let deviation = libm::fabs(d - predicted);
            if deviation.is_finite() && deviation > self.jitter_max_s {
                self.jitter_max_s = deviation;
            }
        }
        // Welford: co-moments about the running means.
        self.n += 1.0;
        let dk = k - self.mean_k;
        let dd = d - self.mean_d;
        self.mean_k += dk / self.n;
        self.mean_d += dd / self.n;
        self.ckk += dk * (k - self.mean_k);
        self.ckd += dk * (d - self.mean_d);
        self.cdd += dd * (d - self.mean_d);
        if !self.rate_exceeded && self.n >= RATE_CHECK_MIN_SAMPLES {
            let t = self.timing_of(0);
            let excess = libm::fabs(t.rate_error) - 3.0 * t.rate_error_sigma;
            self.rate_exceeded = excess > self.tolerance;
        }
    }

    /// Residual variance of d about the fitted line, s².
    fn residual_variance(&self) -> f64 {
        if self.n < 3.0 || self.ckk <= 0.0 {
            return 0.0;
        }
        let ss = self.cdd - self.ckd * self.ckd / self.ckk;
        (ss / (self.n - 2.0)).max(0.0)
    }

    /// What was measured, `samples` being the count of samples placed.
    pub fn timing_of(&self, samples: u64) -> Timing {
        let variance = self.residual_variance();
        let rate_error_sigma = if self.ckk > 0.0 {
            libm::sqrt(variance / self.ckk) / self.nominal_s
        } else {
            0.0
        };
        Timing {
            samples,
            from_sequence: self.counter == Counter::Counting,
            jitter_rms_s: libm::sqrt(variance),
            jitter_max_s: self.jitter_max_s,
            rate_error: self.slope() / self.nominal_s,
            rate_error_sigma,
            period_s: self.period_s(),
            rate_exceeded: self.rate_exceeded,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(base: &mut TimeBase, time_s: f64, sequence: Option<u64>) -> Place {
        let p = base.place(time_s, sequence).expect("placed");
        base.commit(p, time_s, sequence);
        p
    }

    #[test]
    fn the_counter_places_late_and_lost_frames() {
        let mut b = TimeBase::new(1e-3, 1e-4);
        assert_eq!(feed(&mut b, 5.0, Some(100)).index, 0);
        // Late by 0.7 periods: the counter keeps it in its place.
        assert_eq!(feed(&mut b, 5.0017, Some(101)).index, 1);
        // Two frames lost.
        let p = feed(&mut b, 5.004, Some(104));
        assert_eq!((p.index, p.step), (4, 3));
        assert!(b.timing_of(3).from_sequence);
        // A counter running back once counting: refused, nothing changed.
        let before = b;
        assert_eq!(b.place(5.005, Some(103)), None);
        assert_eq!(b, before);
        // Time not increasing: refused.
        assert_eq!(b.place(5.004, Some(105)), None);
    }

    #[test]
    fn without_a_counter_the_timestamps_place_the_samples() {
        let mut b = TimeBase::new(1e-3, 1e-4);
        feed(&mut b, 0.0, Some(0));
        // A counter that stands still is ignored from then on.
        assert_eq!(feed(&mut b, 1.1e-3, Some(0)).index, 1);
        let p = feed(&mut b, 3.9e-3, Some(7));
        assert_eq!((p.index, p.step), (4, 3));
        assert!(!b.timing_of(3).from_sequence);
        // A step under half a period still advances by one.
        assert_eq!(feed(&mut b, 4.2e-3, None).index, 5);
    }

    /// Jitter is measured as the spread about the line, and a clock 1 % fast trips the check
    /// (its period is then measured), while jitter alone does not.
    #[test]
    fn jitter_and_rate_are_measured() {
        let jitter = |k: u64| 1e-5 * [1.0, -1.0, 0.5, -0.5][(k % 4) as usize];
        let mut b = TimeBase::new(1e-3, 1e-4);
        for k in 0..2000u64 {
            feed(&mut b, 10.0 + k as f64 * 1e-3 + jitter(k), Some(k));
        }
        let t = b.timing_of(2000);
        // rms of ±1e-5, ±0.5e-5 is 0.79e-5.
        assert!((t.jitter_rms_s / 0.79e-5 - 1.0).abs() < 0.01, "{t:?}");
        assert!((t.jitter_max_s - 1e-5).abs() < 5e-7, "{t:?}");
        assert!(t.rate_error.abs() < 1e-6 && !t.rate_exceeded, "{t:?}");
        assert_eq!(t.period_s, 1e-3);

        let mut fast = TimeBase::new(1e-3, 1e-4);
        for k in 0..2000u64 {
            feed(&mut fast, k as f64 * 0.99e-3, Some(k));
        }
        let t = fast.timing_of(2000);
        assert!(t.rate_exceeded, "{t:?}");
        assert!((t.rate_error + 0.01).abs() < 1e-9, "{t:?}");
        assert!((t.period_s - 0.99e-3).abs() < 1e-12, "{t:?}");
    }
}
