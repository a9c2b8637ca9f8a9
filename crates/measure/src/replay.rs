//! The estimator re-run offline on a measurement's recorded sensor frames, by the same
//! frame-to-sample rule ([`crate::feed`]) and with the same feeding as the online run
//! ([`crate::tick`]): every frame of the measurement in sequence order (put back in order
//! first, [`crate::reorder`]: a log holds frames as the link delivered them), from the home
//! pose's warm start;
//! frames before the window only warm the conditioning; frames after it are not fed. With the
//! recorded settings the result is the online estimate, to rounding.

use control::io::SensorFrame;
use estimator::{Estimate, EstimatorConfig, OnlineEstimator, Outcome, Sample};
use kinematics::FkOptions;

use crate::feed::Feed;
use crate::reorder::{Reorder, ReorderCounts};
use crate::report::ThetaHistory;
use rig_description::config::ImuMounting;

/// One estimate along the way.
#[derive(Clone, Copy, Debug)]
pub struct TracePoint {
    /// Backend time, s.
    pub time_s: f64,
    /// The estimate of everything on the plate.
    pub estimate: Estimate,
}

/// The offline estimate of one measurement.
#[derive(Clone, Debug)]
pub struct ReplayOutcome {
    /// The settings used.
    pub config: EstimatorConfig,
    /// The final estimate of everything on the plate.
    pub estimate: Estimate,
    /// θ after every used sample (decimated beyond [`ThetaHistory::CAPACITY`] samples).
    pub theta_history: ThetaHistory,
    /// Estimates every `trace_every` frames from the window's start (every 2ᵏ·`trace_every` once
    /// more than [`TRACE_CAPACITY`] points), and the final one.
    pub trace: Vec<TracePoint>,
    /// Backend time of the first frame in the window (the excitation's start), s.
    pub excitation_start_s: f64,
    /// From there to the last sample used, s.
    pub excitation_s: f64,
    /// Frames whose forward kinematics failed.
    pub fk_failures: u64,
    /// Frames of the measurement given.
    pub frames: u64,
    /// Frames the reordering dropped: later than its window, or duplicates
    /// ([`crate::reorder`]).
    pub reordered: ReorderCounts,
    /// Change of θ from one sigma of accelerometer bias along x, y, z (rows), when a bias
    /// figure is known.
    pub accel_bias_effect: Option<[[f64; 10]; 3]>,
    /// Change of θ from one sigma of zero offset on each load cell (rows), when a figure is
    /// known.
    pub load_cell_bias_effect: Option<[[f64; 10]; 6]>,
    /// The run's error-budget inputs ([`crate::budget`]), when the replay was given the rig
    /// description's figures ([`Replay::with_budget`]).
    pub budget: Option<crate::budget::RunBudget>,
    /// The brake hold's static weighing ([`crate::weigh`]), when the replay was asked for it
    /// ([`Replay::with_weighing`]) and the hold's frames were given.
    pub static_weighing: Option<crate::weigh::StaticWeighing>,
}

/// Why a replay gave nothing.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    /// The estimator refused the settings.
    #[error("the estimator refused its settings: {0}")]
    Settings(estimator::EstimatorError),
    /// No frame reached the window.
    #[error("no frame reaches the estimator's window (from {window_start_s} s on)")]
    NoFramesInWindow {
        /// Start of the window, s.
        window_start_s: f64,
    },
}

/// The datasheet sigmas whose effects the replay reports (see [`crate::systematic`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BiasSigmas {
    /// Accelerometer bias, m/s².
    pub accel_m_s2: f64,
    /// Load-cell zero offset, N.
    pub load_cell_n: f64,
}

/// Trace points kept at most: beyond, every other one is dropped and the spacing doubles, so
/// a replay's memory does not grow with the log's length.
pub const TRACE_CAPACITY: usize = 4096;

/// A replay fed one frame at a time (a log streamed chunk by chunk): [`Replay::push`] each
/// frame of the measurement in order, then [`Replay::finish`]. Memory is bounded: θ's history
/// is a [`ThetaHistory`], the trace at most [`TRACE_CAPACITY`] points.
pub struct Replay {
    config: EstimatorConfig,
    /// Boxed, as [`crate::tick::Tick::estimator`] is.
    estimator: Box<OnlineEstimator>,
    feed: Feed,
    sigmas: BiasSigmas,
    trace_every: u64,
    history: ThetaHistory,
    trace: Vec<TracePoint>,
    /// Frame index of each trace point.
    trace_index: Vec<u64>,
    fk_failures: u64,
    frames: u64,
    /// The frames given to [`Self::push`], put back in sequence order.
    reorder: Reorder,
    start_s: f64,
    last_used_s: f64,
    last_time_s: f64,
    /// The budget's record and figures, when asked for.
    budget: Option<(crate::record::RunRecord, crate::budget::Figures)>,
    /// The static weighing of the first frames (the brake hold's), with the figures it counts.
    weighing: Option<(crate::weigh::Weigher, u64, crate::budget::Figures)>,
}

