//! The estimator re-run offline on a measurement's recorded sensor frames, by the same
//! frame-to-sample rule ([`crate::feed`]) and with the same feeding as the online run
//! ([`crate::tick`]): every frame of the measurement in order, from the home pose's warm start;
//! frames before the window only warm the conditioning; frames after it are not fed. With the
//! recorded settings the result is the online estimate, to rounding.

use control::io::SensorFrame;
use estimator::{Estimate, EstimatorConfig, OnlineEstimator, Outcome};
use kinematics::FkOptions;

use crate::config::ImuMounting;
use crate::feed::Feed;

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
    /// θ after every used sample.
    pub theta_history: Vec<[f64; 10]>,
    /// Estimates every `trace_every` frames from the window's start, and the final one.
    pub trace: Vec<TracePoint>,
    /// Backend time of the first frame in the window (the excitation's start), s.
    pub excitation_start_s: f64,
    /// From there to the last sample used, s.
    pub excitation_s: f64,
    /// Frames whose forward kinematics failed.
    pub fk_failures: u64,
    /// Frames of the measurement given.
    pub frames: u64,
    /// Change of θ from one sigma of accelerometer bias along x, y, z (rows), when a bias
    /// figure is known.
    pub accel_bias_effect: Option<[[f64; 10]; 3]>,
    /// Change of θ from one sigma of zero offset on each load cell (rows), when a figure is
    /// known.
    pub load_cell_bias_effect: Option<[[f64; 10]; 6]>,
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

/// Re-runs the estimator with `config` on `frames` (one measurement's, in order), posed by
/// forward kinematics with `fk` and the IMU turned by `imu`; a trace point every
/// `trace_every` frames once the window started.
pub fn replay<'a>(
    frames: impl IntoIterator<Item = &'a SensorFrame>,
    config: EstimatorConfig,
    fk: FkOptions,
    imu: &ImuMounting,
    sigmas: BiasSigmas,
    trace_every: u64,
) -> Result<ReplayOutcome, ReplayError> {
    let mut estimator = OnlineEstimator::new(config).map_err(ReplayError::Settings)?;
    let mut feed = Feed::new(config.geometry, fk, imu);
    let trace_every = trace_every.max(1);
    let mut history = Vec::new();
    let mut trace = Vec::new();
    let (mut fk_failures, mut frames_seen) = (0u64, 0u64);
    let (mut start_s, mut last_used_s, mut last_time_s) = (f64::NAN, f64::NAN, f64::NAN);
    for (index, frame) in frames.into_iter().enumerate() {
        frames_seen += 1;
        let sample = feed.next(frame);
        if start_s.is_nan() && frame.time_s >= config.window_start_s {
            start_s = frame.time_s;
        }
        match sample {
            Some(s) if frame.time_s <= config.window_end_s => {
                if let Ok(Outcome::Used) = estimator.update(&s) {
                    history.push(estimator.theta().into());
                    last_used_s = frame.time_s;
                }
            }
            Some(_) => {}
            None => fk_failures += 1,
        }
        if start_s.is_finite() && (index as u64).is_multiple_of(trace_every) {
            trace.push(TracePoint {
                time_s: frame.time_s,
                estimate: estimator.estimate(),
            });
        }
        last_time_s = frame.time_s;
    }
    if start_s.is_nan() {
        return Err(ReplayError::NoFramesInWindow {
            window_start_s: config.window_start_s,
        });
    }
    let estimate = estimator.estimate();
    if trace.last().is_none_or(|t| t.time_s != last_time_s) {
        trace.push(TracePoint {
            time_s: last_time_s,
            estimate,
        });
    }
    Ok(ReplayOutcome {
        config,
        estimate,
        theta_history: history,
        trace,
        excitation_start_s: start_s,
        excitation_s: if last_used_s.is_finite() {
            last_used_s - start_s
        } else {
            0.0
        },
        fk_failures,
        frames: frames_seen,
        accel_bias_effect: crate::systematic::accel_bias_effect(&estimator, sigmas.accel_m_s2),
        load_cell_bias_effect: crate::systematic::load_cell_bias_effect(
            &estimator,
            sigmas.load_cell_n,
        ),
    })
}
