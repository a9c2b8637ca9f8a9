//! One measurement on any [`Backend`] (the simulator, a rig behind a link, or a user's own
//! hardware): brake hold, settle, excitation, park — with the online estimator fed on every
//! tick, an [`Observer`] told everything, and a controlled stop on request or fault.
//!
//! The sequence, per measurement:
//!
//! 1. **Brake hold** (`run.brake_hold_s`): safe-stop commands while the braked platform carries
//!    its load; the mean leg forces of the last 0.1 s become the PID feed-forward, so the
//!    integrators need not build up the static load (no model of the load is needed: what the
//!    load cells read is what the legs must push).
//! 2. **Controller** ([`control::controller::Controller`]): ramp to home and hold
//!    (`run.settle_s`), the excitation, the park ramp and hold, then brakes on.
//! 3. **Estimator**: fed every frame from the first one by the rule of [`crate::feed`], through
//!    [`crate::tick::Tick`]; frames before the excitation only warm its conditioning, the fit
//!    window opens on the first frame of the excitation and closes a trajectory's length later.
//!
//! The estimator sees only sensor frames; nothing here can read a simulator's truth. Nothing in
//! the per-frame loop allocates: the history of θ is reserved for the whole window up front.

use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{anyhow, bail, Result};
use control::controller::Controller;
use control::io::{Backend, CommandFrame, SensorFrame};
use control::supervisor::Phase;
use control::trajectory::Trajectory;
use estimator::{Estimate, EstimatorConfig, Outcome, Sample};
use kinematics::Geometry;

use crate::observer::{EstimatorStarted, MeasurementEnded, Observer, TickEvent};
use crate::report::ThetaHistory;
use crate::setup::{self, Measurement};
use crate::tick::Tick;
use crate::TareEstimate;
use rig_description::config::Config;

/// What a measurement needs besides the backend and the controller.
#[derive(Clone, Copy, Debug)]
pub struct MeasureSetup<'a> {
    /// The rig description.
    pub config: &'a Config,
    /// The platform design.
    pub geometry: Geometry,
    /// Tare or loaded.
    pub measurement: Measurement,
    /// The tare to subtract for the observer's payload estimate (loaded runs).
    pub tare: Option<&'a TareEstimate>,
}

/// How a measurement ended.
#[derive(Clone, Debug, PartialEq)]
pub enum End {
    /// Excitation completed and the platform parked.
    Completed,
    /// Stop requested (Ctrl-C): parked early.
    Interrupted,
    /// The supervisor latched a fault, or the backend failed (the safe stop was sent).
    Fault(String),
}

/// The last sensor frame the loop read: what a safe stop sent after a failure answers.
#[derive(Clone, Copy, Debug, Default)]
struct LastFrame {
    sequence: u64,
    time_s: f64,
}

impl LastFrame {
    fn saw(&mut self, frame: &SensorFrame) {
        self.sequence = frame.sequence;
        self.time_s = frame.time_s;
    }
}

