//! The overlapping windows over which the residual scores are summed.
//!
//! The covariance's scores ([`crate::score::ScoreCovariance`]) are sums of φ r over
//! stretches of the run. Summed with a rectangular window, a stretch of derivative noise
//! ẋ (the gyro's, through J ω̇) telescopes to its two edge values: the score of a parameter
//! with a near-constant regressor column (the first moment h, through gravity) is then
//! mostly x_end − x_start, a term that does not grow with the stretch, whose true share of
//! the whole run's score is only the run's own two ends, and which the stretches' spread
//! counts once per stretch (measured on the noise-only world, 20 s: mean z² of c_x 0.32, 0.18
//! and 0.09 with half-blocks of 0.4, 0.2 and 0.1 s — proportional to the half-block's length, as a
//! per-half-block constant predicts). A window that falls to zero at both ends turns the sum into
//! −Σ ẇ x, of order 1/B of it, and where the kinematics measure the gyro's error x the score
//! takes that sum out altogether ([`slope_scale`] gives ẇ; [`crate::score`]).
//!
//! Each window spans two half-blocks of B samples, rising over the first and falling over the
//! second, and consecutive windows overlap by one half-block. At position t of a half-block,
//! u = (t + ½)/B, the rising weight is sin(πu/2) and the falling one cos(πu/2), so every
//! sample's squared weights over the two windows that hold it add to one
//! (the Princen–Bradley condition of the MDCT's windows): Σ over windows of g gᵀ has, for
//! white or short-memory errors, the expectation of the whole run's score covariance,
//! whatever the information's distribution inside the half-blocks, and it stays positive
//! semi-definite (no lag terms). Consecutive windows' scores correlate through their shared
//! half-block (Σ sin·cos of it), which the degrees of freedom count ([`crate::dof`]).
//!
//! The sums below are the closed forms of Σ sin(a + t d) = sin(B d/2) sin(a + (B−1)d/2) /
//! sin(d/2) (and its cosine twin) over t = 0 … B−1.

use core::f64::consts::FRAC_PI_2;

/// What the close of half-block `index` (0-based) does to the counted windows: `None` when it
/// ends no counted window; else `Some(shares)`, `shares` telling whether the window it ends
/// shares its first half-block with a counted window before it. Window k rises over
/// half-block k and falls over k + 1, so it ends with half-block k + 1; window 0, where the
/// prior still shapes the fit, does not count.
pub fn closing(index: u64) -> Option<bool> {
    (index >= 2).then_some(index >= 3)
}

/// Counted windows that `half_blocks` finished half-blocks give: every half-block from the
/// third on closes one ([`closing`]), so G = H − 2. The rule behind [`half_blocks_for`], and
/// the one a planner uses to count a run's windows before it runs.
pub fn counted_windows(half_blocks: u64) -> u64 {
    half_blocks.saturating_sub(UNCOUNTED_HALF_BLOCKS)
}

/// Finished half-blocks that give `windows` counted windows, H = G + 2 ([`counted_windows`]).
pub fn half_blocks_for(windows: u32) -> u32 {
    windows.saturating_add(UNCOUNTED_HALF_BLOCKS as u32)
}

/// The half-blocks that close no counted window: the first window's two (window 0, where
/// the prior still shapes the fit, does not count; [`closing`]).
const UNCOUNTED_HALF_BLOCKS: u64 = 2;

/// The rising and falling weights (sin(πu/2), cos(πu/2)) of the sample at position `t`
/// (0-based) of a half-block of `half_block` samples, u = (t + ½)/B.
pub fn weights(t: u32, half_block: u32) -> (f64, f64) {
    let u = (f64::from(t) + 0.5) / f64::from(half_block.max(1));
    libm::sincos(FRAC_PI_2 * u)
}

/// π/(2 B Δt): the rising and falling weights' slopes per second are this times
/// (cos(πu/2), −sin(πu/2)), i.e. times the falling weight and minus the rising one, for
/// half-blocks of B samples `period_s` apart.
pub fn slope_scale(half_block: u32, period_s: f64) -> f64 {
    FRAC_PI_2 / (f64::from(half_block.max(1)) * period_s)
}

/// κ = Σw / Σw² over a whole window of two half-blocks of B samples: Σ sin = Σ cos =
/// ½ / sin(π/4B) and Σ sin² + Σ cos² = B, so κ = 1 / (B sin(π/4B)) (4/π for long half-blocks).
/// A window's weighted information A_w = Σ w φ φᵀ is κ times its squared-weight information
/// Σ w² φ φᵀ where the information is spread evenly over the window.
pub fn mean_to_square(half_block: u32) -> f64 {
    let b = f64::from(half_block.max(1));
    1.0 / (b * libm::sin(FRAC_PI_2 / (2.0 * b)))
}

