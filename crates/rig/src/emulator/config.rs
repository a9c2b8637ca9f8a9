//! The emulator's configuration, counters, and what it tells its operator.

use std::time::Duration;

use control::io::LEG_COUNT;

use crate::firmware::CoreStats;
use crate::key::Key;
use crate::transport::Peer;
use crate::wire::{Fault, Limits, SensorLayout};

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
    /// After this many sensor frames sent (over all sessions) the emulator goes silent until a
    /// host opens a new session, once: a link that drops out and comes back (a host's stall
    /// seen from the rig).
    pub stall_once_after_frames: Option<u64>,
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
    /// tripping the speed limit (10; at most `firmware::MAX_SPEED_WINDOW`, 32).
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
    /// With `lockstep`: once the host has answered the last sensor frame, the next sample
    /// follows at once instead of at its time (false, the default: real time). The emulated
    /// world then runs as fast as host and emulator compute, and the rig core's clock (its
    /// watchdog, its session timeout) runs on the emulated time: each sample is one sample
    /// period later, however soon it came. While no session is open, or the host has not
    /// answered, or the link is silenced by injection, the clock is the wall's again. For tests
    /// and demonstrations: a rig runs in real time.
    pub fast_forward: bool,
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
            fast_forward: false,
            seed: rand::random(),
        }
    }
}

/// What the emulator did and saw: its own counters (the clock, the link's injected damage)
/// and the rig core's ([`CoreStats`]), said once there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Sample periods run.
    pub ticks: u64,
    /// Ticks that started more than one period late (the machine could not keep up).
    pub overruns: u64,
    /// The latest a tick started, µs past its time: the emulator's own stall, to compare with
    /// the host's loop period.
    pub latest_tick_us: u64,
    /// The latest a tick started while a session was being commanded (open, no fault, the
    /// host's commands arriving), µs past its time: the only lateness that can starve the
    /// host of frames. A tick between sessions (the payload changed, a new Hello) may run late
    /// with nothing waiting on it.
    pub latest_commanded_tick_us: u64,
    /// The slowest step of the served backend (the simulator's physics), µs: whether a late
    /// tick was the emulator's own work or its pacing.
    pub slowest_step_us: u64,
    /// Sensor frames offered to the link in sessions (including dropped ones; none once
    /// `stop_after_frames` silenced the emulator, which the core still assembles and counts).
    pub sensor_frames: u64,
    /// Sensor frames put on the link.
    pub sent: u64,
    /// Sensor frames dropped by fault injection.
    pub dropped_injected: u64,
    /// Sensor frames corrupted by fault injection.
    pub corrupted_injected: u64,
    /// Sensor frames delayed by fault injection.
    pub delayed_injected: u64,
    /// Sensor frames the link would not take (a serial output buffer full because the host
    /// stopped reading, a UDP send refused): dropped, as rig firmware must, never waited for.
    pub send_failed: u64,
    /// The rig core's counters: sessions, frames received and refused, commands, faults,
    /// braked ticks.
    pub core: CoreStats,
}

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