impl Replay {
    /// A replay with `config`, posed by forward kinematics with `fk` and the IMU turned by
    /// `imu`; a trace point every `trace_every` frames once the window started.
    pub fn new(
        config: EstimatorConfig,
        fk: FkOptions,
        imu: &ImuMounting,
        sigmas: BiasSigmas,
        trace_every: u64,
    ) -> Result<Self, ReplayError> {
        Ok(Self {
            estimator: Box::new(OnlineEstimator::new(config).map_err(ReplayError::Settings)?),
            feed: Feed::new(config.geometry, fk, imu),
            config,
            sigmas,
            trace_every: trace_every.max(1),
            history: ThetaHistory::default(),
            trace: Vec::new(),
            trace_index: Vec::new(),
            fk_failures: 0,
            frames: 0,
            reorder: Reorder::default(),
            start_s: f64::NAN,
            last_used_s: f64::NAN,
            last_time_s: f64::NAN,
            budget: None,
            weighing: None,
        })
    }

    /// Also weighs the load statically over the measurement's first frames, its brake hold
    /// (`run.brake_hold_s` of `config`) or the rest before the plate first moves if that is
    /// shorter ([`crate::weigh::RestWatch`]), as the online measurement does ([`crate::weigh`]).
    pub fn with_weighing(mut self, config: &rig_description::Config) -> Self {
        let hold =
            ((config.run.brake_hold_s * config.sensors.sample_rate_hz).round() as u64).max(1);
        let weigher = crate::weigh::Weigher::new(
            self.config.geometry,
            self.config.legs,
            crate::weigh::gravity_of(config),
        )
        .watching(crate::weigh::RestWatch::of(config));
        self.weighing = Some((weigher, hold, crate::budget::Figures::of(config)));
        self
    }

    /// Applies a fitted IMU alignment ([`Feed::aligned`]), as the online measurement does
    /// when the rig description references a calibration.
    pub fn with_alignment(
        mut self,
        alignment: Option<&rig_description::calibration::ImuAlignment>,
    ) -> Self {
        self.feed = self.feed.aligned(alignment, self.config.sample_period_s);
        self
    }

    /// Applies fitted load-cell gains ([`Feed::with_load_cell_gains`]), as the online
    /// measurement does when the rig description references a calibration.
    pub fn with_load_cell_gains(
        mut self,
        gains: Option<&rig_description::calibration::LoadCellGains>,
    ) -> Self {
        self.feed = self.feed.with_load_cell_gains(gains);
        self
    }

    /// Also records the used samples for the error budget, with the rig description's
    /// `figures` ([`crate::budget`]), as the online measurement does.
    pub fn with_budget(mut self, figures: crate::budget::Figures) -> Self {
        let record =
            crate::record::RunRecord::new(self.config.geometry, self.config.sample_period_s, 0);
        self.budget = Some((record, figures));
        self
    }

    /// The next frame of the measurement as it came: put back in sequence order
    /// ([`crate::reorder`]), then turned into its sample.
    pub fn push(&mut self, frame: &SensorFrame) {
        let mut reorder = std::mem::take(&mut self.reorder);
        reorder.push(*frame, &mut |f| self.push_in_order(&f));
        self.reorder = reorder;
    }

    fn push_in_order(&mut self, frame: &SensorFrame) {
        let sample = self.feed.next(frame);
        self.push_fed(frame.time_s, sample);
    }

    /// The frame-to-sample stage ([`Feed`]) in its current state, to run on another thread:
    /// a reader that turns each frame into its sample there and hands it to
    /// [`Self::push_fed`] splits the per-frame work (forward kinematics on one side, the
    /// estimator on the other) with the same result as [`Self::push`] when the frames come in
    /// sequence order ([`crate::reorder`] puts them so). Use one or the other for a whole
    /// measurement.
    pub fn feed(&self) -> Feed {
        self.feed
    }

