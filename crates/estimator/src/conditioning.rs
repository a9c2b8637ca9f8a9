//! Signal conditioning: angular acceleration by a filtered derivative, one low-pass for every
//! signal the regressor is linear in and for the measured wrench, lever-arm correction.
//!
//! Both stages run on the uniform grid of the sample period ([`crate::timebase`]: a sample's
//! place comes from its sequence counter, or from its timestamp rounded to whole periods), and
//! are linear and identical for every channel except the derivative:
//! 1. interpolation stage: over the last four samples, Lagrange interpolation to the midpoint
//!    of the middle two, t_m = (tₙ₋₂ + tₙ₋₁)/2, gives every channel's value there and, for ω,
//!    its derivative ω̇ there. On the grid these are the fourth-order staggered stencils
//!    x(t_m) ≈ (−xₙ₋₃ + 9xₙ₋₂ + 9xₙ₋₁ − xₙ)/16 and ω̇(t_m) ≈ (ωₙ₋₃ − 27ωₙ₋₂ + 27ωₙ₋₁ − ωₙ)/(24Δt).
//!    Value and derivative refer to the same instant, so no channel is skewed (a half-step skew
//!    between channels raises the fit residual a thousandfold), and their O(Δt⁴) error (≈ 1e-10 at
//!    3 Hz and 1 kHz) stays far below any noise; a two-point pair would leave O((ωΔt)²/12) ≈
//!    2e-5 of the dynamic terms, which biases J by several sigma in a long, quiet run.
//! 2. the same Butterworth low-pass on all 18 channels: ω̇ (3), the products ωᵢωⱼ (6), the
//!    accelerometer's specific force (3), force (3) and torque (3).
//!
//! **Lost frames.** A gap of a few grid steps (up to `max_gap_s`) is bridged: the missing raw
//! samples are filled by linear interpolation of every raw channel (the products ωᵢωⱼ, the
//! wrench and the leg map included, with the same weights, so the equations stay linear in
//! what is filled) between the samples either side of the gap, and go through both stages like
//! any other. Linear, because its fill carries half a sample's noise: a cubic through three
//! samples before the gap extrapolates their noise 3.4-fold (measured on white gyro noise with
//! 4.6 % lost: conditioned ω̇ variance +51 % against +8 %), while the linear fill's error,
//! about (G+1)²T²|x''|/8 for G lost samples, stays far below the sensors' noise at rig rates.
//! Only the samples that came produce an output,
//! so the solver never counts information that was not measured. Feeding the stages the
//! uneven steps instead would unbalance the derivative's taps around the gap, and the gyro
//! noise they cancel at low frequency would leak through the low-pass into ω̇. A longer gap
//! (or one of more than [`MAX_BRIDGED_STEPS`] samples) restarts the conditioning (and its
//! warm-up).
//!
//! The products are formed per raw sample before filtering, never from filtered ω: the rigid-body
//! equations are linear in (ω̇, ωᵢωⱼ, f, wrench), so a linear filter applied alike to all of them
//! keeps `filtered wrench = Φ(filtered signals) θ` exact, and with it the delays. The lever arm
//! f_O = f_r − ω̇ × r − ω × (ω × r) is linear in the same signals and is applied after filtering.

use crate::error::EstimatorError;
use crate::filter::{Biquad, LowPass};
use crate::legs::PlateMotion;
use crate::regressor::{rate_products, RegressorSignals};
use crate::timebase::{TimeBase, Timing};
use kinematics::{Pose, Wrench};
use nalgebra::{Matrix3, Matrix6, Rotation3, SVector, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

/// Channels through the low-pass.
const CHANNELS: usize = 18;

/// Raw motion channels of a sample that carries its pose: position (3) and the rotation
/// matrix's entries (9, column-major).
const POSE_CHANNELS: usize = 12;

/// Filtered motion channels: position (3), rotation (9), ω (3), the position's derivative
/// v (3) and the pose's own rate ω_k (3).
const MOTION_CHANNELS: usize = 21;

/// Largest magnitude accepted for any conditioned channel (SI units). Far beyond any rig; it
/// keeps every later product finite, so a finite but absurd sample is rejected up front.
pub const MAX_ABS_SIGNAL: f64 = 1e9;

/// Settings of the conditioning stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditioningConfig {
    /// Nominal sample period, s (sets the low-pass coefficients).
    pub sample_period_s: f64,
    /// Low-pass cut-off, Hz; `None` for no low-pass (the interpolation stage still runs).
    pub lowpass_cutoff_hz: Option<f64>,
    /// Accelerometer mounting point r in P, m.
    pub accelerometer_position_m: Vector3<f64>,
    /// A step longer than this restarts the conditioning (s); shorter gaps are bridged.
    pub max_gap_s: f64,
    /// Largest relative error of the nominal rate the timestamps may show before the measured
    /// period replaces the nominal one ([`crate::timebase`]).
    pub max_rate_error: f64,
    /// One-sigma white noise of each gyro axis per sample, rad/s (0 if unknown). Its square is
    /// the mean that noise adds to each ωᵢ², removed from the conditioned products.
    pub gyro_noise_rad_s: f64,
}

