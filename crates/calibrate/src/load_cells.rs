//! The load cells' gains from a reference body of known mass: the empty fixture's run (tare)
//! and the fixture with the reference on it (loaded), both fitted at once with the gains
//! shared, each with its uncertainty counting the noise, the joints' tolerance, the legs'
//! figures and the reference mass's own tolerance.
//!
//! **The model.** Cell i reads f_i = (1 + g_i) t_i + o_i, t_i the true axial force and o_i its
//! zero offset. The wrench on the plate the record holds is W = Σ f_i L_i(pose) (L_i the unit
//! wrench of leg i at the pose, [`kinematics::Geometry::wrench_in_platform`]; plus the legs'
//! own wrench when the estimator compensates them, [`measure::budget::legs`]), so to first order
//! in g
//!
//! - tare run: W = Φ(motion) θ_F + Σ_i (g_i f_i + o_i) L_i,
//! - loaded run: W = Φ(motion) (θ_F + θ_R) + Σ_i (g_i f_i + o_i) L_i,
//!
//! with Φ the rigid-body regressor ([`estimator::regressor::from_signals`]: the recorded
//! rate, its derivative and the specific force moved to the P origin), θ_F the fixture's ten
//! parameters, θ_R the reference's with its mass m_R known (its centre of mass and inertia
//! are fitted, not needed), and the cells' zero offsets o_i shared by both runs (a datasheet's
//! 4 N is twice what a 5e-4 gain does to a 4 kN leg force, so they cannot be left out). Linear
//! least squares in [g (6), θ_F (10), θ_R without m (9), o (6)], each equation weighted by the
//! estimator's
//! equation sigma and smoothed alike on both sides (`normal`); the accelerometer's
//! offset measured at rest before each run ([`estimator::hold`]) is taken out of its
//! specific force, as the estimator does.
//!
//! **What fixes the gains.** Scaling every gain by the same 1 + s scales both runs' wrenches,
//! which θ_F absorbs in the tare run; only the known mass m_R fixes the overall scale: the
//! gains' mean is m_R's tolerance and the loaded run's weight away from the truth, the gains'
//! differences come from how the legs share the force as the plate moves and tilts. The zero
//! offsets take the static share of each cell's gain away from its difference, so the
//! differences come mostly from the motion's dynamic forces.
//!
//! **Uncertainty.** The noise's part is the sandwich covariance over blocks of the record
//! (`normal`). To it add, each as one more independent error whose change of the fit
//! counts: each of the 36 joint coordinates moved by the joints' tolerance (the poses the same
//! leg lengths would have had, and the wrench map of the moved rig), each `[legs]` figure moved
//! by its tolerance ([`measure::budget::legs::tolerance`]), each cell's zero drift at its
//! datasheet rate (a ramp from the tare run's start, which the shared offsets do not take
//! up), and the reference's mass moved by its tolerance.
//!
//! **The joints, counted once.** The joints that blur the gains are the rig's own, and the
//! error budget's `geometry` line moves the same joints in the measurement. So the fit keeps,
//! beside the covariance, each joint coordinate's change of the applied gains
//! s_k = (I − K) δĝ_k (K the prior's gain below) and the applied gains' covariance without
//! the joints' part, T (C − Σ δĝ_k δĝ_kᵀ) Tᵀ + σ_d² K Kᵀ with T = I − K. The budget then moves
//! the gains by s_k whenever it moves joint k ([`measure::budget::perturb::CalibratedGains`]):
//! one correlated effect per joint instead of two independent ones.
//!
//! **The datasheet's prior.** The joints' tolerance makes the gains' differences nearly
//! interchangeable with the joints' positions (a joint 0.2 mm off changes a leg's share of a
//! load as a gain of a few 1e-4 does): the fit alone gives each gain to about 9e-4 with a
//! default rig, worse than the cells' datasheet (`gain_error`, 5e-4), and only their mean
//! well (about 9e-5). The applied gains combine the fit with the datasheet's figure as a prior
//! g ~ N(0, σ_d² I): with the fit's ĝ and its whole covariance C,
//! C' = C − C (C + σ_d² I)⁻¹ C and ĝ' = ĝ − C (C + σ_d² I)⁻¹ ĝ (the Gaussian posterior, in a
//! form that never inverts C). The mean takes the fit's, the differences stay near the
//! datasheet's, narrowed where the motion does determine them.
//!
//! **What is not fitted.** The cells' transverse sensitivity (crosstalk): the transverse
//! force through a cell comes only from the legs' own weight and the joints' friction, tens of
//! newtons, so its 2e-3 sensitivity moves a reading by a tenth of a newton, below what the
//! motion separates from the gains; it stays the datasheet's, in the budget.

