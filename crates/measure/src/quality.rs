//! The rule that decides whether a measurement measured anything: every command that reports
//! one (`simulate`, `rig`, `estimate`) applies it, so none prints a table of numbers built on
//! no samples, or on the few left after most were rejected.
//!
//! A measurement fails when its estimator used no sample, or rejected more than
//! [`MAX_REJECTED_SHARE`] of the samples it was given (rejected: non-finite or out-of-range
//! inputs, time not increasing, or forward kinematics that failed). Rejections that many mean
//! the sensors or the log are broken, and what is left is not a fair sample of the excitation.
//!
//! It fails too when the loaded run or the tare gave fewer residual windows than
//! [`MIN_COVARIANCE_WINDOWS`] (plus the first, which does not count): the sigma's statistical
//! part would then be the configured equation sigmas' P, not a measurement, and understates
//! the error (measured: 20 runs of a 1 s window of the default scenario, mean z² of J_C zz
//! 34; see docs/accuracy.md, "Short measurements"). The error says how long to excite.

pub use estimator::uncertainty::MIN_COVARIANCE_WINDOWS;
use estimator::window;

/// Largest share of a measurement's samples that may be rejected, 0..1.
pub const MAX_REJECTED_SHARE: f64 = 0.5;

/// Why a measurement measured nothing trustworthy.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum QualityError {
    /// The estimator used no sample.
    #[error(
        "nothing was measured: the estimator used no samples ({rejected} rejected as non-finite, \
         out of range or failing forward kinematics), so every figure would be meaningless; \
         check the leg force and length sensors (all non-finite?) and that the platform starts \
         near its home pose"
    )]
    NoSamples {
        /// Samples rejected.
        rejected: u64,
    },
    /// More than [`MAX_REJECTED_SHARE`] of the samples were rejected.
    #[error(
        "the estimator rejected {rejected} of {total} samples ({percent:.1} %, more than the \
         {limit:.0} % allowed): the rest is not a fair sample of the excitation, so the figures \
         are not trusted; check the leg force and length sensors and the log for gaps",
        percent = 100.0 * *rejected as f64 / *total as f64,
        limit = 100.0 * MAX_REJECTED_SHARE
    )]
    MostlyRejected {
        /// Samples rejected.
        rejected: u64,
        /// Samples used plus rejected.
        total: u64,
    },
    /// Too few residual windows for the sigma to be measured.
    #[error(
        "the {run} run is too short for an honest sigma: its excitation gave {windows} residual \
         window(s) (two half-blocks of {half_block_s:.2} s each) after the first, and the noise's \
         covariance needs at least {needed} (with fewer, the sigma would be the configured equation sigmas' guess and \
         understate the error); excite for at least {seconds:.1} s",
        needed = MIN_COVARIANCE_WINDOWS,
        seconds = needed_seconds(*half_block_s)
    )]
    TooShort {
        /// `"loaded"` or `"tare"`.
        run: &'static str,
        /// Residual windows that counted.
        windows: u64,
        /// Length of one half-block, s.
        half_block_s: f64,
    },
}

/// Excitation that gives [`MIN_COVARIANCE_WINDOWS`] counted windows on half-blocks of
/// `half_block_s`, s: the half-blocks the estimator's rule needs for them
/// ([`window::half_blocks_for`]), and one more for the samples the conditioning withholds at
/// the start and the half-block left unfinished at the end.
pub fn needed_seconds(half_block_s: f64) -> f64 {
    f64::from(window::half_blocks_for(MIN_COVARIANCE_WINDOWS) + 1) * half_block_s
}

/// Residual windows a long run keeps ([`half_block_samples_for`]): 24, about 20 degrees of freedom
/// (Student factor 1.11, a sigma's own relative spread about a third).
pub const LONG_RUN_WINDOWS: u32 = 24;

