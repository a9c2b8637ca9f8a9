//! `stewart report REPORT.json --html FILE`'s work: a measurement report handed over as one
//! self-contained HTML page ([`inertial_certificate`], docs/report.md), and the same page
//! written by `--html FILE` on `simulate`, `rig` and `estimate` ([`write_page`]).

use std::path::{Path, PathBuf};

use rig_description::load::LoadedConfig;

/// Options of `stewart report`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReportOptions {
    /// The JSON report of one measurement; a campaign report is refused.
    pub report: PathBuf,
    /// Where the page goes (written atomically: a temporary file renamed).
    pub html: PathBuf,
    /// The rig description whose figures the page lists (`None`: the file the report names,
    /// when it can be read, or the embedded default when the report used it).
    pub rig: Option<PathBuf>,
}

/// Why `report` wrote no page.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The report could not be read or is not one measurement's report (nothing written).
    #[error("{0}")]
    Report(String),
    /// The rig description of [`ReportOptions::rig`] was refused (nothing written).
    #[error("{0}")]
    Rig(#[from] rig_description::load::ConfigError),
    /// The page could not be written.
    #[error("{0}")]
    Write(String),
}

/// The tool's name and version, as the page states it.
pub fn tool() -> String {
    format!("stewart {}", env!("CARGO_PKG_VERSION"))
}

/// The rig description a report names (`run.config`): the embedded default, or the file when
/// it can still be read; `None` otherwise (the page then says no rig figures were given).
pub fn rig_of_report(config: &str) -> Option<LoadedConfig> {
    if config == rig_description::load::DEFAULT_CONFIG_NAME {
        rig_description::load::load(None).ok()
    } else if Path::new(config).is_file() {
        rig_description::load::load(Some(Path::new(config))).ok()
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
            log_sha256: input.report.run.log.as_deref().and_then(file_sha256),
        },
    );
    inertial_export::file::write_atomically(path, &html).map_err(|e| e.to_string())
}

/// SHA-256 of the file at `path`, read in blocks (a log of any size), lower-case hex; `None`
/// when it cannot be read.
pub fn file_sha256(path: &str) -> Option<String> {
    use sha2::Digest as _;
    use std::io::Read as _;
    let mut file = std::fs::File::open(path).ok()?;
    let mut hasher = sha2::Sha256::new();
    let mut block = vec![0u8; 1 << 16];
    loop {
        match file.read(&mut block) {
            Ok(0) => break,
            Ok(n) => hasher.update(&block[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return None,
        }
    }
    Some(
        hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
    )
}

/// Runs `report`: reads the report (and the rig description), writes the page.
pub fn run(options: &ReportOptions) -> Result<(), Error> {
    let text = rig_description::bounded::read_to_string_capped(
        &options.report,
        rig_description::bounded::REPORT_CAP_BYTES,
        "a report",
    )
    .map_err(|e| {
        Error::Report(format!(
            "cannot read the report {}: {e}",
            options.report.display()
        ))
    })?;
    inertial_certificate::parse(&text).map_err(|e| Error::Report(e.to_string()))?;
    let rig = match &options.rig {
        Some(p) => Some(rig_description::load::load(Some(p))?),
        None => None,
    };
    write_page(
        &text,
        &options.html,
        &options.report.display().to_string(),
        rig.as_ref(),
    )
    .map_err(Error::Write)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The page of a report file is written whole; a campaign report writes nothing and is
    /// refused.
    #[test]
    fn a_report_becomes_a_page_and_a_campaign_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("r.json");
        let mut r = measure::Report::default();
        r.estimate.mass = 12.5;
        r.run.config = rig_description::load::DEFAULT_CONFIG_NAME.into();
        std::fs::write(&report, r.to_json()).unwrap();
        let html = dir.path().join("r.html");
        let options = ReportOptions {
            report: report.clone(),
            html: html.clone(),
            rig: None,
        };
        run(&options).unwrap();
        let page = std::fs::read_to_string(&html).unwrap();
        assert!(page.contains("data-quantity=\"estimate.mass_kg\" data-value=\"12.5\""));
        // The embedded default's plate radius is listed.
        assert!(
            page.contains("joints: base, plate radius"),
            "rig figures listed"
        );
        std::fs::write(&report, "{\"reports\": [], \"parameters\": []}").unwrap();
        let other = dir.path().join("c.html");
        let options = ReportOptions {
            html: other.clone(),
            ..options
        };
        assert!(matches!(run(&options), Err(Error::Report(_))));
        assert!(!other.exists());
    }
}