/// One conditioned sample: the regressor's signals at the P origin and the measured wrench,
/// all through the same filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioned {
    /// ω̇, ωᵢωⱼ and the specific force at the P origin (lever arm removed).
    pub signals: RegressorSignals,
    /// Measured wrench on the plate about the P origin, in P axes.
    pub wrench: Wrench,
    /// The leg-force → wrench map (column i: the wrench of a unit force of leg i, about the P
    /// origin in P axes) through the same conditioning, when the samples carried it
    /// ([`Conditioner::push_with_leg_map`]): a constant leg-force offset δf adds exactly
    /// `leg_map · δf` to `wrench`.
    pub leg_map: Option<Matrix6<f64>>,
    /// The plate's motion through the same conditioning, when the samples carried their pose
    /// ([`Conditioner::push_sequenced`]): pose, v (the position's derivative, on the stencil
    /// as ω̇ is), ω, and from the conditioned signals ω̇ and a = R f_O + g. Entries pass the
    /// low-pass one by one, so the rotation is orthonormal only to the filter's distortion of
    /// the motion (far below 1e-4 for motion well inside the pass band); it feeds the legs'
    /// model ([`crate::legs`]), a small correction, where that is negligible.
    pub motion: Option<PlateMotion>,
    /// The gyro's rate less the kinematic rate of the pose, ω − ω_k, through the same
    /// conditioning, when the samples carried their pose: ω_k = vee(Rᵀ Ṙ) at the stencil's
    /// midpoint, R and Ṙ from the value and derivative stencils of the pose's rotation. The
    /// encoders resolve the plate's angle to about a micro-radian, so at the excitation's
    /// frequencies this is the gyro's own error (noise, bias, delay), which reaches ω̇ through
    /// the derivative ([`crate::score::ScoreCovariance`] takes it out of the windows' slopes).
    pub gyro_excess_rad_s: Option<Vector3<f64>>,
    /// The excess's change over the last grid step, (n̂ₜ − n̂ₜ₋₁)/Δt, the samples a bridged
    /// gap filled in counting as steps: the gyro's error as it reaches ω̇
    /// ([`crate::gyro_error::integral`]). `None` without the pose, and on a start's first output
    /// if the warm-up left no step before it.
    pub gyro_excess_change_rad_s2: Option<Vector3<f64>>,
}

/// What one pushed sample produced.
// No heap, so no boxing: the conditioned sample travels inline.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// One of the first samples after a start or a gap: the stencil's first three, then the
    /// low-pass's warm-up ([`Conditioner::warmup_samples`]); nothing produced yet.
    Started,
    /// A conditioned sample.
    Ready(Conditioned),
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Raw {
    omega: Vector3<f64>,
    /// [ωᵢωⱼ (6), f_r (3), F (3), τ (3)]
    rest: SVector<f64, 15>,
    /// The leg-force → wrench map, column-major (zero when not given).
    leg_map: SVector<f64, 36>,
    /// Position and rotation (zero when not given).
    pose: SVector<f64, POSE_CHANNELS>,
}

impl Raw {
    fn zero() -> Self {
        Self {
            omega: Vector3::zeros(),
            rest: SVector::zeros(),
            leg_map: SVector::zeros(),
            pose: SVector::zeros(),
        }
    }
}

/// Which optional channels a stream carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Carried {
    leg_map: bool,
    pose: bool,
}

/// Samples in the interpolation stencil.
pub const STENCIL: usize = 4;

/// Samples before a gap that its fill interpolates through (with the one after it).
const FILL_POINTS_BEFORE: usize = 1;

/// Longest gap bridged, in lost samples, whatever `max_gap_s` allows: a straight line says
/// little about what happened far from its ends.
pub const MAX_BRIDGED_STEPS: u64 = 32;

/// The conditioning state machine. Allocation-free; a rejected sample changes nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioner {
    config: ConditioningConfig,
    filter: LowPass<CHANNELS>,
    /// The same low-pass for the 36 entries of the leg-force → wrench map.
    map_filter: LowPass<36>,
    /// The same low-pass for the motion channels.
    motion_filter: LowPass<MOTION_CHANNELS>,
    /// The last samples, oldest first; `held` of them are valid.
    history: [Raw; STENCIL],
    held: usize,
    primed: bool,
    /// The gyro's excess over the kinematic rate at the last grid step since the filter was
    /// primed (filled samples included), for [`Conditioned::gyro_excess_change_rad_s2`].
    last_excess: Option<Vector3<f64>>,
    /// Filtered samples still to be withheld after the filter was primed.
    warming: u32,
    /// Filtered samples withheld after every (re)start: see [`Self::warmup_samples`].
    warmup: u32,
    restarts: u64,
    time: TimeBase,
    /// Samples accepted.
    samples: u64,
    /// Grid steps without a sample: all of them, and those filled in by bridging.
    lost: u64,
    bridged: u64,
    bridged_gaps: u64,
}

/// Value and derivative weights of the staggered stencil on a grid of step `period_s`, oldest
/// sample first: x(t_m) ≈ Σ valueₖ xₙ₋₃₊ₖ and ω̇(t_m) ≈ Σ slopeₖ ωₙ₋₃₊ₖ (module docs). With
/// [`crate::filter::Biquad::butterworth`] at the same cut-off they give the whole conditioning's
/// impulse response, which a noise prediction needs.
pub fn stencil_weights(period_s: f64) -> ([f64; STENCIL], [f64; STENCIL]) {
    let value = [-1.0 / 16.0, 9.0 / 16.0, 9.0 / 16.0, -1.0 / 16.0];
    let d = 1.0 / (24.0 * period_s);
    (value, [d, -27.0 * d, 27.0 * d, -d])
}

/// Lagrange weights at `x` of the first `n` of the points `xs` (distinct, n ≤ 4).
fn lagrange_weights(xs: &[f64; STENCIL], n: usize, x: f64) -> [f64; STENCIL] {
    let mut w = [0.0; STENCIL];
    for (k, (wk, xk)) in w.iter_mut().zip(xs).enumerate().take(n) {
        let mut v = 1.0;
        for (j, xj) in xs.iter().enumerate().take(n) {
            if j != k {
                v *= (x - xj) / (xk - xj);
            }
        }
        *wk = v;
    }
    w
}

