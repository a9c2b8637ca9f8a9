//! The crate's one error enum.

use kinematics::KinematicsError;

/// Everything that can go wrong building or running the simulator.
///
/// Construction errors name the offending field (a dotted path as it appears in a TOML section,
/// e.g. `actuator.bandwidth_hz`) so that a front end can point at the key.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SimError {
    /// A configuration value is out of range or not finite.
    #[error("invalid config `{field}` = {value}: {reason}")]
    InvalidConfig {
        /// Dotted path of the field, e.g. `sensors.gyro.noise_density_rad_s_sqrt_hz`.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A body's inertial properties are not physical.
    #[error("invalid {body} body: {reason}")]
    InvalidBody {
        /// Which body (`fixture` or `payload`).
        body: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The requested pose puts a leg outside its stroke or is otherwise unreachable.
    #[error("pose not reachable: {0}")]
    Unreachable(KinematicsError),
    /// A command carried a non-finite force.
    #[error("command for leg {leg} is not finite")]
    InvalidCommand {
        /// 0-based index of the leg.
        leg: usize,
    },
    /// The physics state became non-finite (a config that passed validation still blew up).
    #[error("simulation diverged (non-finite state) at t = {time_s} s")]
    Diverged {
        /// Simulated time of the failed sample, seconds.
        time_s: f64,
    },
}

/// The kind of a [`SimError`], without its data (for matching and for exit codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimErrorKind {
    /// See [`SimError::InvalidConfig`].
    InvalidConfig,
    /// See [`SimError::InvalidBody`].
    InvalidBody,
    /// See [`SimError::Unreachable`].
    Unreachable,
    /// See [`SimError::InvalidCommand`].
    InvalidCommand,
    /// See [`SimError::Diverged`].
    Diverged,
}

impl SimError {
    /// The kind of this error.
    pub fn kind(&self) -> SimErrorKind {
        match self {
            SimError::InvalidConfig { .. } => SimErrorKind::InvalidConfig,
            SimError::InvalidBody { .. } => SimErrorKind::InvalidBody,
            SimError::Unreachable(_) => SimErrorKind::Unreachable,
            SimError::InvalidCommand { .. } => SimErrorKind::InvalidCommand,
            SimError::Diverged { .. } => SimErrorKind::Diverged,
        }
    }
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn check_positive(field: &'static str, value: f64) -> Result<(), SimError> {
    check(field, value, value > 0.0, "must be positive")
}

/// Checks that `value` is finite and not negative.
pub(crate) fn check_non_negative(field: &'static str, value: f64) -> Result<(), SimError> {
    check(field, value, value >= 0.0, "must not be negative")
}

/// Checks that `value` is finite (any sign).
pub(crate) fn check_finite(field: &'static str, value: f64) -> Result<(), SimError> {
    check(field, value, true, "")
}

fn check(field: &'static str, value: f64, ok: bool, reason: &'static str) -> Result<(), SimError> {
    if !value.is_finite() {
        Err(SimError::InvalidConfig {
            field,
            value,
            reason: "must be finite",
        })
    } else if !ok {
        Err(SimError::InvalidConfig {
            field,
            value,
            reason,
        })
    } else {
        Ok(())
    }
}
