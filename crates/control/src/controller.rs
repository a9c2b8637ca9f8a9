//! The per-tick pipeline that the CLI and the rig run:
//!
//! ```text
//! sensors ─► supervisor watchdog ─► FK (warm start: last pose) ─► phase ─► desired pose
//!         ─► IK ─► six PIDs (+ static, rate and inverse-dynamics feed-forward) ─► supervisor gate
//!         ─► CommandFrame
//! ```
//!
//! The procedure: [`Phase::Idle`] until the first good frame; [`Phase::Settle`]: a quintic ramp
//! from the measured pose to the trajectory's offset (home) pose, then a hold for `settle_s`;
//! [`Phase::Excite`]: the trajectory; [`Phase::Park`]: a brake to rest from wherever the
//! set-point is, a quintic ramp back to home, a hold for `park_hold_s`; [`Phase::Done`]: brakes on.
//! Any fault (sensor watchdog, limits, forward kinematics failing, a desired leg length outside
//! the stroke) latches [`Phase::Fault`] and the safe stop.
//!
//! Nothing allocates and nothing panics. Every tick yields a command to send, even on a fault
//! (then it is the safe stop), so [`Controller::tick`] returns a [`TickOutput`] rather than a
//! `Result`: a caller cannot skip writing the safe stop by propagating an error. Use
//! [`TickOutput::result`] where an error is wanted.

use kinematics::{FkOptions, Geometry, Matrix6, Pose, Vector3, Vector6};

use stewart_types::InertialParameters;

use crate::error::ControlError;
use crate::inverse_dynamics::{load_leg_forces, load_leg_forces_with};
use crate::io::{CommandFrame, SensorFrame, LEG_COUNT};
use crate::pid::{PidBank, PidConfig, PidOutput};
use crate::supervisor::{Fault, Phase, Supervisor, SupervisorConfig};
use crate::trajectory::{FeasibilityLimits, FeasibilityReport, Ramp, Trajectory, TrajectorySample};

/// Standard gravity g₀ = 9.80665 m/s²; gravity in the base frame B (z up) is (0, 0, −g₀).
/// The same constant as `stewart_types::STANDARD_GRAVITY_M_S2`, kept under this name for
/// existing callers.
pub use stewart_types::STANDARD_GRAVITY_M_S2 as GRAVITY_M_S2;

/// Everything the controller needs besides the geometry and the trajectory. Plain `Copy` data;
/// the CLI maps its TOML onto it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerConfig {
    /// Nominal time between sensor frames, s (> 0). Used as the PID step on the first tick.
    pub sample_period_s: f64,
    /// Shortest settle ramp from the initial pose to home, s (> 0). Lengthened when needed so
    /// that no leg moves faster than half the feasibility speed limit on average × 1.875 peak.
    pub settle_ramp_s: f64,
    /// Hold at home after the settle ramp, s (≥ 0): lets transients die out and the
    /// integrators find the static load.
    pub settle_s: f64,
    /// Park ramp back to home, s (> 0).
    pub park_s: f64,
    /// Hold at home after the park ramp before braking, s (≥ 0).
    pub park_hold_s: f64,
    /// Leg PID gains and limits (the same on every leg).
    pub pid: PidConfig,
    /// Constant per-leg feed-forward force added to each PID output, N (e.g. the static
    /// gravity load from [`gravity_feedforward`]), so that the integrators need not build it up.
    pub feedforward_n: [f64; LEG_COUNT],
    /// Add `kd·l̇_d` (the desired leg speed from `J·[v; ω]` of the set-point, analytic and
    /// smooth) to each leg's feed-forward. The PID differentiates the measurement only (no
    /// set-point kick), which on a moving set-point leaves a lag; this term restores the
    /// missing `kd·ṙ` without differentiating anything.
    pub rate_feedforward: bool,
    /// Safety limits.
    pub supervisor: SupervisorConfig,
    /// Limits the trajectory must meet before any motion.
    pub feasibility: FeasibilityLimits,
    /// Forward-kinematics tolerance, iteration cap and jump limits.
    pub fk: FkOptions,
}