use estimator::legs::PlateMotion;
use estimator::regressor::{from_signals, Regressor};
use kinematics::{Geometry, Pose};
use nalgebra::{DMatrix, Matrix6, SVector, Vector3, Vector6};

use crate::normal::{Normal, BLOCK_ENTRIES};
use measure::budget::fit::{Data, Mode, Model};
use measure::budget::legs::{self, LegEffects};
use measure::budget::perturb::moved_poses;
use measure::record::derivative::interior;
use measure::record::Entry;
use rig_description::config::LegsConfig;

pub use rig_description::calibration::load_cells::LoadCellGains;

/// Fewest interior entries each run needs (two seconds at 100 Hz).
pub const MIN_ENTRIES: usize = 200;

/// Parameters of the fit: gains, fixture, reference without its mass, zero offsets.
const P: usize = 6 + 10 + 9 + 6;

/// Why no gains could be fitted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GainError {
    /// Too short a record.
    #[error(
        "the {run} run gave {got} record entries of regular motion, the load-cell calibration \
         needs at least {MIN_ENTRIES} (2 s of excitation)"
    )]
    TooShort {
        /// "tare" or "loaded".
        run: &'static str,
        /// Entries found.
        got: usize,
    },
    /// The motion does not determine every parameter.
    #[error(
        "the motion does not determine the load cells' gains: excite all three rotations and \
         translations, with the reference on the plate in the loaded run"
    )]
    Unobservable,
    /// The reference's mass is not a positive number.
    #[error("the reference mass must be a positive number of kg, got {0}")]
    ReferenceMass(f64),
}

/// One run's record as the fit takes it.
#[derive(Clone, Copy, Debug)]
pub struct Run<'a> {
    /// The record's entries (the estimator's samples, no gains applied).
    pub entries: &'a [Entry],
    /// The accelerometer's offset measured at rest before the run, subtracted from each
    /// entry's specific force (zero: none measured).
    pub accel_offset_m_s2: Vector3<f64>,
}

/// What the fit knows besides the records: the rig description's figures.
#[derive(Clone, Copy, Debug)]
pub struct Setup<'a> {
    /// The described platform.
    pub geometry: Geometry,
    /// The accelerometer's position in P, m.
    pub lever_m: Vector3<f64>,
    /// One sigma of each equation [Fx, Fy, Fz, τx, τy, τz] (the estimator's).
    pub equation_sigma: Vector6<f64>,
    /// The legs the estimator compensates, when it does.
    pub legs: Option<&'a LegsConfig>,
    /// One sigma of each joint coordinate, m.
    pub joint_tolerance_m: f64,
    /// One sigma of each cell's zero drift, N per minute.
    pub zero_drift_n_per_min: f64,
    /// The reference's mass, kg.
    pub reference_mass_kg: f64,
    /// Its tolerance, one sigma, kg.
    pub reference_mass_tolerance_kg: f64,
    /// The cells' datasheet gain error, one sigma, the prior of each gain (0 or not finite:
    /// none).
    pub prior_gain_sigma: f64,
}

/// One run's equations' ingredients.
struct Prepared {
    data: Data,
    idx: Vec<usize>,
    /// Φ at each interior entry.
    phi: Vec<Regressor>,
    motions: Vec<Option<PlateMotion>>,
    /// The described legs' wrench at each entry (zero without compensation).
    legs: LegEffects,
}