/// What a measurement produced.
#[derive(Clone, Debug)]
pub struct MeasureOutcome {
    /// The final estimate of everything on the plate (None if the excitation never started).
    pub estimate: Option<Estimate>,
    /// θ after every used sample (everything on the plate, not tare-corrected), decimated
    /// beyond [`ThetaHistory::CAPACITY`] samples.
    pub theta_history: ThetaHistory,
    /// The estimator's settings (None if the excitation never started).
    pub estimator_config: Option<EstimatorConfig>,
    /// Backend time from the first excitation sample to the last one fed, s.
    pub excitation_s: f64,
    /// Frames that gave no pose (forward kinematics failed or the controller refused the
    /// frame's sensors): not fed to the estimator.
    pub fk_failures: u64,
    /// Change of θ caused by an accelerometer bias of one datasheet sigma along P's x, y and z
    /// (rows), from the estimator's first-order sensitivity; `None` without a bias figure
    /// (ideal sensors) or without an excitation. See [`crate::systematic`].
    pub accel_bias_effect: Option<[[f64; 10]; 3]>,
    /// Change of θ caused by a zero offset of one datasheet sigma on each load cell (rows:
    /// legs); `None` without a figure or an excitation.
    pub load_cell_bias_effect: Option<[[f64; 10]; 6]>,
    /// The run's error-budget inputs ([`crate::budget`]): each systematic source's effects
    /// from the run's own record, its counts and statistical shares, the rigid-body check;
    /// `None` without an excitation.
    pub budget: Option<crate::budget::RunBudget>,
    /// The run's record of the samples the estimator used (~100 Hz block means,
    /// [`crate::record`]): what the IMU calibration fits ([`rig_description::calibration::imu`]);
    /// `None` without an excitation.
    pub record: Option<crate::record::RunRecord>,
    /// The accelerometer's offset measured at rest before the excitation and subtracted from
    /// every sample the estimator fitted ([`estimator::hold`]), P axes, m/s²; `None` when none
    /// was measured. The record holds the readings before it is subtracted.
    pub accel_offset_m_s2: Option<[f64; 3]>,
    /// The brake hold's static weighing of everything on the plate ([`crate::weigh`]); `None`
    /// when the hold was too short or stopped.
    pub static_weighing: Option<crate::weigh::StaticWeighing>,
    /// How it ended.
    pub end: End,
    /// It ended by a stall (a sample gap, the link silent, the rig's watchdog) rather than a
    /// fault of the platform: the run may be repeated.
    pub stall: bool,
}

impl MeasureOutcome {
    /// A measurement that ended (`end`) before its excitation: no estimate.
    pub fn ended_early(end: End, fk_failures: u64) -> Self {
        Self {
            estimate: None,
            theta_history: ThetaHistory::default(),
            estimator_config: None,
            excitation_s: 0.0,
            fk_failures,
            accel_bias_effect: None,
            load_cell_bias_effect: None,
            budget: None,
            record: None,
            accel_offset_m_s2: None,
            static_weighing: None,
            end,
            stall: false,
        }
    }
}

/// Expected number of samples of a measurement of `trajectory`, for progress displays.
pub fn expected_samples(config: &Config, trajectory: &Trajectory) -> u64 {
    let c = &config.control;
    let r = &config.run;
    let total_s = r.brake_hold_s
        + c.settle_ramp_s
        + r.settle_s
        + trajectory.duration_s()
        + r.park_s
        + c.park_hold_s;
    (total_s * config.sensors.sample_rate_hz).ceil() as u64
}

/// Runs one measurement with `controller`, built (and so checked) beforehand for the
/// measurement's trajectory, e.g. by [`setup::controller`]: nothing slow happens between
/// samples once the backend runs (a rig's watchdog counts). Its feed-forward is replaced by the
/// brake hold's load. When `stop` is set the platform parks and the outcome says
/// [`End::Interrupted`]. Errors are backend or observer failures (after a best-effort safe
/// stop); a supervisor fault ends the measurement normally with [`End::Fault`].
pub fn measure<B, O>(
    backend: &mut B,
    setup: &MeasureSetup<'_>,
    controller: Controller,
    observer: &mut O,
    stop: &AtomicBool,
) -> Result<MeasureOutcome>
where
    B: Backend,
    B::Error: std::fmt::Display,
    O: Observer + ?Sized,
{
    let mut last_frame = LastFrame::default();
    let result = run(backend, setup, controller, observer, stop, &mut last_frame);
    if result.is_err() {
        // Whatever failed (the backend, the observer), the platform must not keep moving, and
        // the record says so.
        let command = CommandFrame::safe_stop(u64::MAX, last_frame.sequence);
        let _ = backend.write(&command);
        let _ = observer.safe_stop(setup.measurement, last_frame.time_s, &command);
    }
    result
}

