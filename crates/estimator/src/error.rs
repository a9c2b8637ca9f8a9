//! The crate's one error type.

use core::fmt;

/// Broad class of an [`EstimatorError`], for callers that only need to decide what to do next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The configuration is unusable; nothing was built.
    Config,
    /// One sample was rejected and counted; the estimator state is unchanged and later samples
    /// are still accepted.
    RejectedSample,
    /// A linear-algebra step had no solution (for example a singular batch problem).
    Numerical,
}

/// Everything that can go wrong in this crate. Flat and `Copy`, so that it costs nothing on the
/// per-sample path; the `&'static str` names the offending field or channel.
///
/// `#[non_exhaustive]`: match with a wildcard arm, or on [`EstimatorError::kind`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum EstimatorError {
    /// A configuration value is out of range; the text names the field and the rule.
    InvalidConfig(&'static str),
    /// A sample held a NaN or an infinity in the named channel.
    NonFiniteSample(&'static str),
    /// A sample's time was not after the previous accepted sample's time.
    TimeNotIncreasing,
    /// Every input was finite, but the named derived quantity overflowed (values far beyond any
    /// physical rig); the sample was rejected before it reached any filter or the solver.
    Overflow(&'static str),
    /// The normal equations of a batch solve are not positive definite: the data do not
    /// identify every parameter.
    Singular,
}

impl EstimatorError {
    /// The broad class of this error.
    pub fn kind(&self) -> ErrorKind {
        match self {
            EstimatorError::InvalidConfig(_) => ErrorKind::Config,
            EstimatorError::NonFiniteSample(_)
            | EstimatorError::TimeNotIncreasing
            | EstimatorError::Overflow(_) => ErrorKind::RejectedSample,
            EstimatorError::Singular => ErrorKind::Numerical,
        }
    }
}

impl fmt::Display for EstimatorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EstimatorError::InvalidConfig(what) => {
                write!(f, "invalid estimator configuration: {what}")
            }
            EstimatorError::NonFiniteSample(channel) => {
                write!(f, "sample rejected: non-finite value in {channel}")
            }
            EstimatorError::TimeNotIncreasing => {
                write!(f, "sample rejected: time does not increase")
            }
            EstimatorError::Overflow(what) => write!(f, "sample rejected: {what} overflowed"),
            EstimatorError::Singular => {
                write!(
                    f,
                    "normal equations are singular: the data do not identify every parameter"
                )
            }
        }
    }
}

impl core::error::Error for EstimatorError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_and_messages_name_the_cause() {
        let e = EstimatorError::NonFiniteSample("gyro");
        assert_eq!(e.kind(), ErrorKind::RejectedSample);
        assert!(std::format!("{e}").contains("gyro"));
        assert_eq!(EstimatorError::InvalidConfig("x").kind(), ErrorKind::Config);
        assert_eq!(EstimatorError::Singular.kind(), ErrorKind::Numerical);
    }
}