fn prepare(run: &Run<'_>, setup: &Setup<'_>, name: &'static str) -> Result<Prepared, GainError> {
    let mut entries = run.entries.to_vec();
    for e in &mut entries {
        e.accel_m_s2 -= run.accel_offset_m_s2;
    }
    let model = Model {
        geometry: setup.geometry,
        lever_m: setup.lever_m,
        equation_sigma: setup.equation_sigma,
        mode: Mode::Full,
    };
    let mut data = Data::new(entries, model);
    let times: Vec<f64> = data.entries.iter().map(|e| e.time_s).collect();
    let (idx, h) = interior(&times);
    if idx.len() < MIN_ENTRIES {
        return Err(GainError::TooShort {
            run: name,
            got: idx.len(),
        });
    }
    let motions = legs::motions(&data, &idx, h);
    let effects = match setup.legs {
        Some(l) => legs::effects(&data, &motions, l),
        None => LegEffects {
            dynamics: vec![Vector6::zeros(); data.entries.len()],
            friction: vec![Vector6::zeros(); data.entries.len()],
            transverse: Vec::new(),
        },
    };
    for (e, (d, f)) in data
        .entries
        .iter_mut()
        .zip(effects.dynamics.iter().zip(&effects.friction))
    {
        e.wrench += d + f;
    }
    let gyro = data.gyro();
    let phi = idx
        .iter()
        .map(|&i| from_signals(&data.signals(&gyro, i, h)))
        .collect();
    Ok(Prepared {
        data,
        idx,
        phi,
        motions,
        legs: effects,
    })
}

/// The unit wrenches of the six legs at `pose`, as columns.
fn wrench_map(g: &Geometry, pose: &Pose) -> Matrix6<f64> {
    Matrix6::from_fn(|row, leg| {
        let mut f = Vector6::zeros();
        f[leg] = 1.0;
        estimator::wrench::to_vector(&g.wrench_in_platform(pose, &f))[row]
    })
}

/// What one refit changes.
enum Change {
    None,
    /// The rig built with one joint moved, and each run's poses on it.
    Joint(Box<Geometry>, [Vec<Pose>; 2]),
    /// The legs' wrench changed by this at each entry of each run.
    Legs([Vec<Vector6<f64>>; 2]),
    /// Cell `leg`'s zero drifting by this many N/s from the time given.
    Drift(usize, f64, f64),
    /// The reference's mass changed by this, kg.
    Mass(f64),
}

/// The fit's solution [g, θ_F, θ_R without m, c] and its noise covariance, residual rms.
fn solve(
    runs: [&Prepared; 2],
    setup: &Setup<'_>,
    change: &Change,
) -> Option<(SVector<f64, P>, DMatrix<f64>, f64)> {
    let w = setup.equation_sigma.map(|s| 1.0 / s);
    let mass = setup.reference_mass_kg
        + match change {
            Change::Mass(d) => *d,
            _ => 0.0,
        };
    let mut normal = Normal::<P>::new();
    // The loaded run's entries well apart from the tare run's: a break, other blocks.
    let offset = runs[0].data.entries.len() + 2 * BLOCK_ENTRIES;
    for (r, run) in runs.iter().enumerate() {
        let loaded = r == 1;
        for (j, &i) in run.idx.iter().enumerate() {
            let e = &run.data.entries[i];
            let pose = run.data.poses[i];
            let base = wrench_map(&setup.geometry, &pose);
            let mut y = e.wrench;
            let map = match change {
                Change::Joint(built, poses) => {
                    let moved = wrench_map(built, &poses[r][i]);
                    y += (moved - base) * e.leg_forces_n;
                    moved
                }
                Change::Legs(dy) => {
                    y += dy[r][i];
                    base
                }
                Change::Drift(leg, rate, t0) => {
                    y += base.column(*leg) * (rate * (e.time_s - t0));
                    base
                }
                _ => base,
            };
            let d = map * Matrix6::from_diagonal(&e.leg_forces_n);
            let phi = &run.phi[j];
            for k in 0..6 {
                let mut row = SVector::<f64, P>::zeros();
                for l in 0..6 {
                    row[l] = d[(k, l)];
                    row[25 + l] = map[(k, l)];
                }
                for p in 0..10 {
                    row[6 + p] = phi[(k, p)];
                }
                let mut rhs = y[k];
                if loaded {
                    for p in 1..10 {
                        row[15 + p] = phi[(k, p)];
                    }
                    rhs -= phi[(k, 0)] * mass;
                }
                let index = if loaded { offset + i } else { i };
                normal.push(index, k, row * w[k], rhs * w[k]);
            }
        }
    }
    let (x, cov, rms) = normal.solve()?;
    Some((SVector::from_iterator(x.iter().copied()), cov, rms))
}

fn gains_of(x: &SVector<f64, P>) -> Vector6<f64> {
    Vector6::from_fn(|i, _| x[i])
}

