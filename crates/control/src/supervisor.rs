//! Safety supervisor: procedure phases, limits, sensor watchdog, command gate.
//!
//! Every sensor frame passes [`Supervisor::check_sensors`] before the controller uses it, and
//! every force command passes [`Supervisor::gate`] before it reaches a backend. The first fault
//! latches: the phase becomes [`Phase::Fault`], every later command is
//! [`CommandFrame::safe_stop`], and [`Supervisor::fault`] keeps the cause (which limit, which
//! leg, which value) until an operator calls [`Supervisor::clear_fault`].
//!
//! Commands that pass are clamped to `±max_command_force_n` whatever the PID computed, so no
//! gain or feed-forward setting can command more than the configured force.

use kinematics::StrokeLimits;

use crate::error::ControlError;
pub use crate::fault::{Fault, SensorChannel};
use crate::io::{CommandFrame, SensorFrame, Status, LEG_COUNT};

/// Where the measurement procedure is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Not started: brakes on.
    #[default]
    Idle,
    /// Moving to and holding the home pose so that transients die out.
    Settle,
    /// Following the excitation trajectory.
    Excite,
    /// Ramping back to the home pose.
    Park,
    /// Finished: brakes on.
    Done,
    /// A fault latched: brakes on until [`Supervisor::clear_fault`].
    Fault,
}

impl Phase {
    /// True in the phases where the actuators are driven (Settle, Excite, Park).
    pub const fn is_active(self) -> bool {
        matches!(self, Self::Settle | Self::Excite | Self::Park)
    }

    /// Lower-case name for logs.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Idle => "idle",
            Self::Settle => "settle",
            Self::Excite => "excite",
            Self::Park => "park",
            Self::Done => "done",
            Self::Fault => "fault",
        }
    }
}

/// Limits and watchdog settings. Plain `Copy` data; the stroke itself comes from the geometry
/// (see [`Supervisor::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupervisorConfig {
    /// Measured lengths may exceed the stroke by this much before tripping, m (≥ 0). Covers
    /// sensor noise at the end stops.
    pub leg_length_margin_m: f64,
    /// Largest allowed |leg speed|, m/s (> 0).
    pub max_leg_speed_m_s: f64,
    /// Time constant of the first-order filter on the differentiated leg lengths, s (≥ 0);
    /// keeps sensor noise from tripping the speed limit.
    pub leg_speed_filter_s: f64,
    /// Force commands are clamped to ±this, N (> 0).
    pub max_command_force_n: f64,
    /// Largest allowed |measured leg force|, N (> 0).
    pub max_measured_force_n: f64,
    /// Largest allowed time between consecutive sensor frames, s (> 0).
    pub max_sample_gap_s: f64,
    /// Largest allowed age of a frame on the host clock, s (> 0), checked only when the caller
    /// supplies an age ([`Supervisor::check_age`]).
    pub max_sensor_age_s: f64,
}

impl Default for SupervisorConfig {
    /// 1 mm length margin, 0.5 m/s with a 5 ms speed filter, 25 kN command and 30 kN measured
    /// force limits, 20 ms watchdog on gaps and age (twenty samples at 1 kHz).
    fn default() -> Self {
        Self {
            leg_length_margin_m: 0.001,
            max_leg_speed_m_s: 0.5,
            leg_speed_filter_s: 0.005,
            max_command_force_n: 25_000.0,
            max_measured_force_n: 30_000.0,
            max_sample_gap_s: 0.02,
            max_sensor_age_s: 0.02,
        }
    }
}

impl SupervisorConfig {
    /// Checks every field's range (see the field docs).
    pub fn validate(&self) -> Result<(), ControlError> {
        let non_negative = [
            ("supervisor.leg_length_margin_m", self.leg_length_margin_m),
            ("supervisor.leg_speed_filter_s", self.leg_speed_filter_s),
        ];
        for (parameter, value) in non_negative {
            if !value.is_finite() || value < 0.0 {
                return Err(ControlError::InvalidConfig {
                    parameter,
                    reason: "must be finite and >= 0",
                });
            }
        }
        let positive = [
            ("supervisor.max_leg_speed_m_s", self.max_leg_speed_m_s),
            ("supervisor.max_command_force_n", self.max_command_force_n),
            ("supervisor.max_measured_force_n", self.max_measured_force_n),
            ("supervisor.max_sample_gap_s", self.max_sample_gap_s),
            ("supervisor.max_sensor_age_s", self.max_sensor_age_s),
        ];
        for (parameter, value) in positive {
            if !value.is_finite() || value <= 0.0 {
                return Err(ControlError::InvalidConfig {
                    parameter,
                    reason: "must be finite and > 0",
                });
            }
        }
        Ok(())
    }
}

