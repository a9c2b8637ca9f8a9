//! The built joints counted once: calibrated load-cell gains that carry their joints'
//! sensitivity move with each joint in the `geometry` line, and a calibration whose gains
//! would take up a joint's effect on the measurement exactly leaves nothing of it.

use estimator::ParameterSet;
use nalgebra::{DMatrix, DVector, Vector6};

use super::perturb::CalibratedGains;
use super::testkit::{self, Synth};
use super::tests::{figures, run_budget_with};
use super::*;

/// The six J_C entries (θ's last six) of each effect.
fn tensor(effects: &[[f64; 10]]) -> Vec<DVector<f64>> {
    effects
        .iter()
        .map(|e| DVector::from_iterator(6, e[4..].iter().copied()))
        .collect()
}

/// With the paper's six parameters (J_C about a known centre of mass) six gains move J_C
/// as freely as a joint does: the gains s_k = M⁻¹ δθ_k (M the gains' effects on J_C, column
/// per cell) take up joint k's effect exactly. A calibration file carrying those s_k as its
/// joints' sensitivity, and no other uncertainty, leaves a `geometry` line of nothing and a
/// `load_cell_scale` line of nothing; with the sensitivity's sign turned, the two effects add
/// and the line doubles.
#[test]
fn gains_that_take_up_each_joint_exactly_leave_no_geometry_line() {
    let g = testkit::geometry();
    let synth = Synth::default();
    let samples = synth.samples(&g, |_, _, _| {});
    let body = synth.body;
    let six = move |c: &mut estimator::EstimatorConfig| {
        c.parameters = ParameterSet::InertiaAboutKnownCom {
            mass_kg: body.mass_kg,
            com_m: body.first_moment_kg_m / body.mass_kg,
        };
    };
    let tol = 2e-4;
    let unit_gain = 1e-3;
    let mut f = figures();
    f.joint_tolerance_m = tol;
    f.sensors.load_cell.gain_error = unit_gain;
    f.load_cells = None;
    let plain = run_budget_with(&g, &synth, &samples, &f, six);
    let joints = tensor(plain.effects_of(ErrorSource::Geometry));
    let gains = tensor(plain.effects_of(ErrorSource::LoadCellScale));
    assert_eq!((joints.len(), gains.len()), (36, 6));
    let m = DMatrix::from_fn(6, 6, |r, c| gains[c][r] / unit_gain);
    let inv = m.clone().try_inverse().expect("six gains move J_C freely");
    let per_m: Vec<Vector6<f64>> = joints
        .iter()
        .map(|d| Vector6::from_iterator((&inv * d / tol).iter().copied()))
        .collect();
    let with = |sign: f64| {
        let mut f = f.clone();
        f.load_cells = Some(CalibratedGains {
            modes: (0..6).map(|k| (0.0, Vector6::ith(k, 1.0))).collect(),
            joint_per_m: per_m.iter().map(|s| s * sign).collect(),
        });
        run_budget_with(&g, &synth, &samples, &f, six)
    };
    let size = |b: &RunBudget, s: ErrorSource| -> f64 {
        tensor(b.effects_of(s))
            .iter()
            .map(|d| d.norm_squared())
            .sum::<f64>()
            .sqrt()
    };
    let before = size(&plain, ErrorSource::Geometry);
    assert!(before > 0.0);
    let cancelled = with(1.0);
    assert!(
        size(&cancelled, ErrorSource::Geometry) < 1e-6 * before,
        "{:e} of {before:e}",
        size(&cancelled, ErrorSource::Geometry)
    );
    assert_eq!(size(&cancelled, ErrorSource::LoadCellScale), 0.0);
    let doubled = size(&with(-1.0), ErrorSource::Geometry) / before;
    assert!((doubled - 2.0).abs() < 1e-6, "{doubled}");
}

/// A file without the joints' sensitivity counts as before: the whole covariance in
/// `load_cell_scale`, the joints alone in `geometry`.
#[test]
fn a_file_without_sensitivities_counts_its_whole_covariance() {
    let mut gains = crate::testkit::gains_with([1e-4; 6]);
    let c = CalibratedGains::of(&gains);
    assert!(c.joint_per_m.is_empty());
    let sigma = |c: &CalibratedGains| c.modes.iter().map(|m| m.0 * m.0).sum::<f64>();
    assert!((sigma(&c) - 6e-8).abs() < 1e-20);
    assert_eq!(c.joint_change(true, 2, 1, 1e-3), Vector6::zeros());
    // With the share: the modes of the rest, the sensitivities per metre.
    gains.covariance_without_joints = (0..6)
        .map(|i| (0..6).map(|j| if i == j { 4e-9 } else { 0.0 }).collect())
        .collect();
    gains.joint_sensitivity = (0..36).map(|k| [k as f64 * 1e-6; 6]).collect();
    let c = CalibratedGains::of(&gains);
    assert!((sigma(&c) - 2.4e-8).abs() < 1e-20);
    let k = rig_description::calibration::load_cells::joint_index(true, 2, 1);
    let want = k as f64 * 1e-6 / gains.joint_tolerance_m * 1e-3;
    assert!((c.joint_change(true, 2, 1, 1e-3)[0] - want).abs() < 1e-15);
}
