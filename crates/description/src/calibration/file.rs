//! The calibration file: what a calibration command fitted, with its uncertainty, when and from
//! what, as TOML beside the rig description, which references it (`[calibration] imu`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::imu::ImuAlignment;

/// The file's `format`, checked on reading.
pub const FORMAT: &str = "stewart-calibration-1";

/// When a calibration's data were taken, by what and from what: every calibration file's
/// `[provenance]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
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
}

impl Provenance {
    /// Data taken at `unix_s` on `backend` with rig description `rig`, fitted by this tool.
    pub fn new(unix_s: u64, rig: &str, backend: &str) -> Self {
        let t = crate::calendar::UtcTime::from_unix_s(unix_s);
        Self {
            calibrated_unix_s: unix_s,
            calibrated_utc: format!(
                "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z",
                t.year, t.month, t.day, t.hour, t.minute, t.second
            ),
            tool: super::tool(),
            rig: rig.into(),
            backend: backend.into(),
            log: None,
        }
    }

    /// The calibration's age at `now_unix_s`, days (0 for data from the future).
    pub fn age_days(&self, now_unix_s: u64) -> f64 {
        now_unix_s.saturating_sub(self.calibrated_unix_s) as f64 / 86_400.0
    }
}

/// Why a calibration file could not be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationFileError {
    /// The file could not be read.
    #[error("cannot read the calibration file {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not a calibration file of this format, or damaged.
    #[error("{path} is not a calibration file this tool reads ({problem}); write it again with the command that made it (`stewart simulate --calibrate-imu FILE`, `--calibrate-load-cells FILE`)")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        problem: String,
    },
}

/// A kind of calibration file: its `format`, its [`Provenance`] and its own table, with the
/// checks of what that table holds. Reading, parsing, writing and dating are the same for
/// every kind.
pub trait CalibrationDocument: Serialize + serde::de::DeserializeOwned {
    /// What the file's first line says it holds.
    const DESCRIPTION: &'static str;

    /// Its `format` field.
    fn format(&self) -> &str;

    /// Its provenance.
    fn provenance(&self) -> &Provenance;

    /// What is wrong with its own table (sizes, non-finite numbers, impossible values).
    fn problem(&self) -> Option<String>;

    /// Reads and checks `path`.
    fn read(path: &Path) -> Result<Self, CalibrationFileError> {
        let name = path.display().to_string();
        let text = crate::bounded::read_to_string_capped(
            path,
            crate::bounded::CALIBRATION_CAP_BYTES,
            "a calibration file",
        )
        .map_err(|source| CalibrationFileError::Read {
            path: name.clone(),
            source,
        })?;
        Self::parse(&text, &name)
    }

    /// Parses and checks a file's `text`, named `name` in messages: the format, then
    /// [`Self::problem`].
    fn parse(text: &str, name: &str) -> Result<Self, CalibrationFileError> {
        let format = |problem: String| CalibrationFileError::Format {
            path: name.to_string(),
            problem,
        };
        let file: Self = toml::from_str(text).map_err(|e| format(e.message().to_string()))?;
        if file.format() != FORMAT {
            return Err(format(format!(
                "format {:?}, expected {FORMAT:?}",
                file.format()
            )));
        }
        match file.problem() {
            Some(problem) => Err(format(problem)),
            None => Ok(file),
        }
    }

    /// The file's text as TOML (what [`Self::write`] writes, and a run log carries).
    fn to_toml(&self) -> String {
        format!(
            "# {} fitted by `{}`; see docs/calibration.md.\n{}",
            Self::DESCRIPTION,
            self.provenance().tool,
            toml::to_string(self).unwrap_or_default()
        )
    }

    /// Writes the file (TOML) to `path`.
    fn write(&self, path: &Path) -> anyhow::Result<()> {
        std::fs::write(path, self.to_toml()).map_err(|e| {
            anyhow::anyhow!("cannot write the calibration file {}: {e}", path.display())
        })
    }
}

/// The IMU calibration file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    /// [`FORMAT`].
    pub format: String,
    /// When, by what, from what.
    pub provenance: Provenance,
    /// The IMU's alignment ([`super::imu`]).
    pub imu: ImuAlignment,
}

impl CalibrationFile {
    /// A file for `imu`, fitted at `unix_s` on `backend` with rig description `rig`.
    pub fn new(imu: ImuAlignment, unix_s: u64, rig: &str, backend: &str) -> Self {
        Self {
            format: FORMAT.into(),
            provenance: Provenance::new(unix_s, rig, backend),
            imu,
        }
    }
}

impl CalibrationDocument for CalibrationFile {
    const DESCRIPTION: &'static str = "IMU alignment, against the platform's forward kinematics,";

    fn format(&self) -> &str {
        &self.format
    }

    fn provenance(&self) -> &Provenance {
        &self.provenance
    }

