//! The online estimator: one call per sample, allocation-free, a deterministic function of the
//! sample stream and its configuration (re-running a log reproduces it bit for bit).

use crate::conditioning::{Conditioned, Conditioner, ConditioningConfig, Step, MAX_ABS_SIGNAL};
use crate::drift::{DriftFit, LoadCellDrift, ZeroDrift};
use crate::error::EstimatorError;
use crate::estimate::{Counts, Estimate, ParameterCovariance};
use crate::gyro_error::{self, GyroError, RateErrorNormals};
use crate::hold::{AccelerometerOffset, HoldAverage};
use crate::legs::{unseen_total, LegModel};
use crate::regressor::{from_signals, inertia_columns, RegressorSignals};
use crate::rls::Rls;
use crate::score::ScoreCovariance;
use crate::timebase::Timing;
use crate::uncertainty::derived_jacobian;
use crate::wrench::{measured, to_vector};
use kinematics::{Geometry, Pose, Wrench};
use nalgebra::{Const, DimMin, Matrix6, SMatrix, SVector, Vector3, Vector6};
use stewart_types::{InertialParameters, ParameterVector, GRAVITY_B_M_S2, PARAMETER_COUNT};

/// Which parameters are estimated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParameterSet {
    /// All ten: m, h = m·c and J_O (six equations per sample).
    Full,
    /// The paper's six: the tensor about a known centre of mass, from the three torque
    /// equations about it (τ_C = τ_O − c × F = J_C ω̇ + ω × (J_C ω)). The mass is used only to
    /// report J_O and the force residuals; its sigma and the centre of mass's are zero.
    InertiaAboutKnownCom {
        /// Known mass, kg.
        mass_kg: f64,
        /// Known centre of mass in P, m (the paper's case: the origin).
        com_m: Vector3<f64>,
    },
}

/// Estimator settings. Re-running a log with the same settings reproduces the estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorConfig {
    /// Platform design, for the leg-force → wrench map.
    pub geometry: Geometry,
    /// Nominal sample period, s.
    pub sample_period_s: f64,
    /// Low-pass cut-off, Hz, applied alike to every signal; `None` for none. Keep it well above
    /// the excitation's highest frequency and well below Nyquist.
    pub lowpass_cutoff_hz: Option<f64>,
    /// Forgetting factor λ ∈ (0, 1]; 1 for a constant payload.
    pub forgetting_factor: f64,
    /// Ten parameters or the paper's six.
    pub parameters: ParameterSet,
    /// Expected one-sigma noise of each equation after conditioning, [Fx, Fy, Fz] in N and
    /// [τx, τy, τz] in N·m; rows are divided by it. Sets the relative weights and the sigmas
    /// reported before enough residual windows exist; afterwards the residuals decide.
    pub equation_sigma: Vector6<f64>,
    /// Prior one-sigma of every parameter about zero, SI units (a weak prior: large).
    pub prior_sigma: f64,
    /// Accelerometer mounting point in P, m.
    pub accelerometer_position_m: Vector3<f64>,
    /// Samples before this time only warm the conditioning, s.
    pub window_start_s: f64,
    /// Samples after this time are ignored, s.
    pub window_end_s: f64,
    /// A longer step between samples restarts the conditioning, s; a shorter gap (lost frames)
    /// is bridged ([`crate::conditioning`]).
    pub max_gap_s: f64,
    /// Largest relative error of the nominal sample rate that the timestamps may show before
    /// the conditioning uses the measured period instead ([`crate::timebase`]).
    pub max_rate_error: f64,
    /// One-sigma white noise of each gyro axis per sample, rad/s; 0 if unknown. When given, the
    /// bias that this noise causes by entering the regressor (through ω̇ and ωᵢ²) is removed:
    /// the estimate solves (A − n·C) θ = b instead of A θ = b, with C the second moment the
    /// conditioned noise adds to each weighted regressor row (errors-in-variables correction).
    pub gyro_noise_rad_s: f64,
    /// One-sigma white noise of each accelerometer axis per sample, m/s²; 0 if unknown. Used as
    /// `gyro_noise_rad_s` (its bias is usually negligible beside gravity).
    pub accel_noise_m_s2: f64,
    /// Accumulate the sensitivity of θ to constant leg-force offsets (load-cell zero offsets),
    /// [`OnlineEstimator::leg_force_offset_sensitivity`]: the leg-force → wrench map of every
    /// sample goes through the conditioning too (36 more filtered channels, about a third of a
    /// microsecond per sample). Off by default.
    pub leg_force_offsets: bool,
    /// Fit each load cell's zero drift rate over the run as a nuisance of the fit
    /// ([`crate::drift`]): θ is then that of the measurements with the cells' zeros held at
    /// their value at the window's start, θ = θ̂ − Q S_r r̂, and its covariance counts r̂'s
    /// uncertainty. Needs the conditioned leg map, which it turns on as
    /// [`Self::leg_force_offsets`] does. Samples without a pose
    /// ([`OnlineEstimator::update_with_wrench`]) carry no drift rows. Off by default.
    pub load_cell_drift: bool,
    /// Samples per half-block of the covariance estimate's residual windows (each window spans
    /// two, [`crate::window`]); half-blocks must be long compared with the filter's memory
    /// (≈ 1/f_c), and what the windows leave of the gyro's derivative noise falls with their
    /// length; a run needs some tens of them for a steady sigma.
    pub covariance_half_block_samples: u32,
    /// The legs' mass properties and the joints' friction, when known: each conditioned
    /// sample's wrench then gains what the load cells do not see of them ([`crate::legs`]),
    /// from the plate's conditioned motion. `None`: the cells' wrench is taken as the whole
    /// wrench on the plate (massless, frictionless legs). Samples without a pose
    /// ([`OnlineEstimator::update_with_wrench`]) are not compensated.
    pub legs: Option<LegModel>,
    /// The site's gravity, m/s² (a gravity survey or map; 9.80665 is standard gravity, not a
    /// site's). The samples before the window (the brake hold and the settle, which start and
    /// end at rest) against it give the accelerometer's offset, subtracted from every sample
    /// in the window ([`crate::hold`]). 0 leaves the offset in.
    pub local_gravity_m_s2: f64,
    /// End of the stretch at rest whose readings give the accelerometer's offset, s: the
    /// excitation's start when the window starts later (a re-estimate of part of the run: the
    /// samples between are in motion, and their mean is not gravity's). `None`: the window's
    /// start.
    pub hold_end_s: Option<f64>,
}

impl EstimatorConfig {
    /// Defaults: low-pass at 20 Hz (at most a fifth of the sample rate), λ = 1, all ten
    /// parameters, equation sigmas 1 N and 0.2 N·m, prior sigma 1e4, accelerometer at the P
    /// origin, no time window, gaps of more than 10 periods restart (shorter ones are bridged),
    /// a rate error of 1e-4 (100 ppm, beyond a crystal's) tolerated, covariance half-blocks of 8/f_c
    /// (at least 20 samples).
    pub fn new(geometry: Geometry, sample_period_s: f64) -> Self {
        Self {
            geometry,
            sample_period_s,
            lowpass_cutoff_hz: Some(Self::default_cutoff_hz(sample_period_s)),
            forgetting_factor: 1.0,
            parameters: ParameterSet::Full,
            equation_sigma: Vector6::new(1.0, 1.0, 1.0, 0.2, 0.2, 0.2),
            prior_sigma: 1e4,
            accelerometer_position_m: Vector3::zeros(),
            window_start_s: f64::NEG_INFINITY,
            window_end_s: f64::INFINITY,
            max_gap_s: 10.0 * sample_period_s,
            max_rate_error: DEFAULT_MAX_RATE_ERROR,
            gyro_noise_rad_s: 0.0,
            accel_noise_m_s2: 0.0,
            leg_force_offsets: false,
            load_cell_drift: false,
            covariance_half_block_samples: Self::default_covariance_half_block_samples(
                sample_period_s,
            ),
            legs: None,
            local_gravity_m_s2: 0.0,
            hold_end_s: None,
        }
    }

