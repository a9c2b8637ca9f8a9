//! The error budget: for every error source of a real rig ([`rig_description::sources::ErrorSource`]),
//! its one-sigma contribution to every reported quantity, from the rig description's figures
//! and the measurement's own data, never from a simulator's truth.
//!
//! - [`crate::record`]: a bounded record of each run (the estimator's samples, averaged to
//!   ~100 Hz), fed on the estimator's path, online ([`crate::measurement`]) and offline
//!   ([`crate::replay`]).
//! - [`fit`]: at the end of a run, an independent least-squares fit of the rigid-body
//!   equations on the record; A = Σ Φᵀ W Φ.
//! - [`perturb`]: each elementary error of each systematic source applied to the recorded
//!   data, one sigma at a time; its effect δθ = A⁻¹ Σ Φᵀ W (r(ε) − r(0)). The accelerometer's
//!   bias and the load cells' zero offsets use the estimator's own exact sensitivities instead
//!   when the run has them ([`crate::systematic`]; they include its conditioning), the
//!   budget's fit giving the rest (the cells' drift among them).
//! - [`calibrated`]: applied calibrations' uncertainties as the budget counts them.
//! - [`legs`]: the legs' mass and the joints' friction as the estimator misses them, and the
//!   transverse force through each cell (its crosstalk).
//! - [`statistical`]: the estimator's covariance split into noise, frame loss and timestamp
//!   jitter.
//! - [`rigid`]: whether the rigid-body model explains the data.
//! - [`combine`]: the payload's share (loaded − tare, the same physical error in both runs)
//!   and each source's covariance.

pub mod calibrated;
pub mod combine;
pub mod fit;
pub mod legs;
pub mod perturb;
pub mod rigid;
pub mod statistical;

#[cfg(test)]
mod joint_gain_tests;
#[cfg(test)]
pub(crate) mod testkit;
#[cfg(test)]
mod tests;

use estimator::wrench::to_vector;
use estimator::{EstimatorConfig, ParameterVector};
use nalgebra::Vector6;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::record::Entry;
pub use crate::record::RunRecord;
pub use combine::{payload_covariances, SourceCovariance};
use rig_description::config::{Config, LegsConfig, SensorsConfig};
use rig_description::sources::ErrorSource;
pub use rigid::RigidBody;

/// The rig description's figures the budget reads: the sensors' datasheets, the joints'
/// tolerance and the legs.
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// `[sensors]`.
    pub sensors: SensorsConfig,
    /// `platform.joint_position_tolerance_m`.
    pub joint_tolerance_m: f64,
    /// `[legs]`.
    pub legs: LegsConfig,
    /// Whether the estimator compensates the legs (`estimator.compensate_legs`): the budget
    /// then counts the `[legs]` tolerances, else the legs' whole effect.
    pub legs_compensated: bool,
    /// The IMU calibration applied (`[calibration] imu`): the IMU's lines then count its
    /// uncertainty instead of the datasheet's figures.
    pub imu: Option<perturb::CalibratedImu>,
    /// The load-cell gains applied (`[calibration] load_cells`): `load_cell_scale` then counts
    /// their uncertainty instead of the datasheet's `gain_error`.
    pub load_cells: Option<perturb::CalibratedGains>,
}

impl Figures {
    /// The figures of `config`.
    pub fn of(config: &Config) -> Self {
        Self {
            sensors: config.sensors.clone(),
            joint_tolerance_m: config.platform.joint_position_tolerance_m,
            legs: config.legs,
            legs_compensated: crate::setup::leg_model(config).is_some(),
            imu: config
                .calibration
                .imu_alignment()
                .map(perturb::CalibratedImu::of),
            load_cells: config
                .calibration
                .load_cell_gains()
                .map(perturb::CalibratedGains::of),
        }
    }
}

/// One source's effects: θ's change from one sigma of each of its elementary errors
/// ([`perturb::scalars`] order).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SourceEffects {
    /// The source's id ([`ErrorSource::id`]).
    pub source: String,
    /// δθ per elementary error, θ's units.
    pub effects: Vec<[f64; 10]>,
    /// The errors are this run's own, independent of the other run's (an offset measured on
    /// each run, [`estimator::hold`]), not one error shared by the tare run and the loaded run.
    #[serde(default)]
    pub per_run: bool,
}

