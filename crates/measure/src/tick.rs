//! The tick the product runs: one sensor frame through the controller (sensor checks, forward
//! kinematics, set-point, inverse kinematics, six PIDs, supervisor gate), then the same frame
//! through the frame-to-sample rule ([`crate::feed`]) at the pose the controller found, then the
//! estimator's update. [`crate::measurement`] runs exactly this per sample; the criterion
//! benches, `stewart bench` and the zero-allocation test time and count exactly this.
//! Allocation-free, `Copy`.
//!
//! The estimator exists from the measurement's first frame: every frame before the excitation
//! only warms its conditioning (filtered derivative, low-pass, warm-up), so the whole
//! excitation reaches the fit. Its window `[t₀, t₀ + T]` is set on the first frame of the
//! excitation (t₀ its time, T the trajectory's length); frames after the window are not fed.

use control::controller::{Controller, TickOutput};
use control::io::SensorFrame;
use control::supervisor::Phase;
use estimator::{EstimatorConfig, EstimatorError, OnlineEstimator, Outcome, Sample};

use crate::feed::Feed;

/// The state of one measurement's tick: controller, frame-to-sample rule and estimator.
#[derive(Clone, Debug)]
pub struct Tick {
    /// FK, set-point, IK, PIDs, supervisor.
    pub controller: Controller,
    /// The frame-to-sample rule.
    pub feed: Feed,
    /// Wrench, conditioning, regressor, RLS. Boxed: its inline state (tens of kilobytes, see
    /// `estimator::ONLINE_ESTIMATOR_MAX_BYTES`) would otherwise be copied through the frames of
    /// every call that moves a tick, which an unoptimised build's thread stack cannot afford.
    pub estimator: Box<OnlineEstimator>,
    /// Length of the excitation (the fit window), s.
    pub excitation_s: f64,
    /// The fit window, once the excitation started.
    pub window: Option<(f64, f64)>,
}

/// What one [`Tick::step`] produced.
#[derive(Clone, Copy, Debug)]
pub struct TickStep {
    /// The controller's output; its `command` goes to the backend.
    pub control: TickOutput,
    /// The frame as the estimator's input; `None` when forward kinematics gave no pose.
    pub sample: Option<Sample>,
    /// The estimator's verdict on the sample; `None` when it was not fed (no sample, or past
    /// its window).
    pub estimator: Option<Result<Outcome, EstimatorError>>,
    /// This frame opened the fit window (the first frame of the excitation).
    pub window_opened: bool,
}

/// Start of the fit window before the excitation: after every frame, so frames only warm the
/// conditioning.
pub const WINDOW_NOT_OPEN_S: f64 = f64::MAX;

impl Tick {
    /// A tick whose estimator is built from `estimator` (window not yet open) and whose
    /// excitation lasts `excitation_s`.
    pub fn new(
        controller: Controller,
        feed: Feed,
        mut estimator: EstimatorConfig,
        excitation_s: f64,
    ) -> Result<Self, EstimatorError> {
        estimator.window_start_s = WINDOW_NOT_OPEN_S;
        estimator.window_end_s = f64::INFINITY;
        Ok(Self {
            controller,
            feed,
            estimator: Box::new(OnlineEstimator::new(estimator)?),
            excitation_s,
            window: None,
        })
    }

    /// One tick of the brake hold, before the controller runs: the frame's pose by the feed's
    /// own forward kinematics, fed to the estimator's conditioning.
    pub fn hold(&mut self, frame: &SensorFrame) -> Option<Sample> {
        let sample = self.feed.next(frame)?;
        let _ = self.estimator.update(&sample);
        Some(sample)
    }

    /// After the brake hold: the static load `feedforward_n` as the PIDs' feed-forward, the
    /// hold's last pose as the controller's forward-kinematics warm start, and the inverse
    /// dynamics of `load` (the plate with what it carries, as its owner knows it; see
    /// [`crate::setup::feedforward_load`]) on top, when given.
    pub fn start_control(
        &mut self,
        feedforward_n: [f64; 6],
        load: Option<estimator::InertialParameters>,
    ) -> anyhow::Result<()> {
        self.controller.set_pose_guess(self.feed.pose_guess());
        self.controller
            .set_feedforward(feedforward_n)
            .map_err(|e| anyhow::anyhow!("refused before motion: {e}"))?;
        if let Some(load) = load {
            self.controller.set_load(load).map_err(|e| {
                anyhow::anyhow!("refused before motion: the feed-forward's load: {e}")
            })?;
        }
        Ok(())
    }

    /// One tick on `frame`. See the [module docs](self).
    #[inline]
    pub fn step(&mut self, frame: &SensorFrame) -> TickStep {
        let control = self.controller.tick(frame);
        let sample = control.measured_pose.map(|pose| {
            self.feed.accept(pose);
            self.feed.sample(frame, pose)
        });
        let mut window_opened = false;
        if self.window.is_none() && control.phase == Phase::Excite {
            let window = (frame.time_s, frame.time_s + self.excitation_s);
            if self.estimator.set_window(window.0, window.1).is_ok() {
                self.window = Some(window);
                window_opened = true;
            }
        }
        let estimator = match &sample {
            // Every frame up to the window's end, whatever the phase, so that a replay of the
            // log feeds exactly the same samples.
            Some(s) if frame.time_s <= self.estimator.config().window_end_s => {
                Some(self.estimator.update(s))
            }
            _ => None,
        };
        TickStep {
            control,
            sample,
            estimator,
            window_opened,
        }
    }
}