/// Samples until the start transient of `biquad` has died away: the filter primed with a unit
/// value and fed zeros (the state error that priming with one wrong sample leaves) until its
/// output stays below 1e-3. The poles' envelope |p|ⁿ = a₂^(n/2) alone would be a few samples
/// short, the second-order response's amplitude being above one.
fn warmup_samples(biquad: &Biquad) -> u32 {
    let radius_sq = biquad.pole_radius_squared();
    if !(radius_sq > 0.0 && radius_sq < 1.0) {
        return 0;
    }
    // The envelope bounds the search: a generous multiple of where it reaches 1e-3.
    let envelope = libm::log(1e-3) / (0.5 * libm::log(radius_sq));
    let limit = if envelope.is_finite() {
        (4.0 * envelope + 100.0).clamp(0.0, 1e7) as u32
    } else {
        return 0;
    };
    let mut f = LowPass::<1>::new(*biquad);
    f.reset_to(&SVector::from_element(1.0));
    let mut last_above = 0;
    for k in 0..limit {
        if f.step(&SVector::zeros()).x.abs() > 1e-3 {
            last_above = k + 1;
        }
    }
    last_above
}

fn all_bounded<const N: usize>(v: &SVector<f64, N>) -> bool {
    v.iter().all(|x| x.is_finite() && x.abs() <= MAX_ABS_SIGNAL)
}