/// Samples per residual half-block for an excitation of `excitation_s` sampled every
/// `period_s`:
///
/// - a long excitation, which would give more than [`LONG_RUN_WINDOWS`] windows of
///   `default_samples` (the estimator's default,
///   [`estimator::EstimatorConfig::default_covariance_half_block_samples`]: 8/(20 Hz)), gets half-blocks that give about that many
///   (the excitation over [`window::half_blocks_for`] of them, plus one half-block for the
///   conditioning's start and the unfinished end). What the windows leave of the gyro's derivative
///   noise in the scores of h falls with the half-block's square while the degrees of freedom
///   fall only with its length (measured, noise-only world, planned 20 s: mean z² of c_x 0.50
///   with 0.4 s half-blocks and 48 windows, 1.00 with 0.8 s and 23, 1.13 with 1.2 s and 14;
///   every other quantity within [0.6, 1.5] in all three);
/// - a short one, which would give fewer than [`MIN_COVARIANCE_WINDOWS`] counted windows of the
///   default, the length that gives them with one half-block to spare
///   (the excitation over [`window::half_blocks_for`] of them plus two: the conditioning's
///   start and the unfinished end, and the spare), but never under half the default: 4/(20 Hz)
///   is still several times the low-pass's memory, so windows that do not share a half-block
///   stay nearly independent, and a shorter excitation is refused ([`check_covariance`]);
/// - the default in between.
pub fn half_block_samples_for(default_samples: u32, excitation_s: f64, period_s: f64) -> u32 {
    let samples = excitation_s / period_s;
    if !(samples.is_finite() && samples > 0.0) {
        return default_samples;
    }
    let long = (samples / f64::from(window::half_blocks_for(LONG_RUN_WINDOWS) + 1)).floor();
    if long > f64::from(default_samples) {
        return long.min(f64::from(u32::MAX)) as u32;
    }
    let fitting =
        (samples / f64::from(window::half_blocks_for(MIN_COVARIANCE_WINDOWS) + 2)).floor();
    if fitting >= f64::from(default_samples) {
        return default_samples;
    }
    let floor = default_samples.div_ceil(2).max(1);
    (fitting as u32).max(floor)
}

/// Residual windows that count in a run whose excitation lasts `excitation_s`, sampled every
/// `period_s`, on half-blocks of `block_samples`: the fit sees the excitation's samples but
/// one (the conditioning warms up during the settle phase before it); the half-block left
/// unfinished at the end does not count, and the finished ones give the estimator's count
/// ([`window::counted_windows`]). Measured against runs of the default rig (fades 0.25 s): 1.5 s → 5
/// (refused), 1.7 s → 6, 2.0 s → 7, 2.4 s → 7, 3.5 s → 7 (half-blocks 0.2, 0.2, 0.2, 0.24,
/// 0.35 s).
pub fn excitation_windows(excitation_s: f64, period_s: f64, half_block_samples: u32) -> u64 {
    let samples = (excitation_s / period_s).floor();
    if !(samples.is_finite() && samples > 0.0 && half_block_samples > 0) {
        return 0;
    }
    window::counted_windows((samples as u64).saturating_sub(1) / u64::from(half_block_samples))
}

/// The rule on a run's excitation before it moves: the windows it will give
/// ([`excitation_windows`] with [`half_block_samples_for`]'s half-blocks) must be enough for
/// [`check_covariance`]. `default_half_block_samples` is the estimator's default
/// ([`estimator::EstimatorConfig::default_covariance_half_block_samples`]).
pub fn check_excitation(
    run: &'static str,
    excitation_s: f64,
    period_s: f64,
    default_half_block_samples: u32,
) -> Result<(), QualityError> {
    let block = half_block_samples_for(default_half_block_samples, excitation_s, period_s);
    check_covariance(
        run,
        excitation_windows(excitation_s, period_s, block),
        f64::from(block) * period_s,
    )
}

/// rejected / (used + rejected); 0 without samples.
pub fn rejected_share(used: u64, rejected: u64) -> f64 {
    let total = used.saturating_add(rejected);
    if total == 0 {
        0.0
    } else {
        rejected as f64 / total as f64
    }
}

