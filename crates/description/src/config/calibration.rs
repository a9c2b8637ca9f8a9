//! `[calibration]`: which calibration files the measurement applies, read with the rig
//! description, and what the report and the age warnings say of them.

use serde::{Deserialize, Serialize};

/// `[calibration]`: the calibration files the measurement applies (docs/calibration.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationConfig {
    /// The IMU alignment file (`stewart simulate --calibrate-imu FILE`), relative to the rig
    /// description's directory; omitted: the IMU as `[sensors.imu]` describes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imu: Option<String>,
    /// Without an `imu` file: calibrate the IMU at the start of every measurement, the empty
    /// fixture moving once through the tare run's excitation first (`stewart simulate`;
    /// docs/calibration.md). A file named in `imu` is applied instead.
    #[serde(default)]
    pub measure_imu: bool,
    /// The load cells' gain file (`stewart simulate --calibrate-load-cells FILE`), relative to
    /// the rig description's directory; omitted: the cells as `[sensors.load_cell]` describes
    /// them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_cells: Option<String>,
    /// Without a `load_cells` file: calibrate the load cells before every measurement of
    /// `stewart simulate` on the same simulated world (a tare run, then the world's reference
    /// body, [`reference_mass_kg`](Self::reference_mass_kg)), and apply the gains. On a rig it
    /// only says to calibrate with `stewart rig calibrate-load-cells` and name the file.
    #[serde(default)]
    pub measure_load_cells: bool,
    /// The reference body's mass the load-cell calibration takes as known (a calibrated weight
    /// of the rig's owner), kg; needed only to calibrate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_mass_kg: Option<f64>,
    /// One sigma of the reference's mass (its calibration certificate), kg.
    #[serde(default)]
    pub reference_mass_tolerance_kg: f64,
    /// A measurement warns when a calibration it applies is older than this, days.
    #[serde(default = "default_max_age_days")]
    pub max_age_days: f64,
    /// The calibration file `imu` names, read when the rig description is loaded.
    #[serde(skip)]
    pub imu_file: Option<crate::calibration::CalibrationFile>,
    /// The calibration file `load_cells` names, read when the rig description is loaded.
    #[serde(skip)]
    pub load_cells_file: Option<crate::calibration::LoadCellFile>,
}

fn default_max_age_days() -> f64 {
    90.0
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            imu: None,
            measure_imu: false,
            load_cells: None,
            measure_load_cells: false,
            reference_mass_kg: None,
            reference_mass_tolerance_kg: 0.0,
            max_age_days: default_max_age_days(),
            imu_file: None,
            load_cells_file: None,
        }
    }
}

impl CalibrationConfig {
    /// Each applied calibration: what it calibrates (`"imu"`, `"load_cells"`), where it came
    /// from, its provenance, and the command that makes it again.
    fn files(
        &self,
    ) -> Vec<(
        &'static str,
        &String,
        &crate::calibration::Provenance,
        &'static str,
    )> {
        let mut out = Vec::new();
        if let (Some(source), Some(f)) = (&self.imu, &self.imu_file) {
            let again = "`stewart simulate --calibrate-imu FILE` or `stewart rig calibrate-imu \
                         --out FILE`";
            out.push(("imu", source, &f.provenance, again));
        }
        if let (Some(source), Some(f)) = (&self.load_cells, &self.load_cells_file) {
            let again = "`stewart simulate --calibrate-load-cells FILE` or `stewart rig \
                         calibrate-load-cells --out FILE`";
            out.push(("load_cells", source, &f.provenance, again));
        }
        out
    }

    /// The calibrations applied, for the report: what each calibrates, its source, when its
    /// data were taken and what fitted it.
    pub fn applied(&self) -> Vec<crate::calibration::AppliedCalibration> {
        use crate::calibration::CalibrationDocument as _;
        // The texts the log records, in the order of `files`.
        let texts = [
            self.imu
                .as_ref()
                .and(self.imu_file.as_ref().map(|f| f.to_toml())),
            self.load_cells
                .as_ref()
                .and(self.load_cells_file.as_ref().map(|f| f.to_toml())),
        ];
        self.files()
            .into_iter()
            .zip(texts.into_iter().flatten())
            .map(
                |((kind, source, p, _), text)| crate::calibration::AppliedCalibration {
                    kind: kind.into(),
                    source: source.clone(),
                    calibrated_utc: p.calibrated_utc.clone(),
                    tool: p.tool.clone(),
                    sha256: crate::digest::sha256_hex(&text),
                },
            )
            .collect()
    }

    /// Whether the IMU is calibrated at the start of every measurement (`measure_imu` and no
    /// `imu` file).
    pub fn calibrates_imu_each_run(&self) -> bool {
        self.measure_imu && self.imu.is_none()
    }

    /// Whether the load cells are calibrated before every measurement (`measure_load_cells`
    /// and no `load_cells` file).
    pub fn calibrates_load_cells_each_run(&self) -> bool {
        self.measure_load_cells && self.load_cells.is_none()
    }

    /// The IMU alignment applied, if any.
    pub fn imu_alignment(&self) -> Option<&crate::calibration::ImuAlignment> {
        self.imu_file.as_ref().map(|f| &f.imu)
    }

    /// The load cells' gains applied, if any.
    pub fn load_cell_gains(&self) -> Option<&crate::calibration::LoadCellGains> {
        self.load_cells_file.as_ref().map(|f| &f.load_cells)
    }

    /// A warning for each applied calibration older than `max_age_days` at `now_unix_s`.
    pub fn age_warnings(&self, now_unix_s: u64) -> Vec<String> {
        self.files()
            .into_iter()
            .filter_map(|(kind, source, p, again)| {
                let age = p.age_days(now_unix_s);
                let what = if kind == "imu" { "IMU" } else { "load-cell" };
                (age > self.max_age_days).then(|| {
                    format!(
                        "the {what} calibration {source} is {age:.0} days old (taken {}; \
                         calibration.max_age_days = {}): calibrate again with {again}",
                        p.calibrated_utc, self.max_age_days
                    )
                })
            })
            .collect()
    }
}
