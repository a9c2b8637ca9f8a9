//! `stewart export REPORT.json --format urdf|sdf|mjcf|csv`: the payload's measured inertial
//! element (mass, centre of mass, J_C, optionally its principal axes) for a robot or vehicle
//! model, with the sigmas as comments (columns in CSV): the flags of [`ops::export`]
//! (docs/export.md).

use std::path::PathBuf;

use clap::Args;
use inertial_export::Format;
use ops::export::{Error, ExportOptions};

/// `stewart export` arguments.
#[derive(Clone, Debug, Args)]
pub struct ExportArgs {
    /// The JSON report of one measurement (`simulate --report`, `rig --report`,
    /// `estimate --report`); a campaign report (`simulate --runs`) is refused.
    #[arg(value_name = "REPORT.json")]
    pub report: PathBuf,
    /// The model format: `urdf` (ROS `<inertial>`), `sdf` (SDFormat `<inertial>`), `mjcf`
    /// (MuJoCo `<inertial fullinertia>`) or `csv` (header row with units, value row, sigma
    /// columns). Frame P, SI units; products of inertia are the tensor's entries,
    /// ixy = Jxy = -∫xy dm about the centre of mass (docs/export.md).
    #[arg(long, value_parser = format_parser())]
    pub format: Format,
    /// Write to this file (atomically: a temporary file renamed) instead of standard output.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Give the inertia diagonal in its principal frame, with the frame's rotation in the
    /// origin's rpy (URDF), the pose (SDF) or quat (MJCF), or as extra columns (CSV), instead of
    /// the full tensor in P axes.
    #[arg(long)]
    pub principal_axes: bool,
}

/// The parser of `--format`: the names of [`Format::ALL`] (listed in `--help`).
fn format_parser() -> impl clap::builder::TypedValueParser<Value = Format> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(Format::ALL.map(Format::name))
        .map(|name| Format::from_name(&name).unwrap_or(Format::Urdf))
}

/// Runs `stewart export`: the document, or the reason with exit code 2 (report refused,
/// nothing written) or 1 (the output could not be written).
pub fn main(args: &ExportArgs) -> u8 {
    match run(args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                Error::Report(_) => 2,
                Error::Write(_) => 1,
            }
        }
    }
}

/// The export of `args`, to `-o FILE` or standard output.
fn run(args: &ExportArgs) -> Result<(), Error> {
    let text = ops::export::run(&ExportOptions {
        report: args.report.clone(),
        format: args.format,
        output: args.output.clone(),
        principal_axes: args.principal_axes,
    })?;
    if args.output.is_none() {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        out.write_all(text.as_bytes())
            .and_then(|()| out.flush())
            .map_err(|e| Error::Write(format!("cannot write the output: {e}")))?;
    }
    Ok(())
}
