//! The tare: the empty fixture's inertial parameters, measured once and subtracted from every
//! loaded measurement on the same rig. Saved and loaded as JSON (`--tare FILE`), and logged on
//! `/run/tare`.

use std::path::Path;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};

/// Format tag of a tare file.
pub const TARE_FORMAT: &str = "stewart-tare/1";

/// A saved tare.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TareFile {
    /// Always [`TARE_FORMAT`].
    pub format: String,
    /// θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] of the empty fixture (and plate), about
    /// the P origin in P axes.
    pub theta: [f64; 10],
    /// Covariance of θ (symmetric).
    pub covariance: [[f64; 10]; 10],
    /// Samples the estimate used.
    pub samples: u64,
    /// RMS residual per equation [Fx, Fy, Fz, τx, τy, τz] of the tare run.
    pub residual_rms: [f64; 6],
    /// Base joints of the rig it was measured on, in B, m (a tare only fits the same rig).
    pub base_joints_m: [[f64; 3]; 6],
    /// Plate joints of that rig, in P, m.
    pub plate_joints_m: [[f64; 3]; 6],
    /// Scenario it was measured with.
    pub config: String,
    /// Where it came from (`"sim"`, `"rig"`).
    pub backend: String,
    /// The tare run's first-order sensitivity of θ to a constant accelerometer bias along P's
    /// x, y and z (rows), θ per m/s²: with the loaded run's, it gives the payload's share of
    /// the bias ([`crate::systematic`]). `null` when not known (ideal sensors, or a file
    /// written before this field, which still loads: its share then counts as zero).
    #[serde(default)]
    pub accel_bias_sensitivity: Option<[[f64; 10]; 3]>,
    /// The same for a constant zero offset on each load cell (rows: legs), θ per N.
    #[serde(default)]
    pub load_cell_offset_sensitivity: Option<[[f64; 10]; 6]>,
    /// The tare run's error-budget inputs ([`crate::budget::RunBudget`]: θ's change from one
    /// sigma of each elementary error of each source, at the tare run's rig description, its
    /// counts and statistical shares), so that a loaded run made later with this file counts
    /// the tare's share of each source. `null` in a file written without them (which still
    /// loads: the report then counts the tare's share as zero and says so).
    #[serde(default)]
    pub budget: Option<crate::budget::RunBudget>,
    /// Residual windows behind `covariance` ([`estimator::Counts::covariance_windows`]), which
    /// [`crate::quality::check_covariance`] checks; `null` in a file written without it (a file
    /// that names it `covariance_blocks` loads too).
    #[serde(default, alias = "covariance_blocks")]
    pub covariance_windows: Option<u64>,
    /// The tare run's brake-hold static weighing ([`crate::weigh`]), subtracted from a loaded
    /// run's for the payload's; `null` in a file written without it.
    #[serde(default)]
    pub static_weighing: Option<crate::weigh::StaticWeighing>,
}

