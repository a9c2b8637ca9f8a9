//! The rig emulator: any `control::io::Backend` (the simulator, in practice) served behind the
//! protocol in real time, with the safety a real rig controller enforces by itself.
//!
//! The rig's side of the protocol is the firmware's own code, [`crate::firmware::RigCore`]:
//! the emulator adds a wall clock, a transport and the inner backend as the rig core's sensors
//! and actuators. Every sample period, paced by the wall clock, it asks the rig core for the
//! actuator output (the newest valid command, or the brakes), applies it to the inner backend
//! (`write`, which advances a simulator by one period), hands the backend's sensors to the
//! rig core and sends the frames the rig core assembled. Frames that arrive between ticks go to
//! the rig core as they come. The rig core brakes and reports a [`Fault`] when no valid command
//! arrived within the watchdog time (20 ms) while the last one drove the actuators (after a
//! braking command it stays braked without a fault), when a command exceeds the force limits,
//! or when a leg leaves its stroke or exceeds its speed limit; a fault holds the brakes until
//! the host opens a new session.
//!
//! After a handshake, only the session's host may command: frames from other addresses, out
//! of sequence, or (with a key) without a valid tag are dropped and counted.
//!
//! [`FaultInjection`] degrades the link on purpose, for tests: it acts on the frames the
//! rig core emits, as a damaged link between the firmware and the host would.

mod config;

pub use config::{
    EmulatorConfig, EmulatorEvent, EmulatorStats, EventHook, FaultInjection, SessionHook,
    SessionStart,
};

use std::collections::VecDeque;
use std::fmt::Display;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use control::io::{Backend, CommandFrame};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::codec::MAX_FRAME_LEN;
use crate::error::RigError;
use crate::firmware::{
    CoreConfig, CoreEvent, CoreKey, FrameKind, Outbox, RigCore, OUTBOX_EVENTS, OUTBOX_FRAMES,
};
use crate::transport::{self, Address, Peer, Recv, Transport};
use crate::wire::{identity_from_str, Command, Fault};

/// At most this many waiting frames are handled per tick once the tick is due, so that a
/// flood of datagrams cannot stall the rig's loop.
const MAX_LATE_DRAIN: usize = 64;

