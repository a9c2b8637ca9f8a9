//! The rule that decides whether a measurement measured anything: every command that reports
//! one (`simulate`, `rig`, `estimate`) applies it, so none prints a table of numbers built on
//! no samples, or on the few left after most were rejected.
//!
//! A measurement fails when its estimator used no sample, or rejected more than
//! [`MAX_REJECTED_SHARE`] of the samples it was given (rejected: non-finite or out-of-range
//! inputs, time not increasing, or forward kinematics that failed). Rejections that many mean
//! the sensors or the log are broken, and what is left is not a fair sample of the excitation.

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
