//! `stewart report REPORT.json --html FILE`: the flags of [`ops::report`], which writes a
//! measurement report as one self-contained HTML page (docs/report.md).

use std::path::PathBuf;

use clap::Args;

/// `stewart report` arguments.
#[derive(Clone, Debug, Args)]
pub struct ReportArgs {
    /// The JSON report of one measurement (`simulate --report`, `rig --report`,
    /// `estimate --report`); a campaign report (`simulate --runs`) is refused.
    #[arg(value_name = "REPORT.json")]
    pub report: PathBuf,
    /// Write the page here (atomically: a temporary file renamed): results with expanded
    /// uncertainty (k = 2), principal axes and the payload's ellipsoid on the fixture, error
    /// budget, convergence, residuals, rig, provenance; prints on A4.
    #[arg(long, value_name = "FILE.html")]
    pub html: PathBuf,
    /// The rig description whose figures the page lists (default: the file the report names,
    /// when it can be read, or the embedded default when the report used it).
    #[arg(long, value_name = "FILE")]
    pub rig: Option<PathBuf>,
}

/// Runs `stewart report`: 0 written, 2 the report or rig description refused (nothing
/// written), 1 the page could not be written.
pub fn main(args: &ReportArgs) -> u8 {
    let options = ops::report::ReportOptions {
        report: args.report.clone(),
        html: args.html.clone(),
        rig: args.rig.clone(),
    };
    match ops::report::run(&options) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                ops::report::Error::Write(_) => 1,
                ops::report::Error::Report(_) | ops::report::Error::Rig(_) => 2,
            }
        }
    }
}