    /// The next frame of the measurement, at backend time `time_s`, as its [`Feed`] (from
    /// [`Self::feed`]) turned it into a sample; `None` when its forward kinematics failed.
    pub fn push_fed(&mut self, time_s: f64, sample: Option<Sample>) {
        let index = self.frames;
        self.frames += 1;
        let config = &self.config;
        if self.start_s.is_nan() && time_s >= config.window_start_s {
            self.start_s = time_s;
        }
        if let (Some((weigher, hold, _)), Some(s)) = (&mut self.weighing, &sample) {
            if index < *hold {
                weigher.push(s.time_s, &s.pose, &s.leg_forces_n);
            }
        }
        match sample {
            Some(s) if time_s <= config.window_end_s => {
                if let Ok(Outcome::Used) = self.estimator.update(&s) {
                    self.history.push(self.estimator.theta_quick().into());
                    if let Some((record, _)) = &mut self.budget {
                        record.push(&s);
                    }
                    self.last_used_s = time_s;
                }
            }
            Some(_) => {}
            None => self.fk_failures += 1,
        }
        if self.start_s.is_finite() && index.is_multiple_of(self.trace_every) {
            self.trace.push(TracePoint {
                time_s,
                estimate: self.estimator.estimate(),
            });
            self.trace_index.push(index);
            if self.trace.len() >= TRACE_CAPACITY {
                self.thin_trace();
            }
        }
        self.last_time_s = time_s;
    }

    /// Keeps the trace points at multiples of twice the spacing.
    fn thin_trace(&mut self) {
        let every = self.trace_every * 2;
        let keep: Vec<bool> = self
            .trace_index
            .iter()
            .map(|i| i.is_multiple_of(every))
            .collect();
        let mut k = keep.iter();
        self.trace.retain(|_| k.next().copied().unwrap_or(false));
        self.trace_index.retain(|i| i.is_multiple_of(every));
        self.trace_every = every;
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The outcome, the frames still held for reordering fed first. Errors: no frame
    /// reached the window.
    pub fn finish(mut self) -> Result<ReplayOutcome, ReplayError> {
        let mut reorder = std::mem::take(&mut self.reorder);
        reorder.flush(&mut |f| self.push_in_order(&f));
        let config = self.config;
        if self.start_s.is_nan() {
            return Err(ReplayError::NoFramesInWindow {
                window_start_s: config.window_start_s,
            });
        }
        let estimate = self.estimator.estimate();
        let mut trace = self.trace;
        if trace.last().is_none_or(|t| t.time_s != self.last_time_s) {
            trace.push(TracePoint {
                time_s: self.last_time_s,
                estimate,
            });
        }
        let exact = crate::budget::EstimatorEffects {
            accel: crate::systematic::accel_bias_effect(&self.estimator, self.sigmas.accel_m_s2),
            load_cell: crate::systematic::load_cell_bias_effect(
                &self.estimator,
                self.sigmas.load_cell_n,
            ),
            accel_offset_measured: self.estimator.accelerometer_offset().is_some(),
            load_cell_drift: self.estimator.load_cell_drift(),
        };
        let budget = self.budget.as_ref().map(|(record, figures)| {
            crate::budget::analyse(record, &config, figures, &estimate, &exact)
        });
        Ok(ReplayOutcome {
            config,
            estimate,
            theta_history: self.history,
            trace,
            excitation_start_s: self.start_s,
            excitation_s: if self.last_used_s.is_finite() {
                self.last_used_s - self.start_s
            } else {
                0.0
            },
            fk_failures: self.fk_failures,
            frames: self.frames,
            reordered: reorder.counts(),
            accel_bias_effect: exact.accel,
            load_cell_bias_effect: exact.load_cell,
            budget,
            static_weighing: self
                .weighing
                .as_ref()
                .and_then(|(w, _, figures)| w.finish(figures)),
        })
    }
}

/// Re-runs the estimator with `config` on `frames` (one measurement's, in order), posed by
/// forward kinematics with `fk` and the IMU turned by `imu`; a trace point every
/// `trace_every` frames once the window started ([`Replay`] on every frame).
pub fn replay<'a>(
    frames: impl IntoIterator<Item = &'a SensorFrame>,
    config: EstimatorConfig,
    fk: FkOptions,
    imu: &ImuMounting,
    sigmas: BiasSigmas,
    trace_every: u64,
) -> Result<ReplayOutcome, ReplayError> {
    let mut r = Replay::new(config, fk, imu, sigmas, trace_every)?;
    for frame in frames {
        r.push(frame);
    }
    r.finish()
}
