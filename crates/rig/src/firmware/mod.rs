//! The rig core: the rig's side of the protocol as a firmware runs it (no_std, no heap, no
//! clock, no sockets, no threads).
//!
//! A [`RigCore`] holds the session with one host: the handshake and the key, command
//! validation, the command watchdog, force, stroke and speed limits, the brakes, fault latching
//! and reporting, and the assembly of sensor frames. Its caller owns the clock, the link and
//! the hardware and drives it with three calls:
//!
//! * [`RigCore::receive`]`(now, from, frame, out)` for every frame that arrives;
//! * [`RigCore::actuate`]`(now, out) -> CommandFrame` at the start of every sample period: the
//!   actuator output for the period (the newest valid command, or the brakes);
//! * [`RigCore::report`]`(sensors, out)` with the sensors sampled at the end of the period:
//!   the stroke and speed checks and the sensor frame for the host.
//!
//! [`RigCore::tick`]`(now, sensors, out)` is `report` then `actuate`, the order of a firmware
//! loop that samples, reports and drives at each period boundary. Every call appends the frames
//! to send and the events to an [`Outbox`] the caller drains.
//!
//! Rules it enforces (docs/protocol.md): after a handshake only the session's host may command;
//! frames from other senders, out of sequence, or (with a key) without a valid tag are dropped
//! and counted; a `Hello` from the session's host with a new nonce opens a new session. The
//! rig core brakes (a `CommandFrame` with `enable = false`) and reports a [`Fault`] when no
//! valid command arrived for longer than the watchdog time while the last one drove the
//! actuators (quiet > watchdog; after a braking command it stays braked), when a command
//! force is outside [force_min, force_max] (NaN included), or while driven when a sensed leg
//! length leaves [stroke_min, stroke_max] or a leg speed |lᵢ(k) − lᵢ(k−w)| / (w·T) exceeds
//! speed_max. The first fault of a session latches, is reported again every
//! `FAULT_REPEAT_FRAMES` sensor frames, and holds the brakes until the host opens a new session.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

mod config;
mod motion;
mod outbox;

pub use config::{ConfigError, CoreConfig, CoreKey, KEY_BLOCK_LEN, MAX_SPEED_WINDOW};
pub use outbox::{CoreEvent, FrameKind, Outbox, Outgoing, OUTBOX_EVENTS, OUTBOX_FRAMES};

use stewart_types::{CommandFrame, SensorFrame, Status};

use crate::codec::{self, Auth, CodecError, CodecErrorKind, MAX_FRAME_LEN};
use crate::wire::{
    Command, Fault, FaultCode, Hello, HelloAck, Message, Sensor, FAULT_REPEAT_FRAMES, NO_LEG,
    PROTOCOL_VERSION,
};
use motion::SpeedWindow;

/// What the rig core did and saw (the counters the emulator reports and tests read).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoreStats {
    /// Sessions opened.
    pub sessions: u64,
    /// Frames received, of any kind and from anyone (garbled ones included).
    pub received: u64,
    /// Commands accepted from the session's host.
    pub commands_accepted: u64,
    /// Gaps in the command sequence.
    pub commands_lost: u64,
    /// Commands repeating the last sequence.
    pub duplicate: u64,
    /// Commands older than the last accepted.
    pub out_of_sequence: u64,
    /// Frames from senders other than the session's host.
    pub foreign_sender: u64,
    /// Frames whose tag was missing, unexpected or wrong.
    pub auth_failed: u64,
    /// Damaged frames.
    pub corrupt: u64,
    /// Frames of another protocol version or protocol.
    pub version_mismatch: u64,
    /// Valid frames of a kind the rig does not take (or commands outside a session).
    pub unexpected: u64,
    /// Faults latched and reported (repeats not counted).
    pub faults_sent: u64,
    /// Reports in a session after a braked period.
    pub braked_ticks: u64,
    /// Sensor frames assembled in sessions.
    pub sensor_frames: u64,
    /// `Hello`s dropped as replays: a `host_nonce` that opened an earlier session.
    pub replayed_hellos: u64,
}

