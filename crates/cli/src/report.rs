//! `stewart report REPORT.json --html FILE`: a measurement report handed over as one
//! self-contained HTML page ([`inertial_certificate`], docs/report.md), and the same page
//! written by `--html FILE` on `simulate`, `rig` and `estimate` ([`write_page`]).

use std::path::{Path, PathBuf};

use clap::Args;
use measure::load::LoadedConfig;

use crate::common::{refuse, CommandError};

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

/// The tool's name and version, as the page states it.
pub fn tool() -> String {
    format!("stewart {}", env!("CARGO_PKG_VERSION"))
}

/// The rig description a report names (`run.config`): the embedded default, or the file when
/// it can still be read; `None` otherwise (the page then says no rig figures were given).
pub fn rig_of_report(config: &str) -> Option<LoadedConfig> {
    if config == measure::load::DEFAULT_CONFIG_NAME {
        measure::load::load(None).ok()
    } else if Path::new(config).is_file() {
        measure::load::load(Some(Path::new(config))).ok()
    } else {
        None
    }
}

/// Renders the page of the report `json` (the JSON text as written, station extras included)
/// and writes it to `path` atomically. `source` says where the report came from; `rig` is the
/// rig description to list (for `None` the one the report names, if readable).
pub fn write_page(
    json: &str,
    path: &Path,
    source: &str,
    rig: Option<&LoadedConfig>,
) -> Result<(), String> {
    let input = inertial_certificate::parse(json).map_err(|e| e.to_string())?;
    let named;
    let rig = match rig {
        Some(r) => Some(r),
        None => {
            named = rig_of_report(&input.report.run.config);
            named.as_ref()
        }
    };
    let tool = tool();
    let html = inertial_certificate::render(
        &input,
        &inertial_certificate::Context {
            tool: &tool,
            report_source: source,
            rig: rig.map(|r| &r.config),
            rig_source: rig.map(|r| r.source.as_str()),
            issued_unix_s: Some(inertial_certificate::now_unix_s()),
        },
    );
    inertial_export::file::write_atomically(path, &html).map_err(|e| e.to_string())
}

/// Runs `stewart report`: 0 written, 2 the report or rig description refused (nothing
/// written), 1 the page could not be written.
pub fn main(args: &ReportArgs) -> u8 {
    match run(args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

/// Reads the report (and `--rig`), writes the page.
pub fn run(args: &ReportArgs) -> Result<(), CommandError> {
    let text = std::fs::read_to_string(&args.report).map_err(|e| {
        refuse(format!(
            "cannot read the report {}: {e}",
            args.report.display()
        ))
    })?;
    inertial_certificate::parse(&text).map_err(|e| refuse(e.to_string()))?;
    let rig = match &args.rig {
        Some(p) => Some(measure::load::load(Some(p))?),
        None => None,
    };
    write_page(
        &text,
        &args.html,
        &args.report.display().to_string(),
        rig.as_ref(),
    )
    .map_err(|e| CommandError::Run(anyhow::anyhow!(e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The page of a report file is written whole; a campaign report writes nothing and is
    /// refused (exit 2).
    #[test]
    fn a_report_becomes_a_page_and_a_campaign_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("r.json");
        let mut r = measure::Report::default();
        r.estimate.mass = 12.5;
        r.run.config = measure::load::DEFAULT_CONFIG_NAME.into();
        std::fs::write(&report, r.to_json()).unwrap();
        let html = dir.path().join("r.html");
        let args = ReportArgs {
            report: report.clone(),
            html: html.clone(),
            rig: None,
        };
        assert_eq!(main(&args), 0);
        let page = std::fs::read_to_string(&html).unwrap();
        assert!(page.contains("data-quantity=\"estimate.mass_kg\" data-value=\"12.5\""));
        // The embedded default's plate radius is listed.
        assert!(page.contains("joint circles"), "rig figures listed");
        std::fs::write(&report, "{\"reports\": [], \"parameters\": []}").unwrap();
        let other = dir.path().join("c.html");
        let args = ReportArgs {
            html: other.clone(),
            ..args
        };
        assert_eq!(main(&args), 2);
        assert!(!other.exists());
    }
}