/// The rule on a measurement's counts: `used` samples reached the solver, `rejected` (FK
/// failures included) were refused.
pub fn check(used: u64, rejected: u64) -> Result<(), QualityError> {
    if used == 0 {
        return Err(QualityError::NoSamples { rejected });
    }
    if rejected_share(used, rejected) > MAX_REJECTED_SHARE {
        return Err(QualityError::MostlyRejected {
            rejected,
            total: used.saturating_add(rejected),
        });
    }
    Ok(())
}

/// The rule on the residual windows of one run (`run`: `"loaded"` or `"tare"`): at least
/// [`MIN_COVARIANCE_WINDOWS`] on half-blocks of `half_block_s`.
pub fn check_covariance(
    run: &'static str,
    windows: u64,
    half_block_s: f64,
) -> Result<(), QualityError> {
    if windows < u64::from(MIN_COVARIANCE_WINDOWS) {
        return Err(QualityError::TooShort {
            run,
            windows,
            half_block_s,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_excitation_gets_shorter_half_blocks_down_to_half_the_default_a_long_one_longer() {
        // 400 samples of 1 ms (0.4 s) by default; MIN_COVARIANCE_WINDOWS + 4 = 10 half-blocks.
        assert_eq!(half_block_samples_for(400, 10.0, 1e-3), 400);
        assert_eq!(half_block_samples_for(400, 4.0, 1e-3), 400);
        // A long one: about LONG_RUN_WINDOWS windows (27 half-blocks of 20 s: 740 samples).
        assert_eq!(half_block_samples_for(400, 20.0, 1e-3), 740);
        assert_eq!(excitation_windows(20.0, 1e-3, 740), 25);
        assert_eq!(half_block_samples_for(400, 60.0, 1e-3), 2222);
        assert_eq!(half_block_samples_for(400, 3.0, 1e-3), 300);
        assert_eq!(half_block_samples_for(400, 2.0, 1e-3), 200);
        assert_eq!(half_block_samples_for(400, 1.0, 1e-3), 200);
        assert_eq!(half_block_samples_for(400, f64::INFINITY, 1e-3), 400);
        assert_eq!(half_block_samples_for(400, f64::NAN, 1e-3), 400);
        assert_eq!(half_block_samples_for(400, -1.0, 1e-3), 400);
        // A 2 s excitation at 200 samples needs needed_seconds(0.2) = 1.8 s: it fits.
        assert!(needed_seconds(0.2) <= 2.0);
    }

    #[test]
    fn no_samples_or_mostly_rejected_fail_and_say_so() {
        assert_eq!(check(0, 0), Err(QualityError::NoSamples { rejected: 0 }));
        let e = check(0, 5000).unwrap_err();
        assert!(e.to_string().contains("5000 rejected"), "{e}");
        let e = check(400, 600).unwrap_err();
        assert_eq!(
            e,
            QualityError::MostlyRejected {
                rejected: 600,
                total: 1000
            }
        );
        assert!(e.to_string().contains("60.0 %"), "{e}");
        assert_eq!(check(500, 500), Ok(()));
        assert_eq!(check(1000, 0), Ok(()));
        assert_eq!(rejected_share(0, 0), 0.0);
        assert_eq!(rejected_share(3, 1), 0.25);
    }

    #[test]
    fn too_few_residual_blocks_fail_and_say_how_long_to_excite() {
        assert_eq!(check_covariance("loaded", 6, 0.4), Ok(()));
        let e = check_covariance("tare", 5, 0.4).unwrap_err();
        assert_eq!(
            e,
            QualityError::TooShort {
                run: "tare",
                windows: 5,
                half_block_s: 0.4
            }
        );
        // Six counted windows on half-blocks of 0.4 s span seven; the first window and one
        // half-block of margin: 3.6 s.
        assert!((needed_seconds(0.4) - 3.6).abs() < 1e-12);
        let text = e.to_string();
        assert!(
            text.contains("tare run") && text.contains("at least 3.6 s"),
            "{text}"
        );
    }
}

/// Degrees of freedom below which a quantity's sigma is flagged as heavy-tailed: 4. The
/// standardised error of a variance with ν degrees of freedom is Student-t; scaled by
/// ν/(ν − 2) its mean z² is 1 (`estimator::uncertainty::student_factor`), but z² has a finite
/// variance only for ν > 4, so below it one run's error can be many sigmas more often than
/// a Gaussian's (a planned 2 s excitation leaves J_C xx about 3.2). Not refused: the sigma
/// is the honest scale; the report and the table say so, and a longer excitation gives more.
pub const HEAVY_TAIL_DEGREES_OF_FREEDOM: f64 = 4.0;

/// The quantity whose sigma rests on the fewest degrees of freedom, with that number;
/// `names` and `degrees_of_freedom` in the same order (the report's
/// [`crate::report::Quantities::flat`]); `None` where none is known.
pub fn fewest_degrees_of_freedom<'a>(
    names: &[&'a str],
    degrees_of_freedom: &[Option<f64>],
) -> Option<(&'a str, f64)> {
    names
        .iter()
        .zip(degrees_of_freedom)
        .filter_map(|(name, nu)| nu.filter(|v| v.is_finite()).map(|v| (*name, v)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// [`fewest_degrees_of_freedom`] when it is below [`HEAVY_TAIL_DEGREES_OF_FREEDOM`].
pub fn heavy_tailed<'a>(
    names: &[&'a str],
    degrees_of_freedom: &[Option<f64>],
) -> Option<(&'a str, f64)> {
    fewest_degrees_of_freedom(names, degrees_of_freedom)
        .filter(|(_, nu)| *nu < HEAVY_TAIL_DEGREES_OF_FREEDOM)
}

#[cfg(test)]
mod excitation_tests {
    use super::*;

    /// The counts a run gives (measured: `simulate --duration D` with 0.25 s fades on the
    /// default rig, the report's `covariance_basis`), and the refusal below six.
    #[test]
    fn counted_blocks_match_the_runs_and_short_ones_are_refused() {
        assert_eq!(excitation_windows(1.5, 1e-3, 200), 5);
        assert_eq!(excitation_windows(1.7, 1e-3, 200), 6);
        assert_eq!(excitation_windows(2.0, 1e-3, 200), 7);
        assert_eq!(excitation_windows(2.4, 1e-3, 240), 7);
        assert_eq!(excitation_windows(3.5, 1e-3, 350), 7);
        assert_eq!(excitation_windows(0.0, 1e-3, 200), 0);
        assert_eq!(excitation_windows(f64::NAN, 1e-3, 200), 0);
        assert!(check_excitation("loaded", 2.0, 1e-3, 400).is_ok());
        assert!(check_excitation("loaded", 20.0, 1e-3, 400).is_ok());
        let err = check_excitation("tare", 1.2, 1e-3, 400).unwrap_err();
        assert!(
            matches!(
                err,
                QualityError::TooShort {
                    run: "tare",
                    windows: 3,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(
            err.to_string().contains("excite for at least 1.8 s"),
            "{err}"
        );
    }
}

#[cfg(test)]
mod heavy_tail_tests {
    use super::*;

    #[test]
    fn the_fewest_degrees_of_freedom_below_four_are_named() {
        let names = ["mass", "com x", "J_C xx"];
        assert_eq!(
            heavy_tailed(&names, &[Some(5.6), Some(4.8), Some(3.2)]),
            Some(("J_C xx", 3.2))
        );
        assert_eq!(
            heavy_tailed(&names, &[Some(5.6), Some(4.8), Some(4.1)]),
            None
        );
        assert_eq!(heavy_tailed(&names, &[None, Some(f64::NAN), None]), None);
        assert_eq!(
            heavy_tailed(&names, &[None, Some(2.5), Some(3.9)]),
            Some(("com x", 2.5))
        );
    }
}
