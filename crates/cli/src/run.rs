//! One measurement on any [`Backend`] (the simulator now, a rig later): brake hold, settle,
//! excitation, park — with the online estimator fed during the excitation, everything logged,
//! and a controlled stop on Ctrl-C or a fault.
//!
//! The sequence, per measurement:
//!
//! 1. **Brake hold** (`run.brake_hold_s`): safe-stop commands while the braked platform carries
//!    its load; the mean leg forces of the last 0.1 s become the PID feed-forward, so the
//!    integrators need not build up the static load (no model of the load is needed: what the
//!    load cells read is what the legs must push).
//! 2. **Controller** (`control::controller::Controller`): ramp to home and hold
//!    (`run.settle_s`), the excitation, the park ramp and hold, then brakes on.
//! 3. **Estimator**: created on the first excitation sample with the window
//!    `[t_start, t_start + trajectory duration]`, then fed every earlier sample of the
//!    measurement (they only warm its conditioning: the estimator withholds the low-pass's start
//!    transient from the fit by itself, and warming it on the brake hold and settle frames keeps
//!    the whole excitation for the fit) and every later one up to the window's end. Its pose
//!    input is the forward kinematics of the measured leg lengths, warm-started from the
//!    previous sample's solution (the first sample of the measurement from the home pose), so
//!    `stewart estimate` can rebuild the same inputs from `/sensors` alone.
//!
//! The estimator sees only sensor frames; nothing here can read a simulator's truth.

use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{anyhow, bail, Result};
use control::controller::{Controller, TickOutput};
use control::io::{Backend, CommandFrame, SensorFrame};
use control::supervisor::Phase;
use control::trajectory::Trajectory;
use estimator::{
    Estimate, EstimatorConfig, InertialParameters, OnlineEstimator, Outcome, ParameterCovariance,
    Sample,
};
use indicatif::ProgressBar;
use kinematics::{Geometry, Pose, Vector3, Vector6};

use crate::config::ParamCount;
use crate::foxglove::{self, InertiaEllipsoid, SceneGeometry, Time};
use crate::log_messages::{
    self as topics, BodyEstimate, CommandMsg, EstimateMsg, LegsMsg, PidMsg, PoseMsg, PoseValue,
    SensorMsg, SupervisorMsg,
};
use crate::metadata::EstimatorSettings;
use crate::preflight::{self, Measurement};
use crate::run_log::{rates, RunLog};

/// What a measurement needs besides the backend.
pub struct MeasureSetup<'a> {
    /// The effective configuration.
    pub config: &'a crate::config::Config,
    /// The platform design.
    pub geometry: Geometry,
    /// Tare or loaded.
    pub measurement: Measurement,
    /// The excitation (already checked for feasibility).
    pub trajectory: Trajectory,
    /// The tare to subtract for the logged payload estimate (loaded runs).
    pub tare: Option<(InertialParameters, ParameterCovariance)>,
}

/// Where the measurement reports as it goes.
pub struct Hooks<'a> {
    /// The log.
    pub log: &'a mut RunLog,
    /// Progress bar (may be hidden).
    pub progress: &'a ProgressBar,
    /// Set by the Ctrl-C handler.
    pub interrupt: &'a AtomicBool,
    /// The fixed parts of the 3D scene.
    pub scene: &'a SceneGeometry,
    /// Command sequence counter, continued across measurements.
    pub command_sequence: &'a mut u64,
}

/// How a measurement ended.
#[derive(Clone, Debug, PartialEq)]
pub enum End {
    /// Excitation completed and the platform parked.
    Completed,
    /// Ctrl-C: parked early.
    Interrupted,
    /// The supervisor latched a fault (the safe stop was sent).
    Fault(String),
}