fn outer(d: &Vector6<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(6, 6, |i, j| d[i] * d[j])
}

fn sigmas(cov: &DMatrix<f64>) -> [f64; 6] {
    core::array::from_fn(|i| cov[(i, i)].max(0.0).sqrt())
}

/// Fits the cells' gains to the tare run's and the loaded run's records. See the
/// [module docs](self).
pub fn fit(
    tare: &Run<'_>,
    loaded: &Run<'_>,
    setup: &Setup<'_>,
) -> Result<LoadCellGains, GainError> {
    let m = setup.reference_mass_kg;
    if !(m.is_finite() && m > 0.0) {
        return Err(GainError::ReferenceMass(m));
    }
    let runs = [
        prepare(tare, setup, "tare")?,
        prepare(loaded, setup, "loaded")?,
    ];
    let both = [&runs[0], &runs[1]];
    let (x, noise_full, rms) = solve(both, setup, &Change::None).ok_or(GainError::Unobservable)?;
    let g0 = gains_of(&x);
    let noise = DMatrix::from_fn(6, 6, |i, j| noise_full[(i, j)]);
    let mut joints = DMatrix::zeros(6, 6);
    // The fit's change for each joint coordinate (base joints, then plate joints; x, y, z of
    // each leg's): zero where the moved rig could not be built.
    let mut deltas = vec![Vector6::zeros(); JOINT_COORDINATES];
    if setup.joint_tolerance_m > 0.0 {
        for plate in [false, true] {
            for leg in 0..kinematics::LEG_COUNT {
                for coord in 0..3 {
                    let moved = |r: &Prepared| {
                        moved_poses(
                            &setup.geometry,
                            &r.data.poses,
                            plate,
                            leg,
                            coord,
                            setup.joint_tolerance_m,
                        )
                    };
                    let (Some(p0), Some(p1)) = (moved(&runs[0]), moved(&runs[1])) else {
                        continue;
                    };
                    let mut b = *setup.geometry.base_joints_m();
                    let mut p = *setup.geometry.plate_joints_m();
                    let joint = if plate { &mut p[leg] } else { &mut b[leg] };
                    joint[coord] += setup.joint_tolerance_m;
                    let Ok(built) = setup.geometry.with_joints(b, p) else {
                        continue;
                    };
                    if let Some((xm, _, _)) =
                        solve(both, setup, &Change::Joint(Box::new(built), [p0, p1]))
                    {
                        let d = gains_of(&xm) - g0;
                        joints += outer(&d);
                        deltas[joint_index(plate, leg, coord)] = d;
                    }
                }
            }
        }
    }
    let mut legs_cov = DMatrix::zeros(6, 6);
    if let Some(described) = setup.legs {
        for k in 0..legs::FIGURES {
            let tol = legs::tolerance(described, k);
            if !(tol.is_finite() && tol != 0.0) {
                continue;
            }
            let off = legs::moved(described, k, tol);
            let dy = |r: &Prepared| -> Vec<Vector6<f64>> {
                let e = legs::effects(&r.data, &r.motions, &off);
                (0..r.data.entries.len())
                    .map(|i| {
                        e.dynamics[i] + e.friction[i] - r.legs.dynamics[i] - r.legs.friction[i]
                    })
                    .collect()
            };
            let change = Change::Legs([dy(&runs[0]), dy(&runs[1])]);
            if let Some((xm, _, _)) = solve(both, setup, &change) {
                legs_cov += outer(&(gains_of(&xm) - g0));
            }
        }
    }
    let mut drift_cov = DMatrix::zeros(6, 6);
    let rate = setup.zero_drift_n_per_min / 60.0;
    let start = runs[0].data.entries.first().map_or(0.0, |e| e.time_s);
    if rate.is_finite() && rate > 0.0 {
        for leg in 0..6 {
            if let Some((xm, _, _)) = solve(both, setup, &Change::Drift(leg, rate, start)) {
                drift_cov += outer(&(gains_of(&xm) - g0));
            }
        }
    }
    let mut mass_cov = DMatrix::zeros(6, 6);
    let tol = setup.reference_mass_tolerance_kg;
    if tol.is_finite() && tol > 0.0 {
        if let Some((xm, _, _)) = solve(both, setup, &Change::Mass(tol)) {
            mass_cov += outer(&(gains_of(&xm) - g0));
        }
    }
    let total = &noise + &joints + &legs_cov + &drift_cov + &mass_cov;
    let prior = with_prior(&g0, &total, setup.prior_gain_sigma);
    let (gains, covariance) = (prior.gains, &prior.covariance);
    let joint_sensitivity: Vec<[f64; 6]> = deltas
        .iter()
        .map(|d| {
            let s = &prior.transfer * nalgebra::DVector::from_iterator(6, d.iter().copied());
            core::array::from_fn(|i| s[i])
        })
        .collect();
    let without = prior.without(&(&total - &joints));
    let h = Vector3::new(x[16], x[17], x[18]);
    let nested = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
        (0..6)
            .map(|i| (0..6).map(|j| m[(i, j)]).collect())
            .collect()
    };
    Ok(LoadCellGains {
        gains: gains.into(),
        covariance: nested(covariance),
        covariance_without_joints: nested(&without),
        joint_sensitivity,
        fitted_gains: g0.into(),
        fitted_covariance: nested(&total),
        prior_sigma: if setup.prior_gain_sigma.is_finite() {
            setup.prior_gain_sigma.max(0.0)
        } else {
            0.0
        },
        noise_sigma: sigmas(&noise),
        joints_sigma: sigmas(&joints),
        legs_sigma: sigmas(&legs_cov),
        drift_sigma: sigmas(&drift_cov),
        mass_sigma: sigmas(&mass_cov),
        reference_mass_kg: m,
        reference_mass_tolerance_kg: tol,
        reference_com_m: (h / m).into(),
        fixture_mass_kg: x[6],
        joint_tolerance_m: setup.joint_tolerance_m,
        residual_rms: rms,
        entries: (runs[0].idx.len() + runs[1].idx.len()) as u64,
    })
}