    /// The default low-pass cut-off: 20 Hz, at most a fifth of the sample rate.
    pub fn default_cutoff_hz(sample_period_s: f64) -> f64 {
        let rate_hz = 1.0 / sample_period_s;
        if rate_hz.is_finite() && rate_hz > 0.0 {
            20.0f64.min(0.2 * rate_hz)
        } else {
            20.0
        }
    }

    /// The default residual half-block: 8 / [`Self::default_cutoff_hz`] (at least 20
    /// samples), whatever cut-off a caller then sets.
    pub fn default_covariance_half_block_samples(sample_period_s: f64) -> u32 {
        let cutoff_hz = Self::default_cutoff_hz(sample_period_s);
        let block = libm::ceil(8.0 / (cutoff_hz * sample_period_s));
        if block.is_finite() {
            block.clamp(20.0, 1e6) as u32
        } else {
            20
        }
    }

    /// The conditioning stage's settings, as the estimator builds its conditioning
    /// ([`Conditioner`]): the sample period, the low-pass, the accelerometer's position, the
    /// gap and rate limits and the gyro's noise, each this configuration's own.
    pub fn conditioning(&self) -> ConditioningConfig {
        ConditioningConfig {
            sample_period_s: self.sample_period_s,
            lowpass_cutoff_hz: self.lowpass_cutoff_hz,
            accelerometer_position_m: self.accelerometer_position_m,
            max_gap_s: self.max_gap_s,
            max_rate_error: self.max_rate_error,
            gyro_noise_rad_s: self.gyro_noise_rad_s,
        }
    }
}

/// One sensor sample; every channel describes the same instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time, s (strictly increasing).
    pub time_s: f64,
    /// The frame's sequence counter (one per sample period), when the source has one: it
    /// places the sample on the conditioning's grid, telling a lost frame from a late one
    /// ([`crate::timebase`]). `None`: the timestamps place the samples.
    pub sequence: Option<u64>,
    /// Pose of P in B from forward kinematics of the measured leg lengths.
    pub pose: Pose,
    /// Axial leg forces, N (positive pushes the plate away from the base).
    pub leg_forces_n: Vector6<f64>,
    /// Gyro: ω in P, rad/s.
    pub gyro_rad_s: Vector3<f64>,
    /// Accelerometer: specific force a − g at its mounting point, in P, m/s².
    pub accel_m_s2: Vector3<f64>,
}

/// What an accepted sample did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// It reached the least-squares solver.
    Used,
    /// It only fed the conditioning (the first samples after a start or a gap, while the
    /// stencil fills and the low-pass's start transient dies away, or before the window).
    Conditioning,
    /// It lies after the window and was ignored.
    AfterWindow,
}

/// [`EstimatorConfig::max_rate_error`]'s default: timestamps whose mean period is within 1e-4
/// of the nominal one (0.1 µs at 1 kHz) keep the nominal period.
pub const DEFAULT_MAX_RATE_ERROR: f64 = 1e-4;

/// x = (𝟙 − M)⁻¹ b as the Neumann series Σₖ Mᵏ b, `apply` giving M v: `None` when a term
/// is more than half the one before or not finite (the series converges too slowly or not at
/// all), or when [`NEUMANN_TERMS`] terms leave it unconverged. Converged means the last
/// term's largest entry is within [`NEUMANN_TOLERANCE`] of the sum's.
pub(crate) fn neumann_solve<const N: usize>(
    apply: impl Fn(&SVector<f64, N>) -> SVector<f64, N>,
    b: &SVector<f64, N>,
) -> Option<SVector<f64, N>> {
    let mut term = *b;
    let mut sum = *b;
    let mut previous = f64::INFINITY;
    for _ in 0..NEUMANN_TERMS {
        term = apply(&term);
        let size = term.amax();
        sum += term;
        if !(size.is_finite() && size <= 0.5 * previous) {
            return None;
        }
        if size <= NEUMANN_TOLERANCE * sum.amax() {
            return Some(sum);
        }
        previous = size;
    }
    None
}

/// Most terms of the Neumann series behind [`OnlineEstimator::theta_quick`] before it gives
/// way to an LU solve.
const NEUMANN_TERMS: usize = 24;

/// The series stops when a term's largest entry is below this share of the sum's largest:
/// a few units of rounding, where further terms no longer change the sum.
const NEUMANN_TOLERANCE: f64 = 4.0 * f64::EPSILON;

/// How θ is taken from the solver ([`OnlineEstimator::theta`], [`OnlineEstimator::theta_quick`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Correction {
    /// Corrected for regressor noise, its definiteness checked.
    Full,
    /// Corrected by one solve, on the last half-block's verdict.
    Quick,
    /// The plain least-squares θ.
    None,
}

/// Least squares plus residual scores for `N` parameters and `R` equations per sample
/// (`NR` = N·R sizes the scores' offset terms).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Solver<const N: usize, const R: usize, const NR: usize> {
    rls: Rls<N>,
    score: ScoreCovariance<N, R, NR>,
    inv_sigma: SVector<f64, R>,
    /// Second moment the regressor noise adds per sample, C (weighted rows).
    noise_moment: SMatrix<f64, N, N>,
    /// The reported quantities, whose sigmas each take their own degrees of freedom
    /// ([`ScoreCovariance::covariance`]).
    quantities: Reported,
    /// Effective number of samples, Σ λ^(age).
    samples: f64,
    /// Σ λ^(age) φ_wᵀ W L over the samples, L the (conditioned) map from the six leg forces
    /// to the sample's equations: b's sensitivity to constant leg-force offsets.
    leg: SMatrix<f64, N, 6>,
    /// Whether the full correction at the last residual window's close applied (a definite
    /// corrected system); `None` before the first half-block closed.
    correction_applied: Option<bool>,
    /// The gyro's measured error: at the ends of the conditioning's stretches, taken out of
    /// θ, and over the whole run, taken out of the estimate the residual windows are scored
    /// at (not out of θ: [`crate::gyro_error`]).
    gyro: GyroError<N, R>,
    /// The load cells' drift sums, when it is fitted ([`EstimatorConfig::load_cell_drift`]).
    drift: Option<ZeroDrift<N, R>>,
    /// Q S_r r̂ at the last residual window's close: the drift's share of θ that
    /// [`Self::theta_quick`] takes out.
    drift_shift: SVector<f64, N>,
}

/// Which correction K of the normal equations (A − K) θ = b a solve applies
/// ([`Solver::shift`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shift {
    /// The regressor noise's moment alone, n C: P' = (𝟙 − n P C)⁻¹ P.
    Noise,
    /// n C + Δ, the gyro's error at the stretches' ends besides: θ.
    NoiseAndEnds,
    /// n C − n_u C_ω̇ + Q̂, the gyro's measured error over the run: θ_w, the estimate the
    /// residual windows are scored at.
    ScoredAt,
}