/// What a measurement produced.
#[derive(Clone, Debug)]
pub struct MeasureOutcome {
    /// The final estimate of everything on the plate (None if the excitation never started).
    pub estimate: Option<Estimate>,
    /// θ after every used sample (everything on the plate, not tare-corrected).
    pub theta_history: Vec<[f64; 10]>,
    /// The estimator's settings (None if the excitation never started).
    pub estimator_config: Option<EstimatorConfig>,
    /// Backend time from the first excitation sample to the last one fed, s.
    pub excitation_s: f64,
    /// Samples whose forward kinematics failed (not fed to the estimator).
    pub fk_failures: u64,
    /// Change of θ caused by an accelerometer bias of one datasheet sigma along P's x, y and z
    /// (rows), from the estimator's first-order sensitivity; `None` without a bias figure
    /// (ideal sensors) or without an excitation. See [`crate::systematic`].
    pub accel_bias_effect: Option<[[f64; 10]; 3]>,
    /// Change of θ caused by a zero offset of one datasheet sigma on each load cell (rows:
    /// legs); `None` without a figure or an excitation.
    pub load_cell_bias_effect: Option<[[f64; 10]; 6]>,
    /// How it ended.
    pub end: End,
}

/// Expected number of samples of a measurement, for the progress bar.
pub fn expected_samples(config: &crate::config::Config, trajectory: &Trajectory) -> u64 {
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

fn every(rate_hz: f64, sample_rate_hz: f64) -> u64 {
    ((sample_rate_hz / rate_hz).round() as u64).max(1)
}

/// Runs one measurement. Errors are backend or log failures (after a best-effort safe stop);
/// a supervisor fault or an interrupt end the measurement normally with [`End::Fault`] or
/// [`End::Interrupted`]. The controller (and its feasibility check) is built before the first
/// sample; see [`measure_with`] to hand over one built earlier.
pub fn measure<B: Backend>(
    backend: &mut B,
    setup: &MeasureSetup<'_>,
    hooks: &mut Hooks<'_>,
) -> Result<MeasureOutcome>
where
    B::Error: std::fmt::Display,
{
    let controller = Controller::new(
        setup.geometry,
        setup.trajectory,
        preflight::controller_config(setup.config),
    )
    .map_err(|e| anyhow!("controller refused the run: {e}"))?;
    measure_with(backend, setup, controller, hooks)
}

/// [`measure`] with `controller` built (and so checked) beforehand for `setup`'s trajectory,
/// e.g. by [`preflight::controller`]: nothing slow happens between samples once the backend
/// runs (a rig's watchdog counts). Its feed-forward is replaced by the brake hold's load.
pub fn measure_with<B: Backend>(
    backend: &mut B,
    setup: &MeasureSetup<'_>,
    mut controller: Controller,
    hooks: &mut Hooks<'_>,
) -> Result<MeasureOutcome>
where
    B::Error: std::fmt::Display,
{
    let run = setup.measurement.name();
    let config = setup.config;
    let rate_hz = config.sensors.sample_rate_hz;
    let period_s = 1.0 / rate_hz;
    let home = setup.geometry.home_pose();
    let mut fk_guess = home;
    let fk_options = preflight::controller_config(config).fk;

    let mut state = Logging {
        run,
        derived_every: every(rates::DERIVED_HZ, rate_hz),
        estimate_every: every(rates::ESTIMATE_HZ, rate_hz),
        scene_every: every(rates::SCENE_HZ, rate_hz),
        supervisor_every: every(rates::SUPERVISOR_HZ, rate_hz),
        tick: 0,
        last_phase: None,
        last_fault: None,
    };

    // 1. Brake hold: read the static load.
    let hold_samples = ((config.run.brake_hold_s * rate_hz).round() as u64).max(1);
    let average_samples = ((0.1 * rate_hz).round() as u64).clamp(1, hold_samples);
    let mut force_sum = [0.0; 6];
    let mut first_time: Option<f64> = None;
    // Samples before the excitation: fed to the estimator when it is created, so that its
    // conditioning (filtered derivative, low-pass, warm-up) is done by the window's start and
    // no excitation sample is spent on it.
    let mut pending: Vec<Sample> = Vec::with_capacity(8192);
    let mut fk_failures = 0u64;
    for i in 0..hold_samples {
        let frame = read(backend)?;
        first_time.get_or_insert(frame.time_s);
        let pose = fk(&setup.geometry, &frame, &mut fk_guess, &fk_options);
        match pose {
            Some(p) => pending.push(sample_of(&frame, p)),
            None => fk_failures += 1,
        }
        hooks
            .log
            .write(topics::SENSORS, frame.time_s, &SensorMsg::new(run, &frame))?;
        let command = CommandFrame::safe_stop(next(hooks.command_sequence), frame.sequence);
        write(backend, &command)?;
        hooks.log.write(
            topics::COMMANDS,
            frame.time_s,
            &CommandMsg::new(run, frame.time_s, &command),
        )?;
        if i >= hold_samples - average_samples {
            for (s, f) in force_sum.iter_mut().zip(frame.leg_forces_n) {
                *s += f;
            }
        }
        state.scene(hooks, &setup.geometry, &frame, pose.as_ref(), None)?;
        state.supervisor(hooks, frame.time_s, Phase::Idle, None, false, false)?;
        state.tick += 1;
        hooks.progress.inc(1);
        if hooks.interrupt.load(Ordering::SeqCst) {
            return Ok(MeasureOutcome {
                estimate: None,
                theta_history: Vec::new(),
                estimator_config: None,
                excitation_s: 0.0,
                fk_failures: 0,
                accel_bias_effect: None,
                load_cell_bias_effect: None,
                end: End::Interrupted,
            });
        }
    }
    let feedforward = force_sum.map(|s| s / average_samples as f64);
    if !feedforward.iter().all(|f| f.is_finite()) {
        bail!("the load cells gave non-finite forces during the brake hold");
    }

    // 2. The controller, with the static load as feed-forward.
    controller
        .set_feedforward(feedforward)
        .map_err(|e| anyhow!("controller refused the feed-forward: {e}"))?;
    controller.set_pose_guess(fk_guess);

    let expected = expected_samples(config, &setup.trajectory);
    let budget = expected + (120.0 * rate_hz) as u64;
    let mut estimator: Option<OnlineEstimator> = None;
    let bias_sigma = preflight::accel_bias_sigma(config);
    let load_cell_sigma = crate::systematic::load_cell_bias_sigma(config);
    let mut history = Vec::with_capacity((setup.trajectory.duration_s() * rate_hz) as usize + 16);
    let mut excite_start_s = f64::NAN;
    let mut last_fed_s = f64::NAN;
    let mut park_requested = false;
    let mut last_pose = fk_guess;

    for _ in 0..budget {
        let frame = read(backend)?;
        let pose = fk(&setup.geometry, &frame, &mut fk_guess, &fk_options);
        let interrupted = hooks.interrupt.load(Ordering::SeqCst);
        if interrupted && !park_requested {
            controller.request_park();
            park_requested = true;
        }
        let out = controller.tick(&frame);
        write(backend, &out.command)?;
        *hooks.command_sequence += 1;

        // Estimator: from the first excitation sample, while the excitation lasts.
        if out.phase == Phase::Excite && estimator.is_none() && !park_requested {
            let end_s = frame.time_s + setup.trajectory.duration_s();
            let mut c = preflight::estimator_config(
                config,
                &setup.geometry,
                setup.measurement,
                frame.time_s,
                end_s,
            );
            c.leg_force_offsets = load_cell_sigma > 0.0;
            estimator = Some(
                OnlineEstimator::new(c)
                    .map_err(|e| anyhow!("estimator refused its settings: {e}"))?,
            );
            hooks.log.write(
                topics::ESTIMATOR_SETTINGS,
                frame.time_s,
                &EstimatorSettings::from_config(run, &c, &fk_options),
            )?;
            excite_start_s = frame.time_s;
            // Every earlier sample of the measurement only warms the conditioning (they lie
            // before the window), so the whole excitation reaches the fit.
            if let Some(est) = estimator.as_mut() {
                for sample in pending.drain(..) {
                    let _ = est.update(&sample);
                }
            }
        }
        let sample = pose.map(|p| sample_of(&frame, p));
        if sample.is_none() {
            fk_failures += 1;
        }
        match (estimator.as_mut(), sample) {
            // Every frame up to the window's end, whatever the phase, so that a re-run from
            // the log feeds exactly the same samples.
            (Some(est), Some(sample)) if frame.time_s <= est.config().window_end_s => {
                if let Ok(Outcome::Used) = est.update(&sample) {
                    history.push(est.theta().into());
                    last_fed_s = frame.time_s;
                }
            }
            (None, Some(sample)) if !park_requested => pending.push(sample),
            _ => {}
        }

        // Log.
        hooks
            .log
            .write(topics::SENSORS, frame.time_s, &SensorMsg::new(run, &frame))?;
        hooks.log.write(
            topics::COMMANDS,
            frame.time_s,
            &CommandMsg::new(run, frame.time_s, &out.command),
        )?;
        if let Some(p) = pose {
            last_pose = p;
        }
        state.tick_logs(hooks, &frame, &out, &last_pose)?;
        let payload = if state.tick.is_multiple_of(state.scene_every) {
            estimator
                .as_ref()
                .map(|e| payload_estimate(&e.estimate(), setup.tare.as_ref()))
        } else {
            None
        };
        if state.tick.is_multiple_of(state.estimate_every) {
            if let Some(est) = estimator.as_ref() {
                let e = est.estimate();
                hooks.log.write(
                    topics::ESTIMATE,
                    frame.time_s,
                    &estimate_msg(run, frame.time_s, &e, setup.tare.as_ref()),
                )?;
                // platform → payload_com: the payload's estimated centre of mass and axes.
                if let Some(tare) = setup.tare.as_ref() {
                    let p = payload_estimate(&e, Some(tare));
                    let time = Time::from_ns(hooks.log.time_ns(frame.time_s));
                    let body = InertiaEllipsoid {
                        mass_kg: p.parameters.mass_kg,
                        com_m: p.com_m,
                        inertia_com_kg_m2: p.inertia_com_kg_m2,
                    };
                    if let Some(tf) = foxglove::payload_transform(time, &body) {
                        hooks.log.write(topics::TF_PAYLOAD, frame.time_s, &tf)?;
                    }
                }
            }
        }
        state.scene(
            hooks,
            &setup.geometry,
            &frame,
            Some(&last_pose),
            payload.as_ref(),
        )?;
        state.supervisor(
            hooks,
            frame.time_s,
            out.phase,
            out.fault.map(|f| f.to_string()),
            out.clamped,
            interrupted,
        )?;
        state.tick += 1;
        hooks.progress.inc(1);
        hooks
            .progress
            .set_message(format!("{run}: {}", out.phase.name()));

        match out.phase {
            Phase::Done | Phase::Fault => {
                let end = match out.fault {
                    Some(f) => End::Fault(f.to_string()),
                    None if park_requested => End::Interrupted,
                    None => End::Completed,
                };
                let estimate = estimator.as_ref().map(OnlineEstimator::estimate);
                if let Some(e) = &estimate {
                    hooks.log.write(
                        topics::ESTIMATE,
                        frame.time_s,
                        &estimate_msg(run, frame.time_s, e, setup.tare.as_ref()),
                    )?;
                }
                hooks.log.flush()?;
                return Ok(MeasureOutcome {
                    estimate,
                    theta_history: history,
                    estimator_config: estimator.map(|e| *e.config()),
                    excitation_s: if last_fed_s.is_finite() {
                        last_fed_s - excite_start_s
                    } else {
                        0.0
                    },
                    fk_failures,
                    accel_bias_effect: estimator
                        .as_ref()
                        .and_then(|e| crate::systematic::accel_bias_effect(e, bias_sigma)),
                    load_cell_bias_effect: estimator
                        .as_ref()
                        .and_then(|e| crate::systematic::load_cell_bias_effect(e, load_cell_sigma)),
                    end,
                });
            }
            _ => {}
        }
    }
    // The procedure overran its time budget: stop the platform and give up.
    let frame = read(backend)?;
    let stop = CommandFrame::safe_stop(next(hooks.command_sequence), frame.sequence);
    write(backend, &stop)?;
    bail!(
        "the {run} measurement did not finish within {:.0} s of backend time; the brakes were applied",
        budget as f64 * period_s
    )
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

fn next(sequence: &mut u64) -> u64 {
    let s = *sequence;
    *sequence += 1;
    s
}

/// The estimator's input of one frame at `pose`.
fn sample_of(frame: &SensorFrame, pose: Pose) -> Sample {
    Sample {
        time_s: frame.time_s,
        pose,
        leg_forces_n: Vector6::from(frame.leg_forces_n),
        gyro_rad_s: Vector3::from(frame.gyro_rad_s),
        accel_m_s2: Vector3::from(frame.accel_m_s2),
    }
}

/// Forward kinematics of the frame's leg lengths, warm-started from (and updating) `guess`.
fn fk(
    geometry: &Geometry,
    frame: &SensorFrame,
    guess: &mut Pose,
    options: &kinematics::FkOptions,
) -> Option<Pose> {
    let lengths = Vector6::from(frame.leg_lengths_m);
    match geometry.forward_kinematics(&lengths, guess, options) {
        Ok(s) => {
            *guess = s.pose;
            Some(s.pose)
        }
        Err(_) => None,
    }
}

/// The payload alone (tare subtracted) when a tare is known, else everything on the plate.
pub fn payload_estimate(
    loaded: &Estimate,
    tare: Option<&(InertialParameters, ParameterCovariance)>,
) -> Estimate {
    match tare {
        Some((p, c)) => loaded.without_tare(p, c),
        None => *loaded,
    }
}

fn estimate_msg(
    run: &'static str,
    time_s: f64,
    e: &Estimate,
    tare: Option<&(InertialParameters, ParameterCovariance)>,
) -> EstimateMsg {
    EstimateMsg {
        run,
        time_s,
        samples: e.counts.used,
        rejected: e.counts.rejected,
        theta: e.parameters.to_vector().into(),
        theta_sigma: e.parameter_sigma.into(),
        residual_rms: e.residual_rms.into(),
        body: BodyEstimate::new(e),
        payload: tare.map(|t| BodyEstimate::new(&payload_estimate(e, Some(t)))),
    }
}

/// Decimation state of the derived channels.
struct Logging {
    run: &'static str,
    derived_every: u64,
    estimate_every: u64,
    scene_every: u64,
    supervisor_every: u64,
    tick: u64,
    last_phase: Option<Phase>,
    last_fault: Option<String>,
}

impl Logging {
    fn tick_logs(
        &mut self,
        hooks: &mut Hooks<'_>,
        frame: &SensorFrame,
        out: &TickOutput,
        measured: &Pose,
    ) -> Result<()> {
        let t = frame.time_s;
        if self.tick.is_multiple_of(self.derived_every) {
            hooks.log.write(
                topics::POSE,
                t,
                &PoseMsg {
                    run: self.run,
                    time_s: t,
                    desired: PoseValue::new(&out.desired.pose),
                    measured: PoseValue::new(measured),
                },
            )?;
            let error_m =
                core::array::from_fn(|i| out.desired_leg_lengths_m[i] - frame.leg_lengths_m[i]);
            hooks.log.write(
                topics::LEGS,
                t,
                &LegsMsg {
                    run: self.run,
                    time_s: t,
                    desired_length_m: out.desired_leg_lengths_m,
                    measured_length_m: frame.leg_lengths_m,
                    error_m,
                    command_force_n: out.command.leg_forces_n,
                    measured_force_n: frame.leg_forces_n,
                },
            )?;
            hooks
                .log
                .write(topics::PID, t, &PidMsg::new(self.run, t, &out.pid))?;
        }
        if self.tick.is_multiple_of(self.estimate_every) {
            let time = Time::from_ns(hooks.log.time_ns(t));
            let tf = foxglove::platform_transform(time, measured.position_m, &measured.rotation);
            hooks.log.write(topics::TF, t, &tf)?;
        }
        Ok(())
    }

    fn scene(
        &mut self,
        hooks: &mut Hooks<'_>,
        geometry: &Geometry,
        frame: &SensorFrame,
        pose: Option<&Pose>,
        payload: Option<&Estimate>,
    ) -> Result<()> {
        if !self.tick.is_multiple_of(self.scene_every) {
            return Ok(());
        }
        let pose = pose.copied().unwrap_or_else(|| geometry.home_pose());
        let time = Time::from_ns(hooks.log.time_ns(frame.time_s));
        let ellipsoid = payload.and_then(|e| {
            (e.parameters.mass_kg > 0.0 && e.com_m.iter().all(|v| v.is_finite())).then_some(
                InertiaEllipsoid {
                    mass_kg: e.parameters.mass_kg,
                    com_m: e.com_m,
                    inertia_com_kg_m2: e.inertia_com_kg_m2,
                },
            )
        });
        let scene = foxglove::scene(
            time,
            hooks.scene,
            pose.position_m,
            &pose.rotation,
            &frame.leg_forces_n,
            ellipsoid.as_ref(),
        );
        hooks.log.write(topics::SCENE, frame.time_s, &scene)
    }

    fn supervisor(
        &mut self,
        hooks: &mut Hooks<'_>,
        time_s: f64,
        phase: Phase,
        fault: Option<String>,
        clamped: bool,
        interrupted: bool,
    ) -> Result<()> {
        let changed = self.last_phase != Some(phase) || self.last_fault != fault;
        if changed || clamped || self.tick.is_multiple_of(self.supervisor_every) {
            self.last_phase = Some(phase);
            self.last_fault.clone_from(&fault);
            hooks.log.write(
                topics::SUPERVISOR,
                time_s,
                &SupervisorMsg {
                    run: self.run,
                    time_s,
                    phase: phase.name().to_string(),
                    fault,
                    clamped,
                    interrupted,
                },
            )?;
        }
        Ok(())
    }
}

/// samples_to_1pct: the 1-based index of the first sample after which every estimated parameter
/// stays within 1 % of its final value (`None` without samples). `tare` is subtracted from each
/// θ; with the 6-parameter model only the tensor entries count (m and h are not estimated).
pub fn samples_to_1pct(
    history: &[[f64; 10]],
    tare: Option<&[f64; 10]>,
    params: ParamCount,
) -> Option<u64> {
    let last = history.last()?;
    let sub = |t: &[f64; 10]| -> [f64; 10] {
        match tare {
            Some(z) => core::array::from_fn(|i| t[i] - z[i]),
            None => *t,
        }
    };
    let fin = sub(last);
    let range = match params {
        ParamCount::Ten => 0..10,
        ParamCount::Six => 4..10,
    };
    let within = |t: &[f64; 10]| {
        let t = sub(t);
        range
            .clone()
            .all(|i| (t[i] - fin[i]).abs() <= 0.01 * fin[i].abs())
    };
    let last_outside = history.iter().rposition(|t| !within(t));
    Some(match last_outside {
        None => 1,
        Some(k) => k as u64 + 2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_to_1pct_finds_the_last_excursion() {
        let mut h = vec![[1.0; 10]; 10];
        h[3][5] = 1.2;
        h[6][0] = 0.985;
        // Sample 7 (index 6) is outside, so from sample 8 on all stay within 1 %.
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(8));
        // Only the tensor entries count with six parameters: index 3's entry 5 is the last.
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Six), Some(5));
        assert_eq!(samples_to_1pct(&[], None, ParamCount::Ten), None);
        assert_eq!(samples_to_1pct(&h[..1], None, ParamCount::Ten), Some(1));
    }

    #[test]
    fn samples_to_1pct_subtracts_the_tare() {
        // Loaded θ 102 → 100 with a tare of 99: the payload goes 3 → 1, far outside 1 %.
        let h = vec![[102.0; 10], [100.0; 10], [100.0; 10]];
        let tare = [99.0; 10];
        assert_eq!(samples_to_1pct(&h, Some(&tare), ParamCount::Ten), Some(2));
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(2));
        let h = vec![[100.5; 10], [100.0; 10]];
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(1));
        assert_eq!(samples_to_1pct(&h, Some(&tare), ParamCount::Ten), Some(2));
    }
}
