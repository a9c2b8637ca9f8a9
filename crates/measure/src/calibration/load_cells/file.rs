//! The load cells' calibration file: the gains with their covariance, when and from what, as
//! TOML beside the rig description, which references it (`[calibration] load_cells`). Its
//! header is the IMU calibration file's ([`crate::calibration::file`]); its table is
//! `[load_cells]`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::LoadCellGains;
use crate::calibration::file::{CalibrationFileError, FORMAT};

/// A load-cell calibration file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellFile {
    /// [`FORMAT`].
    pub format: String,
    /// When the calibration's data were taken, seconds since 1970-01-01 UTC.
    pub calibrated_unix_s: u64,
    /// The same instant, readable (`2026-11-24T17:40:00Z`).
    pub calibrated_utc: String,
    /// The tool and its version that fitted it.
    pub tool: String,
    /// The rig description it was taken with (its file name).
    pub rig: String,
    /// The station: `"sim"` or `"rig"`.
    pub backend: String,
    /// The run log of the calibration's runs, when one was written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log: Option<String>,
    /// The gains ([`super`]).
    pub load_cells: LoadCellGains,
}

impl LoadCellFile {
    /// A file for `gains`, fitted at `unix_s` on `backend` with rig description `rig`.
    pub fn new(gains: LoadCellGains, unix_s: u64, rig: &str, backend: &str) -> Self {
        let t = crate::calendar::UtcTime::from_unix_s(unix_s);
        Self {
            format: FORMAT.into(),
            calibrated_unix_s: unix_s,
            calibrated_utc: format!(
                "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z",
                t.year, t.month, t.day, t.hour, t.minute, t.second
            ),
            tool: format!("stewart {}", env!("CARGO_PKG_VERSION")),
            rig: rig.into(),
            backend: backend.into(),
            log: None,
            load_cells: gains,
        }
    }

    /// Reads and checks `path`: the format, six finite gains and a 6 × 6 finite covariance.
    pub fn read(path: &Path) -> Result<Self, CalibrationFileError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CalibrationFileError::Read {
            path: name.clone(),
            source,
        })?;
        Self::parse(&text, &name)
    }

    /// The file's text as TOML (what [`Self::write`] writes, and a run log carries).
    pub fn to_toml(&self) -> String {
        format!(
            "# Load-cell gains fitted by `{}` from a reference mass; see docs/calibration.md.\n{}",
            self.tool,
            toml::to_string(self).unwrap_or_default()
        )
    }

    /// Parses and checks a load-cell calibration file's `text`, named `name` in messages.
    pub fn parse(text: &str, name: &str) -> Result<Self, CalibrationFileError> {
        let format = |problem: String| CalibrationFileError::Format {
            path: name.to_string(),
            problem,
        };
        let file: Self = toml::from_str(text).map_err(|e| format(e.message().to_string()))?;
        if file.format != FORMAT {
            return Err(format(format!(
                "format {:?}, expected {FORMAT:?}",
                file.format
            )));
        }
        let c = &file.load_cells;
        if c.covariance.len() != 6 || c.covariance.iter().any(|r| r.len() != 6) {
            return Err(format("covariance of the wrong size".into()));
        }
        let finite = c
            .gains
            .iter()
            .chain(c.covariance.iter().flatten())
            .all(|v| v.is_finite());
        if !finite {
            return Err(format("a value is not a finite number".into()));
        }
        // A gain of −1 or below would divide a reading by zero or turn its sign.
        if c.gains.iter().any(|g| *g <= -0.5) {
            return Err(format("a gain of −50 % or less".into()));
        }
        Ok(file)
    }

    /// Writes the file (TOML) to `path`.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        std::fs::write(path, self.to_toml()).map_err(|e| {
            anyhow::anyhow!("cannot write the calibration file {}: {e}", path.display())
        })
    }

    /// Its age at `now_unix_s`, days (0 for a file from the future).
    pub fn age_days(&self, now_unix_s: u64) -> f64 {
        now_unix_s.saturating_sub(self.calibrated_unix_s) as f64 / 86_400.0
    }
}
