//! The rig emulator: any `control::io::Backend` (the simulator, in practice) served behind the
//! protocol in real time, with the safety a real rig controller enforces by itself.
//!
//! Every sample period, paced by the wall clock, the emulator applies the newest valid command
//! to the inner backend (`write`, which advances a simulator by one period), reads its sensors
//! and sends them to the session's host. It brakes the inner backend (a command with
//! `enable = false`) and reports a [`Fault`] when no valid command arrived within the watchdog
//! time (20 ms), when a command exceeds the force limits, or when a leg leaves its stroke or
//! exceeds its speed limit. A fault holds the brakes until the host opens a new session.
//!
//! After a handshake, only the session's host may command: frames from other addresses, out
//! of sequence, or (with a key) without a valid tag are dropped and counted.
//!
//! [`FaultInjection`] degrades the link on purpose, for tests.

use std::collections::VecDeque;
use std::fmt::Display;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use control::io::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::codec::{self, Auth, CodecError, CodecErrorKind, MAX_FRAME_LEN};
use crate::error::RigError;
use crate::key::Key;
use crate::transport::{self, Address, Peer, Recv, Transport};
use crate::wire::{
    identity_from_str, Command, Fault, FaultCode, Hello, HelloAck, Limits, Message, Sensor,
    SensorLayout, FAULT_REPEAT_FRAMES, NO_LEG, PROTOCOL_VERSION,
};

/// Deliberate damage to the link, for tests. All fractions are probabilities per sensor frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaultInjection {
    /// Fraction of sensor frames not sent (their sequence numbers are used up).
    pub drop_fraction: f64,
    /// Fraction of sensor frames sent with one bit flipped (the CRC catches it).
    pub corrupt_fraction: f64,
    /// Fraction of sensor frames held back by [`delay`](Self::delay) before sending.
    pub delay_fraction: f64,
    /// How long delayed frames are held back.
    pub delay: Duration,
    /// After this many sensor frames in a session the emulator stops answering altogether
    /// (no frames, no faults), as a rig whose link died.
    pub stop_after_frames: Option<u64>,
}

/// How the emulator presents itself and what it enforces.
#[derive(Clone, Debug)]
pub struct EmulatorConfig {
    /// Identity string sent in the handshake.
    pub identity: String,
    /// Sensor layout sent in the handshake.
    pub layout: SensorLayout,
    /// Hard limits: sent in the handshake and enforced.
    pub limits: Limits,
    /// Brake when no valid command arrived for this long (20 ms).
    pub watchdog: Duration,
    /// Drop a session whose host has been silent this long (1 s), so another host may connect.
    pub session_timeout: Duration,
    /// Shared key: accept only frames tagged with it, tag every frame sent.
    pub key: Option<Key>,
    /// Brake on measured stroke and speed violations while the actuators are driven (true).
    pub enforce_motion_limits: bool,
    /// Leg speed is the length change over this many samples, to keep sensor noise from
    /// tripping the speed limit (10).
    pub speed_window: usize,
    /// Link damage for tests.
    pub faults: FaultInjection,
    /// Lockstep, for tests on busy machines (`None`, the default: real time, as a rig).
    /// With `Some(limit)`, before each sample of a session the emulator waits, at most `limit`,
    /// until the host has answered the last sensor frame it sent intact (not dropped or
    /// corrupted by injection): a host that is descheduled then pauses the emulated world
    /// instead of letting the platform run on its last command. The watchdog still trips
    /// when the host stays silent for longer than the watchdog time.
    pub lockstep: Option<Duration>,
    /// Seed for session numbers and fault injection.
    pub seed: u64,
}

impl EmulatorConfig {
    /// Defaults around the given limits: identity "stewart-emulator", six legs, an IMU at the
    /// P origin, a 20 ms watchdog, no key, no injected faults, a random seed.
    pub fn new(limits: Limits) -> Self {
        Self {
            identity: "stewart-emulator".into(),
            layout: SensorLayout {
                leg_count: LEG_COUNT as u8,
                imu_present: true,
                accel_position_m: [0.0; 3],
            },
            limits,
            watchdog: Duration::from_millis(20),
            session_timeout: Duration::from_secs(1),
            key: None,
            enforce_motion_limits: true,
            speed_window: 10,
            faults: FaultInjection::default(),
            lockstep: None,
            seed: rand::random(),
        }
    }
}