impl<const N: usize, const R: usize, const NR: usize> Solver<N, R, NR> {
    /// `noise`: the regressor noise's second moment per sample C, and C_ω̇, the part of it
    /// the gyro's derivative noise adds ([`noise_moment`]).
    fn new(
        config: &EstimatorConfig,
        sigma: SVector<f64, R>,
        noise: (SMatrix<f64, N, N>, SMatrix<f64, N, N>),
        quantities: Reported,
    ) -> Result<Self, EstimatorError> {
        let (noise_moment, rate_moment) = noise;
        let p0 = config.prior_sigma * config.prior_sigma;
        Ok(Self {
            rls: Rls::new(
                SVector::zeros(),
                SVector::from_element(p0),
                config.forgetting_factor,
            )?
            .with_variance_cap(p0),
            score: ScoreCovariance::new(
                config.covariance_half_block_samples,
                config.forgetting_factor,
            )
            .with_sample_period(config.sample_period_s)
            .with_rate_moment(rate_moment),
            inv_sigma: sigma.map(|s| 1.0 / s),
            noise_moment,
            quantities,
            samples: 0.0,
            leg: SMatrix::zeros(),
            correction_applied: None,
            gyro: GyroError::new(config.sample_period_s, config.forgetting_factor),
            drift: config
                .load_cell_drift
                .then(|| ZeroDrift::new(config.forgetting_factor)),
            drift_shift: SVector::zeros(),
        })
    }

    fn weigh(&self, rows: &SMatrix<f64, R, N>) -> SMatrix<f64, R, N> {
        let mut w = *rows;
        for (mut row, s) in w.row_iter_mut().zip(self.inv_sigma.iter()) {
            row.scale_mut(*s);
        }
        w
    }

    /// Weights the rows, updates, and records the residual scores. On a non-finite result the
    /// solver is left as it was. `time_s` places the sample on the drift's ramp.
    // One argument per input of the sample's equations; a struct would only rename them.
    #[allow(clippy::too_many_arguments)]
    fn update(
        &mut self,
        time_s: f64,
        rows: &SMatrix<f64, R, N>,
        y: &SVector<f64, R>,
        leg_map: Option<&SMatrix<f64, R, 6>>,
        rate_error_rows: Option<&SMatrix<f64, R, N>>,
        rate_change_rows: Option<&SMatrix<f64, R, N>>,
        starts_stretch: bool,
    ) -> Result<(), EstimatorError> {
        let wrows = self.weigh(rows);
        let wy = y.component_mul(&self.inv_sigma);
        let before = self.rls;
        self.rls.update(&wrows, &wy);
        if !self.rls.is_finite() {
            self.rls = before;
            return Err(EstimatorError::Overflow("least-squares update"));
        }
        // Φᵀψ and Φᵀψ(ṅ̂) once per sample, for the windows and for the run's ends and whole.
        let change = rate_change_rows.map(|psi| self.weigh(psi));
        let psi = rate_error_rows.map(|psi| self.weigh(psi));
        let (rate, derivative) =
            self.gyro
                .add(&wrows, psi.as_ref(), change.as_ref(), starts_stretch);
        let products = rate.as_ref().map(|rate| RateErrorNormals {
            rate,
            derivative: derivative.as_ref(),
        });
        let wl = leg_map.map(|l| {
            let mut wl = *l;
            for (mut row, s) in wl.row_iter_mut().zip(self.inv_sigma.iter()) {
                row.scale_mut(*s);
            }
            wl
        });
        let psi = match (&mut self.drift, &wl) {
            (Some(drift), Some(wl)) => {
                let psi = drift.rows(time_s, wl);
                drift.add(&wrows, &wy, &psi);
                Some(psi)
            }
            _ => None,
        };
        if self.score.add_sample(&wrows, &wy, products, psi.as_ref()) {
            let (theta, p, moment) = self.corrected_with_moment();
            let scored = self.scored_theta(&moment).unwrap_or(theta);
            let fit = self.drift_fit(&theta, &p);
            self.score.close_half_block_with_drift(
                &scored,
                &p,
                &moment,
                &self.quantities.gradients(&theta),
                fit.as_ref().map(|f| &f.rate_n_s),
            );
            self.correction_applied = Some(moment.iter().any(|v| *v != 0.0));
            self.drift_shift = self.drift_shift_of(fit.as_ref());
        }
        self.samples = self.samples * self.rls.forgetting() + 1.0;
        if let Some(wl) = wl {
            self.leg = self.leg * self.rls.forgetting() + wrows.tr_mul(&wl);
        }
        Ok(())
    }

    /// The drift rates fitted over the samples so far at the fit's θ̂ and P (without the
    /// drift, [`crate::drift`]); `None` when the drift is not fitted or not yet determined.
    fn drift_fit(&self, theta: &SVector<f64, N>, p: &SMatrix<f64, N, N>) -> Option<DriftFit<R>> {
        let drift = self.drift.as_ref()?;
        drift.fit(
            theta,
            p,
            &self.score.totals(),
            &self.gyro.residual_sum(theta),
        )
    }

    /// Q S_r r̂, the fitted drift's share of θ ([`Self::gain`]); zero without a fit.
    fn drift_shift_of(&self, fit: Option<&DriftFit<R>>) -> SVector<f64, N> {
        match (&self.drift, fit) {
            (Some(drift), Some(fit)) => {
                let shift = self.gain() * (drift.sensitivity() * fit.rate_n_s);
                if shift.iter().all(|v| v.is_finite()) {
                    shift
                } else {
                    SVector::zeros()
                }
            }
            _ => SVector::zeros(),
        }
    }

    /// K of the corrected normal equations (A − K) θ' = b, for `shift` with the noise
    /// moment `moment` applied (zero where it fell back): n C, n C + Δ, or θ_w's
    /// n C − n_u C_ω̇ + Q̂ ([`GyroError::scored_shift`]). `None` where that K has no part of
    /// its own: the ends' Δ zero, or no measured change of the gyro's error.
    fn shift(&self, shift: Shift, moment: &SMatrix<f64, N, N>) -> Option<SMatrix<f64, N, N>> {
        match shift {
            Shift::Noise => Some(moment * self.samples),
            Shift::NoiseAndEnds => {
                let delta = self.gyro.delta();
                (!delta.iter().all(|v| *v == 0.0)).then(|| moment * self.samples + delta)
            }
            Shift::ScoredAt => self
                .gyro
                .scored_shift(&(moment * self.samples), &self.score.rate_moment(moment)),
        }
    }

    /// (𝟙 − P K)⁻¹ for `shift`'s K ([`Self::shift`]), with A = P⁻¹ the map from θ to the
    /// corrected θ' = (A − K)⁻¹ A θ and from P to the corrected P' = (𝟙 − P K)⁻¹ P: the one
    /// solve behind every correction. `None` where K has no part of its own, or the system
    /// is singular or its inverse not finite.
    fn correction(
        &self,
        p: &SMatrix<f64, N, N>,
        shift: Shift,
        moment: &SMatrix<f64, N, N>,
    ) -> Option<SMatrix<f64, N, N>> {
        // P C n in that order for the moment alone, as the noise's share of the information.
        let pk = match shift {
            Shift::Noise => p * moment * self.samples,
            _ => p * self.shift(shift, moment)?,
        };
        (SMatrix::<f64, N, N>::identity() - pk)
            .try_inverse()
            .filter(|i| i.iter().all(|v| v.is_finite()))
    }

    /// The estimate the residual windows are scored at when the gyro's error is measured:
    /// θ_w = (A − n C + n_u C_ω̇ − Q̂)⁻¹ b = (𝟙 − P (n C − n_u C_ω̇ + Q̂))⁻¹ θ, Q̂ the measured
    /// Σ Φᵀψ(ṅ̂) over n_u samples, which stands in for both the ends' Δ and the derivative
    /// noise's expected moment C_ω̇ ([`crate::gyro_error`], [`crate::score`]). `None`
    /// without a measured error, or where the system is singular or not finite.
    fn scored_theta(&self, moment: &SMatrix<f64, N, N>) -> Option<SVector<f64, N>> {
        self.correction(&self.rls.covariance(), Shift::ScoredAt, moment)
            .map(|i| i * self.rls.theta())
            .filter(|t| t.iter().all(|v| v.is_finite()))
    }

