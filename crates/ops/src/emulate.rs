//! The emulator: the simulator behind the rig protocol, in real time, so that the host's
//! session ([`crate::rig`]) can be run and tested without hardware.
//!
//! The same scenario file as `simulate` builds the simulated platform (platform, fixture,
//! payload, actuator, sensors, seed); the rig's limits sent in the handshake and enforced are
//! the platform's stroke, `control.max_leg_speed_m_s` and the actuators' `max_force_n`. The
//! emulator serves one host session after another, as a rig does.
//!
//! **The payload.** A real rig's operator puts the vehicle on between the tare and the
//! loaded measurement; the emulator does it when a session opens, by [`PayloadMode`]:
//! `tare-first` (default) leaves the fixture empty for the first session and loads the payload
//! for every later one, which is what `stewart rig` (tare session, then loaded session) and
//! `rig tare` followed by `rig measure` need; `on` and `off` fix it for every session (use
//! `on` for a `rig measure --tare FILE` against a fresh emulator). Loading happens while the
//! platform is braked between sessions: the brakes take the new static load and the plate
//! settles for 2 s before the session's first frame. [`EmulateOptions::reference`]
//! puts the world's reference weight (`[world.reference]`) on instead of the payload, as the
//! rig's owner does for `rig calibrate-load-cells`.
//!
//! Fault injection for tests: dropped and corrupted fractions of sensor frames, frames held
//! back, a rig that stops answering after N sensor frames of a session (as a rig whose link
//! died). Lockstep trades real time for robustness on a busy machine: the emulated world waits
//! for the host's answer to each frame (up to the watchdog time); fast-forward then goes on as
//! soon as the answer came, faster than real time.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::anyhow;
use rig::emulator::{
    Emulator, EmulatorConfig, EmulatorEvent, EmulatorStats, FaultInjection, SessionStart,
};
use rig::wire::{Limits, SensorLayout, LEG_COUNT};
use rig::RigError;
use serde::{Deserialize, Serialize};

use rig_description::load::{ConfigError, LoadedConfig};
use rig_description::Config;

use crate::measurement::{flag_issue, refuse, Error};
use rig_description::range::{ranges, Range};
use sim::scenario::{Scenario, World};
use sim::NoisePreset;

/// Whether the emulated fixture carries the payload.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PayloadMode {
    /// Empty for the first session, loaded for every later one (tare, then measure).
    #[default]
    TareFirst,
    /// Loaded in every session.
    On,
    /// Empty in every session.
    Off,
}

impl PayloadMode {
    /// Whether session `number` (1-based) sees the payload.
    pub fn loaded_in_session(self, number: u64) -> bool {
        match self {
            Self::TareFirst => number > 1,
            Self::On => true,
            Self::Off => false,
        }
    }
}

/// A fraction of the sensor frames (`--drop`, `--corrupt`, `--delay-fraction`).
pub const FRACTION: Range = Range::new(0.0, 1.0, "");

/// How long `--delay-ms` holds sensor frames back: at most the longest link silence a host
/// admits (`rig.link_silence_ms`); a frame held longer reaches a host that has faulted the
/// link already, and every frame held takes memory until it is sent.
pub const DELAY_MS: Range = Range::new(0.0, ranges::LINK_SILENCE_MS.max, "ms");

/// The emulator's options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EmulateOptions {
    /// Where to listen (udp://HOST:PORT, port 0: any free port; serial:///dev/DEVICE?baud=N)
    /// instead of `rig.address`.
    pub listen: Option<String>,
    /// The scenario laid over the embedded default (the same file as the simulator's).
    pub config: Option<PathBuf>,
    /// The simulated world's seed instead of `world.seed`.
    pub seed: Option<u64>,
    /// The sensors' grade instead of the datasheet's.
    pub noise: Option<NoisePreset>,
    /// When the payload is on the fixture.
    pub payload: PayloadMode,
    /// The body put on is the world's reference weight (`[world.reference]`), not its payload.
    pub reference: bool,
    /// The watchdog, ms, instead of `rig.watchdog_ms`.
    pub watchdog_ms: Option<f64>,
    /// Fault injection: fraction of sensor frames not sent.
    pub drop: f64,
    /// Fault injection: fraction of sensor frames sent with a bit flipped.
    pub corrupt: f64,
    /// Fault injection: hold sensor frames back this long, ms.
    pub delay_ms: Option<f64>,
    /// Fault injection: fraction of sensor frames held back by `delay_ms`.
    pub delay_fraction: f64,
    /// Fault injection: stop answering after this many sensor frames of a session.
    pub stop_after: Option<u64>,
    /// Fault injection: go silent after this many sensor frames (over all sessions), once,
    /// until the host opens a new session (a stall the host rides out: `rig.stall_retries`).
    pub stall_once_after: Option<u64>,
    /// Wait (up to the watchdog time) for the host's answer to each frame before simulating the
    /// next.
    pub lockstep: bool,
    /// With `lockstep`: simulate the next sample as soon as the host has answered the last one.
    pub fast_forward: bool,
}

