//! `stewart export REPORT.json --format urdf|sdf|mjcf|csv`: the payload's measured inertial
//! element (mass, centre of mass, J_C, optionally its principal axes) for a robot or vehicle
//! model, with the sigmas as comments (columns in CSV). The formats and their conventions are
//! [`inertial_export`]'s (docs/export.md); this module turns the flags into its options.

use std::path::PathBuf;

use clap::Args;
use inertial_export::{ExportError, Format, Options};

use crate::common::{refuse, CommandError};

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
            e.exit_code()
        }
    }
}

/// Reads and checks the report, renders the document, writes it to `-o FILE` or stdout.
pub fn run(args: &ExportArgs) -> Result<(), CommandError> {
    let payload = inertial_export::input::load(&args.report).map_err(|e| refuse(e.to_string()))?;
    let text = inertial_export::render(
        &payload,
        Options {
            format: args.format,
            principal_axes: args.principal_axes,
        },
    );
    match &args.output {
        Some(path) => inertial_export::file::write_atomically(path, &text)
            .map_err(|e: ExportError| CommandError::Run(anyhow::anyhow!(e.to_string()))),
        None => {
            use std::io::Write;
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|()| out.flush())
                .map_err(|e| CommandError::Run(anyhow::anyhow!("cannot write the output: {e}")))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use measure::report::{Quantities, Report};

    fn report(mass: f64) -> String {
        Report {
            estimate: Quantities {
                mass,
                com: [0.1, -0.05, 0.6],
                inertia_com: [
                    [600.0, -20.0, 40.0],
                    [-20.0, 2400.0, 5.0],
                    [40.0, 5.0, 2700.0],
                ],
            },
            ..Report::default()
        }
        .to_json()
    }

    fn args(report: PathBuf, output: PathBuf) -> ExportArgs {
        ExportArgs {
            report,
            format: Format::Urdf,
            output: Some(output),
            principal_axes: false,
        }
    }

    #[test]
    fn a_report_is_written_to_the_output_file() {
        let dir = tempfile::tempdir().unwrap();
        let (input, output) = (dir.path().join("r.json"), dir.path().join("p.urdf"));
        std::fs::write(&input, report(1500.0)).unwrap();
        assert_eq!(main(&args(input, output.clone())), 0);
        let text = std::fs::read_to_string(&output).unwrap();
        assert!(text.contains("<mass value=\"1500\"/>"), "{text}");
    }

    #[test]
    fn a_refused_report_exits_2_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (input, output) = (dir.path().join("r.json"), dir.path().join("p.urdf"));
        std::fs::write(&input, report(-1.0)).unwrap();
        let e = run(&args(input.clone(), output.clone())).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("estimate.mass"), "{e}");
        assert!(!output.exists());
        let missing = run(&args(dir.path().join("none.json"), output.clone())).unwrap_err();
        assert_eq!(missing.exit_code(), 2);
        assert!(!output.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
