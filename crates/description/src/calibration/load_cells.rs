//! The load cells' gains as calibrated from a reference mass (measure's `reference_mass` fits
//! them), with their covariance and its parts; their dated file is
//! [`LoadCellFile`](super::LoadCellFile).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// The fitted gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellGains {
    /// ĝ_i: cell i reads (1 + g_i) times its true force (the fit with the datasheet's prior;
    /// what is applied).
    pub gains: [f64; 6],
    /// Covariance of ĝ (with the prior).
    pub covariance: Vec<Vec<f64>>,
    /// Covariance of ĝ without the joints' part: what the budget's `load_cell_scale` line
    /// counts when [`joint_sensitivity`](Self::joint_sensitivity) is given (the joints then
    /// count in its `geometry` line). Empty in files without it.
    #[serde(default)]
    pub covariance_without_joints: Vec<Vec<f64>>,
    /// s_k: the change of ĝ when joint coordinate k is off the drawing by
    /// [`joint_tolerance_m`](Self::joint_tolerance_m), k = 0..36 (the base joints' x, y, z leg
    /// after leg, then the plate joints': [`joint_index`]). Empty in
    /// files without it: the budget then counts the whole covariance in `load_cell_scale`.
    #[serde(default)]
    pub joint_sensitivity: Vec<[f64; 6]>,
    /// The fit's own gains, before the prior.
    #[serde(default)]
    pub fitted_gains: [f64; 6],
    /// The fit's own covariance: noise, joints' tolerance, legs' figures, zero drift,
    /// reference mass.
    #[serde(default)]
    pub fitted_covariance: Vec<Vec<f64>>,
    /// The datasheet's one sigma of each gain taken as the prior (0: none).
    #[serde(default)]
    pub prior_sigma: f64,
    /// One sigma of each gain from the noise alone.
    pub noise_sigma: [f64; 6],
    /// One sigma of each gain from the joints' tolerance alone.
    pub joints_sigma: [f64; 6],
    /// One sigma of each gain from the `[legs]` figures' tolerances alone.
    pub legs_sigma: [f64; 6],
    /// One sigma of each gain from the cells' zero drift alone.
    #[serde(default)]
    pub drift_sigma: [f64; 6],
    /// One sigma of each gain from the reference mass's tolerance alone.
    pub mass_sigma: [f64; 6],
    /// The reference's mass the fit took as known, kg.
    pub reference_mass_kg: f64,
    /// Its tolerance, one sigma, kg.
    pub reference_mass_tolerance_kg: f64,
    /// The reference's centre of mass in P the fit found, m (a check, not applied).
    pub reference_com_m: [f64; 3],
    /// The fixture's mass the fit found, kg (a check, not applied).
    pub fixture_mass_kg: f64,
    /// The joints' tolerance counted, m.
    pub joint_tolerance_m: f64,
    /// RMS residual of the smoothed equations, in equation sigmas.
    pub residual_rms: f64,
    /// Record entries fitted, both runs.
    pub entries: u64,
}

impl LoadCellGains {
    /// The covariance as a matrix (zero where the file is short).
    pub fn covariance_matrix(&self) -> DMatrix<f64> {
        DMatrix::from_fn(6, 6, |i, j| {
            self.covariance
                .get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or(0.0)
        })
    }

    /// The joints' share, when the file carries it: the covariance without the joints' part
    /// and each joint coordinate's sensitivity per metre, s_k / tolerance.
    pub fn joint_share(&self) -> Option<(DMatrix<f64>, Vec<nalgebra::Vector6<f64>>)> {
        let t = self.joint_tolerance_m;
        let complete = self.joint_sensitivity.len() == JOINT_COORDINATES
            && self.covariance_without_joints.len() == 6
            && self.covariance_without_joints.iter().all(|r| r.len() == 6)
            && t.is_finite()
            && t > 0.0;
        if !complete {
            return None;
        }
        let cov = DMatrix::from_fn(6, 6, |i, j| self.covariance_without_joints[i][j]);
        let per_m = self
            .joint_sensitivity
            .iter()
            .map(|s| nalgebra::Vector6::from_column_slice(s) / t)
            .collect();
        Some((cov, per_m))
    }

    /// One sigma of gain `leg`.
    pub fn sigma(&self, leg: usize) -> f64 {
        self.covariance
            .get(leg)
            .and_then(|r| r.get(leg))
            .map_or(f64::NAN, |v| v.max(0.0).sqrt())
    }
}

/// Number of joint coordinates: 6 base joints and 6 plate joints, 3 coordinates each.
pub const JOINT_COORDINATES: usize = 36;

/// Index of a joint coordinate in [`LoadCellGains::joint_sensitivity`]: the base joints'
/// coordinates first (leg-major, x y z), then the plate joints', the error budget's
/// `geometry` order.
pub fn joint_index(plate: bool, leg: usize, coord: usize) -> usize {
    usize::from(plate) * 18 + leg * 3 + coord
}