impl Default for ControllerConfig {
    /// 1 kHz, settle ramp ≥ 1 s then 2 s hold, 2 s park ramp and 0.5 s hold, default PID,
    /// supervisor, feasibility and FK settings, no constant feed-forward, rate feed-forward on.
    fn default() -> Self {
        Self {
            sample_period_s: 1e-3,
            settle_ramp_s: 1.0,
            settle_s: 2.0,
            park_s: 2.0,
            park_hold_s: 0.5,
            pid: PidConfig::default(),
            feedforward_n: [0.0; LEG_COUNT],
            rate_feedforward: true,
            supervisor: SupervisorConfig::default(),
            feasibility: FeasibilityLimits::default(),
            fk: FkOptions::default(),
        }
    }
}

impl ControllerConfig {
    /// Checks every field (and the nested configs).
    pub fn validate(&self) -> Result<(), ControlError> {
        self.pid.validate()?;
        self.supervisor.validate()?;
        self.feasibility.validate()?;
        let positive = [
            ("controller.sample_period_s", self.sample_period_s),
            ("controller.settle_ramp_s", self.settle_ramp_s),
            ("controller.park_s", self.park_s),
        ];
        for (parameter, value) in positive {
            if !value.is_finite() || value <= 0.0 {
                return Err(ControlError::InvalidConfig {
                    parameter,
                    reason: "must be finite and > 0",
                });
            }
        }
        let non_negative = [
            ("controller.settle_s", self.settle_s),
            ("controller.park_hold_s", self.park_hold_s),
        ];
        for (parameter, value) in non_negative {
            if !value.is_finite() || value < 0.0 {
                return Err(ControlError::InvalidConfig {
                    parameter,
                    reason: "must be finite and >= 0",
                });
            }
        }
        if let Some(index) = self.feedforward_n.iter().position(|f| !f.is_finite()) {
            return Err(ControlError::NonFinite {
                what: "controller.feedforward_n",
                index,
            });
        }
        if !(self.fk.tolerance_m.is_finite() && self.fk.tolerance_m > 0.0) {
            return Err(ControlError::InvalidConfig {
                parameter: "controller.fk.tolerance_m",
                reason: "must be finite and > 0",
            });
        }
        Ok(())
    }
}

/// Everything one tick computed, for the backend and the log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutput {
    /// What to write to the backend (the safe stop outside Settle/Excite/Park and on a fault).
    pub command: CommandFrame,
    /// Phase after this tick.
    pub phase: Phase,
    /// Time since that phase began, s (trajectory time during Excite).
    pub phase_time_s: f64,
    /// The latched fault, if any.
    pub fault: Option<Fault>,
    /// PID step used, s (0 when the PIDs did not run).
    pub dt_s: f64,
    /// Desired pose, twist and acceleration (home at rest outside the active phases).
    pub desired: TrajectorySample,
    /// Desired leg lengths (IK of the desired pose), m.
    pub desired_leg_lengths_m: [f64; LEG_COUNT],
    /// Desired leg speeds `J·[v; ω]`, m/s.
    pub desired_leg_speeds_m_s: [f64; LEG_COUNT],
    /// Measured leg lengths, m.
    pub measured_leg_lengths_m: [f64; LEG_COUNT],
    /// The supervisor's filtered leg-speed estimates, m/s.
    pub measured_leg_speeds_m_s: [f64; LEG_COUNT],
    /// Pose from forward kinematics (None when the sensors were rejected or FK failed).
    pub measured_pose: Option<Pose>,
    /// Newton iterations FK used (0 when it did not run).
    pub fk_iterations: u32,
    /// FK's largest leg-length residual, m (NaN when it did not run).
    pub fk_residual_m: f64,
    /// Each leg's PID terms (zeros when the PIDs did not run).
    pub pid: [PidOutput; LEG_COUNT],
    /// True when the supervisor clamped a force to its limit.
    pub clamped: bool,
}

impl TickOutput {
    /// `Err(ControlError::Faulted(fault))` when a fault is latched, else `Ok(())`. The command
    /// must be written either way.
    pub fn result(&self) -> Result<(), ControlError> {
        match self.fault {
            Some(fault) => Err(ControlError::Faulted(fault)),
            None => Ok(()),
        }
    }
}

/// The brake lengths [`Controller`]'s park chooses from, s: from a tenth of a second (a slow
/// set-point stops at once) to one second (a fast one stops without a jolt).
pub const BRAKE_DURATIONS_S: [f64; 5] = [0.1, 0.2, 0.35, 0.6, 1.0];