    /// ∂θ/∂δf for constant offsets δf of the six leg forces: θ = P' b and b gains L δf.
    fn leg_sensitivity(&self) -> SMatrix<f64, N, 6> {
        self.gain() * self.leg
    }

    /// θ and P corrected for regressor noise and for the gyro's error at the stretches' ends:
    /// with A = P⁻¹ and b = A θ, the corrected normal equations (A − nC − Δ) θ = b give
    /// θ' = (𝟙 − P (nC + Δ))⁻¹ θ, and P' = (𝟙 − nPC)⁻¹ P (Δ, two samples' worth, carries no
    /// information; [`crate::gyro_error::ends`]). The noise moment is left out when none is
    /// configured or when it would not leave a definite system; Δ when the kinematics are
    /// not carried.
    fn corrected(&self) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
        let (theta, p, _) = self.corrected_with_moment();
        (theta, p)
    }

    /// [`Self::corrected`] and the noise moment C it applied (zero when it fell back).
    fn corrected_with_moment(&self) -> (SVector<f64, N>, SMatrix<f64, N, N>, SMatrix<f64, N, N>) {
        let theta = *self.rls.theta();
        let p = self.rls.covariance();
        let (pc, moment, inv) = self.moment_corrected(&p);
        let t = self
            .correction(&p, Shift::NoiseAndEnds, &moment)
            .or(inv)
            .map_or(theta, |i| i * theta);
        if t.iter().all(|v| v.is_finite()) {
            (t, pc, moment)
        } else {
            (theta, pc, moment)
        }
    }

    /// Q = (A − nC − Δ)⁻¹ = (𝟙 − P (nC + Δ))⁻¹ P, the map from the normal equations' b to
    /// θ' ([`Self::corrected`]): what a change of b does to the estimate. P' where Δ is zero
    /// or leaves the system singular.
    fn gain(&self) -> SMatrix<f64, N, N> {
        let p = self.rls.covariance();
        let (pc, moment, _) = self.moment_corrected(&p);
        self.correction(&p, Shift::NoiseAndEnds, &moment)
            .map_or(pc, |i| i * p)
    }

    /// P' = (𝟙 − nPC)⁻¹ P, the moment C and (𝟙 − nPC)⁻¹ when the noise moment applies (a
    /// definite, finite P'); P, zero and `None` otherwise.
    #[allow(clippy::type_complexity)]
    fn moment_corrected(
        &self,
        p: &SMatrix<f64, N, N>,
    ) -> (
        SMatrix<f64, N, N>,
        SMatrix<f64, N, N>,
        Option<SMatrix<f64, N, N>>,
    ) {
        let plain = (*p, SMatrix::zeros(), None);
        if self.samples <= 0.0 || self.noise_moment.iter().all(|v| *v == 0.0) {
            return plain;
        }
        let Some(inv) = self.correction(p, Shift::Noise, &self.noise_moment) else {
            return plain;
        };
        let pc = inv * p;
        let pc = (pc + pc.transpose()) * 0.5;
        if pc.diagonal().iter().all(|v| *v > 0.0) && pc.iter().all(|v| v.is_finite()) {
            (pc, self.noise_moment, Some(inv))
        } else {
            plain
        }
    }

    /// θ: the corrected fit ([`Self::corrected`]) less the fitted drift's share Q S_r r̂
    /// when the load cells' drift is fitted ([`crate::drift`]).
    fn theta(&self) -> SVector<f64, N> {
        let (theta, p) = self.corrected();
        if self.drift.is_none() {
            return theta;
        }
        theta - self.drift_shift_of(self.drift_fit(&theta, &p).as_ref())
    }

    /// θ' = (𝟙 − P (nC + Δ))⁻¹ θ, when the last half-block's full correction applied (its
    /// definiteness check needs P' = (𝟙 − nPC)⁻¹ P, ten solves and a product more); otherwise
    /// [`Self::theta`].
    ///
    /// The correction is small beside θ (nPC is the noise's share of the information), so the
    /// Neumann series θ' = Σₖ (P (nC + Δ))ᵏ θ converges fast: each term is two matrix–vector
    /// products through P's factors, and the sum stops when a term no longer changes it
    /// ([`NEUMANN_TOLERANCE`]). A series that converges slowly (a term more than half the one
    /// before) or not within [`NEUMANN_TERMS`] gives way to one LU solve of the same system.
    ///
    /// With the load cells' drift fitted, the drift's share of θ is the one at the last
    /// window's close (a fit at most one half-block old).
    fn theta_quick(&self) -> SVector<f64, N>
    where
        Const<N>: DimMin<Const<N>, Output = Const<N>>,
    {
        self.theta_quick_without_drift() - self.drift_shift
    }

    fn theta_quick_without_drift(&self) -> SVector<f64, N>
    where
        Const<N>: DimMin<Const<N>, Output = Const<N>>,
    {
        if self.correction_applied != Some(true) {
            return self.corrected().0;
        }
        let theta = *self.rls.theta();
        // K = n C + Δ whether or not Δ is zero yet: the series needs no inverse to skip.
        let k = self.noise_moment * self.samples + self.gyro.delta();
        if let Some(t) = neumann_solve(|v| self.rls.covariance_times(&(k * v)), &theta) {
            return t;
        }
        let m = SMatrix::<f64, N, N>::identity() - self.rls.covariance() * k;
        let mut t = theta;
        match m.lu().solve_mut(&mut t) {
            true if t.iter().all(|v| v.is_finite()) => t,
            _ => self.corrected().0,
        }
    }

    /// ∂θ/∂c for a constant offset c added to every sample's (unweighted) measurements:
    /// θ = Q b ([`Self::gain`]) and b gains S W c, so Δθ = Q S W c (exact for λ = 1: P does
    /// not see y).
    fn offset_sensitivity(&self) -> SMatrix<f64, N, R> {
        let (s, _) = self.score.totals();
        let mut sw = self.gain() * s;
        for (mut column, s) in sw.column_iter_mut().zip(self.inv_sigma.iter()) {
            column.scale_mut(*s);
        }
        sw
    }

    /// Δθ caused by a constant perturbation `b` of every sample's (unweighted) regressor, to
    /// first order: with Φ → Φ + B, A gains S B_w + B_wᵀ Sᵀ and b gains B_wᵀ Y (B_w = W B), so
    /// Δθ = Q (B_wᵀ (Y − Sᵀθ) − S B_w θ) ([`Self::gain`]): from the accumulated S and Y, no
    /// second fit.
    fn regressor_perturbation_effect(&self, b: &SMatrix<f64, R, N>) -> SVector<f64, N> {
        let (s, y) = self.score.totals();
        let theta = self.corrected().0;
        let bw = self.weigh(b);
        self.gain() * (bw.tr_mul(&(y - s.tr_mul(&theta))) - s * (bw * theta))
    }

    /// Covariance of θ, each reported quantity with its own small-sample factor. With the
    /// load cells' drift fitted ([`crate::drift`]): the scores' offset fitted jointly with
    /// the drift, and the rate's own uncertainty added, D Q S_r G⁻¹ S_rᵀ Q D with
    /// D = diag √(C_ii / P_ii), C the residuals' covariance: G⁻¹ is the rate's covariance for
    /// errors of the configured sigmas, and the rates' rows meet the same equation errors,
    /// which the residuals measure entry by entry.
    fn covariance(&self) -> SMatrix<f64, N, N>
    where
        Const<N>: DimMin<Const<N>, Output = Const<N>>,
    {
        let (theta, p) = self.corrected();
        let ends = self.gyro.residual_sum(&theta);
        let fit = self.drift_fit(&theta, &p);
        let reported = match &fit {
            Some(f) => theta - self.drift_shift_of(Some(f)),
            None => theta,
        };
        let gradients = self.quantities.gradients(&reported);
        let drift = fit.as_ref().map(|f| (&f.offset_share, 6));
        let c = self
            .score
            .covariance_with_drift(&theta, &p, &gradients, &ends, drift);
        let (Some(drift), Some(fit)) = (&self.drift, &fit) else {
            return c;
        };
        let k = self.gain() * drift.sensitivity();
        let rate = k * fit.covariance * k.transpose();
        // D = diag √(C_ii / P_ii): the residuals' measure of how far P misstates each entry's
        // noise, applied to the rate's share as D (Q S_r G⁻¹ S_rᵀ Q) D.
        let d = c.diagonal().zip_map(&p.diagonal(), |ci, pi| {
            if ci > 0.0 && pi > 0.0 {
                libm::sqrt(ci / pi)
            } else {
                1.0
            }
        });
        let d = SMatrix::<f64, N, N>::from_diagonal(&d);
        let total = c + d * rate * d;
        if total.iter().all(|v| v.is_finite()) {
            (total + total.transpose()) * 0.5
        } else {
            c
        }
    }

    /// The load cells' drift fitted over the run ([`crate::drift`]); `None` when not fitted
    /// or not determined.
    fn drift(&self) -> Option<LoadCellDrift> {
        let (theta, p) = self.corrected();
        let fit = self.drift_fit(&theta, &p)?;
        Some(LoadCellDrift {
            rate_n_s: fit.rate_n_s,
            covariance: fit.covariance,
            start_s: self.drift.as_ref()?.start_s()?,
        })
    }
}