impl Default for EmulateOptions {
    fn default() -> Self {
        Self {
            listen: None,
            config: None,
            seed: None,
            noise: None,
            payload: PayloadMode::TareFirst,
            reference: false,
            watchdog_ms: None,
            drop: 0.0,
            corrupt: 0.0,
            delay_ms: None,
            delay_fraction: 1.0,
            stop_after: None,
            stall_once_after: None,
            lockstep: false,
            fast_forward: false,
        }
    }
}

/// What the emulator tells as it runs (from its own thread).
#[derive(Clone, Copy, Debug)]
pub enum News<'a> {
    /// A remark for its user, before it runs.
    Note(&'a str),
    /// A host opened a session; the payload is on or off.
    Session(&'a SessionStart, bool),
    /// The payload could not be changed between sessions.
    PayloadFailed(&'a sim::SimError),
    /// A fault was reported, or a session timed out.
    Event(&'a EmulatorEvent),
}

/// Where the emulator's [`News`] goes.
pub type Newsroom = Arc<dyn Fn(News<'_>) + Send + Sync>;

/// An emulator ready to run, and what it was built from.
pub struct Prepared {
    /// The emulator, bound.
    pub emulator: Emulator<sim::Simulator>,
    /// The address hosts connect to (`udp://IP:PORT` with the port actually bound).
    pub address: String,
    /// The configuration used.
    pub loaded: LoadedConfig,
    sessions: Arc<Mutex<Vec<SessionStart>>>,
}

/// The rig limits the emulator announces and enforces: the rig description's stroke and leg
/// speed, the simulated actuators' force.
pub fn limits(config: &Config, world: &World) -> Limits {
    Limits {
        stroke_min_m: config.platform.min_leg_length_m,
        stroke_max_m: config.platform.max_leg_length_m,
        speed_max_m_s: config.control.max_leg_speed_m_s,
        force_min_n: -world.actuator.max_force_n,
        force_max_n: world.actuator.max_force_n,
    }
}

/// Loads the configuration, builds the simulator and binds the emulator (nothing runs yet).
/// `key` chooses the shared key given the key file the description names (`rig.key_file`);
/// `news` hears what the emulator tells.
pub fn prepare(
    options: &EmulateOptions,
    key: &mut dyn FnMut(Option<PathBuf>) -> Result<Option<rig::Key>, Error>,
    news: Newsroom,
) -> Result<Prepared, Error> {
    let mut scenario = Scenario::new(
        rig_description::load::load(options.config.as_deref())?,
        options.seed,
        options.noise,
    )?;
    if options.reference {
        // The rig's owner's calibrated weight in the payload's place: one rigid body.
        scenario.world.payload = scenario.world.reference;
        scenario.world.suspension.enabled = false;
    }
    let scenario = scenario;
    if scenario.noise != NoisePreset::Realistic {
        news(News::Note(&format!(
            "the emulated sensors are `{}` (the rig description's datasheet × {}); give \
             `stewart rig` a rig description with those figures, or its sigmas describe other \
             sensors than these",
            scenario.noise.name(),
            scenario.noise.scale()
        )));
    }
    let loaded = scenario.loaded.clone();
    let config = &loaded.config;
    let mut rig_config = config.rig.clone();
    // Options are checked as the flags they stand for: a bad value is blamed on the flag, not
    // on `rig.watchdog_ms` at a line of the embedded configuration that the user never wrote.
    let mut flag_issues = Vec::new();
    if let Some(ms) = options.watchdog_ms {
        if let Some(problem) = rig_description::range::ranges::WATCHDOG_MS.problem(ms) {
            flag_issues.push(flag_issue("--watchdog-ms", problem));
        }
        rig_config.watchdog_ms = ms;
    }
    for (flag, value, range) in [
        ("--drop", options.drop, FRACTION),
        ("--corrupt", options.corrupt, FRACTION),
        ("--delay-fraction", options.delay_fraction, FRACTION),
        ("--delay-ms", options.delay_ms.unwrap_or(0.0), DELAY_MS),
    ] {
        if let Some(problem) = range.problem(value) {
            flag_issues.push(flag_issue(flag, problem));
        }
    }
    if let Some(listen) = &options.listen {
        if let Err(e) = listen.parse::<rig::transport::Address>() {
            flag_issues.push(flag_issue("--listen", e.to_string()));
        }
        rig_config.address = listen.clone();
    }
    if !flag_issues.is_empty() {
        return Err(Error::Config(ConfigError {
            issues: flag_issues,
        }));
    }
    let problems = rig_config.problems();
    if !problems.is_empty() {
        return Err(Error::Config(ConfigError {
            issues: problems
                .into_iter()
                .map(|(key, problem)| loaded.issue(&key, problem))
                .collect(),
        }));
    }
    let geometry = measure::setup::geometry(&loaded)?;
    // Both worlds must be accepted before a host connects.
    scenario.simulator(geometry, true)?;
    let simulator = scenario.simulator(geometry, options.payload.loaded_in_session(1))?;
    let payload = scenario.world.payload.to_sim();

    let key = key(rig_config.key_path(&loaded.directory()))?;
    let faults = FaultInjection {
        drop_fraction: options.drop,
        corrupt_fraction: options.corrupt,
        delay_fraction: if options.delay_ms.is_some() {
            options.delay_fraction
        } else {
            0.0
        },
        // Checked against DELAY_MS above: finite and not negative.
        delay: Duration::from_secs_f64(options.delay_ms.unwrap_or(0.0) * 1e-3),
        stop_after_frames: options.stop_after,
        stall_once_after_frames: options.stall_once_after,
    };
    let watchdog = Duration::from_secs_f64(rig_config.watchdog_ms * 1e-3);
    let emulator_config = EmulatorConfig {
        identity: "stewart-emulator".into(),
        layout: SensorLayout {
            leg_count: LEG_COUNT as u8,
            imu_present: true,
            accel_position_m: config.sensors.imu.position_m,
        },
        limits: limits(config, &scenario.world),
        watchdog,
        key,
        faults,
        lockstep: options.lockstep.then_some(watchdog),
        fast_forward: options.fast_forward,
        seed: scenario.world.seed,
        ..EmulatorConfig::new(limits(config, &scenario.world))
    };
    let mut emulator =
        Emulator::bind(&rig_config.address, simulator, emulator_config).map_err(refuse)?;
    let address = match emulator.local_addr() {
        Some(addr) if rig_config.address.starts_with("udp://") => format!("udp://{addr}"),
        _ => rig_config.address.clone(),
    };
    let sessions = Arc::new(Mutex::new(Vec::new()));
    let seen = Arc::clone(&sessions);
    let mode = options.payload;
    let told = Arc::clone(&news);
    emulator.set_session_hook(Box::new(
        move |sim: &mut sim::Simulator, start: &SessionStart| {
            let on = mode.loaded_in_session(start.number);
            if on != sim.true_payload().is_some() {
                if let Err(e) = put_payload(sim, on.then_some(payload)) {
                    told(News::PayloadFailed(&e));
                }
            }
            told(News::Session(start, sim.true_payload().is_some()));
            if let Ok(mut list) = seen.lock() {
                list.push(*start);
            }
        },
    ));
    emulator.set_event_hook(Box::new(move |event: &EmulatorEvent| {
        news(News::Event(event));
    }));
    Ok(Prepared {
        emulator,
        address,
        loaded,
        sessions,
    })
}

/// What an operator does between sessions: the payload goes on (or off) the braked platform,
/// whose brakes take the new static load, and the plate settles for
/// [`crate::simulate::PAYLOAD_SETTLE_S`] before the session's brake hold (as the simulator's
/// session does between its runs): a hold that begins on a plate still sagging onto its brakes
/// takes the sag into the accelerometer's offset it measures, and so into the payload's mass.
fn put_payload(
    sim: &mut sim::Simulator,
    payload: Option<sim::BodyProperties>,
) -> Result<(), sim::SimError> {
    sim.change_payload_and_settle(payload, crate::simulate::PAYLOAD_SETTLE_S)
}

fn backend_failed(e: RigError) -> Error {
    Error::Run(anyhow!("the emulator stopped: {e}"))
}

impl Prepared {
    /// Runs the emulator until `stop` is set; returns its counters.
    pub fn run(mut self, stop: &AtomicBool) -> Result<EmulatorStats, Error> {
        self.emulator.run(stop).map_err(backend_failed)?;
        Ok(*self.emulator.stats())
    }
}

/// An emulator running on its own thread (for tests and tools): stops and joins on
/// [`stop`](Self::stop) or drop.
pub struct RunningEmulator {
    address: String,
    stop: Arc<AtomicBool>,
    sessions: Arc<Mutex<Vec<SessionStart>>>,
    thread: Option<JoinHandle<Result<Emulator<sim::Simulator>, RigError>>>,
}

/// Starts a [`Prepared`] emulator on a thread of its own.
pub fn spawn(prepared: Prepared) -> Result<RunningEmulator, Error> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let mut emulator = prepared.emulator;
    let thread = std::thread::Builder::new()
        .name("emulator".into())
        .spawn(move || emulator.run(&flag).map(|()| emulator))
        .map_err(|e| Error::Run(anyhow!("cannot start the emulator thread: {e}")))?;
    Ok(RunningEmulator {
        address: prepared.address,
        stop,
        sessions: prepared.sessions,
        thread: Some(thread),
    })
}

impl RunningEmulator {
    /// The address to connect to.
    pub fn address(&self) -> &str {
        &self.address
    }

    /// The sessions opened so far.
    pub fn sessions(&self) -> Vec<SessionStart> {
        self.sessions.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Stops the emulator and gives it back (its counters, faults, last command, simulator).
    pub fn stop(mut self) -> Result<Emulator<sim::Simulator>, Error> {
        self.stop.store(true, Ordering::SeqCst);
        let thread = self
            .thread
            .take()
            .ok_or_else(|| Error::Run(anyhow!("the emulator was already stopped")))?;
        thread
            .join()
            .map_err(|_| Error::Run(anyhow!("the emulator thread panicked")))?
            .map_err(backend_failed)
    }
}

impl Drop for RunningEmulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// One line for an emulator event: the session, its host, and the cause.
pub fn event_line(event: &EmulatorEvent) -> String {
    match event {
        EmulatorEvent::Fault {
            session,
            peer,
            fault,
        } => {
            let cause = match fault.code {
                rig::wire::FaultCode::WATCHDOG => format!(
                    "no valid command for {:.1} ms (the watchdog)",
                    fault.value * 1e3
                ),
                _ => {
                    let leg = if fault.leg == rig::wire::NO_LEG {
                        String::new()
                    } else {
                        format!(" on leg {}", fault.leg)
                    };
                    format!("{}{leg}, value {}", fault.code.name(), fault.value)
                }
            };
            format!(
                "session {session} from {peer}: fault: {cause}, after command {}; braked until \
                 the host opens a new session",
                fault.command_sequence
            )
        }
        EmulatorEvent::SessionTimedOut {
            session,
            peer,
            silent_for,
        } => format!(
            "session {session} from {peer}: ended, the host was silent for {:.2} s (session \
             timeout); the next Hello from anyone opens a new one",
            silent_for.as_secs_f64()
        ),
    }
}

/// The emulator's counters in one line; `paced`: its ticks keep to the wall clock (not
/// `--lockstep`), so how late they came means something.
pub fn summary(s: &EmulatorStats, paced: bool) -> String {
    let timing = if paced {
        format!(
            "{} overruns, the latest {:.1} ms late, {:.1} ms while commanded",
            s.overruns,
            s.latest_tick_us as f64 * 1e-3,
            s.latest_commanded_tick_us as f64 * 1e-3
        )
    } else {
        // In lockstep a tick waits for the host's answer: its lateness is the host's pace.
        "in lockstep: paced by the host's answers, not the wall clock".to_string()
    };
    format!(
        "{} ticks ({timing}; the slowest physics step {:.1} ms), {} sessions, {} sensor frames sent ({} dropped, {} corrupted, \
         {} delayed by injection; {} refused by the link), {} commands accepted ({} lost, {} duplicate, {} out of \
         sequence), {} foreign, {} auth failed, {} corrupt, {} faults reported",
        s.ticks,
        s.slowest_step_us as f64 * 1e-3,
        s.core.sessions,
        s.sent,
        s.dropped_injected,
        s.corrupted_injected,
        s.delayed_injected,
        s.send_failed,
        s.core.commands_accepted,
        s.core.commands_lost,
        s.core.duplicate,
        s.core.out_of_sequence,
        s.core.foreign_sender,
        s.core.auth_failed,
        s.core.corrupt,
        s.core.faults_sent
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_modes_follow_the_sessions() {
        assert!(!PayloadMode::TareFirst.loaded_in_session(1));
        assert!(PayloadMode::TareFirst.loaded_in_session(2));
        assert!(PayloadMode::TareFirst.loaded_in_session(7));
        assert!(PayloadMode::On.loaded_in_session(1));
        assert!(!PayloadMode::Off.loaded_in_session(3));
    }

    #[test]
    fn limits_come_from_the_scenario() {
        let s = Scenario::new(rig_description::load::load(None).unwrap(), None, None).unwrap();
        let c = &s.loaded.config;
        let l = limits(c, &s.world);
        assert_eq!(l.stroke_min_m, c.platform.min_leg_length_m);
        assert_eq!(l.stroke_max_m, c.platform.max_leg_length_m);
        assert_eq!(l.speed_max_m_s, c.control.max_leg_speed_m_s);
        assert_eq!(l.force_max_n, s.world.actuator.max_force_n);
        assert_eq!(l.force_min_n, -s.world.actuator.max_force_n);
    }

    /// `emulate --watchdog-ms 0` is blamed on the flag, not on `rig.watchdog_ms` at a line of
    /// the embedded configuration.
    #[test]
    fn a_bad_watchdog_flag_is_blamed_on_the_flag() {
        for (args, flag) in [
            (
                EmulateOptions {
                    watchdog_ms: Some(0.0),
                    listen: Some("udp://127.0.0.1:0".into()),
                    ..EmulateOptions::default()
                },
                "--watchdog-ms",
            ),
            (
                EmulateOptions {
                    listen: Some("tcp://x:1".into()),
                    ..EmulateOptions::default()
                },
                "--listen",
            ),
        ] {
            let e = refused(&args);
            let message = e.to_string();
            assert!(message.contains(flag), "{message}");
            assert!(
                message.contains(rig_description::load::COMMAND_LINE_NAME),
                "{message}"
            );
            assert!(!message.contains("rig.watchdog_ms"), "{message}");
            assert!(matches!(e, Error::Config(_) | Error::Input(_)), "{e}");
        }
    }

    /// `prepare`'s refusal of `options` (no key, no news), which the test expects.
    fn refused(options: &EmulateOptions) -> Error {
        prepare(
            options,
            &mut |_| Ok(None),
            std::sync::Arc::new(|_: News<'_>| {}),
        )
        .err()
        .expect("refused")
    }

    #[test]
    fn bad_fault_injection_is_refused_before_binding() {
        let args = EmulateOptions {
            listen: Some("udp://127.0.0.1:0".into()),
            drop: 1.5,
            ..EmulateOptions::default()
        };
        let e = refused(&args);
        assert!(e.to_string().contains("`--drop`"), "{e}");
        assert!(e.to_string().contains("between 0 and 1"), "{e}");
        assert!(matches!(e, Error::Config(_) | Error::Input(_)), "{e}");
    }

    /// The emulator prints a line when its watchdog trips or a session times out.
    #[test]
    fn watchdog_trips_and_timeouts_are_one_line_each_naming_the_session_and_cause() {
        let peer = rig::transport::Peer::Udp("127.0.0.1:5000".parse().unwrap());
        let trip = event_line(&EmulatorEvent::Fault {
            session: 3,
            peer,
            fault: rig::wire::Fault {
                code: rig::wire::FaultCode::WATCHDOG,
                leg: rig::wire::NO_LEG,
                value: 0.0213,
                command_sequence: 1234,
            },
        });
        assert_eq!(
            trip,
            "session 3 from udp://127.0.0.1:5000: fault: no valid command for 21.3 ms (the \
             watchdog), after command 1234; braked until the host opens a new session"
        );
        let timeout = event_line(&EmulatorEvent::SessionTimedOut {
            session: 3,
            peer,
            silent_for: Duration::from_millis(1004),
        });
        assert!(timeout.starts_with("session 3 from udp://127.0.0.1:5000: ended"));
        assert!(timeout.contains("silent for 1.00 s (session timeout)"));
        assert!(!trip.contains('\n') && !timeout.contains('\n'));
    }
}
