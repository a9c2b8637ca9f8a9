//! The payload's measured inertial element written for the models it goes into (`stewart export`):
//! URDF, SDF, MJCF and CSV, each in its own convention (docs/export.md).
//!
//! - [`input`]: the JSON report of `simulate`/`rig`/`estimate --report` read into a checked
//!   [`Payload`] (mass > 0, J_C symmetric, positive definite and within the triangle
//!   inequality, sigmas finite and non-negative); a campaign report is refused.
//! - [`principal`]: the principal frame, J_C = R·diag(I)·Rᵀ with R a proper rotation, as
//!   roll-pitch-yaw and as a quaternion.
//! - [`xml`]: the URDF, SDF and MJCF documents; [`table`]: the CSV.
//! - [`file`]: writing a file atomically (a temporary file in the same directory, renamed).
//!
//! Every format gets the report's own numbers: f64 written in Rust's shortest round-trip form,
//! so a parser reads back the exact values of the report (the principal moments and angles are
//! computed, exact to rounding).
#![warn(missing_docs)]

pub mod file;
pub mod input;
pub mod principal;
pub mod table;
pub mod xml;

#[cfg(test)]
mod tests;

pub use input::{ExportError, Payload};
pub use principal::PrincipalFrame;

/// A model format the payload's inertial element is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// URDF (ROS): `<inertial>` with `<origin>`, `<mass>` and `<inertia>` in a `<robot>`.
    Urdf,
    /// SDFormat (Gazebo): `<inertial>` with `<pose>`, `<mass>` and `<inertia>` in an `<sdf>`.
    Sdf,
    /// MJCF (MuJoCo): `<inertial pos mass fullinertia>` in a `<mujoco>` body.
    Mjcf,
    /// One header row with units and one value row, with the sigmas as columns.
    Csv,
}

impl Format {
    /// Every format, in the order `--help` lists them.
    pub const ALL: [Format; 4] = [Format::Urdf, Format::Sdf, Format::Mjcf, Format::Csv];

    /// The name on the command line (`--format NAME`).
    pub fn name(self) -> &'static str {
        match self {
            Format::Urdf => "urdf",
            Format::Sdf => "sdf",
            Format::Mjcf => "mjcf",
            Format::Csv => "csv",
        }
    }

    /// The format of `name` ([`Self::name`]), if it is one.
    pub fn from_name(name: &str) -> Option<Format> {
        Format::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// How to write the inertial element.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// The format.
    pub format: Format,
    /// Diagonal inertia in the principal frame with the frame's rotation (J_C = R·diag·Rᵀ)
    /// instead of the full tensor in P axes.
    pub principal_axes: bool,
}

/// The document of `payload` in `options.format`: the text a model file holds.
pub fn render(payload: &Payload, options: Options) -> String {
    match options.format {
        Format::Urdf => xml::urdf(payload, options.principal_axes),
        Format::Sdf => xml::sdf(payload, options.principal_axes),
        Format::Mjcf => xml::mjcf(payload, options.principal_axes),
        Format::Csv => table::csv(payload, options.principal_axes),
    }
}

/// A number as the documents write it: Rust's shortest decimal that reads back as the same
/// f64, without an exponent (every parser of the four formats reads plain decimals).
pub(crate) fn num(v: f64) -> String {
    format!("{v}")
}
