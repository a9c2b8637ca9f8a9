//! A measurement report handed over as one self-contained HTML page (`--html FILE` on
//! `simulate`, `rig` and `estimate`; `stewart report REPORT.json --html FILE`), laid out as a
//! calibration certificate states its results (docs/report.md):
//!
//! - the payload's mass, centre of mass and J_C with the expanded uncertainty U = k·u, k = 2
//!   ([`COVERAGE_FACTOR`], [`expanded`]), each figure rounded to U's two significant digits
//!   ([`format::rounded`]);
//! - principal moments and axes, and the payload's equivalent ellipsoid on the fixture in
//!   three orthographic views ([`ellipsoid`], [`figures`]);
//! - the error budget, convergence, residuals, the data's losses, the tare, the rig, its
//!   calibrations, the tool version and the log ([`page`]).
//!
//! The page makes no network request: CSS and SVG are inline, no fonts, images or scripts are
//! loaded, and a Content-Security-Policy (`default-src 'none'`) forbids the browser any other
//! fetch. Every number cell carries `data-quantity` (its name) and `data-value` (the report's
//! f64 in Rust's shortest round-trip form), so a test can compare the rendered page with the
//! JSON report.
#![warn(missing_docs)]

pub mod ellipsoid;
pub mod figures;
pub mod format;
pub mod page;

#[cfg(test)]
mod tests;

use measure::report::Report;
use serde::Deserialize;

/// The coverage factor of the page's expanded uncertainties: U = k·u with k = 2, about 95 %
/// coverage for a normally distributed error.
pub const COVERAGE_FACTOR: f64 = 2.0;

/// The expanded uncertainty U = k·u of a standard uncertainty `u` (one sigma), k =
/// [`COVERAGE_FACTOR`].
pub fn expanded(u: f64) -> f64 {
    COVERAGE_FACTOR * u
}

/// Why a report cannot be turned into a page.
#[derive(Debug, thiserror::Error)]
pub enum CertificateError {
    /// The report file could not be read.
    #[error("cannot read the report {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not a measurement report.
    #[error("the report is not a measurement report: {0}")]
    Json(String),
    /// A campaign report (`simulate --runs N`) holds many measurements, not one.
    #[error(
        "this is a campaign report (`simulate --runs`: {runs} runs), not one measurement: write \
         the page from one run's report"
    )]
    Campaign {
        /// How many reports it holds.
        runs: usize,
    },
}

impl From<measure::report::ReportTextError> for CertificateError {
    fn from(e: measure::report::ReportTextError) -> Self {
        match e {
            measure::report::ReportTextError::Campaign { runs } => Self::Campaign { runs },
            measure::report::ReportTextError::Json(message) => Self::Json(message),
            other => Self::Json(other.to_string()),
        }
    }
}

/// The JSON report's `rig` object, which `stewart rig` adds (the rig's address, identity and
/// sample period); absent for a simulation.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
pub struct RigSection {
    /// The rig's address.
    #[serde(default)]
    pub address: Option<String>,
    /// What the rig said it is, as the report holds it.
    #[serde(default)]
    pub identity: Option<serde_json::Value>,
    /// The rig's sample period, s.
    #[serde(default)]
    pub sample_period_s: Option<f64>,
}

/// A parsed report: the measurement and the rig's section.
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// The report, as `measure` writes it.
    pub report: Report,
    /// The `rig` object of a measurement on a rig, when there is one.
    pub rig: Option<RigSection>,
}

/// Reads the report at `path` ([`parse`]).
pub fn load(path: &std::path::Path) -> Result<Input, CertificateError> {
    let text = rig_description::bounded::read_to_string_capped(
        path,
        rig_description::bounded::REPORT_CAP_BYTES,
        "a report",
    )
    .map_err(|source| CertificateError::Read {
        path: path.display().to_string(),
        source,
    })?;
    parse(&text)
}

/// Reads a report's JSON text: the fields of [`Report`] (unknown ones ignored) and the
/// `rig` object of a measurement on a rig. A campaign report is refused.
pub fn parse(text: &str) -> Result<Input, CertificateError> {
    let value = measure::report::one_measurement(text).map_err(CertificateError::from)?;
    let rig = match value.get("rig") {
        Some(v) if v.is_object() => serde_json::from_value(v.clone()).ok(),
        _ => None,
    };
    let report: Report =
        serde_json::from_value(value).map_err(|e| CertificateError::Json(e.to_string()))?;
    Ok(Input { report, rig })
}

/// What the page says about where it came from, besides the report.
#[derive(Clone, Debug, Default)]
pub struct Context<'a> {
    /// The tool that wrote the page, e.g. `stewart 0.1.0`.
    pub tool: &'a str,
    /// Where the report came from (its file, or the command that measured it).
    pub report_source: &'a str,
    /// The rig description, when the writer has it.
    pub rig: Option<&'a rig_description::Config>,
    /// Where that rig description came from (its file, or the embedded default).
    pub rig_source: Option<&'a str>,
    /// When the page was written, s since the Unix epoch (UTC); `None` leaves the date out.
    pub issued_unix_s: Option<u64>,
    /// SHA-256 of the log file the report names, as read when the page was written (lower-case
    /// hex); `None` when it could not be read.
    pub log_sha256: Option<String>,
}

/// The page of `input`: one HTML document, nothing loaded from elsewhere.
pub fn render(input: &Input, context: &Context<'_>) -> String {
    page::render(input, context)
}

/// The page of a report's JSON text ([`parse`], then [`render`]).
pub fn render_json(text: &str, context: &Context<'_>) -> Result<String, CertificateError> {
    Ok(render(&parse(text)?, context))
}

/// Seconds since the Unix epoch now (0 when the clock is before it), for
/// [`Context::issued_unix_s`].
pub fn now_unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}