/// The budget's inputs of one run: its systematic effects, its sample counts and its
/// statistical split; also what a saved tare keeps.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RunBudget {
    /// Per systematic source.
    pub effects: Vec<SourceEffects>,
    /// Samples the estimator used.
    pub used: u64,
    /// Frames lost in its window.
    pub lost: u64,
    /// The timestamp jitter's share of the statistical variance ([`statistical`]).
    pub jitter_share: f64,
    /// The rigid-body check on the run's record; `None` when the record was too short.
    pub rigid_body: Option<RigidBody>,
}

impl RunBudget {
    /// True when `source`'s effects are this run's own errors ([`SourceEffects::per_run`]).
    pub fn per_run(&self, source: ErrorSource) -> bool {
        self.effects
            .iter()
            .any(|e| e.source == source.id() && e.per_run)
    }

    /// The effects of `source` (empty when not known).
    pub fn effects_of(&self, source: ErrorSource) -> &[[f64; 10]] {
        self.effects
            .iter()
            .find(|e| e.source == source.id())
            .map_or(&[], |e| &e.effects[..])
    }

    /// The frame loss's share of the statistical variance, lost/(lost + used).
    pub fn loss_share(&self) -> f64 {
        let n = (self.used + self.lost) as f64;
        if n > 0.0 {
            self.lost as f64 / n
        } else {
            0.0
        }
    }
}

/// The estimator's own exact effects, used in place of the fit's where given.
#[derive(Clone, Copy, Debug, Default)]
pub struct EstimatorEffects {
    /// One sigma of accelerometer bias along x, y, z.
    pub accel: Option<[[f64; 10]; 3]>,
    /// One sigma of zero offset on each load cell.
    pub load_cell: Option<[[f64; 10]; 6]>,
    /// `accel` is the residual of the offset measured on this run, not the datasheet bias
    /// shared by both runs.
    pub accel_offset_measured: bool,
    /// The load cells' zero drift the estimator fitted and took out
    /// ([`estimator::OnlineEstimator::load_cell_drift`]): the budget's fit takes it out of
    /// the record alike.
    pub load_cell_drift: Option<estimator::LoadCellDrift>,
}

/// One elementary error's effect on θ at one sigma.
type Effect = [f64; 10];

/// One elementary error's residual change at the rigid-body check's entries
/// ([`rigid::subset`]), for the errors smooth in the motion.
type Mode = Vec<Vector6<f64>>;