impl TareFile {
    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Writes the file.
    pub fn save(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_json())
            .with_context(|| format!("cannot write the tare file {}", path.display()))
    }

    /// Reads and checks a tare file against the rig's joints.
    pub fn load(
        path: &Path,
        base_joints_m: &[[f64; 3]; 6],
        plate_joints_m: &[[f64; 3]; 6],
    ) -> Result<Self> {
        let name = path.display();
        let text = rig_description::bounded::read_to_string_capped(
            path,
            rig_description::bounded::TARE_CAP_BYTES,
            "a tare file",
        )
        .with_context(|| format!("cannot read the tare file {name}"))?;
        let tare: TareFile = serde_json::from_str(&text)
            .with_context(|| format!("{name}: not a tare file ({TARE_FORMAT})"))?;
        if tare.format != TARE_FORMAT {
            bail!(
                "{name}: `format` is {:?}, expected {TARE_FORMAT:?}",
                tare.format
            );
        }
        tare.check(base_joints_m, plate_joints_m)
            .with_context(|| format!("{name}: refused"))?;
        Ok(tare)
    }

    /// Finite values, a symmetric positive semi-definite covariance, a positive mass, and the
    /// same joints (within 1 mm) as the rig in use.
    pub fn check(
        &self,
        base_joints_m: &[[f64; 3]; 6],
        plate_joints_m: &[[f64; 3]; 6],
    ) -> Result<()> {
        if !self.theta.iter().all(|v| v.is_finite()) {
            bail!("`theta` has a non-finite entry");
        }
        let finite = |rows: &[[f64; 10]]| rows.iter().flatten().all(|v| v.is_finite());
        if !self
            .accel_bias_sensitivity
            .as_ref()
            .is_none_or(|s| finite(s))
        {
            bail!("`accel_bias_sensitivity` has a non-finite entry");
        }
        if !self
            .load_cell_offset_sensitivity
            .as_ref()
            .is_none_or(|s| finite(s))
        {
            bail!("`load_cell_offset_sensitivity` has a non-finite entry");
        }
        if !self.budget.as_ref().is_none_or(|b| {
            b.effects.iter().all(|e| finite(&e.effects)) && b.jitter_share.is_finite()
        }) {
            bail!("`budget` has a non-finite entry");
        }
        if self.theta[0].is_nan() || self.theta[0] <= 0.0 {
            bail!("`theta[0]` (mass) must be positive, got {}", self.theta[0]);
        }
        for r in 0..10 {
            for c in 0..10 {
                let (a, b) = (self.covariance[r][c], self.covariance[c][r]);
                if !a.is_finite() {
                    bail!("`covariance[{r}][{c}]` is not finite");
                }
                if (a - b).abs() > 1e-9 * (a.abs() + b.abs()).max(1e-300) {
                    bail!("`covariance` is not symmetric at [{r}][{c}]");
                }
            }
            if self.covariance[r][r] < 0.0 {
                bail!("`covariance[{r}][{r}]` is negative");
            }
        }
        let far = |a: &[[f64; 3]; 6], b: &[[f64; 3]; 6]| {
            a.iter()
                .zip(b)
                .any(|(x, y)| x.iter().zip(y).any(|(p, q)| (p - q).abs() > 1e-3))
        };
        if far(&self.base_joints_m, base_joints_m) || far(&self.plate_joints_m, plate_joints_m) {
            bail!(
                "it was measured on a rig with other joint positions (`base_joints_m`/`plate_joints_m` differ by more than 1 mm from this configuration's platform)"
            );
        }
        Ok(())
    }

    /// The tare file of a tare measurement's estimate (covariance symmetrised), measured on
    /// the rig with these joints with scenario `config` on `backend`.
    pub fn from_estimate(
        estimate: &estimator::Estimate,
        base_joints_m: &[[f64; 3]; 6],
        plate_joints_m: &[[f64; 3]; 6],
        config: &str,
        backend: &str,
    ) -> Self {
        let c = &estimate.covariance;
        Self {
            format: TARE_FORMAT.into(),
            theta: estimate.parameters.to_vector().into(),
            covariance: core::array::from_fn(|r| {
                core::array::from_fn(|k| 0.5 * (c[(r, k)] + c[(k, r)]))
            }),
            samples: estimate.counts.used,
            residual_rms: estimate.residual_rms.into(),
            base_joints_m: *base_joints_m,
            plate_joints_m: *plate_joints_m,
            config: config.into(),
            backend: backend.into(),
            accel_bias_sensitivity: None,
            load_cell_offset_sensitivity: None,
            budget: None,
            covariance_windows: Some(estimate.counts.covariance_windows),
            static_weighing: None,
        }
    }

    /// Keeps the tare run's static weighing.
    pub fn with_static_weighing(mut self, weighing: Option<crate::weigh::StaticWeighing>) -> Self {
        self.static_weighing = weighing;
        self
    }

    /// Keeps the tare run's error-budget inputs.
    pub fn with_budget(mut self, budget: Option<crate::budget::RunBudget>) -> Self {
        self.budget = budget;
        self
    }

    /// Keeps the tare run's systematic effects (θ change per one sigma, as
    /// [`crate::run::MeasureOutcome`] gives them, with the sigmas they assumed) as
    /// sensitivities per unit bias, so that a loaded run made later with this file can count
    /// the tare's share ([`Self::accel_bias_effect`], [`Self::load_cell_bias_effect`]).
    pub fn with_bias_effects(
        mut self,
        accel: Option<&[[f64; 10]; 3]>,
        accel_sigma_m_s2: f64,
        load_cell: Option<&[[f64; 10]; 6]>,
        load_cell_sigma_n: f64,
    ) -> Self {
        self.accel_bias_sensitivity = per_unit(accel, accel_sigma_m_s2);
        self.load_cell_offset_sensitivity = per_unit(load_cell, load_cell_sigma_n);
        self
    }

    /// Change of the tare's θ from one sigma `sigma_m_s2` of accelerometer bias (rows: x, y,
    /// z); `None` without a stored sensitivity or a positive sigma.
    pub fn accel_bias_effect(&self, sigma_m_s2: f64) -> Option<[[f64; 10]; 3]> {
        scaled(self.accel_bias_sensitivity.as_ref(), sigma_m_s2)
    }

    /// Change of the tare's θ from one sigma `sigma_n` of zero offset on each load cell (rows:
    /// legs); `None` without a stored sensitivity or a positive sigma.
    pub fn load_cell_bias_effect(&self, sigma_n: f64) -> Option<[[f64; 10]; 6]> {
        scaled(self.load_cell_offset_sensitivity.as_ref(), sigma_n)
    }

    /// θ as nalgebra.
    pub fn parameters(&self) -> estimator::InertialParameters {
        estimator::InertialParameters::from_vector(&estimator::ParameterVector::from_row_slice(
            &self.theta,
        ))
    }

    /// The covariance as nalgebra.
    pub fn covariance_matrix(&self) -> estimator::ParameterCovariance {
        estimator::ParameterCovariance::from_fn(|r, c| self.covariance[r][c])
    }
}