pub use rig_description::calibration::load_cells::{joint_index, JOINT_COORDINATES};

/// The applied gains from the fit: ĝ' = T ĝ and C' = C − K C with K = C (C + σ² I)⁻¹ and the
/// transfer T = I − K.
struct Posterior {
    gains: Vector6<f64>,
    covariance: DMatrix<f64>,
    /// T: how an error of the fit's gains reaches the applied gains.
    transfer: DMatrix<f64>,
    /// K (zero without a prior).
    gain: DMatrix<f64>,
    /// σ², the prior's variance of each gain (0: none).
    prior_variance: f64,
}

impl Posterior {
    /// The applied gains' covariance from a part `part` of the fit's covariance:
    /// T part Tᵀ + σ² K Kᵀ (with the whole of C in place of `part` this is C', since
    /// K (C + σ² I) = C).
    fn without(&self, part: &DMatrix<f64>) -> DMatrix<f64> {
        let t = &self.transfer;
        let c = t * part * t.transpose() + &self.gain * self.gain.transpose() * self.prior_variance;
        (&c + c.transpose()) * 0.5
    }
}

/// The fit `g` with covariance `c` combined with the prior N(0, σ² I): ĝ' = g − C (C + σ² I)⁻¹ g,
/// C' = C − C (C + σ² I)⁻¹ C. Without a prior (σ zero or not finite), or when C + σ² I cannot
/// be inverted, the fit as it is.
fn with_prior(g: &Vector6<f64>, c: &DMatrix<f64>, sigma: f64) -> Posterior {
    let fit = || Posterior {
        gains: *g,
        covariance: c.clone(),
        transfer: DMatrix::identity(6, 6),
        gain: DMatrix::zeros(6, 6),
        prior_variance: 0.0,
    };
    if !(sigma.is_finite() && sigma > 0.0) {
        return fit();
    }
    let Some(inv) = (c + DMatrix::identity(6, 6) * (sigma * sigma)).try_inverse() else {
        return fit();
    };
    let gd = nalgebra::DVector::from_iterator(6, g.iter().copied());
    let k = c * inv;
    let post = &gd - &k * &gd;
    let cov = c - &k * c;
    // Symmetric to rounding.
    let cov = (&cov + cov.transpose()) * 0.5;
    Posterior {
        gains: Vector6::from_iterator(post.iter().copied()),
        covariance: cov,
        transfer: DMatrix::identity(6, 6) - &k,
        gain: k,
        prior_variance: sigma * sigma,
    }
}

#[cfg(test)]
pub(crate) mod tests;