/// C = Σ_sources σ² BᵀB over the conditioned noise sources, B the weighted regressor of one
/// unit source: each gyro axis reaches ω̇ (and, through the lever arm, f_O = f_r − ω̇ × r);
/// each accelerometer axis reaches f. Returns C and C_ω̇, the gyro axes' part of it.
fn noise_moment<const N: usize, const R: usize>(
    derivative_variance: f64,
    accel_variance: f64,
    lever_m: &Vector3<f64>,
    inv_sigma: &SVector<f64, R>,
    regressor: impl Fn(&RegressorSignals) -> SMatrix<f64, R, N>,
) -> (SMatrix<f64, N, N>, SMatrix<f64, N, N>) {
    let mut c = SMatrix::<f64, N, N>::zeros();
    let mut c_rate = SMatrix::<f64, N, N>::zeros();
    for e in [Vector3::x(), Vector3::y(), Vector3::z()] {
        let sources = [
            (
                true,
                derivative_variance,
                RegressorSignals::angular_acceleration_error(&e, lever_m),
            ),
            (
                false,
                accel_variance,
                RegressorSignals {
                    angular_acceleration_rad_s2: Vector3::zeros(),
                    rate_products_rad2_s2: Vector6::zeros(),
                    specific_force_m_s2: e,
                },
            ),
        ];
        for (gyro, variance, signals) in sources {
            if variance > 0.0 {
                let mut b = regressor(&signals);
                for (mut row, s) in b.row_iter_mut().zip(inv_sigma.iter()) {
                    row.scale_mut(*s);
                }
                let moment = b.tr_mul(&b) * variance;
                c += moment;
                if gyro {
                    c_rate += moment;
                }
            }
        }
    }
    (c, c_rate)
}

/// Where the paper's six parameters sit in θ: J's entries, θ[4..10].
const SIX_AT: usize = 4;

/// The paper's six-parameter rows (θ's tensor entries, [`ParameterSet::InertiaAboutKnownCom`])
/// in the ten-parameter layout, at [`SIX_AT`], zero for the mass and the first moment: the
/// one embedding of the six-parameter model in θ, for its θ and its sensitivities.
fn six_in_ten<const C: usize>(six: &SMatrix<f64, 6, C>) -> SMatrix<f64, PARAMETER_COUNT, C> {
    let mut ten = SMatrix::<f64, PARAMETER_COUNT, C>::zeros();
    ten.fixed_rows_mut::<6>(SIX_AT).copy_from(six);
    ten
}

/// A six-parameter covariance in the ten-parameter layout, [`six_in_ten`] on its rows and
/// its columns.
fn six_in_ten_square(six: &SMatrix<f64, 6, 6>) -> ParameterCovariance {
    six_in_ten(&six_in_ten(six).transpose()).transpose()
}

/// [−[c]×, 𝟙]: a wrench [F; τ] about the P origin to the torque about c, τ − c × F.
fn to_com_rows(com_m: &Vector3<f64>) -> SMatrix<f64, 3, 6> {
    let mut map = SMatrix::<f64, 3, 6>::zeros();
    map.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-com_m.cross_matrix()));
    map.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&nalgebra::Matrix3::identity());
    map
}

/// The leg-force → wrench map at `pose` in P axes: column i the wrench (about the P origin) of
/// a unit force of leg i, i.e. blockdiag(Rᵀ, Rᵀ) Jᵀ ([`crate::wrench::measured`] is this
/// times the forces).
pub(crate) fn leg_map(geometry: &Geometry, pose: &Pose) -> Matrix6<f64> {
    let jt = geometry.jacobian(pose).transpose();
    let rt = pose.rotation.inverse();
    // Jᵀ's columns, one per leg (nalgebra's arrays are column-major).
    let columns: [[f64; 6]; 6] = jt.into();
    let mut g = Matrix6::zeros();
    for (mut g_col, [f0, f1, f2, t0, t1, t2]) in g.column_iter_mut().zip(columns) {
        let f = rt * Vector3::new(f0, f1, f2);
        let t = rt * Vector3::new(t0, t1, t2);
        for (dst, src) in g_col.iter_mut().zip(f.iter().chain(t.iter())) {
            *dst = *src;
        }
    }
    g
}

// Both variants live inline: no heap, so no boxing; the size is that of the ten-parameter one.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Engine {
    Full(Solver<10, 6, 60>),
    Six {
        solver: Solver<6, 3, 18>,
        mass_kg: f64,
        com_m: Vector3<f64>,
    },
}

/// The bound on [`OnlineEstimator`]'s size, bytes, asserted when the crate compiles: a change
/// that grows the state past it must say so here. 88 KiB: the residual windows' information
/// ([`crate::dof`], 25 KB) and 62 KB of the rest, 5 KB of it the gyro's measured error kept
/// apart in the windows and over the run ([`crate::gyro_error::integral`]), 3.6 KB the load
/// cells' drift rows over the run and in the windows ([`crate::drift`]).
pub const ONLINE_ESTIMATOR_MAX_BYTES: usize = 88 * 1024;

const _: () = assert!(core::mem::size_of::<OnlineEstimator>() <= ONLINE_ESTIMATOR_MAX_BYTES);

/// The online estimator. `update` costs a few microseconds and never allocates.
///
/// Its whole state lives inline: 87 344 bytes on x86-64 for the ten-parameter engine (both
/// engines share the storage), bounded at compile time by [`ONLINE_ESTIMATOR_MAX_BYTES`]; most
/// of it the residual windows' information for each quantity's degrees of freedom (25 KB,
/// [`crate::dof`]), the RLS's U-D factors, the residual scores (with the gyro's measured error
/// at the windows' slopes, in their estimate and at the stretches' ends, [`crate::gyro_error::ends`],
/// [`crate::gyro_error::integral`], and the load cells' drift rows, [`crate::drift`]) and the conditioning's
/// filter states. A firmware gives it a static or a task stack of that size. It is not `Copy`, so that a copy
/// of that size is always a visible `clone()`.
#[derive(Clone, Debug, PartialEq)]
pub struct OnlineEstimator {
    config: EstimatorConfig,
    conditioner: Conditioner,
    engine: Engine,
    residual_sq: Vector6<f64>,
    residual_weight: f64,
    counts: Counts,
    hold: HoldAverage,
    /// b̂, fixed at the window's first sample.
    accel_offset: Option<AccelerometerOffset>,
    hold_closed: bool,
    /// The conditioning's restart count at the last sample the solver took (`None` before
    /// the first): a change starts a new stretch of the gyro's error.
    stretch: Option<u64>,
}

