//! The load cells' gains as calibrated from a reference mass ([`crate::reference_mass`] fits
//! them), with their covariance and its parts, and their dated file ([`file`]).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

pub mod file;

pub use file::LoadCellFile;

/// The fitted gains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCellGains {
    /// ĝ_i: cell i reads (1 + g_i) times its true force (the fit with the datasheet's prior;
    /// what is applied).
    pub gains: [f64; 6],
    /// Covariance of ĝ (with the prior).
    pub covariance: Vec<Vec<f64>>,
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

    /// One sigma of gain `leg`.
    pub fn sigma(&self, leg: usize) -> f64 {
        self.covariance
            .get(leg)
            .and_then(|r| r.get(leg))
            .map_or(f64::NAN, |v| v.max(0.0).sqrt())
    }
}