/// Σ sin·cos / Σ (sin + cos) over one half-block, = sin(π/4B) / (2 sin(π/2B)) (¼ for long
/// half-blocks): the covariance of two consecutive windows' scores is this share of their shared
/// half-block's weighted information A_sin + A_cos, where the information is spread evenly.
pub fn shared_share(half_block: u32) -> f64 {
    let b = f64::from(half_block.max(1));
    libm::sin(FRAC_PI_2 / (2.0 * b)) / (2.0 * libm::sin(FRAC_PI_2 / b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The count of windows agrees with the windows [`closing`] closes, and
    /// [`half_blocks_for`] inverts it.
    #[test]
    fn counted_windows_are_those_the_half_blocks_close() {
        for half_blocks in 0..40u64 {
            let closed = (0..half_blocks).filter(|k| closing(*k).is_some()).count() as u64;
            assert_eq!(
                counted_windows(half_blocks),
                closed,
                "{half_blocks} half-blocks"
            );
        }
        for windows in 1..30u32 {
            let h = u64::from(half_blocks_for(windows));
            assert_eq!(counted_windows(h), u64::from(windows));
            assert_eq!(counted_windows(h - 1), u64::from(windows - 1));
        }
    }

    /// Every sample's squared weights over its two windows add to one.
    #[test]
    fn squared_weights_add_to_one() {
        for b in [1, 2, 7, 400] {
            for t in 0..b {
                let (rise, fall) = weights(t, b);
                assert!((rise * rise + fall * fall - 1.0).abs() < 1e-15);
                assert!(rise > 0.0 && fall > 0.0);
            }
        }
    }

    /// Half-blocks 0 and 1 end no counted window; 2 ends the first (sharing nothing counted),
    /// every later one a window that shares its first half with the one before.
    #[test]
    fn the_first_window_does_not_count() {
        assert_eq!(
            [0, 1, 2, 3, 40].map(closing),
            [None, None, Some(false), Some(true), Some(true)]
        );
    }

    /// The closed forms against the sums themselves.
    #[test]
    fn closed_forms_match_the_sums() {
        for b in [1u32, 2, 3, 10, 1600] {
            let (mut sum, mut square, mut product) = (0.0, 0.0, 0.0);
            for t in 0..b {
                let (rise, fall) = weights(t, b);
                sum += rise + fall;
                square += rise * rise + fall * fall;
                product += rise * fall;
            }
            assert!((mean_to_square(b) - sum / square).abs() < 1e-12, "κ at {b}");
            assert!(
                (shared_share(b) - product / sum).abs() < 1e-12,
                "shared share at {b}"
            );
        }
        assert!((mean_to_square(100_000) - 4.0 / core::f64::consts::PI).abs() < 1e-9);
        assert!((shared_share(100_000) - 0.25).abs() < 1e-9);
    }

    /// The reason for the windows: white noise x differentiated, x_t − x_(t−1), summed over
    /// a window is −Σ (w_(t+1) − w_t) x_t, of rms π/(2√B) (0.11 at B = 200), while its
    /// rectangular sum is x_end − x_start, of rms √2 whatever the length.
    #[test]
    fn windowed_derivative_noise_does_not_telescope_to_its_edges() {
        use rand::{Rng, SeedableRng};
        let b = 200u32;
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let trials = 400;
        let (mut rectangular, mut windowed) = (0.0, 0.0);
        for _ in 0..trials {
            let x: std::vec::Vec<f64> = (0..=2 * b)
                .map(|_| rng.random_range(-1.0..1.0) * 3f64.sqrt())
                .collect();
            let (mut r, mut w) = (0.0, 0.0);
            for (t, pair) in x.windows(2).enumerate() {
                let dx = pair[1] - pair[0];
                let (rise, fall) = weights(t as u32 % b, b);
                r += dx;
                w += dx * if (t as u32) < b { rise } else { fall };
            }
            rectangular += r * r / f64::from(trials);
            windowed += w * w / f64::from(trials);
        }
        let (rectangular, windowed) = (rectangular.sqrt(), windowed.sqrt());
        assert!((1.2..1.7).contains(&rectangular), "{rectangular}");
        assert!((0.07..0.16).contains(&windowed), "{windowed}");
    }
}