/// A backend served behind the rig protocol. See the module documentation.
pub struct Emulator<B> {
    inner: B,
    transport: Box<dyn Transport>,
    config: EmulatorConfig,
    period: Duration,
    core: RigCore<Peer>,
    /// The rig core's clock: its nanoseconds count from here.
    epoch: Instant,
    /// How far the clock ran ahead of the wall ([`EmulatorConfig::fast_forward`]): the
    /// emulator's time is the wall's plus this.
    skipped: Duration,
    stats: EmulatorStats,
    rng: StdRng,
    delayed: VecDeque<(Instant, Peer, Vec<u8>)>,
    silent: bool,
    /// Silent by [`FaultInjection::stall_once_after_frames`] (until the next session), and
    /// whether that stall has been used up.
    stall: (bool, bool),
    last_sensor_sent_at: Option<Instant>,
    /// Sequence of the last sensor frame of the session sent intact (lockstep waits for it).
    last_intact_sequence: u64,
    session_hook: Option<SessionHook<B>>,
    event_hook: Option<EventHook>,
    faults: Vec<Fault>,
    outbox: Outbox<Peer>,
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

/// The rig core's configuration for an emulator's: times in nanoseconds, the key by value.
fn core_config(config: &EmulatorConfig, period: Duration) -> Result<CoreConfig, RigError> {
    let ns = |d: Duration| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
    let key = match &config.key {
        Some(key) => Some(
            CoreKey::new(key.bytes())
                .map_err(|e| RigError::config("the shared key", e.to_string()))?,
        ),
        None => None,
    };
    Ok(CoreConfig {
        identity: identity_from_str(&config.identity),
        layout: config.layout,
        limits: config.limits,
        sample_period_ns: ns(period),
        watchdog_ns: ns(config.watchdog),
        session_timeout_ns: ns(config.session_timeout),
        key,
        enforce_motion_limits: config.enforce_motion_limits,
        speed_window: config.speed_window,
        seed: config.seed,
    })
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
                format!("the emulated rig's sample period {period_s} s"),
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
                    format!("the emulator's fault injection {name} = {value}"),
                    "must be a fraction, between 0 and 1",
                ));
            }
        }
        let l = config.limits;
        if !(l.stroke_min_m < l.stroke_max_m
            && l.force_min_n < l.force_max_n
            && l.speed_max_m_s > 0.0)
        {
            return Err(RigError::config(
                format!("the emulated rig's limits {l:?}"),
                "unusable limits",
            ));
        }
        let period = Duration::from_secs_f64(period_s);
        let core = RigCore::new(core_config(&config, period)?)
            .map_err(|e| RigError::config("the emulator's configuration", e.to_string()))?;
        Ok(Self {
            inner,
            transport,
            period,
            core,
            epoch: Instant::now(),
            skipped: Duration::ZERO,
            stats: EmulatorStats::default(),
            rng: StdRng::seed_from_u64(config.seed),
            delayed: VecDeque::new(),
            silent: false,
            stall: (false, false),
            last_sensor_sent_at: None,
            last_intact_sequence: 0,
            session_hook: None,
            event_hook: None,
            faults: Vec::new(),
            outbox: Outbox::new(),
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

    /// The rig core the emulator runs (its session, its counters).
    pub fn core(&self) -> &RigCore<Peer> {
        &self.core
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
        self.core.last_command()
    }

    /// The current session's host.
    pub fn session_peer(&self) -> Option<Peer> {
        self.core.session().map(|s| s.peer)
    }

    /// When the last sensor frame went onto the link, by the wall's clock (for measuring how
    /// fast a host notices that the rig went silent).
    pub fn last_sensor_sent_at(&self) -> Option<Instant> {
        self.last_sensor_sent_at
    }

    /// How far the emulator's clock ran ahead of the wall's by fast-forwarding
    /// ([`EmulatorConfig::fast_forward`]); zero in real time.
    pub fn fast_forwarded(&self) -> Duration {
        self.skipped
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

    /// The emulator's clock: the wall's, plus what fast-forwarding skipped.
    fn now(&self) -> Instant {
        Instant::now() + self.skipped
    }

    /// Whether the next sample may come before its time: fast-forwarding in lockstep, a
    /// session open whose host has commanded (until then there is no answer to wait for, and
    /// skipping ahead would only run the watchdog out), and the link not silenced by injection.
    fn fast_forwarding(&self) -> bool {
        self.config.fast_forward
            && self.config.lockstep.is_some()
            && !self.silent
            && self.commanded()
    }

    /// Whether a session is open, without a fault, and its host has commanded.
    fn commanded(&self) -> bool {
        self.core
            .session()
            .is_some_and(|s| s.fault.is_none() && s.latest.is_some())
    }

    /// Runs in real time (or faster, [`EmulatorConfig::fast_forward`]) until `stop` is set,
    /// then brakes the inner backend once more.
    pub fn run(&mut self, stop: &AtomicBool) -> Result<(), RigError> {
        let mut next = self.now() + self.period;
        while !stop.load(Ordering::Relaxed) {
            let fast = self.fast_forwarding();
            if !fast {
                self.pump_until(next)?;
            }
            if let Some(limit) = self.config.lockstep {
                let waited = self.wait_for_host(limit)?;
                if waited && (!fast || self.now() > next) {
                    // The emulated world paused with the host: its clock restarts.
                    next = self.now();
                }
            }
            if fast {
                // The host has answered: the sample's time has come.
                self.skipped += next.saturating_duration_since(self.now());
                self.pump_until(next)?;
            }
            let now = self.now();
            let behind = now.saturating_duration_since(next);
            let behind_us = u64::try_from(behind.as_micros()).unwrap_or(u64::MAX);
            self.stats.latest_tick_us = self.stats.latest_tick_us.max(behind_us);
            if self.commanded() {
                self.stats.latest_commanded_tick_us =
                    self.stats.latest_commanded_tick_us.max(behind_us);
            }
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
        let start = self.now();
        let mut waited = false;
        while self.host_is_behind() {
            let now = self.now();
            if now.saturating_duration_since(start) >= limit {
                break;
            }
            waited = true;
            self.pump((now + self.period / 4).min(start + limit), true)?;
        }
        Ok(waited)
    }

    fn host_is_behind(&self) -> bool {
        match self.core.session() {
            Some(s) if s.fault.is_none() && !self.silent => s
                .latest
                .is_some_and(|c| c.sensor_sequence < self.last_intact_sequence),
            _ => false,
        }
    }

    /// The rig core's time of `instant`, ns.
    fn ns(&self, instant: Instant) -> u64 {
        u64::try_from(instant.saturating_duration_since(self.epoch).as_nanos()).unwrap_or(u64::MAX)
    }

    /// One sample period: the rig core's actuator output to the inner backend (which advances
    /// by one period), its sensors back to the rig core, the rig core's frames onto the link.
    fn tick(&mut self, now: Instant) -> Result<(), RigError> {
        self.stats.ticks += 1;
        let command = self.core.actuate(self.ns(now), &mut self.outbox);
        self.deliver(now);
        let step = Instant::now();
        self.inner.write(&command).map_err(|e| RigError::Backend {
            reason: e.to_string(),
        })?;
        let frame = self.inner.read().map_err(|e| RigError::Backend {
            reason: e.to_string(),
        })?;
        let step_us = u64::try_from(step.elapsed().as_micros()).unwrap_or(u64::MAX);
        self.stats.slowest_step_us = self.stats.slowest_step_us.max(step_us);
        self.core.report(&frame, &mut self.outbox);
        self.deliver(now);
        Ok(())
    }

    /// Acts on what the rig core's last call put in the outbox: its events first (a session
    /// hook runs before the `HelloAck` goes out), then its frames, in order; empties it.
    fn deliver(&mut self, now: Instant) {
        // Copies out of the outbox (no heap): the hooks and the link need `self` mutably.
        for k in 0..OUTBOX_EVENTS {
            let Some(event) = self.outbox.events().nth(k).copied() else {
                break;
            };
            match event {
                CoreEvent::SessionOpened {
                    number,
                    peer,
                    session_id,
                } => {
                    // Frames held back for the previous session must not reach the new one.
                    self.delayed.clear();
                    if self.stall.0 {
                        // The stalled link is back for the host's new session.
                        self.silent = false;
                        self.stall = (false, true);
                    }
                    self.last_intact_sequence = 0;
                    if let Some(hook) = self.session_hook.as_mut() {
                        let start = SessionStart {
                            number,
                            peer,
                            session_id,
                        };
                        hook(&mut self.inner, &start);
                    }
                }
                CoreEvent::Fault {
                    session,
                    peer,
                    fault,
                } => {
                    self.faults.push(fault);
                    self.event(EmulatorEvent::Fault {
                        session,
                        peer,
                        fault,
                    });
                }
                CoreEvent::SessionTimedOut {
                    session,
                    peer,
                    silent_for_ns,
                } => self.event(EmulatorEvent::SessionTimedOut {
                    session,
                    peer,
                    silent_for: Duration::from_nanos(silent_for_ns),
                }),
            }
        }
        for k in 0..OUTBOX_FRAMES {
            let Some(frame) = self.outbox.frames().nth(k).copied() else {
                break;
            };
            match frame.kind {
                FrameKind::Sensor { sequence } => {
                    self.send_sensor(frame.bytes(), frame.to, sequence, now)
                }
                // A send error means the link is gone, which the host notices as silence.
                _ if !self.silent => {
                    let _ = self.transport.send(frame.bytes(), &frame.to);
                }
                _ => {}
            }
        }
        self.outbox.clear();
        self.sync_stats();
    }

    /// Copies the rig core's counters into the emulator's.
    fn sync_stats(&mut self) {
        self.stats.core = *self.core.stats();
    }

    /// Puts a sensor frame of the rig core on the link through the injected damage.
    fn send_sensor(&mut self, encoded: &[u8], peer: Peer, sequence: u64, now: Instant) {
        let faults = &self.config.faults;
        if faults.stop_after_frames.is_some_and(|n| sequence > n) {
            self.silent = true;
        }
        if !self.stall.1
            && faults
                .stall_once_after_frames
                .is_some_and(|n| self.stats.sensor_frames >= n)
        {
            self.silent = true;
            self.stall.0 = true;
        }
        if self.silent {
            return;
        }
        self.stats.sensor_frames += 1;
        let (drop, corrupt, delay) = (
            faults.drop_fraction,
            faults.corrupt_fraction,
            faults.delay_fraction,
        );
        let delay_by = faults.delay;
        if drop > 0.0 && self.rng.random::<f64>() < drop {
            self.stats.dropped_injected += 1;
            return;
        }
        let mut frame = encoded.to_vec();
        let n = frame.len();
        if corrupt > 0.0 && n > 0 && self.rng.random::<f64>() < corrupt {
            let bit = self.rng.random_range(0..n * 8);
            if let Some(byte) = frame.get_mut(bit / 8) {
                *byte ^= 1 << (bit % 8);
            }
            self.stats.corrupted_injected += 1;
        } else {
            self.last_intact_sequence = sequence;
        }
        if delay > 0.0 && self.rng.random::<f64>() < delay {
            self.delayed.push_back((now + delay_by, peer, frame));
            self.stats.delayed_injected += 1;
            return;
        }
        self.last_sensor_sent_at = Some(Instant::now());
        self.send_or_count(&frame, peer);
    }

    /// Puts a sensor frame on the link. A send that fails drops the frame and is counted: the
    /// host notices the gap, and if the link is really gone the command watchdog brakes.
    fn send_or_count(&mut self, frame: &[u8], peer: Peer) {
        match self.transport.send(frame, &peer) {
            Ok(()) => self.stats.sent += 1,
            Err(_) => self.stats.send_failed += 1,
        }
    }

    /// Receives frames and hands them to the rig core (and sends delayed ones) until
    /// `deadline`. Frames already waiting are handled even when the deadline has passed: a rig
    /// that runs late must still hear the commands it was sent, or its own watchdog would trip
    /// on a host that answered (on a loaded machine a descheduled rig wakes past its deadline
    /// with commands waiting).
    fn pump_until(&mut self, deadline: Instant) -> Result<(), RigError> {
        self.pump(deadline, false)
    }

    /// [`Self::pump_until`], returning early, when `until_answered`, as soon as the host is no
    /// longer behind (lockstep's wait).
    fn pump(&mut self, deadline: Instant, until_answered: bool) -> Result<(), RigError> {
        let mut drained_late = 0;
        loop {
            let now = self.now();
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
                Recv::Frame { len, from } => {
                    let received = self.now();
                    let at = self.ns(received);
                    match self.buf.get(..len) {
                        Some(frame) => self.core.receive(at, from, frame, &mut self.outbox),
                        None => self.core.receive_garbled(),
                    }
                    self.deliver(received);
                    if until_answered && !self.host_is_behind() {
                        return Ok(());
                    }
                }
                Recv::Garbled => {
                    self.core.receive_garbled();
                    self.sync_stats();
                }
                Recv::Timeout if late => return Ok(()),
                Recv::Timeout => {}
            }
        }
    }
}