fn positive(sigma: f64) -> bool {
    sigma > 0.0 && sigma.is_finite()
}

fn per_unit<const N: usize>(effect: Option<&[[f64; 10]; N]>, sigma: f64) -> Option<[[f64; 10]; N]> {
    let e = effect.filter(|_| positive(sigma))?;
    Some(e.map(|row| row.map(|v| v / sigma)))
}

fn scaled<const N: usize>(
    sensitivity: Option<&[[f64; 10]; N]>,
    sigma: f64,
) -> Option<[[f64; 10]; N]> {
    let s = sensitivity.filter(|_| positive(sigma))?;
    Some(s.map(|row| row.map(|v| v * sigma)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joints() -> ([[f64; 3]; 6], [[f64; 3]; 6]) {
        let b = core::array::from_fn(|i| [i as f64, 1.0, 0.0]);
        let p = core::array::from_fn(|i| [0.5 * i as f64, -1.0, 0.0]);
        (b, p)
    }

    fn tare() -> TareFile {
        let (b, p) = joints();
        let mut cov = [[0.0; 10]; 10];
        for (i, row) in cov.iter_mut().enumerate() {
            row[i] = 1e-4 * (i + 1) as f64;
        }
        cov[0][1] = 1e-6;
        cov[1][0] = 1e-6;
        TareFile {
            format: TARE_FORMAT.into(),
            theta: [400.0, 0.0, 0.0, 20.0, 300.0, 300.0, 450.0, 0.0, 0.0, 0.0],
            covariance: cov,
            samples: 1000,
            residual_rms: [1.0; 6],
            base_joints_m: b,
            plate_joints_m: p,
            config: "x.toml".into(),
            backend: "sim".into(),
            accel_bias_sensitivity: None,
            load_cell_offset_sensitivity: None,
            budget: None,
            covariance_windows: Some(40),
            static_weighing: None,
        }
    }

    /// A tare naming its window count `covariance_blocks` loads with its count.
    #[test]
    fn a_saved_tare_with_covariance_blocks_loads_its_window_count() {
        let json = serde_json::to_string(&tare())
            .unwrap()
            .replace("\"covariance_windows\"", "\"covariance_blocks\"");
        assert!(json.contains("covariance_blocks"));
        let back: TareFile = serde_json::from_str(&json).unwrap();
        assert_eq!(back.covariance_windows, Some(40));
    }

    #[test]
    fn round_trip_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tare.json");
        let t = tare();
        t.save(&path).unwrap();
        let (b, p) = joints();
        assert_eq!(TareFile::load(&path, &b, &p).unwrap(), t);
        assert_eq!(t.parameters().mass_kg, 400.0);
        assert_eq!(t.covariance_matrix()[(0, 1)], 1e-6);
    }

    #[test]
    fn refuses_another_rig_and_bad_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tare.json");
        tare().save(&path).unwrap();
        let (mut b, p) = joints();
        b[3][0] += 0.01;
        let err = TareFile::load(&path, &b, &p).unwrap_err();
        assert!(
            format!("{err:#}").contains("other joint positions"),
            "{err:#}"
        );

        let (b, p) = joints();
        let mut t = tare();
        t.theta[0] = -1.0;
        assert!(t.check(&b, &p).is_err());
        let mut t = tare();
        t.covariance[0][1] = 1.0;
        assert!(t.check(&b, &p).is_err());
        std::fs::write(&path, "{\"format\": \"x\"}").unwrap();
        assert!(TareFile::load(&path, &b, &p).is_err());
    }

    /// Effects go in per sigma and come out per the sigma of the run that uses the file; a
    /// file written before the sensitivities existed still loads, with none.
    #[test]
    fn keeps_the_sensitivities_and_loads_files_without_them() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tare.json");
        let (b, p) = joints();
        let mut accel = [[0.0; 10]; 3];
        accel[2][0] = 0.05; // 0.05 kg per 2e-3 m/s²: 25 kg per m/s².
        let mut load_cell = [[0.0; 10]; 6];
        load_cell[1][3] = -0.2; // per 4 N.
        let t = tare().with_bias_effects(Some(&accel), 2e-3, Some(&load_cell), 4.0);
        t.save(&path).unwrap();
        let back = TareFile::load(&path, &b, &p).unwrap();
        assert_eq!(back.accel_bias_sensitivity.unwrap()[2][0], 25.0);
        assert!((back.accel_bias_effect(1e-3).unwrap()[2][0] - 0.025).abs() < 1e-15);
        assert!((back.load_cell_bias_effect(8.0).unwrap()[1][3] + 0.4).abs() < 1e-15);
        assert_eq!(back.accel_bias_effect(0.0), None);
        assert_eq!(
            tare()
                .with_bias_effects(Some(&accel), 0.0, None, 4.0)
                .accel_bias_sensitivity,
            None
        );

        // The file as written before: no sensitivity fields at all.
        let mut old = serde_json::to_value(tare()).unwrap();
        let map = old.as_object_mut().unwrap();
        map.remove("accel_bias_sensitivity");
        map.remove("load_cell_offset_sensitivity");
        map.remove("budget");
        std::fs::write(&path, old.to_string()).unwrap();
        let old = TareFile::load(&path, &b, &p).unwrap();
        assert_eq!(old, tare());
        assert_eq!(old.load_cell_bias_effect(4.0), None);

        let mut bad = t.clone();
        bad.load_cell_offset_sensitivity.as_mut().unwrap()[0][0] = f64::NAN;
        assert!(bad.check(&b, &p).is_err());
    }

    /// A tare with the budget's effects round-trips through its file; one
    /// without them (an older file, no `budget` key) loads with none.
    #[test]
    fn keeps_the_budget_and_loads_files_without_it() {
        use crate::budget::{RigidBody, RunBudget, SourceEffects};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tare.json");
        let (b, p) = joints();
        let mut e = [0.0; 10];
        e[4] = 0.125;
        let t = tare().with_budget(Some(RunBudget {
            effects: vec![SourceEffects {
                per_run: true,
                source: "geometry".into(),
                effects: vec![e; 36],
            }],
            used: 29_000,
            lost: 30,
            jitter_share: 1e-3,
            rigid_body: Some(RigidBody {
                ok: true,
                residual_ratio: 0.7,
                peak_hz: 1.1,
            }),
        }));
        t.save(&path).unwrap();
        let back = TareFile::load(&path, &b, &p).unwrap();
        assert_eq!(back, t);
        assert_eq!(
            back.budget
                .unwrap()
                .effects_of(rig_description::sources::ErrorSource::Geometry)[35][4],
            0.125
        );
        let mut old = serde_json::to_value(tare()).unwrap();
        old.as_object_mut().unwrap().remove("budget");
        std::fs::write(&path, old.to_string()).unwrap();
        assert_eq!(TareFile::load(&path, &b, &p).unwrap().budget, None);
    }
}