fn run<B, O>(
    backend: &mut B,
    setup: &MeasureSetup<'_>,
    controller: Controller,
    observer: &mut O,
    stop: &AtomicBool,
    last_frame: &mut LastFrame,
) -> Result<MeasureOutcome>
where
    B: Backend,
    B::Error: std::fmt::Display,
    O: Observer + ?Sized,
{
    let measurement = setup.measurement;
    let run = measurement.name();
    let config = setup.config;
    let rate_hz = config.sensors.sample_rate_hz;
    let period_s = 1.0 / rate_hz;
    let trajectory = *controller.trajectory();
    let fk_options = controller.config().fk;
    let mut tick = setup::tick(config, &setup.geometry, measurement, controller)
        .map_err(|e| anyhow!("the estimator refused its settings: {e}"))?;
    let bias_sigma = setup::accel_bias_sigma(config);
    let load_cell_sigma = setup::load_cell_bias_sigma(config);
    // θ after every used sample, reserved for the whole window (or the history's bounded
    // capacity) so the loop never allocates.
    let window_samples = (trajectory.duration_s() * rate_hz).ceil() as usize + 16;
    let mut history = ThetaHistory::with_room_for(window_samples);
    // The error budget's record of the samples the estimator uses, reserved alike.
    let mut record = crate::record::RunRecord::new(setup.geometry, period_s, window_samples);
    let mut fk_failures = 0u64;

    observer.measurement_started(measurement)?;

    // 1. Brake hold: read the static load.
    let mut index = 0u64;
    let mut interrupted_at = None;
    // The hold's static weighing ([`crate::weigh`]): sums only while the loop runs.
    let mut weigher = crate::weigh::Weigher::of(config, setup.geometry);
    let hold = brake_hold(
        backend,
        &mut tick,
        config,
        |frame, command, sample, tick| {
            last_frame.saw(frame);
            match sample {
                Some(s) => weigher.push(s.time_s, &s.pose, &s.leg_forces_n),
                None => fk_failures += 1,
            }
            let posed = sample.is_some();
            let pose = tick.feed.pose_guess();
            let interrupted = stop.load(Ordering::SeqCst);
            observer.tick(&TickEvent {
                measurement,
                index,
                frame,
                command,
                phase: Phase::Idle,
                control: None,
                pose: posed.then_some(&pose),
                estimator: None,
                tare: setup.tare,
                interrupted,
            })?;
            index += 1;
            if interrupted {
                interrupted_at = Some(frame.time_s);
            }
            Ok(interrupted)
        },
    )?;
    let Some(feedforward) = hold else {
        observer.measurement_ended(&MeasurementEnded {
            measurement,
            time_s: interrupted_at.unwrap_or(f64::NAN),
            estimate: None,
            tare: setup.tare,
        })?;
        return Ok(MeasureOutcome::ended_early(End::Interrupted, fk_failures));
    };

    // 2. The controller, with the static load as feed-forward, the hold's pose as its forward
    //    kinematics' warm start, and the inverse dynamics of the load as the owner knows it.
    let load = crate::setup::feedforward_load(config, measurement, setup.tare.map(|(t, _)| t));
    tick.start_control(feedforward, load)?;

    let budget = expected_samples(config, &trajectory) + (120.0 * rate_hz) as u64;
    let mut park_requested = false;
    let mut last_pose = tick.feed.pose_guess();
    let mut last_fed_s = f64::NAN;
    for _ in 0..budget {
        let frame = read(backend)?;
        last_frame.saw(&frame);
        let interrupted = stop.load(Ordering::SeqCst);
        if interrupted && !park_requested {
            tick.controller.request_park();
            park_requested = true;
        }
        let step = tick.step(&frame);
        let command = step.control.command;
        write(backend, &command)?;
        match step.sample {
            Some(s) => last_pose = s.pose,
            None => fk_failures += 1,
        }
        if let (Some(Ok(Outcome::Used)), Some(sample)) = (step.estimator, &step.sample) {
            history.push(tick.estimator.theta_quick().into());
            record.push(sample);
            last_fed_s = frame.time_s;
        }
        if step.window_opened {
            observer.estimator_started(&EstimatorStarted {
                measurement,
                time_s: frame.time_s,
                config: tick.estimator.config(),
                fk: &fk_options,
            })?;
        }
        let estimator = tick.window.map(|_| &*tick.estimator);
        observer.tick(&TickEvent {
            measurement,
            index,
            frame: &frame,
            command: &command,
            phase: step.control.phase,
            control: Some(&step.control),
            pose: Some(&last_pose),
            estimator,
            tare: setup.tare,
            interrupted,
        })?;
        index += 1;

        if matches!(step.control.phase, Phase::Done | Phase::Fault) {
            // Finished here, not after the hold: its error budget allocates, and the loop
            // must not.
            let static_weighing = weigher.finish(&crate::budget::Figures::of(config));
            let stall = step.control.fault.is_some_and(|f| f.is_stall());
            let end = match step.control.fault {
                Some(f) => End::Fault(f.to_string()),
                None if park_requested => End::Interrupted,
                None => End::Completed,
            };
            let estimate = tick.window.map(|_| tick.estimator.estimate());
            observer.measurement_ended(&MeasurementEnded {
                measurement,
                time_s: frame.time_s,
                estimate: estimate.as_ref(),
                tare: setup.tare,
            })?;
            let Some((start_s, _)) = tick.window else {
                return Ok(MeasureOutcome {
                    static_weighing,
                    stall,
                    ..MeasureOutcome::ended_early(end, fk_failures)
                });
            };
            let estimator = &tick.estimator;
            let exact = crate::budget::EstimatorEffects {
                accel: crate::systematic::accel_bias_effect(estimator, bias_sigma),
                load_cell: crate::systematic::load_cell_bias_effect(estimator, load_cell_sigma),
                accel_offset_measured: estimator.accelerometer_offset().is_some(),
                load_cell_drift: estimator.load_cell_drift(),
            };
            let budget = estimate.as_ref().map(|e| {
                crate::budget::analyse(
                    &record,
                    estimator.config(),
                    &crate::budget::Figures::of(config),
                    e,
                    &exact,
                )
            });
            return Ok(MeasureOutcome {
                estimate,
                theta_history: history,
                estimator_config: Some(*estimator.config()),
                excitation_s: if last_fed_s.is_finite() {
                    last_fed_s - start_s
                } else {
                    0.0
                },
                fk_failures,
                accel_bias_effect: exact.accel,
                load_cell_bias_effect: exact.load_cell,
                budget,
                record: Some(record),
                accel_offset_m_s2: estimator
                    .accelerometer_offset()
                    .map(|o| o.offset_m_s2.into()),
                static_weighing,
                end,
                stall,
            });
        }
    }
    // The procedure overran its time budget: stop the platform and give up.
    let frame = read(backend)?;
    let stop_command = CommandFrame::safe_stop(u64::MAX, frame.sequence);
    write(backend, &stop_command)?;
    bail!(
        "the {run} measurement did not finish within {:.0} s of backend time; the brakes were applied",
        budget as f64 * period_s
    )
}