/// A gated command and whether the gate changed it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gated {
    /// What to send to the backend.
    pub command: CommandFrame,
    /// True when at least one force was clamped to the command limit.
    pub clamped: bool,
}

/// Last accepted frame, for the watchdog and the speed estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
struct History {
    sequence: u64,
    time_s: f64,
    lengths_m: [f64; LEG_COUNT],
}

/// The safety supervisor. See the [module docs](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Supervisor {
    config: SupervisorConfig,
    min_length_m: f64,
    max_length_m: f64,
    phase: Phase,
    fault: Option<Fault>,
    history: Option<History>,
    speeds_m_s: [f64; LEG_COUNT],
    command_sequence: u64,
}

impl Supervisor {
    /// A supervisor in [`Phase::Idle`] for legs with the given stroke.
    pub fn new(config: SupervisorConfig, stroke: StrokeLimits) -> Result<Self, ControlError> {
        config.validate()?;
        if !stroke.min_length_m.is_finite()
            || !stroke.max_length_m.is_finite()
            || stroke.min_length_m >= stroke.max_length_m
        {
            return Err(ControlError::InvalidConfig {
                parameter: "stroke",
                reason: "must be finite with min < max",
            });
        }
        Ok(Self {
            config,
            min_length_m: stroke.min_length_m - config.leg_length_margin_m,
            max_length_m: stroke.max_length_m + config.leg_length_margin_m,
            phase: Phase::Idle,
            fault: None,
            history: None,
            speeds_m_s: [0.0; LEG_COUNT],
            command_sequence: 0,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &SupervisorConfig {
        &self.config
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        self.fault
    }

    /// The filtered leg-speed estimates from the last accepted frames, m/s.
    pub fn leg_speeds_m_s(&self) -> &[f64; LEG_COUNT] {
        &self.speeds_m_s
    }

    /// Moves to `phase` and returns the phase now in force. A latched fault is never left this
    /// way (use [`Supervisor::clear_fault`]), and [`Phase::Fault`] is only entered through
    /// [`Supervisor::trip`], which needs a cause.
    pub fn set_phase(&mut self, phase: Phase) -> Phase {
        if self.fault.is_none() && phase != Phase::Fault {
            self.phase = phase;
        }
        self.phase
    }

    /// Latches `fault` (the first cause is kept; later ones are dropped) and enters
    /// [`Phase::Fault`].
    pub fn trip(&mut self, fault: Fault) {
        if self.fault.is_none() {
            self.fault = Some(fault);
        }
        self.phase = Phase::Fault;
    }

    /// Operator reset: clears the fault and the watchdog history and returns to
    /// [`Phase::Idle`].
    pub fn clear_fault(&mut self) {
        self.fault = None;
        self.history = None;
        self.speeds_m_s = [0.0; LEG_COUNT];
        self.phase = Phase::Idle;
    }

    /// Checks one sensor frame: backend status, finiteness, sequence and time advancing, the
    /// gap since the previous frame, leg lengths against the stroke (± margin), measured
    /// forces, and leg speeds (the finite difference of lengths between frames through a
    /// first-order filter, `v̂ ← v̂ + dt/(T + dt)·(Δl/dt − v̂)`). Trips and returns the fault
    /// on the first violation; once faulted, returns the latched fault.
    pub fn check_sensors(&mut self, frame: &SensorFrame) -> Result<(), Fault> {
        if let Some(fault) = self.fault {
            return Err(fault);
        }
        match self.evaluate(frame) {
            Ok(()) => Ok(()),
            Err(fault) => {
                self.trip(fault);
                Err(fault)
            }
        }
    }

    /// Watchdog on the host clock: trips when a frame is older than `max_sensor_age_s`. `age_s`
    /// is the host's now minus the frame's arrival (or its time stamp mapped to host time); a
    /// non-finite age counts as too old.
    pub fn check_age(&mut self, age_s: f64) -> Result<(), Fault> {
        if let Some(fault) = self.fault {
            return Err(fault);
        }
        let limit_s = self.config.max_sensor_age_s;
        if age_s.is_finite() && age_s <= limit_s {
            return Ok(());
        }
        let fault = Fault::SensorTooOld { age_s, limit_s };
        self.trip(fault);
        Err(fault)
    }

    fn evaluate(&mut self, frame: &SensorFrame) -> Result<(), Fault> {
        if frame.status.has(Status::ESTOP) {
            return Err(Fault::EmergencyStop);
        }
        if frame.status.has(Status::FAULT) || frame.status.has(Status::SENSOR_INVALID) {
            return Err(Fault::BackendStatus {
                status: frame.status,
            });
        }
        check_finite(frame)?;
        let config = self.config;
        if let Some(last) = self.history {
            if frame.sequence <= last.sequence {
                return Err(Fault::SequenceNotAdvancing {
                    previous: last.sequence,
                    received: frame.sequence,
                });
            }
            if frame.time_s <= last.time_s {
                return Err(Fault::TimeNotAdvancing {
                    previous_s: last.time_s,
                    received_s: frame.time_s,
                });
            }
            let gap_s = frame.time_s - last.time_s;
            if gap_s > config.max_sample_gap_s {
                return Err(Fault::SampleGap {
                    gap_s,
                    limit_s: config.max_sample_gap_s,
                });
            }
        }
        for (leg, &length_m) in frame.leg_lengths_m.iter().enumerate() {
            if length_m < self.min_length_m {
                return Err(Fault::LegTooShort {
                    leg,
                    length_m,
                    limit_m: self.min_length_m,
                });
            }
            if length_m > self.max_length_m {
                return Err(Fault::LegTooLong {
                    leg,
                    length_m,
                    limit_m: self.max_length_m,
                });
            }
        }
        for (leg, &force_n) in frame.leg_forces_n.iter().enumerate() {
            if force_n.abs() > config.max_measured_force_n {
                return Err(Fault::MeasuredForce {
                    leg,
                    force_n,
                    limit_n: config.max_measured_force_n,
                });
            }
        }
        let mut speeds = self.speeds_m_s;
        if let Some(last) = self.history {
            let dt = frame.time_s - last.time_s;
            let gain = dt / (config.leg_speed_filter_s + dt);
            for ((speed, &now), &before) in speeds
                .iter_mut()
                .zip(&frame.leg_lengths_m)
                .zip(&last.lengths_m)
            {
                *speed += gain * ((now - before) / dt - *speed);
            }
            for (leg, &speed_m_s) in speeds.iter().enumerate() {
                if speed_m_s.abs() > config.max_leg_speed_m_s {
                    return Err(Fault::LegSpeed {
                        leg,
                        speed_m_s,
                        limit_m_s: config.max_leg_speed_m_s,
                    });
                }
            }
        }
        self.speeds_m_s = speeds;
        self.history = Some(History {
            sequence: frame.sequence,
            time_s: frame.time_s,
            lengths_m: frame.leg_lengths_m,
        });
        Ok(())
    }

    /// The command for the backend. Outside the active phases (Idle, Done, Fault) this is the
    /// safe stop whatever `forces_n` says. In Settle, Excite and Park the forces pass, each
    /// clamped to `±max_command_force_n`; a non-finite force trips
    /// [`Fault::CommandNotFinite`] and gives the safe stop. Each call takes the next command
    /// sequence number.
    pub fn gate(&mut self, forces_n: &[f64; LEG_COUNT], sensor_sequence: u64) -> Gated {
        self.command_sequence = self.command_sequence.wrapping_add(1);
        let safe = CommandFrame::safe_stop(self.command_sequence, sensor_sequence);
        if !self.phase.is_active() {
            return Gated {
                command: safe,
                clamped: false,
            };
        }
        if let Some(leg) = forces_n.iter().position(|f| !f.is_finite()) {
            self.trip(Fault::CommandNotFinite { leg });
            return Gated {
                command: safe,
                clamped: false,
            };
        }
        let limit = self.config.max_command_force_n;
        let clamped = forces_n.iter().any(|f| f.abs() > limit);
        Gated {
            command: CommandFrame {
                sequence: self.command_sequence,
                sensor_sequence,
                leg_forces_n: forces_n.map(|f| f.clamp(-limit, limit)),
                enable: true,
            },
            clamped,
        }
    }
}

fn check_finite(frame: &SensorFrame) -> Result<(), Fault> {
    if !frame.time_s.is_finite() {
        return Err(Fault::SensorNotFinite {
            channel: SensorChannel::Time,
            index: 0,
        });
    }
    let channels: [(SensorChannel, &[f64]); 4] = [
        (SensorChannel::LegLength, &frame.leg_lengths_m),
        (SensorChannel::LegForce, &frame.leg_forces_n),
        (SensorChannel::Gyro, &frame.gyro_rad_s),
        (SensorChannel::Accel, &frame.accel_m_s2),
    ];
    for (channel, values) in channels {
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(Fault::SensorNotFinite { channel, index });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