/// The set-point generator of the current phase.
// The park's two ramps make it the largest variant; the core has no heap to box it in, and the
// controller holds a single Motion.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Motion {
    /// Hold home at rest (Idle, Done, Fault).
    Hold,
    /// Ramp to home, then hold until `hold_until_s` (phase time).
    Settle { ramp: Ramp, hold_until_s: f64 },
    /// The trajectory.
    Excite,
    /// Brake to rest (none when the set-point is at rest), ramp from there to home (starting at
    /// the brake's end), then hold until `hold_until_s` (phase time).
    Park {
        brake: Option<Ramp>,
        ramp: Ramp,
        hold_until_s: f64,
    },
}

/// The measurement procedure's controller. See the [module docs](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controller {
    geometry: Geometry,
    trajectory: Trajectory,
    config: ControllerConfig,
    feasibility: FeasibilityReport,
    pids: PidBank,
    supervisor: Supervisor,
    motion: Motion,
    phase_start_s: f64,
    last_time_s: Option<f64>,
    /// Warm start for FK: the last measured pose.
    last_pose: Pose,
    last_desired: TrajectorySample,
    park_requested: bool,
    /// The inverse-dynamics feed-forward's load, when one is set ([`Controller::set_load`]).
    load: Option<LoadFeedforward>,
}

/// The load of [`Controller::set_load`] and the part of the static feed-forward it accounts
/// for: its weight's leg forces at the pose where the static load was read.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LoadFeedforward {
    load: InertialParameters,
    at_hold_n: [f64; LEG_COUNT],
}

impl Controller {
    /// Validates the configuration and checks the whole trajectory against the stroke, leg
    /// speed and conditioning limits (see [`Trajectory::check_feasibility`]) before anything
    /// can move. The FK warm start is the trajectory's offset pose until
    /// [`Controller::set_pose_guess`] says otherwise.
    pub fn new(
        geometry: Geometry,
        trajectory: Trajectory,
        config: ControllerConfig,
    ) -> Result<Self, ControlError> {
        config.validate()?;
        let feasibility = trajectory.check_feasibility(&geometry, &config.feasibility)?;
        let home = *trajectory.offset();
        Ok(Self {
            geometry,
            trajectory,
            config,
            feasibility,
            pids: PidBank::uniform(config.pid)?,
            supervisor: Supervisor::new(config.supervisor, geometry.stroke())?,
            motion: Motion::Hold,
            phase_start_s: 0.0,
            last_time_s: None,
            last_pose: home,
            last_desired: rest_at(&home),
            park_requested: false,
            load: None,
        })
    }

    /// What the pre-motion feasibility check saw.
    pub fn feasibility(&self) -> &FeasibilityReport {
        &self.feasibility
    }

    /// The configuration in use.
    pub fn config(&self) -> &ControllerConfig {
        &self.config
    }

