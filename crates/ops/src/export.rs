//! `stewart export REPORT.json --format urdf|sdf|mjcf|csv`'s work: the payload's measured
//! inertial element (mass, centre of mass, J_C, optionally its principal axes) for a robot or
//! vehicle model, with the sigmas as comments (columns in CSV). The formats and their
//! conventions are [`inertial_export`]'s (docs/export.md).

use std::path::PathBuf;

use inertial_export::Format;

/// Options of `stewart export`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportOptions {
    /// The JSON report of one measurement; a campaign report is refused.
    pub report: PathBuf,
    /// The model format.
    pub format: Format,
    /// Write the document here (atomically: a temporary file renamed); `None`: only return it.
    pub output: Option<PathBuf>,
    /// The inertia diagonal in its principal frame, with the frame's rotation, instead of the
    /// full tensor in P axes.
    pub principal_axes: bool,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            report: PathBuf::new(),
            format: Format::Urdf,
            output: None,
            principal_axes: false,
        }
    }
}

/// Why `export` wrote nothing.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The report could not be read or is refused (nothing written).
    #[error("{0}")]
    Report(String),
    /// The output could not be written.
    #[error("{0}")]
    Write(String),
}

/// Reads and checks the report, renders the document and writes it to
/// [`ExportOptions::output`]; returns the document.
pub fn run(options: &ExportOptions) -> Result<String, Error> {
    let payload =
        inertial_export::input::load(&options.report).map_err(|e| Error::Report(e.to_string()))?;
    let text = inertial_export::render(
        &payload,
        inertial_export::Options {
            format: options.format,
            principal_axes: options.principal_axes,
        },
    );
    if let Some(path) = &options.output {
        inertial_export::file::write_atomically(path, &text)
            .map_err(|e| Error::Write(e.to_string()))?;
    }
    Ok(text)
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

    fn options(report: PathBuf, output: PathBuf) -> ExportOptions {
        ExportOptions {
            report,
            output: Some(output),
            ..ExportOptions::default()
        }
    }

    #[test]
    fn a_report_is_written_to_the_output_file() {
        let dir = tempfile::tempdir().unwrap();
        let (input, output) = (dir.path().join("r.json"), dir.path().join("p.urdf"));
        std::fs::write(&input, report(1500.0)).unwrap();
        let returned = run(&options(input, output.clone())).unwrap();
        let text = std::fs::read_to_string(&output).unwrap();
        assert!(text.contains("<mass value=\"1500\"/>"), "{text}");
        assert_eq!(returned, text);
    }

    #[test]
    fn a_refused_report_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (input, output) = (dir.path().join("r.json"), dir.path().join("p.urdf"));
        std::fs::write(&input, report(-1.0)).unwrap();
        let e = run(&options(input.clone(), output.clone())).unwrap_err();
        assert!(matches!(e, Error::Report(_)));
        assert!(e.to_string().contains("estimate.mass"), "{e}");
        assert!(!output.exists());
        let missing = run(&options(dir.path().join("none.json"), output.clone())).unwrap_err();
        assert!(matches!(missing, Error::Report(_)));
        assert!(!output.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