/// The brake hold (`run.brake_hold_s`): safe stops while the braked platform carries its load,
/// each frame fed to the tick's estimator conditioning. `each` sees every frame, its command,
/// its sample (`None`: the frame had no pose), and the tick, and returns `true` to stop there. Gives the mean
/// leg forces of the last 0.1 s (the PID feed-forward: what the load cells read is what the
/// legs must push), or `None` when stopped.
pub fn brake_hold<B: Backend>(
    backend: &mut B,
    tick: &mut Tick,
    config: &Config,
    mut each: impl FnMut(&SensorFrame, &CommandFrame, Option<&Sample>, &Tick) -> Result<bool>,
) -> Result<Option<[f64; 6]>>
where
    B::Error: std::fmt::Display,
{
    let rate_hz = config.sensors.sample_rate_hz;
    let hold_samples = ((config.run.brake_hold_s * rate_hz).round() as u64).max(1);
    let average_samples = ((0.1 * rate_hz).round() as u64).clamp(1, hold_samples);
    let mut force_sum = [0.0; 6];
    for i in 0..hold_samples {
        let frame = read(backend)?;
        let sample = tick.hold(&frame);
        let command = CommandFrame::safe_stop(i, frame.sequence);
        write(backend, &command)?;
        if i >= hold_samples - average_samples {
            for (s, f) in force_sum.iter_mut().zip(frame.leg_forces_n) {
                *s += f;
            }
        }
        if each(&frame, &command, sample.as_ref(), tick)? {
            return Ok(None);
        }
    }
    let feedforward = force_sum.map(|s| s / average_samples as f64);
    if !feedforward.iter().all(|f| f.is_finite()) {
        bail!("the load cells gave non-finite forces during the brake hold");
    }
    Ok(Some(feedforward))
}