/// What the emulator did and saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Sample periods run.
    pub ticks: u64,
    /// Ticks that started more than one period late (the machine could not keep up).
    pub overruns: u64,
    /// Sessions opened.
    pub sessions: u64,
    /// Sensor frames produced in sessions (including dropped ones).
    pub sensor_frames: u64,
    /// Sensor frames put on the link.
    pub sent: u64,
    /// Sensor frames dropped by fault injection.
    pub dropped_injected: u64,
    /// Sensor frames corrupted by fault injection.
    pub corrupted_injected: u64,
    /// Sensor frames delayed by fault injection.
    pub delayed_injected: u64,
    /// Frames received, of any kind and from anyone.
    pub received: u64,
    /// Commands accepted from the session's host.
    pub commands_accepted: u64,
    /// Gaps in the command sequence.
    pub commands_lost: u64,
    /// Commands repeating the last sequence.
    pub duplicate: u64,
    /// Commands older than the last accepted.
    pub out_of_sequence: u64,
    /// Frames from addresses other than the session's host.
    pub foreign_sender: u64,
    /// Frames whose tag was missing, unexpected or wrong.
    pub auth_failed: u64,
    /// Damaged frames.
    pub corrupt: u64,
    /// Frames of another protocol version or protocol.
    pub version_mismatch: u64,
    /// Valid frames of a kind the rig does not take (or commands outside a session).
    pub unexpected: u64,
    /// Fault reports sent.
    pub faults_sent: u64,
    /// Ticks in a session during which the brakes were applied.
    pub braked_ticks: u64,
    /// Sensor frames the link would not take (a serial output buffer full because the host
    /// stopped reading, a UDP send refused): dropped, as rig firmware must, never waited for.
    pub send_failed: u64,
}

/// At most this many waiting frames are handled per tick once the tick is due, so that a
/// flood of datagrams cannot stall the rig's loop.
const MAX_LATE_DRAIN: usize = 64;

/// What a session hook learns when a host opens a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SessionStart {
    /// 1 for the first session the emulator opened, then +1 per session.
    pub number: u64,
    /// The session's host.
    pub peer: Peer,
    /// The session number sent in the `HelloAck`.
    pub session_id: u64,
}

/// Called with the served backend when a session opens, before the `HelloAck` is sent: the
/// place for what an operator does between sessions (put the payload on, take it off).
pub type SessionHook<B> = Box<dyn FnMut(&mut B, &SessionStart) + Send>;

/// What the emulator tells its operator about a session while it runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EmulatorEvent {
    /// The rig latched a fault and braked (a watchdog trip, a limit).
    Fault {
        /// The session's number (as in [`SessionStart::number`]).
        session: u64,
        /// Its host.
        peer: Peer,
        /// The fault as reported to the host.
        fault: Fault,
    },
    /// The session's host stayed silent for the session timeout: the session ended.
    SessionTimedOut {
        /// The session's number.
        session: u64,
        /// Its host.
        peer: Peer,
        /// How long the host had been silent.
        silent_for: Duration,
    },
}

/// Called on every [`EmulatorEvent`] (e.g. to print it).
pub type EventHook = Box<dyn FnMut(&EmulatorEvent) + Send>;

struct Session {
    peer: Peer,
    number: u64,
    id: u64,
    host_nonce: u64,
    ack: Vec<u8>,
    sensor_sequence: u64,
    last_command_sequence: u64,
    latest: Option<Command>,
    last_command_at: Option<Instant>,
    last_heard: Instant,
    fault: Option<Fault>,
}

/// A backend served behind the rig protocol. See the module documentation.
pub struct Emulator<B> {
    inner: B,
    transport: Box<dyn Transport>,
    config: EmulatorConfig,
    period: Duration,
    session: Option<Session>,
    /// The last command of a session that timed out, for [`Self::last_command`].
    timed_out_command: Option<Command>,
    stats: EmulatorStats,
    rng: StdRng,
    delayed: VecDeque<(Instant, Peer, Vec<u8>)>,
    recent_lengths: VecDeque<[f64; LEG_COUNT]>,
    silent: bool,
    last_sensor_sent_at: Option<Instant>,
    /// Sequence of the last sensor frame of the session sent intact (lockstep waits for it).
    last_intact_sequence: u64,
    session_hook: Option<SessionHook<B>>,
    event_hook: Option<EventHook>,
    faults: Vec<Fault>,
    buf: [u8; MAX_FRAME_LEN + 1],
}