    /// Covariances of the right size, every number finite, the gyro's matrix invertible.
    fn problem(&self) -> Option<String> {
        let a = &self.imu;
        let square = |m: &[Vec<f64>], n: usize| m.len() == n && m.iter().all(|r| r.len() == n);
        if !square(&a.gyro_covariance, 10) || !square(&a.position_covariance, 3) {
            return Some("covariances of the wrong size".into());
        }
        let finite = a
            .gyro_matrix
            .iter()
            .flatten()
            .chain(&a.accelerometer_position_m)
            .chain(a.gyro_covariance.iter().flatten())
            .chain(a.position_covariance.iter().flatten())
            .chain([&a.imu_delay_s])
            .all(|v| v.is_finite());
        if !finite {
            return Some("a value is not a finite number".into());
        }
        if a.gyro().try_inverse().is_none() {
            return Some("the gyro's matrix is singular".into());
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::imu::ImuAlignment;

    fn alignment() -> ImuAlignment {
        let eye = [[1.0, 2e-4, 0.0], [-2e-4, 1.0, 1e-4], [0.0, -1e-4, 1.0005]];
        let cov = |n: usize| {
            (0..n)
                .map(|i| (0..n).map(|j| if i == j { 1e-8 } else { 0.0 }).collect())
                .collect()
        };
        ImuAlignment {
            gyro_matrix: eye,
            gyro_bias_rad_s: [1e-5, 0.0, -2e-5],
            accel_bias_m_s2: [1e-3, 0.0, 0.0],
            accelerometer_position_m: [0.1, -0.2, 0.3],
            imu_delay_s: 1.1e-4,
            gyro_covariance: cov(10),
            position_covariance: cov(3),
            joint_tolerance_m: 2e-4,
            residual_rms: [1e-4, 1e-3],
            entries: 2000,
        }
    }

    #[test]
    fn a_written_file_reads_back_exactly_with_its_date() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("imu.toml");
        let file = CalibrationFile::new(alignment(), 1_795_000_000, "car.toml", "sim");
        file.write(&path).unwrap();
        let back = CalibrationFile::read(&path).unwrap();
        assert_eq!(back, file);
        assert_eq!(back.provenance.calibrated_utc, "2026-11-18T11:06:40Z");
        assert!((back.provenance.age_days(1_795_000_000 + 10 * 86_400) - 10.0).abs() < 1e-12);
    }

    /// The report's hash of an applied calibration is the SHA-256 of the TOML the log
    /// records, and the same after the log's copy is read back (a re-estimate hashes what
    /// the online run hashed).
    #[test]
    fn an_applied_calibrations_hash_is_its_logged_texts_and_survives_the_log() {
        let file = CalibrationFile::new(alignment(), 1_795_000_000, "car.toml", "sim");
        let mut c = crate::load::load(None).unwrap().config.calibration;
        c.imu = Some("imu.toml".into());
        c.imu_file = Some(file.clone());
        let applied = c.applied();
        assert_eq!(applied.len(), 1);
        assert_eq!(
            applied[0].sha256,
            crate::digest::sha256_hex(&file.to_toml())
        );
        assert_eq!(applied[0].calibrated_utc, "2026-11-18T11:06:40Z");
        let back = CalibrationFile::parse(&file.to_toml(), "the log's IMU calibration").unwrap();
        c.imu_file = Some(back);
        assert_eq!(c.applied()[0].sha256, applied[0].sha256);
    }

    #[test]
    fn a_damaged_or_foreign_file_is_refused_with_the_reason() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("imu.toml");
        let file = CalibrationFile::new(alignment(), 0, "car.toml", "sim");
        file.write(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let cases = [
            (text.replace(FORMAT, "other-format"), "format"),
            (
                text.replace("imu_delay_s = 0.00011", "imu_delay_s = nan"),
                "finite",
            ),
            (text.replace("[imu]", "[imux]"), "unknown field"),
            ("not toml at all [".to_string(), ""),
        ];
        for (bad, why) in cases {
            std::fs::write(&path, &bad).unwrap();
            let err = CalibrationFile::read(&path).unwrap_err().to_string();
            assert!(
                err.contains("is not a calibration file") && err.contains(why),
                "{err}"
            );
        }
        let err = CalibrationFile::read(&dir.path().join("none.toml")).unwrap_err();
        assert!(
            err.to_string().contains("cannot read the calibration file"),
            "{err}"
        );
    }

    /// A rig description that references a calibration file applies it (the accelerometer's
    /// position reaches the estimator); one that names a missing file is refused at its key.
    #[test]
    fn a_rig_description_applies_its_calibration_file_or_refuses_a_missing_one() {
        let dir = tempfile::tempdir().unwrap();
        CalibrationFile::new(alignment(), 0, "car.toml", "sim")
            .write(&dir.path().join("imu.toml"))
            .unwrap();
        let rig = dir.path().join("car.toml");
        std::fs::write(&rig, "[calibration]\nimu = \"imu.toml\"\n").unwrap();
        let loaded = crate::load::load(Some(&rig)).unwrap();
        let p = crate::derived::accelerometer_position(&loaded.config);
        assert_eq!([p.x, p.y, p.z], [0.1, -0.2, 0.3]);
        assert_eq!(loaded.config.calibration.age_warnings(0).len(), 0);
        assert_eq!(loaded.config.calibration.age_warnings(91 * 86_400).len(), 1);
        std::fs::write(&rig, "[calibration]\nimu = \"gone.toml\"\n").unwrap();
        let err = crate::load::load(Some(&rig)).unwrap_err();
        assert_eq!(err.issues[0].key, "calibration.imu");
        assert_eq!(err.issues[0].line, Some(2));
    }
}