    /// The geometry in use.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The excitation trajectory.
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.supervisor.phase()
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.supervisor.fault()
    }

    /// Replaces the static feed-forward ([`ControllerConfig::feedforward_n`]), e.g. with the
    /// load the legs carried during a brake hold, without repeating the pre-motion checks of
    /// [`Controller::new`] (the trajectory's feasibility does not depend on it), so a caller can
    /// build the controller before the rig moves and still feed it what the rig then measured.
    /// Refused, leaving the controller unchanged, unless every entry is finite and the leg
    /// loops can hold the load these forces carry at the warm-start pose
    /// ([`crate::stability::translational_stability`]): the one check that needs the load,
    /// made here because this is where the load becomes known, before anything moves.
    pub fn set_feedforward(&mut self, feedforward_n: [f64; LEG_COUNT]) -> Result<(), ControlError> {
        let mut config = self.config;
        config.feedforward_n = feedforward_n;
        config.validate()?;
        let s = crate::stability::translational_stability(
            &self.geometry,
            &self.last_pose,
            &config.pid,
            &feedforward_n,
        );
        if !s.passes() {
            return Err(ControlError::UnstableLoad {
                supported_mass_kg: s.supported_mass_kg,
                ratio: s.ratio,
                max_integral_gain: s.max_integral_gain(&config.pid),
            });
        }
        self.config = config;
        Ok(())
    }

    /// Whether the leg loops can hold `load` (the plate with what it carries, as the rig's owner
    /// knows it) braked at the warm-start pose: [`Controller::set_feedforward`]'s stability
    /// check on the load's static leg forces. Call it with the trajectory checks, before the
    /// log and the brake hold: a rig whose loops cannot hold its load is then refused before
    /// anything runs, and `set_feedforward` checks the forces the hold measures again.
    pub fn check_hold(&self, load: &InertialParameters) -> Result<(), ControlError> {
        let static_n = load_leg_forces(&self.geometry, load, &rest_at(&self.last_pose))?;
        let s = crate::stability::translational_stability(
            &self.geometry,
            &self.last_pose,
            &self.config.pid,
            &static_n,
        );
        if s.passes() {
            Ok(())
        } else {
            Err(ControlError::UnstableLoad {
                supported_mass_kg: s.supported_mass_kg,
                ratio: s.ratio,
                max_integral_gain: s.max_integral_gain(&self.config.pid),
            })
        }
    }

    /// Adds the inverse-dynamics feed-forward of `load`, the plate with everything it carries as
    /// its owner knows it (a CAD model, a weighing): each tick's feed-forward becomes
    ///
    /// ```text
    /// f_ff(t) = f_static + J⁻ᵀ(p_d) W(θ, s_d(t)) − J⁻ᵀ(p_hold) W(θ, rest at p_hold)
    /// ```
    ///
    /// with W the Newton–Euler wrench of [`crate::inverse_dynamics::load_wrench`], s_d the
    /// set-point and p_hold the FK warm start when this is called (the pose where the static
    /// feed-forward [`ControllerConfig::feedforward_n`] was read, so call it after
    /// [`Controller::set_pose_guess`]). The static load stays the measured one; the model adds
    /// only how the load's wrench changes with the motion: the leg loops then follow the
    /// set-point without first building the inertial force up from a tracking error, which
    /// under a heavy payload lets the plate translate and turn where it was not commanded. An
    /// error in θ is left to the loops, as all of the inertial force is without this. Refused,
    /// leaving the controller unchanged, when `load` is not finite, its mass not positive, or
    /// the warm-start pose singular. Cheap (one solve): it runs between the brake hold and the
    /// motion, while a rig's watchdog waits for commands; whether the legs can drive the load
    /// along the excitation is [`Controller::check_load_forces`]'s, before anything runs.
    pub fn set_load(&mut self, load: InertialParameters) -> Result<(), ControlError> {
        if !(load.is_finite() && load.mass_kg > 0.0) {
            return Err(ControlError::InvalidConfig {
                parameter: "controller.load",
                reason: "mass must be finite and > 0, every parameter finite",
            });
        }
        let at_hold_n = load_leg_forces(&self.geometry, &load, &rest_at(&self.last_pose))?;
        self.load = Some(LoadFeedforward { load, at_hold_n });
        Ok(())
    }

    /// Each leg's feed-forward at the set-point `desired` (Jacobian `jacobian`, desired leg
    /// speeds `speeds`): the static load `static_n`, the rate term `kd·l̇_d` when
    /// [`ControllerConfig::rate_feedforward`] is on, and `load`'s inverse dynamics less its
    /// weight's share at the hold pose ([`Controller::set_load`]). The one sum the tick
    /// commands and [`Controller::check_load_forces`] bounds.
    fn feedforward(
        &self,
        desired: &TrajectorySample,
        jacobian: &Matrix6<f64>,
        speeds: &Vector6<f64>,
        static_n: [f64; LEG_COUNT],
        load: Option<&LoadFeedforward>,
    ) -> Result<[f64; LEG_COUNT], ControlError> {
        let mut feedforward = static_n;
        if self.config.rate_feedforward {
            for (f, speed) in feedforward.iter_mut().zip(speeds.iter()) {
                *f += self.config.pid.kd * speed;
            }
        }
        if let Some(l) = load {
            let dynamic = load_leg_forces_with(&self.geometry, jacobian, &l.load, desired)?;
            for ((f, d), h) in feedforward.iter_mut().zip(dynamic).zip(l.at_hold_n) {
                *f += d - h;
            }
        }
        Ok(feedforward)
    }

    /// Whether the legs can drive `load` (the plate with what it carries, as
    /// [`Controller::set_load`] would get it) along the excitation with the load's
    /// feed-forward: the feed-forward's largest command, every [`FeasibilityLimits::step_s`],
    /// the static part the model's own weight (the brake hold reads it only later), refused
    /// beyond the supervisor's command limit ([`ControlError::ForceViolation`]: the commands
    /// would saturate and the integrators' anti-windup ring after it for seconds). Call it
    /// with the trajectory checks, before anything moves: it solves once per step.
    pub fn check_load_forces(&self, load: &InertialParameters) -> Result<(), ControlError> {
        let load = LoadFeedforward {
            load: *load,
            at_hold_n: [0.0; LEG_COUNT],
        };
        let limit_n = self.config.supervisor.max_command_force_n;
        let step_s = self.config.feasibility.step_s.max(1e-4);
        let duration_s = self.trajectory.duration_s();
        let mut worst = (0.0f64, 0usize, 0.0f64);
        let mut t = 0.0;
        while t <= duration_s {
            let s = self.trajectory.sample(t);
            let jacobian = self.geometry.jacobian(&s.pose);
            let speeds = jacobian * s.twist();
            let forces = self.feedforward(&s, &jacobian, &speeds, [0.0; LEG_COUNT], Some(&load))?;
            for (leg, f) in forces.into_iter().enumerate() {
                if f.abs() > worst.0.abs() {
                    worst = (f, leg, t);
                }
            }
            t += step_s;
        }
        let (force_n, leg, time_s) = worst;
        if force_n.abs() > limit_n {
            return Err(ControlError::ForceViolation {
                time_s,
                leg,
                force_n,
                limit_n,
            });
        }
        Ok(())
    }

    /// Sets the FK warm start (e.g. the platform's resting pose before the first tick).
    /// Ignored unless finite.
    pub fn set_pose_guess(&mut self, pose: Pose) {
        if pose.is_finite() {
            self.last_pose = pose;
        }
    }

    /// Asks for a controlled stop: from Settle or Excite the next tick starts the park ramp
    /// from the current set-point; from Idle the controller goes straight to Done.
    pub fn request_park(&mut self) {
        self.park_requested = true;
    }

    /// Operator reset after a fault: clears it and returns to Idle; the next good frame starts
    /// a new settle from the measured pose.
    pub fn clear_fault(&mut self) {
        self.supervisor.clear_fault();
        self.pids.reset();
        self.motion = Motion::Hold;
        self.last_time_s = None;
        self.park_requested = false;
    }

    /// One control tick. See the [module docs](self).
    pub fn tick(&mut self, frame: &SensorFrame) -> TickOutput {
        self.tick_inner(frame, None)
    }

    /// [`Controller::tick`] plus the host-clock watchdog: `age_s` is how old `frame` is on
    /// the host clock (see [`Supervisor::check_age`]).
    pub fn tick_with_age(&mut self, frame: &SensorFrame, age_s: f64) -> TickOutput {
        self.tick_inner(frame, Some(age_s))
    }

    fn tick_inner(&mut self, frame: &SensorFrame, age_s: Option<f64>) -> TickOutput {
        let home = *self.trajectory.offset();
        let mut out = TickOutput {
            command: CommandFrame::default(),
            phase: self.supervisor.phase(),
            phase_time_s: 0.0,
            fault: None,
            dt_s: 0.0,
            desired: rest_at(&home),
            desired_leg_lengths_m: [0.0; LEG_COUNT],
            desired_leg_speeds_m_s: [0.0; LEG_COUNT],
            measured_leg_lengths_m: frame.leg_lengths_m,
            measured_leg_speeds_m_s: [0.0; LEG_COUNT],
            measured_pose: None,
            fk_iterations: 0,
            fk_residual_m: f64::NAN,
            pid: [PidOutput::default(); LEG_COUNT],
            clamped: false,
        };

        let mut sensors_ok = self.supervisor.check_sensors(frame).is_ok();
        if let Some(age) = age_s {
            sensors_ok &= self.supervisor.check_age(age).is_ok();
        }
        out.measured_leg_speeds_m_s = *self.supervisor.leg_speeds_m_s();
        if sensors_ok {
            let lengths = Vector6::from(frame.leg_lengths_m);
            match self
                .geometry
                .forward_kinematics(&lengths, &self.last_pose, &self.config.fk)
            {
                Ok(solution) => {
                    self.last_pose = solution.pose;
                    out.measured_pose = Some(solution.pose);
                    out.fk_iterations = solution.iterations;
                    out.fk_residual_m = solution.residual_m;
                }
                Err(error) => self.supervisor.trip(Fault::ForwardKinematics(error)),
            }
        }

        let now = frame.time_s;
        let dt_s = match self.last_time_s {
            Some(last) if now > last => now - last,
            _ => self.config.sample_period_s,
        };
        if sensors_ok {
            self.last_time_s = Some(now);
        }
        if let Some(pose) = out.measured_pose {
            self.advance_phase(now, &pose);
        }

        let phase = self.supervisor.phase();
        out.phase_time_s = now - self.phase_start_s;
        let mut forces = [0.0; LEG_COUNT];
        if phase.is_active() {
            let desired = self.setpoint(out.phase_time_s);
            self.last_desired = desired;
            out.desired = desired;
            let legs = self.geometry.legs(&desired.pose);
            let jacobian = self.geometry.jacobian_of_legs(&desired.pose, &legs);
            let speeds = jacobian * desired.twist();
            out.desired_leg_lengths_m = legs.lengths_m.into();
            out.desired_leg_speeds_m_s = speeds.into();
            if let Err(fault) = self.check_desired(&out.desired_leg_lengths_m) {
                self.supervisor.trip(fault);
            } else {
                // A set-point that passed the feasibility check is not singular; should the
                // load's solve fail anyway, the non-finite feed-forward trips the fault below.
                let feedforward = self
                    .feedforward(
                        &desired,
                        &jacobian,
                        &speeds,
                        self.config.feedforward_n,
                        self.load.as_ref(),
                    )
                    .unwrap_or([f64::NAN; LEG_COUNT]);
                match self.pids.update(
                    &out.desired_leg_lengths_m,
                    &frame.leg_lengths_m,
                    &feedforward,
                    dt_s,
                ) {
                    Ok(terms) => {
                        out.pid = terms;
                        out.dt_s = dt_s;
                        forces = terms.map(|t| t.output);
                    }
                    Err(ControlError::NonFinite { index, .. }) => {
                        self.supervisor.trip(Fault::CommandNotFinite { leg: index });
                    }
                    Err(_) => self.supervisor.trip(Fault::CommandNotFinite { leg: 0 }),
                }
            }
        } else {
            out.desired_leg_lengths_m = self.geometry.leg_lengths(&home).into();
        }

        let gated = self.supervisor.gate(&forces, frame.sequence);
        if !self.supervisor.phase().is_active() {
            self.pids.reset();
        }
        out.command = gated.command;
        out.clamped = gated.clamped;
        out.phase = self.supervisor.phase();
        out.fault = self.supervisor.fault();
        out
    }

    /// Phase transitions at time `now` (several may happen in one tick, e.g. a zero hold).
    fn advance_phase(&mut self, now: f64, measured: &Pose) {
        let home = *self.trajectory.offset();
        for _ in 0..4 {
            let t = now - self.phase_start_s;
            match (self.supervisor.phase(), self.motion) {
                (Phase::Idle, _) if self.park_requested => {
                    self.park_requested = false;
                    self.enter(Phase::Done, Motion::Hold, now);
                }
                (Phase::Idle, _) => {
                    let duration = self.ramp_duration(measured, self.config.settle_ramp_s);
                    let Ok(ramp) = Ramp::from_pose(home, measured, duration) else {
                        return;
                    };
                    self.pids.reset();
                    let hold_until_s = duration + self.config.settle_s;
                    self.enter(Phase::Settle, Motion::Settle { ramp, hold_until_s }, now);
                    return;
                }
                (Phase::Settle | Phase::Excite, _) if self.park_requested => {
                    self.park_requested = false;
                    self.start_park(now);
                    return;
                }
                (Phase::Settle, Motion::Settle { hold_until_s, .. }) if t >= hold_until_s => {
                    self.enter(Phase::Excite, Motion::Excite, now);
                }
                (Phase::Excite, _) if t >= self.trajectory.duration_s() => self.start_park(now),
                (Phase::Park, Motion::Park { hold_until_s, .. }) if t >= hold_until_s => {
                    self.enter(Phase::Done, Motion::Hold, now);
                }
                _ => return,
            }
        }
    }

    fn enter(&mut self, phase: Phase, motion: Motion, now: f64) {
        if self.supervisor.set_phase(phase) == phase {
            self.motion = motion;
            self.phase_start_s = now;
        }
    }

    /// Park from the last set-point (position, rate and acceleration) in two quintic pieces, so
    /// that the set-point stays C² and within the leg speed limit even when a fast excitation
    /// is cut short: a brake to rest ([`Ramp::brake`]: the longest, so the gentlest, of
    /// [`BRAKE_DURATIONS_S`] that stays inside the stroke and under the feasibility speed limit,
    /// or failing that the one whose peak leg speed is least), then a rest-to-rest ramp home no shorter than `park_s`
    /// and slow enough for half the feasibility speed limit ([`Self::ramp_duration`]). A
    /// single quintic straight home from a fast state carries the start's acceleration for the
    /// whole ramp and can overshoot the speed limit; the brake takes at most a second.
    fn start_park(&mut self, now: f64) {
        let motion = match self.park_motion() {
            Ok(motion) => motion,
            // Unreachable with a validated config and finite set-points; holding home is the
            // conservative fallback.
            Err(_) => Motion::Hold,
        };
        self.enter(Phase::Park, motion, now);
    }

    fn park_motion(&self) -> Result<Motion, ControlError> {
        let d = self.last_desired;
        let home = *self.trajectory.offset();
        let (c, dc, ddc) = (
            &d.coordinates,
            &d.coordinate_rates,
            &d.coordinate_accelerations,
        );
        let zero = Vector6::zeros();
        // A set-point that the shortest brake would stop within 10 µm (or 10 µrad) of is at
        // rest: the end of a faded excitation, whose last sample still carries a little of the
        // fade's acceleration.
        let shortest = Ramp::brake(home, c, dc, ddc, BRAKE_DURATIONS_S[0])?;
        let at_rest = (shortest.target() - c).amax() < 1e-5;
        let brake = if at_rest {
            None
        } else {
            Some(self.gentlest_brake(c, dc, ddc)?)
        };
        let stop = brake.map_or(*c, |b| *b.target());
        let brake_s = brake.map_or(0.0, |b| b.duration_s());
        let stop_pose = TrajectorySample::from_coordinates(&home, &stop, &zero, &zero).pose;
        let ramp_s = self.ramp_duration(&stop_pose, self.config.park_s);
        let ramp = Ramp::from_state(home, &stop, &zero, &zero, ramp_s)?;
        Ok(Motion::Park {
            brake,
            ramp,
            hold_until_s: brake_s + ramp_s + self.config.park_hold_s,
        })
    }

    /// The longest, so the gentlest, of [`BRAKE_DURATIONS_S`] from the state `(c, ċ, c̈)` that
    /// stays inside the stroke and under the feasibility speed limit; failing that, the one
    /// whose peak leg speed is least; failing that (every brake leaves the stroke), the
    /// shortest.
    fn gentlest_brake(
        &self,
        c: &Vector6<f64>,
        dc: &Vector6<f64>,
        ddc: &Vector6<f64>,
    ) -> Result<Ramp, ControlError> {
        let home = *self.trajectory.offset();
        let limit_m_s = self.config.feasibility.max_leg_speed_m_s;
        let mut gentlest: Option<Ramp> = None;
        let mut least: Option<(f64, Ramp)> = None;
        for duration_s in BRAKE_DURATIONS_S {
            let brake = Ramp::brake(home, c, dc, ddc, duration_s)?;
            let Some(peak_m_s) = self.peak_leg_speed(&brake) else {
                continue;
            };
            if peak_m_s <= limit_m_s {
                gentlest = Some(brake);
            }
            if least.is_none_or(|(fastest, _)| peak_m_s < fastest) {
                least = Some((peak_m_s, brake));
            }
        }
        match (gentlest, least) {
            (Some(brake), _) | (None, Some((_, brake))) => Ok(brake),
            (None, None) => Ramp::brake(home, c, dc, ddc, BRAKE_DURATIONS_S[0]),
        }
    }

    /// The largest desired leg speed along `ramp` (sampled), or `None` when a sample leaves
    /// the stroke less the feasibility margin.
    fn peak_leg_speed(&self, ramp: &Ramp) -> Option<f64> {
        const SAMPLES: usize = 24;
        let stroke = self.geometry.stroke();
        let margin_m = self.config.feasibility.stroke_margin_m;
        let mut peak_m_s: f64 = 0.0;
        for i in 0..=SAMPLES {
            let s = ramp.sample(ramp.duration_s() * i as f64 / SAMPLES as f64);
            let lengths = self.geometry.leg_lengths(&s.pose);
            let inside = lengths.iter().all(|&l| {
                l >= stroke.min_length_m + margin_m && l <= stroke.max_length_m - margin_m
            });
            if !inside {
                return None;
            }
            let speeds = self.geometry.jacobian(&s.pose) * s.twist();
            peak_m_s = peak_m_s.max(speeds.amax());
        }
        Some(peak_m_s)
    }

    /// A rest-to-rest ramp's length from `from` to home: at least `shortest_s`, and long
    /// enough that the ramp's peak speed (1.875 × the mean for a quintic rest-to-rest move)
    /// needs at most half the feasibility speed limit on the leg that moves furthest.
    fn ramp_duration(&self, from: &Pose, shortest_s: f64) -> f64 {
        let from = self.geometry.leg_lengths(from);
        let to = self.geometry.leg_lengths(self.trajectory.offset());
        let furthest = (from - to).amax();
        let needed = 1.875 * furthest / (0.5 * self.config.feasibility.max_leg_speed_m_s);
        if needed.is_finite() {
            needed.max(shortest_s)
        } else {
            shortest_s
        }
    }

    fn setpoint(&self, phase_time_s: f64) -> TrajectorySample {
        match self.motion {
            Motion::Settle { ramp, .. } => ramp.sample(phase_time_s),
            Motion::Park {
                brake: Some(brake), ..
            } if phase_time_s < brake.duration_s() => brake.sample(phase_time_s),
            Motion::Park { brake, ramp, .. } => {
                ramp.sample(phase_time_s - brake.map_or(0.0, |b| b.duration_s()))
            }
            Motion::Excite => self.trajectory.sample(phase_time_s),
            Motion::Hold => rest_at(self.trajectory.offset()),
        }
    }

    fn check_desired(&self, lengths_m: &[f64; LEG_COUNT]) -> Result<(), Fault> {
        let stroke = self.geometry.stroke();
        for (leg, &length_m) in lengths_m.iter().enumerate() {
            if length_m.is_nan() || length_m < stroke.min_length_m || length_m > stroke.max_length_m
            {
                return Err(Fault::DesiredOutOfStroke { leg, length_m });
            }
        }
        Ok(())
    }
}

