//! The crate's one error type.

use core::fmt;

use kinematics::KinematicsError;

use crate::fault::Fault;

/// Everything that can go wrong in the control crate, flat, `Copy`, with [`ControlError::kind`]
/// for callers that only care about the category (like `embedded-hal`'s `Error::kind`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum ControlError {
    /// A configuration value is out of range.
    InvalidConfig {
        /// Which parameter (dotted path as in the CLI's TOML where one exists).
        parameter: &'static str,
        /// What it must satisfy.
        reason: &'static str,
    },
    /// An input value is NaN or infinite.
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Leg or component index (0 when the input is a scalar).
        index: usize,
    },
    /// A time step is not finite and positive.
    InvalidTimeStep {
        /// The offending step, seconds.
        dt_s: f64,
    },
    /// More sine components than a [`Trajectory`](crate::trajectory::Trajectory) holds.
    TooManyComponents {
        /// The capacity, [`MAX_COMPONENTS`](crate::trajectory::MAX_COMPONENTS).
        max: usize,
    },
    /// The trajectory takes a leg outside its stroke.
    StrokeViolation {
        /// Trajectory time of the first violation, seconds.
        time_s: f64,
        /// Leg index, 0-based.
        leg: usize,
        /// Leg length there, metres.
        length_m: f64,
        /// The stroke limit it crossed, metres.
        limit_m: f64,
    },
    /// The trajectory drives a leg faster than allowed.
    LegSpeedViolation {
        /// Trajectory time of the first violation, seconds.
        time_s: f64,
        /// Leg index, 0-based.
        leg: usize,
        /// Leg speed `|J·twist|ᵢ` there, m/s.
        speed_m_s: f64,
        /// The configured limit, m/s.
        limit_m_s: f64,
    },
    /// The trajectory passes too close to a singular pose.
    ConditioningViolation {
        /// Trajectory time of the first violation, seconds.
        time_s: f64,
        /// Inverse condition number of the Jacobian there.
        inverse_condition: f64,
        /// The configured threshold.
        threshold: f64,
    },
    /// The legs' PID loops cannot hold the braked load: the translational Routh–Hurwitz ratio
    /// ([`crate::stability`]) is below 1, so the loop would oscillate with growing amplitude.
    UnstableLoad {
        /// The load the legs carry, kg (NaN or ≤ 0: they carry no weight).
        supported_mass_kg: f64,
        /// k_d k_p λ_min / (k_i m).
        ratio: f64,
        /// The largest integral gain that passes, N/(m·s).
        max_integral_gain: f64,
    },
    /// The load's inverse-dynamics feed-forward ([`crate::Controller::set_load`]) asks a leg
    /// for more than the command limit somewhere along the excitation: the commands would
    /// saturate and the loops' anti-windup ring after it.
    ForceViolation {
        /// Excitation time of the largest demand, seconds.
        time_s: f64,
        /// Leg index, 0-based.
        leg: usize,
        /// The feed-forward there (static load, rate term and the load's dynamics), N.
        force_n: f64,
        /// The command limit, N.
        limit_n: f64,
    },
    /// A kinematics computation failed (e.g. a singular pose where a force had to be solved).
    Kinematics(KinematicsError),
    /// The supervisor latched a fault (see [`Fault`]).
    Faulted(Fault),
}

/// Coarse category of a [`ControlError`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// Bad configuration: fix the config, nothing ran.
    InvalidConfig,
    /// Bad input data (non-finite values, non-positive time step).
    InvalidInput,
    /// A trajectory would violate stroke, speed or conditioning limits: nothing moved.
    Infeasible,
    /// A kinematics computation failed.
    Kinematics,
    /// The safety supervisor stopped the platform.
    Faulted,
}

impl ControlError {
    /// The error's category.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::InvalidConfig { .. } | Self::TooManyComponents { .. } => ErrorKind::InvalidConfig,
            Self::NonFinite { .. } | Self::InvalidTimeStep { .. } => ErrorKind::InvalidInput,
            Self::StrokeViolation { .. }
            | Self::LegSpeedViolation { .. }
            | Self::ConditioningViolation { .. }
            | Self::UnstableLoad { .. }
            | Self::ForceViolation { .. } => ErrorKind::Infeasible,
            Self::Kinematics(_) => ErrorKind::Kinematics,
            Self::Faulted(_) => ErrorKind::Faulted,
        }
    }
}

impl fmt::Display for ControlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidConfig { parameter, reason } => {
                write!(f, "invalid configuration: {parameter} {reason}")
            }
            Self::NonFinite { what, index } => write!(f, "{what} [{index}] is not finite"),
            Self::InvalidTimeStep { dt_s } => {
                write!(f, "time step {dt_s} s is not finite and positive")
            }
            Self::TooManyComponents { max } => {
                write!(f, "a trajectory holds at most {max} sine components")
            }
            Self::StrokeViolation {
                time_s,
                leg,
                length_m,
                limit_m,
            } => write!(
                f,
                "trajectory leaves the stroke at t = {time_s:.4} s: leg {leg} length {length_m:.5} m \
                 beyond limit {limit_m:.5} m"
            ),
            Self::LegSpeedViolation {
                time_s,
                leg,
                speed_m_s,
                limit_m_s,
            } => write!(
                f,
                "trajectory too fast at t = {time_s:.4} s: leg {leg} speed {speed_m_s:.4} m/s \
                 exceeds limit {limit_m_s:.4} m/s"
            ),
            Self::ConditioningViolation {
                time_s,
                inverse_condition,
                threshold,
            } => write!(
                f,
                "trajectory too close to a singularity at t = {time_s:.4} s: inverse condition \
                 number {inverse_condition:.3e} below threshold {threshold:.3e}"
            ),
            Self::UnstableLoad {
                supported_mass_kg,
                ratio,
                max_integral_gain,
            } => {
                if supported_mass_kg.is_nan() || *supported_mass_kg <= 0.0 {
                    return write!(
                        f,
                        "the legs carry no weight ({supported_mass_kg:.1} kg from their static \
                         forces): check the load cells' signs and zero before moving"
                    );
                }
                write!(
                    f,
                    "the legs' PID loops cannot hold {supported_mass_kg:.0} kg: the integral gain \
                     outruns the damping in the plate's weakest sideways direction (Routh–Hurwitz \
                     ratio {ratio:.2} < 1), so the platform would oscillate with growing amplitude. \
                     Lower control.ki_n_per_m_s below {max_integral_gain:.3e}, raise \
                     control.kd_n_s_per_m or control.kp_n_per_m, or incline the legs more \
                     (shorter legs, or a larger base against the plate)"
                )
            }
            Self::ForceViolation {
                time_s,
                leg,
                force_n,
                limit_n,
            } => write!(
                f,
                "with the load as [plan] describes it, the excitation needs {force_n:.0} N of leg \
                 {leg} at t = {time_s:.3} s (the load's feed-forward), beyond the command limit \
                 {limit_n:.0} N (control.max_force_n): lower the amplitudes or frequencies, \
                 lengthen excitation.fade_s, correct [plan.payload], or set \
                 control.inertial_feedforward = false to let the loops lag instead"
            ),
            Self::Kinematics(e) => write!(f, "kinematics: {e}"),
            Self::Faulted(fault) => write!(f, "supervisor fault: {fault}"),
        }
    }
}

impl core::error::Error for ControlError {}