fn positive_finite(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

impl OnlineEstimator {
    /// Checks the configuration and starts with the prior.
    pub fn new(config: EstimatorConfig) -> Result<Self, EstimatorError> {
        if !positive_finite(config.sample_period_s) {
            return Err(EstimatorError::InvalidConfig(
                "sample_period_s must be positive and finite",
            ));
        }
        if !config
            .equation_sigma
            .iter()
            .all(|s| positive_finite(*s) && *s >= 1e-12)
        {
            return Err(EstimatorError::InvalidConfig(
                "equation_sigma entries must be finite and at least 1e-12",
            ));
        }
        if !(positive_finite(config.prior_sigma) && config.prior_sigma <= 1e12) {
            return Err(EstimatorError::InvalidConfig(
                "prior_sigma must be in (0, 1e12]",
            ));
        }
        if config.window_start_s.is_nan()
            || config.window_end_s.is_nan()
            || config.window_start_s >= config.window_end_s
        {
            return Err(EstimatorError::InvalidConfig(
                "window_start_s must be before window_end_s",
            ));
        }
        if !config.legs.is_none_or(|l| l.is_valid()) {
            return Err(EstimatorError::InvalidConfig(
                "every leg figure must be finite and not negative",
            ));
        }
        if config.covariance_half_block_samples == 0 {
            return Err(EstimatorError::InvalidConfig(
                "covariance_half_block_samples must be at least 1",
            ));
        }
        if !(config.local_gravity_m_s2.is_finite()
            && (config.local_gravity_m_s2 == 0.0
                || (9.7..=9.9).contains(&config.local_gravity_m_s2)))
        {
            return Err(EstimatorError::InvalidConfig(
                "local_gravity_m_s2 must be 0 (off) or a site's gravity, 9.7 to 9.9 m/s²",
            ));
        }
        let conditioner = Conditioner::new(config.conditioning())?;
        if !(config.accel_noise_m_s2.is_finite() && config.accel_noise_m_s2 >= 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "accel_noise_m_s2 must be finite and not negative",
            ));
        }
        let (derivative_gain, value_gain) =
            if config.gyro_noise_rad_s > 0.0 || config.accel_noise_m_s2 > 0.0 {
                conditioner.noise_gains()
            } else {
                (0.0, 0.0)
            };
        let derivative_variance =
            config.gyro_noise_rad_s * config.gyro_noise_rad_s * derivative_gain;
        let accel_variance = config.accel_noise_m_s2 * config.accel_noise_m_s2 * value_gain;
        let lever = config.accelerometer_position_m;
        let engine = match config.parameters {
            ParameterSet::Full => {
                let sigma = config.equation_sigma;
                let (c, c_rate) = noise_moment(
                    derivative_variance,
                    accel_variance,
                    &lever,
                    &sigma.map(|s| 1.0 / s),
                    from_signals,
                );
                Engine::Full(Solver::new(
                    &config,
                    sigma,
                    (c, c_rate),
                    Reported::MassComInertia,
                )?)
            }
            ParameterSet::InertiaAboutKnownCom { mass_kg, com_m } => {
                if !(positive_finite(mass_kg) && mass_kg <= MAX_ABS_SIGNAL) {
                    return Err(EstimatorError::InvalidConfig(
                        "known mass must be positive and finite",
                    ));
                }
                if !com_m.iter().all(|v| v.is_finite() && v.abs() <= 1e3) {
                    return Err(EstimatorError::InvalidConfig(
                        "known centre of mass must be finite",
                    ));
                }
                // τ_C = τ_O − c × F: its noise adds the force noise through the lever c.
                let sf = config.equation_sigma.fixed_rows::<3>(0).max();
                let st = config.equation_sigma.fixed_rows::<3>(3);
                let sigma: SVector<f64, 3> =
                    st.map(|s| libm::sqrt(s * s + com_m.norm_squared() * sf * sf));
                let (c, c_rate) = noise_moment(
                    derivative_variance,
                    0.0,
                    &lever,
                    &sigma.map(|s| 1.0 / s),
                    inertia_columns,
                );
                Engine::Six {
                    solver: Solver::new(&config, sigma, (c, c_rate), Reported::Parameters)?,
                    mass_kg,
                    com_m,
                }
            }
        };
        Ok(Self {
            config,
            conditioner,
            engine,
            residual_sq: Vector6::zeros(),
            residual_weight: 0.0,
            counts: Counts::default(),
            hold: HoldAverage::new(),
            accel_offset: None,
            hold_closed: false,
            stretch: None,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &EstimatorConfig {
        &self.config
    }

    /// Sets the fit window `[start_s, end_s]` once it is known (e.g. when the excitation
    /// starts). Samples already fed before `start_s` only warmed the conditioning, exactly as
    /// if the window had been set at creation; samples already fitted stay fitted. Refused,
    /// with nothing changed, unless `start_s < end_s` and neither is NaN.
    pub fn set_window(&mut self, start_s: f64, end_s: f64) -> Result<(), EstimatorError> {
        if start_s.is_nan() || end_s.is_nan() || start_s >= end_s {
            return Err(EstimatorError::InvalidConfig(
                "window_start_s must be before window_end_s",
            ));
        }
        self.config.window_start_s = start_s;
        self.config.window_end_s = end_s;
        Ok(())
    }

    /// The accelerometer's offset measured at rest before the window and subtracted from every
    /// sample in it ([`crate::hold`]); `None` before the window, without a site gravity, or with
    /// fewer than [`crate::hold::MIN_HOLD_SAMPLES`] samples before it.
    pub fn accelerometer_offset(&self) -> Option<AccelerometerOffset> {
        self.accel_offset
    }

    /// Sample counters so far.
    pub fn counts(&self) -> Counts {
        let mut c = self.counts;
        c.restarts = self.conditioner.restarts();
        c.lost = self.conditioner.lost();
        c.bridged = self.conditioner.bridged();
        c.bridged_gaps = self.conditioner.bridged_gaps();
        let windows = match &self.engine {
            Engine::Full(s) => s.score.windows(),
            Engine::Six { solver, .. } => solver.score.windows(),
        };
        // Σ λ^(2·age) of whole windows: non-negative and far below u64's range.
        c.covariance_windows = libm::floor(windows + 1e-9) as u64;
        c.covariance_half_block_samples = u64::from(self.config.covariance_half_block_samples);
        c
    }

    /// The time base's measurements so far: timestamp jitter, the rate error of the nominal
    /// period, the period in use and whether the sequence counter placed the samples.
    pub fn timing(&self) -> Timing {
        self.conditioner.timing()
    }

    fn reject(&mut self, e: EstimatorError) -> Result<Outcome, EstimatorError> {
        self.counts.rejected += 1;
        Err(e)
    }

    /// Processes one sample: leg forces and pose → wrench, then [`Self::update_with_wrench`].
    /// Errors mean the sample was rejected (and counted); the estimator is unchanged.
    pub fn update(&mut self, sample: &Sample) -> Result<Outcome, EstimatorError> {
        if !sample.time_s.is_finite() {
            return self.reject(EstimatorError::NonFiniteSample("time"));
        }
        if sample.time_s > self.config.window_end_s {
            self.counts.after_window += 1;
            return Ok(Outcome::AfterWindow);
        }
        if !sample.pose.is_finite() {
            return self.reject(EstimatorError::NonFiniteSample("pose"));
        }
        if !sample.leg_forces_n.iter().all(|v| v.is_finite()) {
            return self.reject(EstimatorError::NonFiniteSample("leg forces"));
        }
        if !sample
            .leg_forces_n
            .iter()
            .all(|v| v.abs() <= MAX_ABS_SIGNAL)
            || !sample
                .pose
                .position_m
                .iter()
                .all(|v| v.abs() <= MAX_ABS_SIGNAL)
        {
            return self.reject(EstimatorError::Overflow("leg forces or pose"));
        }
        // With the leg map at hand the wrench is its product with the forces: one Jacobian
        // per sample, not a second pass over the legs.
        let map = (self.config.leg_force_offsets || self.config.load_cell_drift)
            .then(|| leg_map(&self.config.geometry, &sample.pose));
        let w = match &map {
            Some(m) => {
                let [f0, f1, f2, t0, t1, t2]: [f64; 6] = (m * sample.leg_forces_n).into();
                Wrench {
                    force_n: Vector3::new(f0, f1, f2),
                    torque_nm: Vector3::new(t0, t1, t2),
                }
            }
            None => measured(&self.config.geometry, &sample.pose, &sample.leg_forces_n),
        };
        if !to_vector(&w).iter().all(|v| v.is_finite()) {
            return self.reject(EstimatorError::Overflow("wrench"));
        }
        self.average_at_rest(sample);
        self.update_inner(
            sample.time_s,
            sample.sequence,
            &w,
            &sample.gyro_rad_s,
            &sample.accel_m_s2,
            map.as_ref(),
            (self.config.legs.is_some() || self.measures_gyro_error()).then_some(&sample.pose),
        )
    }

    /// Whether the gyro's error is measured against the kinematics and taken out
    /// ([`gyro_error::is_measured`]).
    fn measures_gyro_error(&self) -> bool {
        gyro_error::is_measured(self.config.gyro_noise_rad_s)
    }

    /// Before the window, adds the reading to the average at rest ([`crate::hold`]).
    fn average_at_rest(&mut self, sample: &Sample) {
        let hold_end_s = self
            .config
            .hold_end_s
            .map_or(self.config.window_start_s, |e| {
                e.min(self.config.window_start_s)
            });
        if self.config.local_gravity_m_s2 > 0.0 && sample.time_s < hold_end_s {
            let up_in_p = sample.pose.rotation.inverse() * Vector3::z();
            self.hold.push(&sample.accel_m_s2, &up_in_p);
        }
    }

    /// The offset, fixed at the window's first sample.
    fn offset_in_window(&mut self) -> Option<Vector3<f64>> {
        if !self.hold_closed {
            self.hold_closed = true;
            self.accel_offset = self
                .hold
                .offset(self.config.local_gravity_m_s2, self.config.accel_noise_m_s2);
        }
        self.accel_offset.map(|o| o.offset_m_s2)
    }

    /// Processes one sample whose wrench on the plate (about the P origin, P axes) is already
    /// known — for rigs with a six-axis load cell, or for tests.
    pub fn update_with_wrench(
        &mut self,
        time_s: f64,
        wrench: &Wrench,
        gyro_rad_s: &Vector3<f64>,
        accel_m_s2: &Vector3<f64>,
    ) -> Result<Outcome, EstimatorError> {
        self.update_inner(time_s, None, wrench, gyro_rad_s, accel_m_s2, None, None)
    }

    // One argument per input of the conditioning; a struct would only rename them.
    #[allow(clippy::too_many_arguments)]
    fn update_inner(
        &mut self,
        time_s: f64,
        sequence: Option<u64>,
        wrench: &Wrench,
        gyro_rad_s: &Vector3<f64>,
        accel_m_s2: &Vector3<f64>,
        leg_map: Option<&Matrix6<f64>>,
        pose: Option<&Pose>,
    ) -> Result<Outcome, EstimatorError> {
        if time_s > self.config.window_end_s {
            self.counts.after_window += 1;
            return Ok(Outcome::AfterWindow);
        }
        let pushed = self.conditioner.push_sequenced(
            time_s, sequence, gyro_rad_s, accel_m_s2, wrench, leg_map, pose,
        );
        let step = match pushed {
            Ok(s) => s,
            Err(e) => return self.reject(e),
        };
        let mut c = match step {
            Step::Ready(c) if time_s >= self.config.window_start_s => c,
            _ => {
                self.counts.conditioning += 1;
                return Ok(Outcome::Conditioning);
            }
        };
        // The conditioning is linear with unit gain at zero frequency: a constant taken off
        // its output is the same constant taken off every input.
        if let Some(offset) = self.offset_in_window() {
            c.signals.specific_force_m_s2 -= offset;
            if let Some(m) = &mut c.motion {
                m.acceleration_m_s2 -= m.pose.rotation * offset;
            }
        }
        if let (Some(legs), Some(motion)) = (&self.config.legs, &c.motion) {
            let u = unseen_total(&self.config.geometry, legs, motion, &GRAVITY_B_M_S2);
            c.wrench.force_n += u.force_n;
            c.wrench.torque_nm += u.torque_nm;
        }
        if let Err(e) = self.solve(time_s, &c) {
            return self.reject(e);
        }
        self.counts.used += 1;
        Ok(Outcome::Used)
    }

    fn solve(&mut self, time_s: f64, c: &Conditioned) -> Result<(), EstimatorError> {
        let phi = from_signals(&c.signals);
        let y = to_vector(&c.wrench);
        // The regressor's part linear in ω̇ at the gyro's measured error and its change.
        let (rate_error, rate_change) = gyro_error::signals(
            self.measures_gyro_error(),
            c.gyro_excess_rad_s,
            c.gyro_excess_change_rad_s2,
            &self.config.accelerometer_position_m,
        );
        // A conditioning restarted since the last sample used starts a new stretch of the
        // gyro's error ([`crate::gyro_error::ends`]).
        let restarts = self.conditioner.restarts();
        let starts_stretch = self.stretch != Some(restarts);
        match &mut self.engine {
            Engine::Full(solver) => {
                let psi = rate_error.map(|s| from_signals(&s));
                let change = rate_change.map(|s| from_signals(&s));
                solver.update(
                    time_s,
                    &phi,
                    &y,
                    c.leg_map.as_ref(),
                    psi.as_ref(),
                    change.as_ref(),
                    starts_stretch,
                )?
            }
            Engine::Six { solver, com_m, .. } => {
                let yc = c.wrench.torque_nm - com_m.cross(&c.wrench.force_n);
                // τ_C = τ − c × F: the leg map reaches the rows as [−[c]×, 𝟙] L.
                let lc = c.leg_map.map(|l| to_com_rows(com_m) * l);
                let psi = rate_error.map(|s| inertia_columns(&s));
                let change = rate_change.map(|s| inertia_columns(&s));
                solver.update(
                    time_s,
                    &inertia_columns(&c.signals),
                    &yc,
                    lc.as_ref(),
                    psi.as_ref(),
                    change.as_ref(),
                    starts_stretch,
                )?;
            }
        }
        self.stretch = Some(restarts);
        let r = y - phi * self.assemble(Correction::None);
        let lambda = self.config.forgetting_factor;
        self.residual_sq = self.residual_sq * lambda + r.component_mul(&r);
        self.residual_weight = self.residual_weight * lambda + 1.0;
        Ok(())
    }

    /// θ of all ten parameters from the solver's, corrected for regressor noise or not.
    pub(crate) fn assemble(&self, correction: Correction) -> ParameterVector {
        match &self.engine {
            Engine::Full(s) => match correction {
                Correction::Full => s.theta(),
                Correction::Quick => s.theta_quick(),
                Correction::None => *s.rls.theta(),
            },
            Engine::Six {
                solver,
                mass_kg,
                com_m,
            } => {
                let j = match correction {
                    Correction::Full => solver.theta(),
                    Correction::Quick => solver.theta_quick(),
                    Correction::None => *solver.rls.theta(),
                };
                let base = InertialParameters::from_vector(&six_in_ten(&j));
                InertialParameters::from_com(*mass_kg, *com_m, base.inertia_origin_kg_m2)
                    .to_vector()
            }
        }
    }

    /// The current θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] (cheap unless a sensor
    /// noise is configured, when the errors-in-variables correction costs a 10×10 solve).
    pub fn theta(&self) -> ParameterVector {
        self.assemble(Correction::Full)
    }

    /// θ as [`Self::theta`] for a per-sample history: the errors-in-variables correction is
    /// one 10×10 LU solve, applied when the last residual window's full correction found the
    /// corrected system definite (a verdict at most one half-block old), where [`Self::theta`]
    /// checks it again at every call. Equal to [`Self::theta`] to rounding whenever both apply
    /// the correction or neither does.
    pub fn theta_quick(&self) -> ParameterVector {
        self.assemble(Correction::Quick)
    }

    /// Covariance of θ (P and the residual scores; see [`crate::uncertainty`]).
    ///
    /// Each reported quantity's variance carries its own small-sample factor
    /// ([`crate::score::ScoreCovariance::covariance`]): for the full model the mass,
    /// the centre of mass and J_C's entries ([`derived_jacobian`] at θ, or θ's own entries
    /// while the mass is not positive), for the paper's six the tensor's entries.
    pub fn covariance(&self) -> ParameterCovariance {
        match &self.engine {
            Engine::Full(s) => s.covariance(),
            Engine::Six { solver, .. } => six_in_ten_square(&solver.covariance()),
        }
    }

    /// Degrees of freedom of each reported quantity's variance, in θ's layout (the mass, the
    /// centre of mass, J_C's entries; for the paper's six only the tensor's): how many the
    /// residual windows give along that quantity ([`crate::dof`]). `None` where none are
    /// measured yet or the quantity is not estimated.
    pub fn degrees_of_freedom(&self) -> [Option<f64>; PARAMETER_COUNT] {
        match &self.engine {
            Engine::Full(s) => s.score.degrees_of_freedom(),
            Engine::Six { solver, .. } => {
                let six = solver.score.degrees_of_freedom();
                core::array::from_fn(|i| {
                    i.checked_sub(SIX_AT)
                        .and_then(|k| six.get(k).copied().flatten())
                })
            }
        }
    }

    /// Sensitivity of θ to a constant offset of the measured wrench, ∂θ/∂w₀ with
    /// w₀ = [F; τ] (N, N·m) about the P origin in P axes, added to every sample: a load cell's
    /// zero offset b on leg i moves θ by (this) · ŵᵢ · b, ŵᵢ the wrench of a unit force of
    /// leg i. Exact for λ = 1 (θ is linear in the measurements); the residual covariance
    /// leaves such offsets out (see [`crate::score::ScoreCovariance`]), so a caller that
    /// knows the offsets' datasheet sigma adds their effect as a systematic term.
    pub fn wrench_offset_sensitivity(&self) -> SMatrix<f64, 10, 6> {
        match &self.engine {
            Engine::Full(s) => s.offset_sensitivity(),
            Engine::Six { solver, com_m, .. } => {
                // τ_C = τ − c × F: a wrench offset reaches the rows as τ₀ − [c]× F₀.
                six_in_ten(&(solver.offset_sensitivity() * to_com_rows(com_m)))
            }
        }
    }

    /// Sensitivity of θ to constant offsets of the six leg forces, ∂θ/∂δf (N⁻¹ in θ's units
    /// per N): a load cell's zero offset b on leg i moves θ by column i · b. Exact for λ = 1
    /// (θ is linear in the measurements and the offset reaches them through each sample's
    /// leg-force → wrench map, conditioned alike). Zero unless
    /// [`EstimatorConfig::leg_force_offsets`] or [`EstimatorConfig::load_cell_drift`] is set.
    /// With the drift fitted, the offsets' share in the fitted rates is left out: a constant
    /// meets the ramp's rows only through their mean, which the joint fit's offsets take.
    pub fn leg_force_offset_sensitivity(&self) -> SMatrix<f64, 10, 6> {
        match &self.engine {
            Engine::Full(s) => s.leg_sensitivity(),
            Engine::Six { solver, .. } => six_in_ten(&solver.leg_sensitivity()),
        }
    }

    /// The load cells' zero drift fitted over the run ([`crate::drift`]): the rates, N/s,
    /// their covariance for errors of the configured equation sigmas, and t₀; `None` unless
    /// [`EstimatorConfig::load_cell_drift`] is set and the samples determine a rate. The
    /// paper's six-parameter model (three torque rows) determines three combinations only.
    pub fn load_cell_drift(&self) -> Option<LoadCellDrift> {
        match &self.engine {
            Engine::Full(s) => s.drift(),
            Engine::Six { solver, .. } => solver.drift(),
        }
    }

    /// Sensitivity of θ to a constant accelerometer bias, ∂θ/∂b (b in m/s², P axes, one
    /// column per axis), to first order: the bias adds b to the conditioned specific force
    /// (the low-pass passes a constant unchanged, and the lever-arm correction does not touch
    /// it), i.e. a constant perturbation of the regressor's specific-force columns. Zero for
    /// the paper's six parameters, whose rows hold no specific force.
    pub fn accel_bias_sensitivity(&self) -> SMatrix<f64, 10, 3> {
        let mut d = SMatrix::<f64, 10, 3>::zeros();
        if let Engine::Full(s) = &self.engine {
            let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
            for (mut column, axis) in d.column_iter_mut().zip(axes) {
                let b = from_signals(&RegressorSignals {
                    specific_force_m_s2: axis,
                    ..RegressorSignals::default()
                });
                column.copy_from(&s.regressor_perturbation_effect(&b));
            }
        }
        d
    }

    /// The full estimate: parameters, covariance, centre-of-mass form with sigmas, principal
    /// axes, consistency, residual rms per equation and counts.
    pub fn estimate(&self) -> Estimate {
        let mut e = Estimate::from_parameters(
            InertialParameters::from_vector(&self.theta()),
            self.covariance(),
        );
        if self.residual_weight > 0.0 {
            e.residual_rms = (self.residual_sq / self.residual_weight).map(libm::sqrt);
        }
        e.counts = self.counts();
        e.timing = self.timing();
        e.degrees_of_freedom = self.degrees_of_freedom();
        e
    }
}

/// Which quantities an engine reports, each with its own sigma's degrees of freedom.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reported {
    /// The full model's mass, centre of mass and J_C's entries ([`reported_quantities`]).
    MassComInertia,
    /// θ's own entries (the paper's six: the tensor about the known centre of mass).
    Parameters,
}

impl Reported {
    /// Their gradients with respect to θ, row by row, at θ (θ's own entries for a model of
    /// other than ten parameters).
    fn gradients<const N: usize>(self, theta: &SVector<f64, N>) -> SMatrix<f64, N, N> {
        match self {
            Self::MassComInertia if N == PARAMETER_COUNT => {
                let full = ParameterVector::from_fn(|i, _| theta.get(i).copied().unwrap_or(0.0));
                let g = reported_quantities(&full);
                SMatrix::from_fn(|i, j| g.get((i, j)).copied().unwrap_or(0.0))
            }
            _ => SMatrix::identity(),
        }
    }
}

/// Gradients of the full model's reported quantities (mass, centre of mass, J_C's entries)
/// with respect to θ, [`derived_jacobian`]; θ's own entries while the mass is not positive.
fn reported_quantities(theta: &SVector<f64, 10>) -> SMatrix<f64, 10, 10> {
    let mass = theta.get(0).copied().unwrap_or(f64::NAN);
    if mass > 0.0 && mass.is_finite() {
        derived_jacobian(theta)
    } else {
        SMatrix::identity()
    }
}