/// Binds `listen` (e.g. `udp://127.0.0.1:7700`), then serves `inner` until `stop` is set.
/// Returns the counters. This is `stewart emulate`.
pub fn serve<B>(
    listen: &str,
    inner: B,
    config: EmulatorConfig,
    stop: &AtomicBool,
) -> Result<EmulatorStats, RigError>
where
    B: Backend,
    B::Error: Display,
{
    let mut emulator = Emulator::bind(listen, inner, config)?;
    emulator.run(stop)?;
    Ok(emulator.stats)
}

impl<B> Emulator<B>
where
    B: Backend,
    B::Error: Display,
{
    /// An emulator listening at `listen` (`udp://HOST:PORT`, port 0 for any free port, or a
    /// serial address).
    pub fn bind(listen: &str, inner: B, config: EmulatorConfig) -> Result<Self, RigError> {
        let address: Address = listen.parse()?;
        let transport = transport::open_server(&address)?;
        Self::new(inner, transport, config)
    }

    /// An emulator on an already opened transport.
    pub fn new(
        inner: B,
        transport: Box<dyn Transport>,
        config: EmulatorConfig,
    ) -> Result<Self, RigError> {
        let period_s = inner.sample_period_s();
        if !(period_s.is_finite() && period_s > 0.0 && period_s < 4.0) {
            return Err(RigError::config(
                format!("sample period {period_s} s"),
                "the backend's sample period must be positive and below 4 s",
            ));
        }
        let f = &config.faults;
        for (name, value) in [
            ("drop_fraction", f.drop_fraction),
            ("corrupt_fraction", f.corrupt_fraction),
            ("delay_fraction", f.delay_fraction),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return Err(RigError::config(
                    format!("{name} = {value}"),
                    "must be between 0 and 1",
                ));
            }
        }
        let l = config.limits;
        if !(l.stroke_min_m < l.stroke_max_m
            && l.force_min_n < l.force_max_n
            && l.speed_max_m_s > 0.0)
        {
            return Err(RigError::config(format!("{l:?}"), "unusable limits"));
        }
        Ok(Self {
            inner,
            transport,
            period: Duration::from_secs_f64(period_s),
            session: None,
            timed_out_command: None,
            stats: EmulatorStats::default(),
            rng: StdRng::seed_from_u64(config.seed),
            delayed: VecDeque::new(),
            recent_lengths: VecDeque::with_capacity(config.speed_window + 1),
            silent: false,
            last_sensor_sent_at: None,
            last_intact_sequence: 0,
            session_hook: None,
            event_hook: None,
            faults: Vec::new(),
            buf: [0; MAX_FRAME_LEN + 1],
            config,
        })
    }

    /// The local address hosts should connect to (UDP).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.transport.local_addr()
    }

    /// The counters so far.
    pub fn stats(&self) -> &EmulatorStats {
        &self.stats
    }

    /// Every fault the emulator reported, in order.
    pub fn faults(&self) -> &[Fault] {
        &self.faults
    }

    /// Calls `hook` with the served backend whenever a session opens (see [`SessionHook`]).
    pub fn set_session_hook(&mut self, hook: SessionHook<B>) {
        self.session_hook = Some(hook);
    }

    /// Calls `hook` on every [`EmulatorEvent`]: a fault latched, a session timed out.
    pub fn set_event_hook(&mut self, hook: EventHook) {
        self.event_hook = Some(hook);
    }

    fn event(&mut self, event: EmulatorEvent) {
        if let Some(hook) = self.event_hook.as_mut() {
            hook(&event);
        }
    }

    /// The newest command accepted from the current session's host, or, when no session is
    /// open (the last one timed out), from the last session's; braking ones included; `None`
    /// before the first.
    pub fn last_command(&self) -> Option<Command> {
        match &self.session {
            Some(s) => s.latest,
            None => self.timed_out_command,
        }
    }

    /// The current session's host.
    pub fn session_peer(&self) -> Option<Peer> {
        self.session.as_ref().map(|s| s.peer)
    }

    /// When the last sensor frame went onto the link (for measuring how fast a host notices
    /// that the rig went silent).
    pub fn last_sensor_sent_at(&self) -> Option<Instant> {
        self.last_sensor_sent_at
    }

    /// The served backend (e.g. to read the simulator's truth).
    pub fn inner(&self) -> &B {
        &self.inner
    }

    /// The served backend, mutably.
    pub fn inner_mut(&mut self) -> &mut B {
        &mut self.inner
    }

    /// Gives the served backend back.
    pub fn into_inner(self) -> B {
        self.inner
    }

    /// Runs in real time until `stop` is set, then brakes the inner backend once more.
    pub fn run(&mut self, stop: &AtomicBool) -> Result<(), RigError> {
        let mut next = Instant::now() + self.period;
        while !stop.load(Ordering::Relaxed) {
            self.pump_until(next)?;
            if let Some(limit) = self.config.lockstep {
                if self.wait_for_host(limit)? {
                    // The emulated world paused with the host: its clock restarts.
                    next = Instant::now();
                }
            }
            let now = Instant::now();
            let behind = now.saturating_duration_since(next);
            if behind > self.period {
                self.stats.overruns += 1;
                if behind > self.period * 50 {
                    // Hopelessly behind (a debugger, a suspended process): restart the clock
                    // rather than replay a burst of ticks.
                    next = now;
                }
            }
            next += self.period;
            self.tick(now)?;
        }
        let stop_command = CommandFrame::safe_stop(0, 0);
        self.inner
            .write(&stop_command)
            .map_err(|e| RigError::Backend {
                reason: e.to_string(),
            })
    }

    /// Lockstep: waits (at most `limit`) while the host has not answered the last frame sent
    /// intact. Returns whether it waited.
    fn wait_for_host(&mut self, limit: Duration) -> Result<bool, RigError> {
        let start = Instant::now();
        let mut waited = false;
        while self.host_is_behind() {
            let now = Instant::now();
            if now.saturating_duration_since(start) >= limit {
                break;
            }
            waited = true;
            self.pump_until((now + self.period / 4).min(start + limit))?;
        }
        Ok(waited)
    }

    fn host_is_behind(&self) -> bool {
        match &self.session {
            Some(s) if s.fault.is_none() && !self.silent => s
                .latest
                .is_some_and(|c| c.sensor_sequence < self.last_intact_sequence),
            _ => false,
        }
    }

    /// One sample period: apply a command, sample, send.
    fn tick(&mut self, now: Instant) -> Result<(), RigError> {
        self.stats.ticks += 1;
        if let Some(s) = &self.session {
            let silent_for = now.saturating_duration_since(s.last_heard);
            if silent_for > self.config.session_timeout {
                let (session, peer) = (s.number, s.peer);
                self.timed_out_command = s.latest;
                self.session = None;
                self.event(EmulatorEvent::SessionTimedOut {
                    session,
                    peer,
                    silent_for,
                });
            }
        }
        let command = self.choose_command(now);
        self.inner.write(&command).map_err(|e| RigError::Backend {
            reason: e.to_string(),
        })?;
        let frame = self.inner.read().map_err(|e| RigError::Backend {
            reason: e.to_string(),
        })?;
        if self.session.is_none() {
            return Ok(());
        }
        if command.enable {
            self.check_motion(&frame);
        } else {
            self.stats.braked_ticks += 1;
            // Braked legs hold still; a stale window would turn the next enabled sample's
            // length change into a bogus speed.
            self.recent_lengths.clear();
        }
        let mut status = frame.status.0;
        status |= if command.enable {
            Status::ENABLED
        } else {
            Status::BRAKED
        };
        let faulted = self.session.as_ref().is_some_and(|s| s.fault.is_some());
        if faulted {
            status |= Status::FAULT;
        }
        let Some(session) = self.session.as_mut() else {
            return Ok(());
        };
        session.sensor_sequence += 1;
        if let Some(fault) = session.fault {
            if session.sensor_sequence % FAULT_REPEAT_FRAMES == 0 {
                let (peer, id) = (session.peer, session.id);
                self.send_message(&Message::Fault(fault), peer, Some(id));
            }
        }
        let Some(session) = self.session.as_ref() else {
            return Ok(());
        };
        let sensor = Sensor {
            sequence: session.sensor_sequence,
            status,
            ..Sensor::from(&frame)
        };
        self.send_sensor(&sensor, now)
    }

    /// The command for the coming period: the newest valid one, or the brakes.
    fn choose_command(&mut self, now: Instant) -> CommandFrame {
        let brake = CommandFrame::safe_stop(0, 0);
        let Some(s) = &self.session else {
            return brake;
        };
        if s.fault.is_some() {
            return brake;
        }
        if let Some(at) = s.last_command_at {
            let quiet = now.saturating_duration_since(at);
            if quiet > self.config.watchdog {
                self.trip(FaultCode::WATCHDOG, NO_LEG, quiet.as_secs_f64());
                return brake;
            }
        }
        match &s.latest {
            Some(c) if c.enable => CommandFrame::from(c),
            // A braking command's forces are meaningless and unchecked (they may be NaN): the
            // inner backend gets zeros.
            Some(c) => CommandFrame::safe_stop(c.sequence, c.sensor_sequence),
            None => brake,
        }
    }

    fn check_motion(&mut self, frame: &SensorFrame) {
        if !self.config.enforce_motion_limits {
            return;
        }
        let l = self.config.limits;
        let lengths = frame.leg_lengths_m;
        if let Some(leg) = lengths
            .iter()
            .position(|&x| !(x >= l.stroke_min_m && x <= l.stroke_max_m))
        {
            self.trip(FaultCode::STROKE_LIMIT, leg as u8, lengths[leg]);
        }
        let window = self.config.speed_window.max(1);
        self.recent_lengths.push_back(lengths);
        if self.recent_lengths.len() > window {
            if let Some(old) = self.recent_lengths.pop_front() {
                let span_s = self.period.as_secs_f64() * window as f64;
                for leg in 0..LEG_COUNT {
                    let speed = (lengths[leg] - old[leg]).abs() / span_s;
                    if speed > l.speed_max_m_s {
                        self.trip(FaultCode::SPEED_LIMIT, leg as u8, speed);
                        break;
                    }
                }
            }
        }
    }

    /// Latches a fault in the session (first one wins) and reports it.
    fn trip(&mut self, code: FaultCode, leg: u8, value: f64) {
        let Some(s) = self.session.as_mut() else {
            return;
        };
        if s.fault.is_some() {
            return;
        }
        let fault = Fault {
            code,
            leg,
            value,
            command_sequence: s.last_command_sequence,
        };
        s.fault = Some(fault);
        let (peer, id, session) = (s.peer, s.id, s.number);
        self.faults.push(fault);
        self.stats.faults_sent += 1;
        self.send_message(&Message::Fault(fault), peer, Some(id));
        self.event(EmulatorEvent::Fault {
            session,
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

    /// Encodes and sends; `session_id` `None` sends untagged (refusals to unknown hosts).
    fn send_message(&mut self, message: &Message, to: Peer, session_id: Option<u64>) {
        if self.silent {
            return;
        }
        let mut out = [0u8; MAX_FRAME_LEN];
        let auth = session_id.and_then(|id| self.auth(id));
        // Every message fits MAX_FRAME_LEN (checked by the codec's tests), so encoding cannot
        // fail; a send error means the link is gone, which the host notices as silence.
        if let Ok(n) = codec::encode(message, auth.as_ref(), &mut out) {
            let _ = self.transport.send(&out[..n], &to);
        }
    }

    fn send_sensor(&mut self, sensor: &Sensor, now: Instant) -> Result<(), RigError> {
        let Some(s) = self.session.as_ref() else {
            return Ok(());
        };
        let (peer, id) = (s.peer, s.id);
        let faults = self.config.faults.clone();
        if faults
            .stop_after_frames
            .is_some_and(|n| sensor.sequence > n)
        {
            self.silent = true;
        }
        if self.silent {
            return Ok(());
        }
        self.stats.sensor_frames += 1;
        if faults.drop_fraction > 0.0 && self.rng.random::<f64>() < faults.drop_fraction {
            self.stats.dropped_injected += 1;
            return Ok(());
        }
        let mut out = [0u8; MAX_FRAME_LEN];
        let auth = self.auth(id);
        let n = codec::encode(&Message::Sensor(*sensor), auth.as_ref(), &mut out)
            .map_err(RigError::Encode)?;
        let frame = &mut out[..n];
        if faults.corrupt_fraction > 0.0 && self.rng.random::<f64>() < faults.corrupt_fraction {
            let bit = self.rng.random_range(0..n * 8);
            frame[bit / 8] ^= 1 << (bit % 8);
            self.stats.corrupted_injected += 1;
        } else {
            self.last_intact_sequence = sensor.sequence;
        }
        if faults.delay_fraction > 0.0 && self.rng.random::<f64>() < faults.delay_fraction {
            self.delayed
                .push_back((now + faults.delay, peer, frame.to_vec()));
            self.stats.delayed_injected += 1;
            return Ok(());
        }
        self.last_sensor_sent_at = Some(Instant::now());
        self.send_or_count(frame, peer);
        Ok(())
    }

    /// Puts a sensor frame on the link. A send that fails drops the frame and is counted: the
    /// host notices the gap, and if the link is really gone the command watchdog brakes.
    fn send_or_count(&mut self, frame: &[u8], peer: Peer) {
        match self.transport.send(frame, &peer) {
            Ok(()) => self.stats.sent += 1,
            Err(_) => self.stats.send_failed += 1,
        }
    }

    /// Receives and handles frames (and sends delayed ones) until `deadline`. Frames already
    /// waiting are handled even when the deadline has passed: a rig that runs late must still
    /// hear the commands it was sent, or its own watchdog would trip on a host that answered
    /// (on a loaded machine a descheduled rig wakes past its deadline with commands waiting).
    fn pump_until(&mut self, deadline: Instant) -> Result<(), RigError> {
        let mut drained_late = 0;
        loop {
            let now = Instant::now();
            while self.delayed.front().is_some_and(|(due, _, _)| *due <= now) {
                if let Some((_, peer, frame)) = self.delayed.pop_front() {
                    if !self.silent {
                        self.send_or_count(&frame, peer);
                    }
                }
            }
            let late = now >= deadline;
            if late {
                if drained_late >= MAX_LATE_DRAIN {
                    return Ok(());
                }
                drained_late += 1;
            }
            let until = match self.delayed.front() {
                Some((due, _, _)) => deadline.min(*due),
                None => deadline,
            };
            match self
                .transport
                .recv(&mut self.buf, until.saturating_duration_since(now))?
            {
                Recv::Frame { len, from } => self.handle(len, from, Instant::now()),
                Recv::Garbled => {
                    self.stats.received += 1;
                    self.stats.corrupt += 1;
                }
                Recv::Timeout if late => return Ok(()),
                Recv::Timeout => {}
            }
        }
    }

    fn count(&mut self, error: &CodecError) {
        match error.kind() {
            CodecErrorKind::Corrupt | CodecErrorKind::Encode => self.stats.corrupt += 1,
            CodecErrorKind::Auth => self.stats.auth_failed += 1,
            CodecErrorKind::Foreign => self.stats.version_mismatch += 1,
        }
    }

    fn refuse(&mut self, to: Peer, code: FaultCode, value: f64) {
        let fault = Fault {
            code,
            leg: NO_LEG,
            value,
            command_sequence: 0,
        };
        self.send_message(&Message::Fault(fault), to, None);
    }

    fn handle(&mut self, len: usize, from: Peer, now: Instant) {
        self.stats.received += 1;
        let Some(frame) = self.buf.get(..len) else {
            self.stats.corrupt += 1;
            return;
        };
        let frame = frame.to_vec();
        let (message, tagged) = match codec::decode_unverified(&frame) {
            Ok(decoded) => decoded,
            Err(CodecError::VersionMismatch(_)) => {
                self.stats.version_mismatch += 1;
                // Answer in our own version: the host names both versions in its error.
                self.refuse(
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
        let session_peer = self.session.as_ref().map(|s| s.peer);
        if session_peer.is_some_and(|peer| peer != from) {
            self.stats.foreign_sender += 1;
            if matches!(message, Message::Hello(_)) {
                self.refuse(from, FaultCode::BUSY, 0.0);
            }
            return;
        }
        match message {
            Message::Hello(hello) => self.handle_hello(&hello, &frame, tagged, from, now),
            Message::Command(_) if session_peer.is_some() => {
                let id = self.session.as_ref().map_or(0, |s| s.id);
                let verified = codec::decode(&frame, self.auth(id).as_ref());
                match verified {
                    Ok(Message::Command(command)) => self.handle_command(&command, now),
                    Ok(_) => self.stats.unexpected += 1,
                    Err(e) => self.count(&e),
                }
            }
            _ => self.stats.unexpected += 1,
        }
    }

    fn handle_hello(
        &mut self,
        hello: &Hello,
        frame: &[u8],
        tagged: bool,
        from: Peer,
        now: Instant,
    ) {
        match &self.config.key {
            Some(key) => {
                let refusal = match hello.key_id {
                    None => Some(FaultCode::KEY_REQUIRED),
                    Some(id) if id != key.id() => Some(FaultCode::KEY_MISMATCH),
                    Some(_) if codec::decode(frame, self.auth(0).as_ref()).is_err() => {
                        Some(FaultCode::KEY_MISMATCH)
                    }
                    Some(_) => None,
                };
                if let Some(code) = refusal {
                    self.stats.auth_failed += 1;
                    self.refuse(from, code, 0.0);
                    return;
                }
            }
            None if tagged => {
                self.stats.auth_failed += 1;
                self.refuse(from, FaultCode::KEY_MISMATCH, 0.0);
                return;
            }
            None => {}
        }
        // A repeated Hello of the session's own handshake (the host retries until answered):
        // answer again, do not restart the session.
        if let Some(s) = &mut self.session {
            if s.peer == from && s.host_nonce == hello.host_nonce {
                s.last_heard = now;
                let ack = s.ack.clone();
                if !self.silent {
                    let _ = self.transport.send(&ack, &from);
                }
                return;
            }
        }
        let id = loop {
            let id: u64 = self.rng.random();
            if id != 0 {
                break id;
            }
        };
        let ack = HelloAck {
            host_nonce: hello.host_nonce,
            session_id: id,
            identity: identity_from_str(&self.config.identity),
            layout: self.config.layout,
            sample_period_ns: u32::try_from(self.period.as_nanos()).unwrap_or(u32::MAX),
            watchdog_ns: u32::try_from(self.config.watchdog.as_nanos()).unwrap_or(u32::MAX),
            limits: self.config.limits,
        };
        let mut out = [0u8; MAX_FRAME_LEN];
        let Ok(n) = codec::encode(&Message::HelloAck(ack), self.auth(0).as_ref(), &mut out) else {
            return;
        };
        self.session = Some(Session {
            peer: from,
            number: self.stats.sessions + 1,
            id,
            host_nonce: hello.host_nonce,
            ack: out[..n].to_vec(),
            sensor_sequence: 0,
            last_command_sequence: 0,
            latest: None,
            last_command_at: None,
            last_heard: now,
            fault: None,
        });
        self.recent_lengths.clear();
        // Frames held back for the previous session must not reach the new one.
        self.delayed.clear();
        self.last_intact_sequence = 0;
        self.stats.sessions += 1;
        if let Some(hook) = self.session_hook.as_mut() {
            let start = SessionStart {
                number: self.stats.sessions,
                peer: from,
                session_id: id,
            };
            hook(&mut self.inner, &start);
        }
        if !self.silent {
            let _ = self.transport.send(&out[..n], &from);
        }
    }

    fn handle_command(&mut self, command: &Command, now: Instant) {
        let limits = self.config.limits;
        let Some(s) = self.session.as_mut() else {
            return;
        };
        if command.sequence == s.last_command_sequence {
            self.stats.duplicate += 1;
            return;
        }
        if command.sequence < s.last_command_sequence {
            self.stats.out_of_sequence += 1;
            return;
        }
        self.stats.commands_lost += command.sequence - s.last_command_sequence - 1;
        s.last_command_sequence = command.sequence;
        s.last_heard = now;
        if command.enable {
            let beyond = command
                .leg_forces_n
                .iter()
                .position(|&f| !(f >= limits.force_min_n && f <= limits.force_max_n));
            if let Some(leg) = beyond {
                let value = command.leg_forces_n[leg];
                self.trip(FaultCode::FORCE_LIMIT, leg as u8, value);
                return;
            }
        }
        s.latest = Some(*command);
        s.last_command_at = Some(now);
        self.stats.commands_accepted += 1;
    }
}