/// The session with one host, as seen from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SessionView<P> {
    /// The host.
    pub peer: P,
    /// 1 for the rig core's first session, then +1 per session.
    pub number: u64,
    /// The session number sent in the `HelloAck`.
    pub session_id: u64,
    /// Sequence of the last sensor frame assembled (0: none yet).
    pub sensor_sequence: u64,
    /// Sequence of the last command taken (0: none).
    pub last_command_sequence: u64,
    /// The newest accepted command, braking ones included.
    pub latest: Option<Command>,
    /// The latched fault.
    pub fault: Option<Fault>,
}

#[derive(Clone, Copy, Debug)]
struct Session<P> {
    view: SessionView<P>,
    host_nonce: u64,
    ack: [u8; MAX_FRAME_LEN],
    ack_len: usize,
    last_command_at: Option<u64>,
    last_heard: u64,
}

/// The `host_nonce`s of the last [`RECENT_NONCES`] sessions: a `Hello` carrying one of them
/// (other than the running session's own retries) is a replay, whose valid tag (made with
/// `session_id` 0, so valid in every session) would otherwise open a new session and end the
/// host's. A genuine host picks a fresh random nonce for every handshake.
#[derive(Clone, Copy, Debug)]
struct RecentNonces {
    nonces: [u64; RECENT_NONCES],
    len: usize,
    next: usize,
}

/// How many sessions' nonces the rig remembers: far more than one host opens between two
/// restarts of a rig in a measurement campaign (two a measurement), in 256 bytes.
pub const RECENT_NONCES: usize = 32;

impl RecentNonces {
    const fn new() -> Self {
        Self {
            nonces: [0; RECENT_NONCES],
            len: 0,
            next: 0,
        }
    }

    fn contains(&self, nonce: u64) -> bool {
        self.nonces.iter().take(self.len).any(|n| *n == nonce)
    }

    fn remember(&mut self, nonce: u64) {
        if let Some(slot) = self.nonces.get_mut(self.next) {
            *slot = nonce;
        }
        self.next = (self.next + 1) % RECENT_NONCES;
        self.len = (self.len + 1).min(RECENT_NONCES);
    }
}

/// A small generator of session numbers: SplitMix64, a bijection of its counter, so numbers
/// from one seed do not repeat within 2⁶⁴ sessions.
#[derive(Clone, Copy, Debug)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// The rig's side of the protocol for peers identified by `P` (a small `Copy` id the caller's
/// transport maps to addresses; `()` on a serial line). See the module documentation.
#[derive(Clone, Debug)]
pub struct RigCore<P> {
    config: CoreConfig,
    session_ids: SplitMix64,
    recent_nonces: RecentNonces,
    session: Option<Session<P>>,
    /// The newest command of the last session, once it timed out.
    timed_out_command: Option<Command>,
    /// The output of the last [`RigCore::actuate`]: what drove the legs until the next report.
    applied: CommandFrame,
    speeds: SpeedWindow,
    stats: CoreStats,
}

