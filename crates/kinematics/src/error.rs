//! The crate's one error type.

use core::fmt;

/// Coarse class of a [`KinematicsError`], for callers that only branch on the kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// The design itself is invalid (bad dimensions, coincident joints, singular architecture).
    InvalidGeometry,
    /// An input value was NaN or infinite.
    NonFinite,
    /// A pose asks a leg for a length outside its stroke.
    Unreachable,
    /// The pose is at or near a singularity.
    Singular,
    /// Forward kinematics found no trustworthy pose.
    NoConvergence,
}

/// Everything that can go wrong in this crate. Each variant says why, with the numbers.
///
/// `#[non_exhaustive]`: match with a wildcard arm, or on [`KinematicsError::kind`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum KinematicsError {
    /// An input (named) contained NaN or infinity.
    NonFinite {
        /// Which input.
        what: &'static str,
    },
    /// A dimension is out of its valid range.
    InvalidDimension {
        /// Which dimension and what it must be.
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// The stroke limits are not `0 < min < max`.
    InvalidStroke {
        /// Minimum leg length given, m.
        min_length_m: f64,
        /// Maximum leg length given, m.
        max_length_m: f64,
    },
    /// Two joints on the same plate coincide.
    CoincidentJoints {
        /// `true` for base joints, `false` for plate joints.
        on_base: bool,
        /// First joint index (0-based).
        first: usize,
        /// Second joint index (0-based).
        second: usize,
    },
    /// The design is singular at its home pose (e.g. the paper's Eq. 1–2 as printed, with
    /// equal joint angles on both circles: the plate turns about z with no change of length).
    ArchitecturallySingular {
        /// Inverse condition number of the scaled Jacobian at home.
        inverse_condition: f64,
    },
    /// No level, centred pose puts the legs at mid-stroke.
    HomeUnreachable,
    /// A leg would be shorter than its minimum length.
    LegTooShort {
        /// Leg index (0-based).
        leg: usize,
        /// Length the pose needs, m.
        length_m: f64,
        /// The minimum, m.
        min_length_m: f64,
    },
    /// A leg would be longer than its maximum length.
    LegTooLong {
        /// Leg index (0-based).
        leg: usize,
        /// Length the pose needs, m.
        length_m: f64,
        /// The maximum, m.
        max_length_m: f64,
    },
    /// The pose is (nearly) singular.
    SingularPose {
        /// Inverse condition number of the scaled Jacobian at the pose.
        inverse_condition: f64,
    },
    /// Newton–Raphson did not reach the tolerance within the iteration cap.
    FkDidNotConverge {
        /// Iterations used.
        iterations: u32,
        /// Largest leg-length residual at the end, m.
        residual_m: f64,
    },
    /// Newton–Raphson converged, but to a pose that cannot be the platform's: a leg points
    /// downwards, or the solution jumped further from the warm start than allowed.
    FkWrongAssembly {
        /// Distance of the solution from the warm start, m.
        jump_m: f64,
        /// Rotation of the solution from the warm start, rad.
        jump_rad: f64,
    },
}

impl KinematicsError {
    /// The coarse class of this error.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::NonFinite { .. } => ErrorKind::NonFinite,
            Self::InvalidDimension { .. }
            | Self::InvalidStroke { .. }
            | Self::CoincidentJoints { .. }
            | Self::ArchitecturallySingular { .. }
            | Self::HomeUnreachable => ErrorKind::InvalidGeometry,
            Self::LegTooShort { .. } | Self::LegTooLong { .. } => ErrorKind::Unreachable,
            Self::SingularPose { .. } => ErrorKind::Singular,
            Self::FkDidNotConverge { .. } | Self::FkWrongAssembly { .. } => {
                ErrorKind::NoConvergence
            }
        }
    }
}

impl fmt::Display for KinematicsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::NonFinite { what } => write!(f, "{what} contains NaN or infinity"),
            Self::InvalidDimension { what, value } => write!(f, "{what} (got {value})"),
            Self::InvalidStroke { min_length_m, max_length_m } => write!(
                f,
                "leg stroke must satisfy 0 < min < max (got min {min_length_m} m, max {max_length_m} m)"
            ),
            Self::CoincidentJoints { on_base, first, second } => write!(
                f,
                "{} joints {} and {} coincide; give each leg its own joint",
                if on_base { "base" } else { "plate" },
                first + 1,
                second + 1
            ),
            Self::ArchitecturallySingular { inverse_condition } => write!(
                f,
                "the design is singular at its home pose (inverse condition number {inverse_condition:.2e}); \
                 turn the plate's joint pairs 60° against the base's, keep the pairs apart, and keep \
                 the plate's and the base's radii of a similar size"
            ),
            Self::HomeUnreachable => write!(
                f,
                "no level pose puts the legs at mid-stroke: the joint circles are too far apart for the stroke"
            ),
            Self::LegTooShort { leg, length_m, min_length_m } => write!(
                f,
                "leg {} would be {length_m:.4} m, shorter than its minimum {min_length_m:.4} m",
                leg + 1
            ),
            Self::LegTooLong { leg, length_m, max_length_m } => write!(
                f,
                "leg {} would be {length_m:.4} m, longer than its maximum {max_length_m:.4} m",
                leg + 1
            ),
            Self::SingularPose { inverse_condition } => write!(
                f,
                "pose is too close to a singularity (inverse condition number {inverse_condition:.2e})"
            ),
            Self::FkDidNotConverge { iterations, residual_m } => write!(
                f,
                "forward kinematics did not converge in {iterations} iterations (residual {residual_m:.3e} m)"
            ),
            Self::FkWrongAssembly { jump_m, jump_rad } => write!(
                f,
                "forward kinematics reached another assembly of the platform ({jump_m:.3} m, {jump_rad:.3} rad from the warm start)"
            ),
        }
    }
}

impl core::error::Error for KinematicsError {}