fn read<B: Backend>(backend: &mut B) -> Result<SensorFrame>
where
    B::Error: std::fmt::Display,
{
    backend
        .read()
        .map_err(|e| anyhow!("backend read failed: {e}"))
}

fn write<B: Backend>(backend: &mut B, command: &CommandFrame) -> Result<()>
where
    B::Error: std::fmt::Display,
{
    backend
        .write(command)
        .map_err(|e| anyhow!("backend write failed: {e}"))
}

/// The payload alone (tare subtracted) when a tare is known, else everything on the plate.
pub fn payload_estimate(loaded: &Estimate, tare: Option<&TareEstimate>) -> Estimate {
    match tare {
        Some((p, c)) => loaded.without_tare(p, c),
        None => *loaded,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::TickEvent;
    use rig_description::load::load;

    /// A platform resting at home whatever it is told, recording the commands.
    struct Resting {
        lengths_m: [f64; 6],
        sequence: u64,
        commands: Vec<CommandFrame>,
    }

    impl Backend for Resting {
        type Error = String;
        fn read(&mut self) -> Result<SensorFrame, String> {
            self.sequence += 1;
            Ok(SensorFrame {
                sequence: self.sequence,
                time_s: self.sequence as f64 * 1e-3,
                leg_lengths_m: self.lengths_m,
                leg_forces_n: [3000.0; 6],
                accel_m_s2: [0.0, 0.0, 9.80665],
                ..SensorFrame::default()
            })
        }
        fn write(&mut self, command: &CommandFrame) -> Result<(), String> {
            self.commands.push(*command);
            Ok(())
        }
        fn sample_period_s(&self) -> f64 {
            1e-3
        }
    }

    /// Fails on its `n`th tick, as a full disk would.
    struct FailsAt(u64);

    impl Observer for FailsAt {
        fn tick(&mut self, e: &TickEvent<'_>) -> Result<()> {
            if e.index + 1 == self.0 {
                bail!("disk full");
            }
            Ok(())
        }
    }

    #[test]
    fn an_observer_failure_mid_motion_ends_with_a_safe_stop() {
        let loaded = load(None).unwrap();
        let geometry = setup::geometry(&loaded).unwrap();
        let trajectory = setup::trajectory(&loaded, &geometry, 10.0).unwrap();
        let controller =
            setup::controller(&loaded, &geometry, trajectory, Measurement::Tare).unwrap();
        let home = geometry.leg_lengths(&geometry.home_pose());
        let mut backend = Resting {
            lengths_m: home.into(),
            sequence: 0,
            commands: Vec::new(),
        };
        let setup = MeasureSetup {
            config: &loaded.config,
            geometry,
            measurement: Measurement::Tare,
            tare: None,
        };
        // The brake hold's ticks, then the controller drives the legs for 100.
        let run = &loaded.config.run;
        let hold = (run.brake_hold_s * loaded.config.sensors.sample_rate_hz).round() as u64;
        let err = measure(
            &mut backend,
            &setup,
            controller,
            &mut FailsAt(hold + 100),
            &AtomicBool::new(false),
        )
        .unwrap_err();
        assert!(err.to_string().contains("disk full"), "{err}");
        let n = backend.commands.len() as u64;
        assert_eq!(n, hold + 101, "the hold, 100 ticks and the safe stop");
        let n = n as usize;
        assert!(backend.commands[n - 2].enable, "the legs were driven");
        assert!(!backend.commands[n - 1].enable, "then braked");
        assert_eq!(backend.commands[n - 1].leg_forces_n, [0.0; 6]);
    }
}