impl<P: Copy + PartialEq> RigCore<P> {
    /// A rig core with no session, braked.
    pub fn new(config: CoreConfig) -> Result<Self, ConfigError> {
        config.check()?;
        Ok(Self {
            session_ids: SplitMix64(config.seed),
            recent_nonces: RecentNonces::new(),
            session: None,
            timed_out_command: None,
            applied: CommandFrame::safe_stop(0, 0),
            speeds: SpeedWindow::new(config.speed_window),
            stats: CoreStats::default(),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &CoreConfig {
        &self.config
    }

    /// The counters so far.
    pub fn stats(&self) -> &CoreStats {
        &self.stats
    }

    /// The open session, if any.
    pub fn session(&self) -> Option<SessionView<P>> {
        self.session.as_ref().map(|s| s.view)
    }

    /// The newest command accepted from the current session's host, or, when no session is
    /// open (the last one timed out), from the last session's; `None` before the first.
    pub fn last_command(&self) -> Option<Command> {
        match &self.session {
            Some(s) => s.view.latest,
            None => self.timed_out_command,
        }
    }

    /// The output of the last [`actuate`](Self::actuate) (the brakes before the first).
    pub fn applied(&self) -> &CommandFrame {
        &self.applied
    }

    /// Counts a frame the link delivered damaged (e.g. broken COBS on a serial line).
    pub fn receive_garbled(&mut self) {
        self.stats.received += 1;
        self.stats.corrupt += 1;
    }

    /// Handles one received frame (`frame`: one datagram, or one COBS-decoded frame) from
    /// `from` at `now_ns`. Answers (a `HelloAck`, a refusal, a fault) go to `out`.
    pub fn receive(&mut self, now_ns: u64, from: P, frame: &[u8], out: &mut Outbox<P>) {
        self.stats.received += 1;
        let (message, tagged) = match codec::decode_unverified(frame) {
            Ok(decoded) => decoded,
            Err(CodecError::VersionMismatch(_)) => {
                self.stats.version_mismatch += 1;
                // Answer in this side's version: the host names both versions in its error.
                refuse(
                    out,
                    from,
                    FaultCode::VERSION_MISMATCH,
                    f64::from(PROTOCOL_VERSION),
                );
                return;
            }
            Err(e) => {
                self.count(&e);
                return;
            }
        };
        let session = self
            .session
            .as_ref()
            .map(|s| (s.view.peer, s.view.session_id));
        if session.is_some_and(|(peer, _)| peer != from) {
            self.stats.foreign_sender += 1;
            if matches!(message, Message::Hello(_)) {
                refuse(out, from, FaultCode::BUSY, 0.0);
            }
            return;
        }
        match (message, session) {
            (Message::Hello(hello), _) => self.hello(&hello, frame, tagged, from, now_ns, out),
            (Message::Command(_), Some((_, id))) => {
                match codec::decode(frame, self.auth(id).as_ref()) {
                    Ok(Message::Command(command)) => self.command(&command, now_ns, out),
                    Ok(_) => self.stats.unexpected += 1,
                    Err(e) => self.count(&e),
                }
            }
            _ => self.stats.unexpected += 1,
        }
    }

    /// The actuator output for the sample period starting at `now_ns`: the newest valid
    /// command, or the brakes (no session, a latched fault, no command yet, a braking
    /// command, or the watchdog: now − last command > watchdog after a driving command, which
    /// latches a fault). Ends a session whose host has
    /// been silent for longer than the session timeout.
    pub fn actuate(&mut self, now_ns: u64, out: &mut Outbox<P>) -> CommandFrame {
        if let Some(s) = &self.session {
            let silent_for_ns = now_ns.saturating_sub(s.last_heard);
            if silent_for_ns > self.config.session_timeout_ns {
                out.push_event(CoreEvent::SessionTimedOut {
                    session: s.view.number,
                    peer: s.view.peer,
                    silent_for_ns,
                });
                self.timed_out_command = s.view.latest;
                self.session = None;
            }
        }
        self.applied = self.choose(now_ns, out);
        self.applied
    }

    /// Takes the sensors sampled at the end of the period [`actuate`](Self::actuate) drove:
    /// while driven, checks stroke and speed (latching a fault); then assembles the session's
    /// next sensor frame (the sample with the next sequence number and the ENABLED or BRAKED
    /// and FAULT status bits) and repeats a latched fault every `FAULT_REPEAT_FRAMES` frames.
    pub fn report(&mut self, sensors: &SensorFrame, out: &mut Outbox<P>) {
        if self.session.is_none() {
            return;
        }
        let enabled = self.applied.enable;
        if enabled {
            self.check_motion(sensors, out);
        } else {
            self.stats.braked_ticks += 1;
            self.speeds.clear();
        }
        let auth_key = self.config.key;
        let Some(s) = self.session.as_mut() else {
            return;
        };
        let mut status = sensors.status.0;
        status |= if enabled {
            Status::ENABLED
        } else {
            Status::BRAKED
        };
        if s.view.fault.is_some() {
            status |= Status::FAULT;
        }
        s.view.sensor_sequence += 1;
        let sequence = s.view.sensor_sequence;
        let auth = auth_key.as_ref().map(|key| Auth {
            key: key.bytes(),
            session_id: s.view.session_id,
        });
        if let Some(fault) = s.view.fault {
            if sequence % FAULT_REPEAT_FRAMES == 0 {
                let message = Message::Fault(fault);
                out.push_message(s.view.peer, FrameKind::Fault, &message, auth.as_ref());
            }
        }
        let sensor = Sensor {
            sequence,
            status,
            ..Sensor::from(sensors)
        };
        out.push_message(
            s.view.peer,
            FrameKind::Sensor { sequence },
            &Message::Sensor(sensor),
            auth.as_ref(),
        );
        self.stats.sensor_frames += 1;
    }

    /// One firmware period at `now_ns`: [`report`](Self::report) the sensors sampled now
    /// (the end of the last period), then [`actuate`](Self::actuate) for the next.
    pub fn tick(
        &mut self,
        now_ns: u64,
        sensors: &SensorFrame,
        out: &mut Outbox<P>,
    ) -> CommandFrame {
        self.report(sensors, out);
        self.actuate(now_ns, out)
    }

    fn choose(&mut self, now_ns: u64, out: &mut Outbox<P>) -> CommandFrame {
        let brake = CommandFrame::safe_stop(0, 0);
        let Some(s) = &self.session else {
            return brake;
        };
        if s.view.fault.is_some() {
            return brake;
        }
        // The watchdog guards driven actuators: after a braking command the rig is braked
        // already, and a host that ends its session with a safe stop and falls silent is the
        // session's normal end (the session timeout closes it), not a fault.
        let driven = s.view.latest.as_ref().is_some_and(|c| c.enable);
        if let (Some(at), true) = (s.last_command_at, driven) {
            let quiet_ns = now_ns.saturating_sub(at);
            if quiet_ns > self.config.watchdog_ns {
                self.trip(FaultCode::WATCHDOG, NO_LEG, quiet_ns as f64 / 1e9, out);
                return brake;
            }
        }
        match &s.view.latest {
            Some(c) if c.enable => CommandFrame::from(c),
            // A braking command's forces are meaningless and unchecked (they may be NaN): the
            // actuators get zeros.
            Some(c) => CommandFrame::safe_stop(c.sequence, c.sensor_sequence),
            None => brake,
        }
    }

    fn check_motion(&mut self, sensors: &SensorFrame, out: &mut Outbox<P>) {
        if !self.config.enforce_motion_limits {
            return;
        }
        let l = self.config.limits;
        let lengths = sensors.leg_lengths_m;
        let outside = lengths
            .iter()
            .enumerate()
            .find(|(_, &x)| !(x >= l.stroke_min_m && x <= l.stroke_max_m));
        if let Some((leg, &length)) = outside {
            self.trip(FaultCode::STROKE_LIMIT, leg_index(leg), length, out);
        }
        let span_s = self.config.sample_period_ns as f64 / 1e9 * self.speeds.window() as f64;
        if let Some(old) = self.speeds.push(lengths) {
            let too_fast = lengths
                .iter()
                .zip(old.iter())
                .map(|(now, then)| (now - then).abs() / span_s)
                .enumerate()
                .find(|&(_, speed)| speed > l.speed_max_m_s);
            if let Some((leg, speed)) = too_fast {
                self.trip(FaultCode::SPEED_LIMIT, leg_index(leg), speed, out);
            }
        }
    }

    /// Latches a fault in the session (the first one wins) and reports it.
    fn trip(&mut self, code: FaultCode, leg: u8, value: f64, out: &mut Outbox<P>) {
        let key = self.config.key;
        let Some(s) = self.session.as_mut() else {
            return;
        };
        if s.view.fault.is_some() {
            return;
        }
        let fault = Fault {
            code,
            leg,
            value,
            command_sequence: s.view.last_command_sequence,
        };
        s.view.fault = Some(fault);
        self.stats.faults_sent += 1;
        let auth = key.as_ref().map(|key| Auth {
            key: key.bytes(),
            session_id: s.view.session_id,
        });
        let peer = s.view.peer;
        out.push_message(
            peer,
            FrameKind::Fault,
            &Message::Fault(fault),
            auth.as_ref(),
        );
        out.push_event(CoreEvent::Fault {
            session: s.view.number,
            peer,
            fault,
        });
    }

    fn auth(&self, session_id: u64) -> Option<Auth<'_>> {
        self.config.key.as_ref().map(|key| Auth {
            key: key.bytes(),
            session_id,
        })
    }

    fn count(&mut self, error: &CodecError) {
        match error.kind() {
            CodecErrorKind::Corrupt | CodecErrorKind::Encode => self.stats.corrupt += 1,
            CodecErrorKind::Auth => self.stats.auth_failed += 1,
            CodecErrorKind::Foreign => self.stats.version_mismatch += 1,
        }
    }

    fn hello(
        &mut self,
        hello: &Hello,
        frame: &[u8],
        tagged: bool,
        from: P,
        now_ns: u64,
        out: &mut Outbox<P>,
    ) {
        let refusal = match &self.config.key {
            Some(key) => match hello.key_id {
                None => Some(FaultCode::KEY_REQUIRED),
                Some(id) if id != key.id() => Some(FaultCode::KEY_MISMATCH),
                Some(_) if codec::decode(frame, self.auth(0).as_ref()).is_err() => {
                    Some(FaultCode::KEY_MISMATCH)
                }
                Some(_) => None,
            },
            None if tagged => Some(FaultCode::KEY_MISMATCH),
            None => None,
        };
        if let Some(code) = refusal {
            self.stats.auth_failed += 1;
            refuse(out, from, code, 0.0);
            return;
        }
        // A repeated Hello of the session's own handshake (the host retries until answered):
        // answer again, do not restart the session.
        if let Some(s) = &mut self.session {
            if s.view.peer == from && s.host_nonce == hello.host_nonce {
                s.last_heard = now_ns;
                out.push_encoded(
                    from,
                    FrameKind::HelloAck,
                    s.ack.get(..s.ack_len).unwrap_or(&[]),
                );
                return;
            }
        }
        if self.recent_nonces.contains(hello.host_nonce) {
            // Answered with nothing: a refusal would reach the host's address too.
            self.stats.replayed_hellos += 1;
            return;
        }
        let session_id = loop {
            let id = self.session_ids.next();
            if id != 0 {
                break id;
            }
        };
        let ack = HelloAck {
            host_nonce: hello.host_nonce,
            session_id,
            identity: self.config.identity,
            layout: self.config.layout,
            sample_period_ns: u32::try_from(self.config.sample_period_ns).unwrap_or(u32::MAX),
            watchdog_ns: u32::try_from(self.config.watchdog_ns).unwrap_or(u32::MAX),
            limits: self.config.limits,
        };
        let mut bytes = [0u8; MAX_FRAME_LEN];
        let Ok(ack_len) = codec::encode(&Message::HelloAck(ack), self.auth(0).as_ref(), &mut bytes)
        else {
            return;
        };
        let number = self.stats.sessions + 1;
        self.recent_nonces.remember(hello.host_nonce);
        self.session = Some(Session {
            view: SessionView {
                peer: from,
                number,
                session_id,
                sensor_sequence: 0,
                last_command_sequence: 0,
                latest: None,
                fault: None,
            },
            host_nonce: hello.host_nonce,
            ack: bytes,
            ack_len,
            last_command_at: None,
            last_heard: now_ns,
        });
        self.speeds.clear();
        self.stats.sessions = number;
        out.push_event(CoreEvent::SessionOpened {
            number,
            peer: from,
            session_id,
        });
        out.push_encoded(
            from,
            FrameKind::HelloAck,
            bytes.get(..ack_len).unwrap_or(&[]),
        );
    }

    fn command(&mut self, command: &Command, now_ns: u64, out: &mut Outbox<P>) {
        let limits = self.config.limits;
        let Some(s) = self.session.as_mut() else {
            return;
        };
        let last = s.view.last_command_sequence;
        if command.sequence == last {
            self.stats.duplicate += 1;
            return;
        }
        if command.sequence < last {
            self.stats.out_of_sequence += 1;
            return;
        }
        self.stats.commands_lost += command.sequence - last - 1;
        s.view.last_command_sequence = command.sequence;
        s.last_heard = now_ns;
        let beyond = command
            .leg_forces_n
            .iter()
            .enumerate()
            .find(|(_, &f)| !(f >= limits.force_min_n && f <= limits.force_max_n));
        if let (true, Some((leg, &force))) = (command.enable, beyond) {
            self.trip(FaultCode::FORCE_LIMIT, leg_index(leg), force, out);
            return;
        }
        let Some(s) = self.session.as_mut() else {
            return;
        };
        s.view.latest = Some(*command);
        s.last_command_at = Some(now_ns);
        self.stats.commands_accepted += 1;
    }
}

/// A leg index as the wire's `u8` (legs are fewer than 255).
fn leg_index(leg: usize) -> u8 {
    u8::try_from(leg).unwrap_or(NO_LEG)
}

/// An untagged fault to a sender without a session.
fn refuse<P: Copy>(out: &mut Outbox<P>, to: P, code: FaultCode, value: f64) {
    let fault = Fault {
        code,
        leg: NO_LEG,
        value,
        command_sequence: 0,
    };
    out.push_message(to, FrameKind::Refusal, &Message::Fault(fault), None);
}

#[cfg(test)]
mod tests;
