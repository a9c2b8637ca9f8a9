//! The load cells' calibration file: the gains with their covariance, when and from what, as
//! TOML beside the rig description, which references it (`[calibration] load_cells`). Its
//! header is the IMU calibration file's ([`super::file`]); its table is
//! `[load_cells]`.

use serde::{Deserialize, Serialize};

use super::LoadCellGains;
use crate::calibration::file::{CalibrationDocument, Provenance, FORMAT};

/// A load-cell calibration file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellFile {
    /// [`FORMAT`].
    pub format: String,
    /// When, by what, from what.
    pub provenance: Provenance,
    /// The gains ([`super`]).
    pub load_cells: LoadCellGains,
}

impl LoadCellFile {
    /// A file for `gains`, fitted at `unix_s` on `backend` with rig description `rig`.
    pub fn new(gains: LoadCellGains, unix_s: u64, rig: &str, backend: &str) -> Self {
        Self {
            format: FORMAT.into(),
            provenance: Provenance::new(unix_s, rig, backend),
            load_cells: gains,
        }
    }
}

impl CalibrationDocument for LoadCellFile {
    const DESCRIPTION: &'static str = "Load-cell gains, from a reference mass,";

    fn format(&self) -> &str {
        &self.format
    }

    fn provenance(&self) -> &Provenance {
        &self.provenance
    }

    /// Six finite gains above −50 %, a 6 × 6 finite covariance, and when given, a 6 × 6
    /// covariance without the joints and 36 finite joint sensitivities.
    fn problem(&self) -> Option<String> {
        let c = &self.load_cells;
        if c.covariance.len() != 6 || c.covariance.iter().any(|r| r.len() != 6) {
            return Some("covariance of the wrong size".into());
        }
        let without = &c.covariance_without_joints;
        if !without.is_empty() && (without.len() != 6 || without.iter().any(|r| r.len() != 6)) {
            return Some("covariance_without_joints of the wrong size".into());
        }
        let n = c.joint_sensitivity.len();
        if n != 0 && n != super::JOINT_COORDINATES {
            return Some(format!(
                "joint_sensitivity has {n} rows, not one per joint coordinate ({})",
                super::JOINT_COORDINATES
            ));
        }
        let finite = c
            .gains
            .iter()
            .chain(c.covariance.iter().flatten())
            .chain(without.iter().flatten())
            .chain(c.joint_sensitivity.iter().flatten())
            .all(|v| v.is_finite());
        if !finite {
            return Some("a value is not a finite number".into());
        }
        // A gain of −1 or below would divide a reading by zero or turn its sign.
        if c.gains.iter().any(|g| *g <= -0.5) {
            return Some("a gain of −50 % or less".into());
        }
        None
    }
}