fn rest_at(pose: &Pose) -> TrajectorySample {
    let zero = Vector6::zeros();
    TrajectorySample::from_coordinates(pose, &zero, &zero, &zero)
}

/// Leg forces that hold a body of `mass_kg` with its centre of mass at `com_in_p_m` (in P)
/// still at `pose` against gravity: the solution of `Jᵀ f = [m g ẑ; (R c) × m g ẑ]` (force up
/// in B, torque about the P origin in B axes; [`Geometry::wrench_in_base`] is `Jᵀ f`). Use it
/// for [`ControllerConfig::feedforward_n`] with the payload plus the plate's own mass.
pub fn gravity_feedforward(
    geometry: &Geometry,
    pose: &Pose,
    mass_kg: f64,
    com_in_p_m: &Vector3<f64>,
) -> Result<[f64; LEG_COUNT], ControlError> {
    if !mass_kg.is_finite() || !com_in_p_m.iter().all(|v| v.is_finite()) || !pose.is_finite() {
        return Err(ControlError::NonFinite {
            what: "gravity feed-forward input",
            index: 0,
        });
    }
    let body = InertialParameters::point_mass(mass_kg, *com_in_p_m);
    load_leg_forces(geometry, &body, &rest_at(pose))
}

#[cfg(test)]
mod tests;