/// The budget of one run at its end: the record, the estimator's settings, the rig
/// description's figures, the run's estimate θ̂ with its counts, and the estimator's own
/// effects. Without a usable record (too short) only the estimator's effects are known.
pub fn analyse(
    record: &RunRecord,
    config: &EstimatorConfig,
    figures: &Figures,
    estimate: &estimator::Estimate,
    exact: &EstimatorEffects,
) -> RunBudget {
    let model = fit::Model {
        geometry: *record.geometry(),
        lever_m: config.accelerometer_position_m,
        equation_sigma: config.equation_sigma,
        mode: fit::Mode::of(&config.parameters),
    };
    let theta: ParameterVector = estimate.parameters.to_vector();
    let mut data = fit::Data::new(without_drift(record, exact.load_cell_drift.as_ref()), model);
    // The record holds the cells' wrench; the estimator fitted it with the legs compensated
    // when it had their model, and so does the budget's fit. An estimator that fits the
    // cells' zero drift (`estimator::drift`) takes a linear drift out exactly, so the drift
    // lines count zero; the fitted rate's own uncertainty is in the statistical part.
    let mut sensors = figures.sensors.clone();
    if config.load_cell_drift {
        sensors.load_cell.zero_drift_n_per_min = 0.0;
    }
    let figures = &Figures {
        legs_compensated: config.legs.is_some(),
        sensors,
        ..figures.clone()
    };
    let times: Vec<f64> = data.entries.iter().map(|e| e.time_s).collect();
    let (interior, h) = crate::record::derivative::interior(&times);
    let motions = legs::motions(&data, &interior, h);
    let described = legs::effects(&data, &motions, &figures.legs);
    if figures.legs_compensated {
        for (e, (d, f)) in data
            .entries
            .iter_mut()
            .zip(described.dynamics.iter().zip(&described.friction))
        {
            e.wrench += d + f;
        }
    }
    let fitted = fit::Fit::new(&data, &theta);
    let mut budget = RunBudget {
        used: estimate.counts.used,
        lost: estimate.counts.lost,
        ..RunBudget::default()
    };
    let Some(fit) = fitted else {
        for source in ErrorSource::ALL {
            let n = perturb::scalars(source, figures).len();
            if n == 0 {
                continue;
            }
            budget
                .effects
                .push(with_exact(source, vec![[0.0; 10]; n], exact));
        }
        return budget;
    };
    let ctx = perturb::Context {
        data: &data,
        fit: &fit,
        legs: &described,
        described: &figures.legs,
        motions: &motions,
        imu: figures.imu.as_ref(),
        load_cells: figures.load_cells.as_ref(),
        rest_gravity_m_s2: (exact.accel_offset_measured && config.local_gravity_m_s2 > 0.0)
            .then_some(config.local_gravity_m_s2),
        joint_baseline: Default::default(),
        leg_maps: Default::default(),
    };
    let rows = rigid::subset(&fit);
    // Each elementary error is a fit of its own on shared, read-only data: they run in
    // parallel, and each source's effects come back in the scalars' order.
    let work: Vec<(ErrorSource, perturb::Scalar)> = ErrorSource::ALL
        .into_iter()
        .flat_map(|source| {
            perturb::scalars(source, figures)
                .into_iter()
                .map(move |s| (source, s))
        })
        .collect();
    let six = matches!(data.model.mode, fit::Mode::Six { .. });
    // The noise's prediction and the residual's spectrum need none of the errors' fits: they
    // run beside them, so that the end of a run's budget is not one thread's serial tail.
    let ((done, prediction), peak_hz) = rayon::join(
        || {
            rayon::join(
                || {
                    work.par_iter()
                        .map(|(_, s)| {
                            let sigma = s.sigma(figures);
                            if !(sigma.is_finite() && sigma != 0.0) {
                                return ([0.0; 10], None);
                            }
                            let dr = s.residual_change(&ctx, sigma);
                            let mode = s.is_smooth().then(|| {
                                rows.iter().map(|&k| dr[k]).collect::<Vec<Vector6<f64>>>()
                            });
                            (fit.effect(&dr).into(), mode)
                        })
                        .collect::<Vec<(Effect, Option<Mode>)>>()
                },
                || statistical::predict(&data, &fit, figures),
            )
        },
        || rigid::residual_peak(&fit, &rows, &times, six),
    );
    let mut modes = Vec::new();
    let mut done = work.iter().zip(done).peekable();
    for source in ErrorSource::ALL {
        let mut effects = Vec::new();
        while let Some(((_, _), (effect, mode))) = done.next_if(|((s, _), _)| *s == source) {
            effects.push(effect);
            modes.extend(mode);
        }
        if !effects.is_empty() {
            budget.effects.push(with_exact(source, effects, exact));
        }
    }
    budget.jitter_share = prediction.jitter_share;
    budget.rigid_body = rigid::check(
        &fit,
        &rows,
        &modes,
        &prediction.noise_variance,
        peak_hz,
        six,
    );
    budget
}

/// The record's entries with the estimator's fitted drift taken out: each entry's cell forces
/// less δf = r̂ (t − t₀) at its mean time, and its wrench less that force's wrench at its mean
/// pose (the drift changes by 0.1 mN over a 10 ms entry, beside newtons of noise).
fn without_drift(record: &RunRecord, drift: Option<&estimator::LoadCellDrift>) -> Vec<Entry> {
    let mut entries = record.entries();
    if let Some(d) = drift {
        let geometry = record.geometry();
        for e in &mut entries {
            let df = d.at(e.time_s);
            e.leg_forces_n -= df;
            e.wrench -= to_vector(&geometry.wrench_in_platform(&e.pose(), &df));
        }
    }
    entries
}

/// `source`'s effects with the estimator's exact ones in place of the fit's (accelerometer
/// bias; the cells' zero offsets, the first six of their source), and whether they are the
/// run's own errors.
fn with_exact(
    source: ErrorSource,
    mut effects: Vec<[f64; 10]>,
    exact: &EstimatorEffects,
) -> SourceEffects {
    override_exact(source, &mut effects, exact);
    SourceEffects {
        source: source.id().into(),
        effects,
        per_run: source == ErrorSource::AccelBias && exact.accel_offset_measured,
    }
}

fn override_exact(source: ErrorSource, effects: &mut [[f64; 10]], exact: &EstimatorEffects) {
    match source {
        ErrorSource::AccelBias => {
            if let Some(a) = exact.accel {
                effects[..3].copy_from_slice(&a);
            }
        }
        ErrorSource::LoadCellOffset => {
            if let Some(l) = exact.load_cell {
                effects[..6].copy_from_slice(&l);
            }
        }
        _ => {}
    }
}