impl Conditioner {
    /// Checks the configuration and builds the filter.
    pub fn new(config: ConditioningConfig) -> Result<Self, EstimatorError> {
        let t = config.sample_period_s;
        if !(t.is_finite() && t > 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "sample_period_s must be positive and finite",
            ));
        }
        if !(config.max_gap_s.is_finite() && config.max_gap_s >= t) {
            return Err(EstimatorError::InvalidConfig(
                "max_gap_s must be finite and at least the sample period",
            ));
        }
        if !(config.max_rate_error.is_finite() && config.max_rate_error >= 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "max_rate_error must be finite and not negative",
            ));
        }
        if !(config.gyro_noise_rad_s.is_finite() && config.gyro_noise_rad_s >= 0.0) {
            return Err(EstimatorError::InvalidConfig(
                "gyro_noise_rad_s must be finite and not negative",
            ));
        }
        if !config
            .accelerometer_position_m
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(EstimatorError::InvalidConfig(
                "accelerometer_position_m must be finite",
            ));
        }
        let biquad = match config.lowpass_cutoff_hz {
            Some(fc) => Biquad::butterworth(fc, t)?,
            None => Biquad::identity(),
        };
        Ok(Self {
            config,
            filter: LowPass::new(biquad),
            map_filter: LowPass::new(biquad),
            motion_filter: LowPass::new(biquad),
            history: [Raw::zero(); STENCIL],
            held: 0,
            primed: false,
            last_excess: None,
            warming: 0,
            warmup: warmup_samples(&biquad),
            restarts: 0,
            time: TimeBase::new(t, config.max_rate_error),
            samples: 0,
            lost: 0,
            bridged: 0,
            bridged_gaps: 0,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &ConditioningConfig {
        &self.config
    }

    /// Filtered samples withheld after every (re)start, while the low-pass's start transient
    /// dies away: the filter is primed with the first interpolated sample, whose ω̇ carries one
    /// raw sample's derivative noise — at 1 kHz about a thousand times what the filter lets
    /// through — so its output starts that far off and relaxes along the poles' envelope
    /// |p|ⁿ = a₂^(n/2) (complex Butterworth poles). Withheld until that transient stays below
    /// 1e-3 of its start (≈ 10 time constants 1/(2π f_c): 0.33 s at 5 Hz, 82 ms at 20 Hz);
    /// none without a low-pass.
    pub fn warmup_samples(&self) -> u32 {
        self.warmup
    }

    /// How many times a gap restarted the conditioning.
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    /// Grid steps that had no sample (frames lost), bridged or not.
    pub fn lost(&self) -> u64 {
        self.lost
    }

    /// Lost samples filled in by bridging a short gap.
    pub fn bridged(&self) -> u64 {
        self.bridged
    }

    /// Short gaps bridged.
    pub fn bridged_gaps(&self) -> u64 {
        self.bridged_gaps
    }

    /// The time base's measurements: jitter, rate error, the period in use.
    pub fn timing(&self) -> Timing {
        self.time.timing_of(self.samples)
    }

    /// White-noise gains of the conditioning at the nominal period: Σ cₖ² for the impulse
    /// response c of (low-pass ∘ derivative stencil) and of (low-pass ∘ value stencil). A white
    /// input of variance σ² comes out with variance σ²·gain.
    pub fn noise_gains(&self) -> (f64, f64) {
        let (value, slope) = stencil_weights(self.config.sample_period_s);
        let gain = |taps: &[f64; STENCIL]| {
            let mut f = self.filter;
            f.reset_to(&SVector::zeros());
            let mut sum = 0.0;
            // An impulse at one sample meets the stencil's taps newest first, then zeros.
            let impulse = taps.iter().rev().copied().chain(core::iter::repeat(0.0));
            for (n, x) in (0..200_000usize).zip(impulse) {
                let [y, ..]: [f64; CHANNELS] = f.step(&SVector::from_element(x)).into();
                sum += y * y;
                if n > 1000 && y.abs() < 1e-18 * (1.0 + libm::sqrt(sum)) {
                    break;
                }
            }
            sum
        };
        (gain(&slope), gain(&value))
    }

    /// Forgets the history: the next sample starts afresh (and warms the filter again).
    pub fn restart(&mut self) {
        self.held = 0;
        self.primed = false;
    }

    fn hold(&mut self, raw: Raw) {
        self.history.rotate_left(1);
        self.history[STENCIL - 1] = raw;
        self.held = (self.held + 1).min(STENCIL);
    }

    /// Pushes one sample: time (s), gyro ω (rad/s, P), accelerometer specific force at its
    /// mounting point (m/s², P) and the measured wrench about the P origin in P axes. The
    /// output, once four samples are held, refers to the midpoint of the two samples before
    /// this one.
    ///
    /// Non-finite or absurd values and non-increasing time are rejected with an error before
    /// any state changes.
    pub fn push(
        &mut self,
        time_s: f64,
        gyro_rad_s: &Vector3<f64>,
        accel_m_s2: &Vector3<f64>,
        wrench: &Wrench,
    ) -> Result<Step, EstimatorError> {
        self.push_sequenced(time_s, None, gyro_rad_s, accel_m_s2, wrench, None, None)
    }

    /// [`Self::push`] with the sample's leg-force → wrench map (column i: the wrench of a unit
    /// force of leg i about the P origin in P axes), conditioned alike and returned in
    /// [`Conditioned::leg_map`]. A stream should carry it on every sample or on none.
    pub fn push_with_leg_map(
        &mut self,
        time_s: f64,
        gyro_rad_s: &Vector3<f64>,
        accel_m_s2: &Vector3<f64>,
        wrench: &Wrench,
        leg_map: &Matrix6<f64>,
    ) -> Result<Step, EstimatorError> {
        self.push_sequenced(
            time_s,
            None,
            gyro_rad_s,
            accel_m_s2,
            wrench,
            Some(leg_map),
            None,
        )
    }

    /// [`Self::push`] or [`Self::push_with_leg_map`] with the frame's sequence counter, when
    /// it carries one: the counter then places the sample on the grid, so that a late frame
    /// keeps its place and a gap in the counter is a lost frame ([`crate::timebase`]); and
    /// with the plate's pose, when given, conditioned alike into [`Conditioned::motion`]. A
    /// stream should carry the leg map and the pose on every sample or on none.
    // One argument per input channel; a struct would only rename them.
    #[allow(clippy::too_many_arguments)]
    pub fn push_sequenced(
        &mut self,
        time_s: f64,
        sequence: Option<u64>,
        gyro_rad_s: &Vector3<f64>,
        accel_m_s2: &Vector3<f64>,
        wrench: &Wrench,
        leg_map: Option<&Matrix6<f64>>,
        pose: Option<&Pose>,
    ) -> Result<Step, EstimatorError> {
        if !time_s.is_finite() {
            return Err(EstimatorError::NonFiniteSample("time"));
        }
        if !gyro_rad_s.iter().all(|v| v.is_finite()) {
            return Err(EstimatorError::NonFiniteSample("gyro"));
        }
        if !accel_m_s2.iter().all(|v| v.is_finite()) {
            return Err(EstimatorError::NonFiniteSample("accelerometer"));
        }
        if !(wrench.force_n.iter().all(|v| v.is_finite())
            && wrench.torque_nm.iter().all(|v| v.is_finite()))
        {
            return Err(EstimatorError::NonFiniteSample("wrench"));
        }
        let q = rate_products(gyro_rad_s);
        let mut rest = SVector::<f64, 15>::zeros();
        rest.fixed_rows_mut::<6>(0).copy_from(&q);
        rest.fixed_rows_mut::<3>(6).copy_from(accel_m_s2);
        rest.fixed_rows_mut::<3>(9).copy_from(&wrench.force_n);
        rest.fixed_rows_mut::<3>(12).copy_from(&wrench.torque_nm);
        if !all_bounded(&rest) || !all_bounded(gyro_rad_s) {
            return Err(EstimatorError::Overflow("sample magnitude"));
        }
        let map = match leg_map {
            Some(m) => SVector::<f64, 36>::from_iterator(m.iter().copied()),
            None => SVector::zeros(),
        };
        if !all_bounded(&map) {
            return Err(EstimatorError::Overflow("leg map"));
        }
        let mut pose_channels = SVector::<f64, POSE_CHANNELS>::zeros();
        if let Some(p) = pose {
            pose_channels
                .fixed_rows_mut::<3>(0)
                .copy_from(&p.position_m);
            for (channel, v) in pose_channels
                .iter_mut()
                .skip(3)
                .zip(p.rotation.matrix().iter())
            {
                *channel = *v;
            }
            if !all_bounded(&pose_channels) {
                return Err(EstimatorError::NonFiniteSample("pose"));
            }
        }
        let raw = Raw {
            omega: *gyro_rad_s,
            rest,
            leg_map: map,
            pose: pose_channels,
        };

        let place = self
            .time
            .place(time_s, sequence)
            .ok_or(EstimatorError::TimeNotIncreasing)?;
        let with = Carried {
            leg_map: leg_map.is_some(),
            pose: pose.is_some(),
        };
        let missing = place.step.saturating_sub(1);
        let step = if missing == 0 || self.held == 0 {
            self.advance(raw, with)?
        } else {
            // Work on a copy: a sample rejected halfway through a bridge changes nothing.
            let mut next = *self;
            let gap_s = place.step as f64 * self.time.period_s();
            if gap_s > self.config.max_gap_s || missing > MAX_BRIDGED_STEPS {
                next.restarts += 1;
                next.restart();
            } else {
                next.bridge(&raw, missing, with)?;
            }
            let step = next.advance(raw, with)?;
            *self = next;
            step
        };
        self.time.commit(place, time_s, sequence);
        self.samples += 1;
        self.lost = self.lost.saturating_add(missing);
        Ok(step)
    }

    /// Fills the `missing` grid steps before `raw` by Lagrange interpolation through the last
    /// [`FILL_POINTS_BEFORE`] samples held and `raw` (see the [module docs](self)), and runs
    /// each through both stages, its output discarded.
    fn bridge(&mut self, raw: &Raw, missing: u64, with: Carried) -> Result<(), EstimatorError> {
        let m = self.held.min(FILL_POINTS_BEFORE);
        // Held samples at −(m−1) … 0 on the grid (the last m of the history, oldest first),
        // then `raw` after the gap: point m and those after it start as `raw` at the gap's
        // end, and only the first m + 1 points are used.
        let mut xs = [missing as f64 + 1.0; STENCIL];
        let mut points = [*raw; STENCIL];
        let held = self.history.iter().skip(STENCIL.saturating_sub(m));
        for (i, ((x, point), h)) in xs.iter_mut().zip(points.iter_mut()).zip(held).enumerate() {
            *x = i as f64 - (m as f64 - 1.0);
            *point = *h;
        }
        for j in 1..=missing {
            let w = lagrange_weights(&xs, m + 1, j as f64);
            let mut fill = Raw::zero();
            for (point, wk) in points.iter().zip(w).take(m + 1) {
                fill.omega += point.omega * wk;
                fill.rest += point.rest * wk;
                if with.leg_map {
                    fill.leg_map += point.leg_map * wk;
                }
                if with.pose {
                    fill.pose += point.pose * wk;
                }
            }
            self.advance(fill, with)?;
            self.bridged += 1;
        }
        self.bridged_gaps += 1;
        Ok(())
    }

    /// One grid step of both stages; on an error nothing has changed.
    fn advance(&mut self, raw: Raw, with: Carried) -> Result<Step, EstimatorError> {
        if self.held + 1 < STENCIL {
            self.hold(raw);
            return Ok(Step::Started);
        }

        let mut window = self.history;
        window.rotate_left(1);
        window[STENCIL - 1] = raw;
        let (value, slope) = stencil_weights(self.time.period_s());
        let mut omega_dot = Vector3::zeros();
        let mut rest_mid = SVector::<f64, 15>::zeros();
        let mut map_mid = SVector::<f64, 36>::zeros();
        let mut motion_mid = SVector::<f64, MOTION_CHANNELS>::zeros();
        let mut rotation_rate = Matrix3::<f64>::zeros();
        for ((sample, value_k), slope_k) in window.iter().zip(value).zip(slope) {
            omega_dot += sample.omega * slope_k;
            rest_mid += sample.rest * value_k;
            if with.leg_map {
                map_mid += sample.leg_map * value_k;
            }
            if with.pose {
                let mut m = motion_mid.fixed_rows_mut::<POSE_CHANNELS>(0);
                m += sample.pose * value_k;
                let mut w = motion_mid.fixed_rows_mut::<3>(POSE_CHANNELS);
                w += sample.omega * value_k;
                let mut v = motion_mid.fixed_rows_mut::<3>(POSE_CHANNELS + 3);
                v += sample.pose.fixed_rows::<3>(0) * slope_k;
                rotation_rate += rotation_of(&sample.pose) * slope_k;
            }
        }
        if with.pose {
            let rotation = rotation_of(&motion_mid.fixed_rows::<POSE_CHANNELS>(0).into_owned());
            let rate = kinematic_rate(&rotation, &rotation_rate);
            motion_mid
                .fixed_rows_mut::<3>(POSE_CHANNELS + 6)
                .copy_from(&rate);
        }
        let mut x = SVector::<f64, CHANNELS>::zeros();
        x.fixed_rows_mut::<3>(0).copy_from(&omega_dot);
        x.fixed_rows_mut::<15>(3).copy_from(&rest_mid);
        if !all_bounded(&x) {
            return Err(EstimatorError::Overflow("angular acceleration"));
        }

        if !self.primed {
            self.filter.reset_to(&x);
            self.map_filter.reset_to(&map_mid);
            self.motion_filter.reset_to(&motion_mid);
            self.primed = true;
            self.last_excess = None;
            self.warming = self.warmup;
        }
        let y = self.filter.step(&x);
        let map_y = if with.leg_map {
            Some(Matrix6::from_iterator(
                self.map_filter.step(&map_mid).iter().copied(),
            ))
        } else {
            None
        };
        let motion_y = with.pose.then(|| self.motion_filter.step(&motion_mid));
        let gyro_excess_rad_s = motion_y
            .map(|m| m.fixed_rows::<3>(POSE_CHANNELS) - m.fixed_rows::<3>(POSE_CHANNELS + 6));
        let gyro_excess_change_rad_s2 = match (gyro_excess_rad_s, self.last_excess) {
            (Some(now), Some(before)) => Some((now - before) / self.time.period_s()),
            _ => None,
        };
        self.last_excess = gyro_excess_rad_s;
        self.hold(raw);
        if self.warming > 0 {
            self.warming -= 1;
            return Ok(Step::Started);
        }

        let mut signals = RegressorSignals {
            angular_acceleration_rad_s2: y.fixed_rows::<3>(0).into_owned(),
            rate_products_rad2_s2: Vector6::from(y.fixed_rows::<6>(3).into_owned()),
            specific_force_m_s2: y.fixed_rows::<3>(9).into_owned(),
        };
        let offset = self.config.gyro_noise_rad_s * self.config.gyro_noise_rad_s;
        // The squares ωx², ωy², ωz² (the first three rate products) carry the noise's variance.
        for square in signals.rate_products_rad2_s2.iter_mut().take(3) {
            *square -= offset;
        }
        let r = self.config.accelerometer_position_m;
        signals.specific_force_m_s2 -=
            signals.angular_acceleration_rad_s2.cross(&r) + signals.centripetal(&r);
        let motion = motion_y.map(|m| plate_motion(&m, &signals));
        Ok(Step::Ready(Conditioned {
            signals,
            wrench: Wrench {
                force_n: y.fixed_rows::<3>(12).into_owned(),
                torque_nm: y.fixed_rows::<3>(15).into_owned(),
            },
            leg_map: map_y,
            motion,
            gyro_excess_rad_s,
            gyro_excess_change_rad_s2,
        }))
    }
}

/// The rotation matrix of a pose's channels (entries 3… column-major).
fn rotation_of(pose: &SVector<f64, POSE_CHANNELS>) -> Matrix3<f64> {
    Matrix3::from_iterator(pose.fixed_rows::<9>(3).iter().copied())
}

/// ω in P of a rotation R (P to B) moving at Ṙ: Rᵀ Ṙ = [ω]×, its skew part's axial vector
/// (the symmetric part, zero for an exact rotation, is the interpolation's error).
fn kinematic_rate(rotation: &Matrix3<f64>, rate: &Matrix3<f64>) -> Vector3<f64> {
    let w = rotation.tr_mul(rate);
    Vector3::new(
        0.5 * (w.m32 - w.m23),
        0.5 * (w.m13 - w.m31),
        0.5 * (w.m21 - w.m12),
    )
}

/// The plate's motion from the filtered motion channels and the conditioned signals:
/// a = R f_O + g, f_O the specific force at the P origin.
fn plate_motion(m: &SVector<f64, MOTION_CHANNELS>, signals: &RegressorSignals) -> PlateMotion {
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_iterator(
        m.fixed_rows::<9>(3).iter().copied(),
    ));
    PlateMotion {
        pose: Pose {
            position_m: m.fixed_rows::<3>(0).into_owned(),
            rotation,
        },
        velocity_m_s: m.fixed_rows::<3>(POSE_CHANNELS + 3).into_owned(),
        acceleration_m_s2: rotation * signals.specific_force_m_s2 + GRAVITY_B_M_S2,
        angular_velocity_rad_s: m.fixed_rows::<3>(POSE_CHANNELS).into_owned(),
        angular_acceleration_rad_s2: signals.angular_acceleration_rad_s2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::regressor::from_signals;
    use crate::testkit::{Motion, PointBody};

    fn config(cutoff: Option<f64>, r: Vector3<f64>) -> ConditioningConfig {
        ConditioningConfig {
            sample_period_s: 1e-3,
            lowpass_cutoff_hz: cutoff,
            accelerometer_position_m: r,
            max_gap_s: 0.01,
            max_rate_error: 1e-4,
            gyro_noise_rad_s: 0.0,
        }
    }

    /// Along a smooth motion, conditioned wrench − Φ(conditioned signals)·θ stays at the level
    /// of the O(Δt²) difference error, from the very first output, with or without a low-pass
    /// and with the accelerometer off the origin.
    #[test]
    fn filtered_equation_stays_consistent() {
        let body = PointBody::vehicle_like();
        let theta = body.parameters().to_vector();
        let motion = Motion::rich();
        let r = Vector3::new(0.3, -0.2, 0.05);
        for cutoff in [None, Some(20.0)] {
            let mut c = Conditioner::new(config(cutoff, r)).unwrap();
            let mut worst: f64 = 0.0;
            let mut scale: f64 = 0.0;
            for k in 0..3000 {
                let t = k as f64 * 1e-3;
                let s = motion.state(t);
                let w = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
                let accel =
                    s.specific_force + s.omega_dot.cross(&r) + s.omega.cross(&s.omega.cross(&r));
                let wrench = Wrench {
                    force_n: w.fixed_rows::<3>(0).into_owned(),
                    torque_nm: w.fixed_rows::<3>(3).into_owned(),
                };
                if let Step::Ready(out) = c.push(t, &s.omega, &accel, &wrench).unwrap() {
                    let pred = from_signals(&out.signals) * theta;
                    let meas = Vector6::new(
                        out.wrench.force_n.x,
                        out.wrench.force_n.y,
                        out.wrench.force_n.z,
                        out.wrench.torque_nm.x,
                        out.wrench.torque_nm.y,
                        out.wrench.torque_nm.z,
                    );
                    worst = worst.max((pred - meas).norm());
                    scale = scale.max(meas.norm());
                }
            }
            // Fourth-order stencils: (ωΔt)⁴ ≈ 1e-7 at 3 Hz and 1 kHz, on a fraction of the wrench.
            assert!(worst < 1e-8 * scale, "{cutoff:?}: worst {worst} of {scale}");
        }
    }

    /// The excess's change is its step over one grid period, lost frames included. A plate at
    /// rest (so that the gap's linear fill is exact for the pose and the gyro alike) under a
    /// gyro whose error ramps by 2e-3 rad/s per second reads 2e-3 rad/s² on every output, the
    /// first after a bridged gap of two lost samples too: differencing consecutive outputs
    /// would read three times that there.
    #[test]
    fn the_gyro_excess_change_spans_one_grid_step_across_a_bridged_gap() {
        let slope = Vector3::new(2e-3, -2e-3, 1e-3);
        let at_rest = Pose::new(Vector3::new(0.0, 0.0, 1.0), nalgebra::Rotation3::identity());
        let gravity = Vector3::new(0.0, 0.0, 9.81);
        let mut c = Conditioner::new(config(Some(5.0), Vector3::zeros())).unwrap();
        let (mut outputs, mut after_gap) = (0, false);
        let mut worst: f64 = 0.0;
        for k in 0u64..1500 {
            if (1000..1002).contains(&k) {
                continue;
            }
            let t = k as f64 * 1e-3;
            let step = c
                .push_sequenced(
                    t,
                    Some(k),
                    &(slope * t),
                    &gravity,
                    &Wrench::default(),
                    None,
                    Some(&at_rest),
                )
                .unwrap();
            if let Step::Ready(out) = step {
                let change = out.gyro_excess_change_rad_s2.unwrap();
                if k >= 1000 {
                    worst = worst.max((change - slope).norm());
                }
                after_gap |= k == 1002;
                outputs += 1;
            }
        }
        assert!(after_gap && outputs > 1000);
        assert_eq!(c.bridged(), 2);
        // From k = 1000 on, the filter's start transient (a ramp meeting a filter primed at
        // rest) has died to below 1e-9.
        assert!(worst < 1e-9, "worst {worst:e}");
    }

    /// The gyro's excess over the kinematic rate of the pose: zero to the stencils' error on
    /// exact readings along a rotating motion (ω up to 0.45 rad/s), the gyro's own error when it
    /// has one (here a constant offset and a slow ramp), and absent without a pose.
    #[test]
    fn gyro_excess_is_the_gyros_own_error() {
        let motion = Motion::rich();
        let offset = Vector3::new(2e-4, -1e-4, 3e-4);
        for error_scale in [0.0, 1.0] {
            let mut c = Conditioner::new(config(Some(5.0), Vector3::zeros())).unwrap();
            let mut worst: f64 = 0.0;
            let mut outputs = 0;
            for k in 0..3000 {
                let t = k as f64 * 1e-3;
                let s = motion.state(t);
                // A ramp of 1e-4 rad/s per second: its conditioned value lags by the filter's
                // group delay, 1e-4 × 45 ms = 4.5e-6 rad/s at most.
                let error = (offset + Vector3::new(1e-4, 1e-4, -1e-4) * t) * error_scale;
                let pose = Pose::new(s.position_m, s.rotation);
                let step = c
                    .push_sequenced(
                        t,
                        None,
                        &(s.omega + error),
                        &s.specific_force,
                        &Wrench::default(),
                        None,
                        Some(&pose),
                    )
                    .unwrap();
                if let Step::Ready(out) = step {
                    let excess = out.gyro_excess_rad_s.unwrap();
                    worst = worst.max((excess - error).norm());
                    outputs += 1;
                }
            }
            assert!(outputs > 2000);
            assert!(worst < 1e-5, "error scale {error_scale}: worst {worst:e}");
            if error_scale == 0.0 {
                assert!(worst < 1e-8, "exact readings: worst {worst:e}");
            }
        }
        let mut c = Conditioner::new(config(None, Vector3::zeros())).unwrap();
        for k in 0..5 {
            let step = c
                .push(
                    f64::from(k) * 1e-3,
                    &Vector3::x(),
                    &Vector3::z(),
                    &Wrench::default(),
                )
                .unwrap();
            if let Step::Ready(out) = step {
                assert_eq!(out.gyro_excess_rad_s, None);
            }
        }
    }

    #[test]
    fn rejects_bad_samples_without_changing_state() {
        // No low-pass, so no warm-up: the fourth sample is the first output.
        let mut c = Conditioner::new(config(None, Vector3::zeros())).unwrap();
        let w = Wrench::default();
        let one = Vector3::new(0.1, 0.2, 0.3);
        assert_eq!(c.push(-0.002, &one, &one, &w), Ok(Step::Started));
        assert_eq!(c.push(-0.001, &one, &one, &w), Ok(Step::Started));
        assert_eq!(c.push(0.0, &one, &one, &w), Ok(Step::Started));
        let before = c;
        let nan = Vector3::new(f64::NAN, 0.0, 0.0);
        assert_eq!(
            c.push(0.001, &nan, &one, &w),
            Err(EstimatorError::NonFiniteSample("gyro"))
        );
        assert_eq!(
            c.push(0.001, &one, &Vector3::new(0.0, f64::INFINITY, 0.0), &w),
            Err(EstimatorError::NonFiniteSample("accelerometer"))
        );
        assert_eq!(
            c.push(f64::NAN, &one, &one, &w),
            Err(EstimatorError::NonFiniteSample("time"))
        );
        assert_eq!(
            c.push(0.0, &one, &one, &w),
            Err(EstimatorError::TimeNotIncreasing)
        );
        assert_eq!(
            c.push(0.001, &Vector3::new(1e200, 0.0, 0.0), &one, &w),
            Err(EstimatorError::Overflow("sample magnitude"))
        );
        assert_eq!(c, before);
        assert!(matches!(c.push(0.001, &one, &one, &w), Ok(Step::Ready(_))));
        // A long gap restarts.
        assert_eq!(c.push(1.0, &one, &one, &w), Ok(Step::Started));
        assert_eq!(c.restarts(), 1);
        // A finite sample whose derivative overflows, on a grid of a picosecond.
        let mut tiny = config(None, Vector3::zeros());
        tiny.sample_period_s = 1e-12;
        tiny.max_gap_s = 1e-11;
        let mut c = Conditioner::new(tiny).unwrap();
        for k in 0..3 {
            assert_eq!(c.push(k as f64 * 1e-12, &one, &one, &w), Ok(Step::Started));
        }
        let before = c;
        assert_eq!(
            c.push(3e-12, &Vector3::new(1e4, 0.0, 0.0), &one, &w),
            Err(EstimatorError::Overflow("angular acceleration"))
        );
        assert_eq!(c, before);
    }

    /// The noise gains against the spread of conditioned white noise.
    #[test]
    fn noise_gains_match_conditioned_white_noise() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut c = Conditioner::new(config(Some(20.0), Vector3::zeros())).unwrap();
        let (dg, vg) = c.noise_gains();
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let n = Normal::new(0.0, 1.0).unwrap();
        let (mut sd, mut sv, mut count) = (0.0, 0.0, 0.0);
        for k in 0..200_000 {
            let g = Vector3::new(n.sample(&mut rng), 0.0, 0.0);
            let a = Vector3::new(n.sample(&mut rng), 0.0, 0.0);
            if let Step::Ready(out) = c.push(k as f64 * 1e-3, &g, &a, &Wrench::default()).unwrap() {
                if k > 1000 {
                    sd += out.signals.angular_acceleration_rad_s2.x.powi(2);
                    sv += out.signals.specific_force_m_s2.x.powi(2);
                    count += 1.0;
                }
            }
        }
        assert!(
            (sd / count / dg - 1.0).abs() < 0.02,
            "{} vs {dg}",
            sd / count
        );
        assert!(
            (sv / count / vg - 1.0).abs() < 0.02,
            "{} vs {vg}",
            sv / count
        );
    }

    /// Lost samples are bridged on the grid: the conditioned ω̇ of white gyro noise keeps the
    /// spread of the uniform stream (fed the uneven steps, the stencil's unbalanced taps let
    /// the noise through at low frequency: σ(J_C) four times larger at 1 % lost), and along a
    /// smooth motion the equation stays consistent across the gaps.
    #[test]
    fn lost_samples_are_bridged_without_leaking_noise() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let lost = |k: u64| k % 37 == 5 || k % 101 == 7 || k % 101 == 8;
        let mut c = Conditioner::new(config(Some(20.0), Vector3::zeros())).unwrap();
        let (dg, _) = c.noise_gains();
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let n = Normal::new(0.0, 1.0).unwrap();
        let (mut sd, mut count) = (0.0, 0.0);
        for k in 0..200_000u64 {
            let g = Vector3::new(n.sample(&mut rng), 0.0, 0.0);
            if lost(k) {
                continue;
            }
            let t = k as f64 * 1e-3;
            let step = c
                .push_sequenced(t, Some(k), &g, &g, &Wrench::default(), None, None)
                .unwrap();
            if let Step::Ready(out) = step {
                if k > 1000 {
                    sd += out.signals.angular_acceleration_rad_s2.x.powi(2);
                    count += 1.0;
                }
            }
        }
        assert!(sd / count < 1.1 * dg, "{} vs {dg}", sd / count);
        // 9260 lost in 7173 gaps (runs of one to three).
        assert_eq!((c.restarts(), c.lost(), c.bridged()), (0, 9260, 9260));
        assert_eq!(c.bridged_gaps(), 7173);
        assert!(c.timing().from_sequence);

        let body = PointBody::vehicle_like();
        let theta = body.parameters().to_vector();
        let motion = Motion::rich();
        let mut c = Conditioner::new(config(Some(20.0), Vector3::zeros())).unwrap();
        let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
        for k in 0..3000u64 {
            if lost(k) {
                continue;
            }
            // Without a counter: the timestamps place the samples.
            let t = k as f64 * 1e-3;
            let s = motion.state(t);
            let w = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
            let wrench = Wrench {
                force_n: w.fixed_rows::<3>(0).into_owned(),
                torque_nm: w.fixed_rows::<3>(3).into_owned(),
            };
            if let Step::Ready(out) = c.push(t, &s.omega, &s.specific_force, &wrench).unwrap() {
                let pred = from_signals(&out.signals) * theta;
                let meas = crate::wrench::to_vector(&out.wrench);
                worst = worst.max((pred - meas).norm());
                scale = scale.max(meas.norm());
            }
        }
        assert!(c.bridged() > 100 && c.restarts() == 0);
        // The linear fill's O(T²) error on a motion up to 3 Hz (4.6e-4 measured).
        assert!(worst < 1e-3 * scale, "worst {worst} of {scale}");
    }

    /// The warm-up is about ten time constants of the low-pass (the 1e-3 decay of a
    /// second-order Butterworth's start transient), and none without one.
    #[test]
    fn warm_up_is_about_ten_time_constants() {
        for (cutoff, period) in [(5.0, 1e-3), (20.0, 1e-3), (20.0, 1e-2)] {
            let mut cc = config(Some(cutoff), Vector3::zeros());
            cc.sample_period_s = period;
            cc.max_gap_s = 10.0 * period;
            let n = Conditioner::new(cc).unwrap().warmup_samples() as f64;
            let tau = 1.0 / (2.0 * core::f64::consts::PI * cutoff * period);
            // Continuous envelope e^(−t/(√2 τ)) reaches 1e-3 at √2·ln(1e3)·τ ≈ 9.8 τ.
            assert!(
                n > 8.0 * tau && n < 13.0 * tau,
                "{cutoff} Hz at {period} s: {n} vs τ {tau}"
            );
        }
        let none = Conditioner::new(config(None, Vector3::zeros())).unwrap();
        assert_eq!(none.warmup_samples(), 0);
    }

    #[test]
    fn stencil_weights_are_the_fourth_order_staggered_ones() {
        let t = 2e-3;
        let (v, d) = stencil_weights(t);
        let ve = [-1.0 / 16.0, 9.0 / 16.0, 9.0 / 16.0, -1.0 / 16.0];
        let de = [1.0 / 24.0, -27.0 / 24.0, 27.0 / 24.0, -1.0 / 24.0];
        for k in 0..4 {
            assert!((v[k] - ve[k]).abs() < 1e-9);
            assert!((d[k] * t - de[k]).abs() < 1e-9);
        }
        // The value weights are Lagrange's at the midpoint of the middle two samples.
        let times = [10.0, 10.0 + t, 10.0 + 2.0 * t, 10.0 + 3.0 * t];
        let tm = 0.5 * (times[1] + times[2]);
        let l = lagrange_weights(&times, STENCIL, tm);
        for k in 0..4 {
            assert!((l[k] - v[k]).abs() < 1e-9, "{l:?}");
        }
        // Exact for cubics, value and derivative.
        let times = [0.0, t, 2.0 * t, 3.0 * t];
        let tm = 0.5 * (times[1] + times[2]);
        let f = |x: f64| 1.0 - 2.0 * x + 3e2 * x * x - 4e4 * x * x * x;
        let fd = |x: f64| -2.0 + 6e2 * x - 12e4 * x * x;
        let val: f64 = (0..4).map(|k| v[k] * f(times[k])).sum();
        let der: f64 = (0..4).map(|k| d[k] * f(times[k])).sum();
        assert!((val - f(tm)).abs() < 1e-12);
        assert!((der - fd(tm)).abs() < 1e-9);
    }
}
