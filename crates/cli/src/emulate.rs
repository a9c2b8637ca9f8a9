//! `stewart emulate`: the flags of the emulator ([`ops::emulate`]) and what it prints.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use clap::{Args, ValueEnum};
use ops::emulate::{event_line, summary};
use ops::emulate::{EmulateOptions, News};
use rig::emulator::{EmulatorEvent, EmulatorStats};
use sim::NoisePreset;

use crate::common::CommandError;

/// Whether the emulated fixture carries the payload (`--payload`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum PayloadMode {
    /// Empty for the first session, loaded for every later one (tare, then measure).
    #[default]
    TareFirst,
    /// Loaded in every session.
    On,
    /// Empty in every session.
    Off,
}

impl From<PayloadMode> for ops::emulate::PayloadMode {
    fn from(m: PayloadMode) -> Self {
        match m {
            PayloadMode::TareFirst => Self::TareFirst,
            PayloadMode::On => Self::On,
            PayloadMode::Off => Self::Off,
        }
    }
}

/// `stewart emulate` flags.
#[derive(Clone, Debug, Args)]
pub struct EmulateArgs {
    /// Where to listen: udp://HOST:PORT (port 0: any free port) or serial:///dev/DEVICE?baud=N
    /// [default: rig.address, udp://127.0.0.1:7700].
    #[arg(long, value_name = "ADDR")]
    pub listen: Option<String>,
    /// Scenario TOML, laid over the embedded default (the same file as `simulate`).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Random seed of the simulated world (world.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Sensor grade: `realistic` the rig description's datasheet, `none` ideal, `harsh` ×10.
    #[arg(long, value_parser = crate::common::noise_preset())]
    pub noise: Option<NoisePreset>,
    /// When the payload is on the fixture (see `stewart emulate --help`).
    #[arg(long, value_enum, default_value_t = PayloadMode::TareFirst)]
    pub payload: PayloadMode,
    /// The body put on is the world's reference weight (`[world.reference]`), not its payload:
    /// the emulated rig for `rig calibrate-load-cells`.
    #[arg(long)]
    pub reference: bool,
    /// Shared-key file (hex), instead of rig.key_file and the user's key file
    /// ($XDG_CONFIG_HOME/stewart/rig.key, else ~/.config/stewart/rig.key, written when
    /// missing).
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// No shared key: accept untagged frames, so that anyone who can reach the port can open
    /// a session and anyone who can forge the host's address can command. For isolated
    /// networks only; the host needs `rig --insecure` too.
    #[arg(long)]
    pub insecure: bool,
    /// Stay at normal priority: do not ask for SCHED_FIFO and locked memory.
    #[arg(long)]
    pub no_realtime: bool,
    /// Brake, with a WATCHDOG fault, when no valid command arrived for this long after one
    /// that drove the actuators, ms (rig.watchdog_ms, default 20).
    #[arg(long, value_name = "MS")]
    pub watchdog_ms: Option<f64>,
    /// Fault injection: fraction of sensor frames not sent, 0 to 1.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.0)]
    pub drop: f64,
    /// Fault injection: fraction of sensor frames sent with a bit flipped, 0 to 1.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.0)]
    pub corrupt: f64,
    /// Fault injection: hold sensor frames back this long, 0 to 10000 ms (the longest
    /// rig.link_silence_ms).
    #[arg(long, value_name = "MS")]
    pub delay_ms: Option<f64>,
    /// Fault injection: fraction of sensor frames held back by --delay-ms, 0 to 1.
    #[arg(long, value_name = "FRACTION", default_value_t = 1.0)]
    pub delay_fraction: f64,
    /// Fault injection: stop answering after this many sensor frames of a session.
    #[arg(long, value_name = "FRAMES")]
    pub stop_after: Option<u64>,
    /// Fault injection: go silent after this many sensor frames (over all sessions), once,
    /// until the host opens a new session (a stall `rig` repeats the run after: rig.stall_retries).
    #[arg(long, value_name = "FRAMES")]
    pub stall_once_after: Option<u64>,
    /// Wait (up to the watchdog time) for the host's answer to each frame before simulating
    /// the next, so that the emulated world pauses while the host is descheduled. Not real
    /// time: for tests on busy machines.
    #[arg(long)]
    pub lockstep: bool,
    /// With --lockstep: simulate the next sample as soon as the host has answered the last
    /// one, so that a run takes as long as host and emulator compute, not its real time (the
    /// emulated rig's watchdog and timeouts count emulated time). For tests and demonstrations.
    #[arg(long, requires = "lockstep")]
    pub fast_forward: bool,
    /// Print nothing but errors.
    #[arg(long)]
    pub quiet: bool,
}

impl EmulateArgs {
    /// The emulator's options.
    pub fn options(&self) -> EmulateOptions {
        EmulateOptions {
            listen: self.listen.clone(),
            config: self.config.clone(),
            seed: self.seed,
            noise: self.noise,
            payload: self.payload.into(),
            reference: self.reference,
            watchdog_ms: self.watchdog_ms,
            drop: self.drop,
            corrupt: self.corrupt,
            delay_ms: self.delay_ms,
            delay_fraction: self.delay_fraction,
            stop_after: self.stop_after,
            stall_once_after: self.stall_once_after,
            lockstep: self.lockstep,
            fast_forward: self.fast_forward,
        }
    }

    /// The shared key of `--key`, `configured` (`rig.key_file`) or the user's key file, written
    /// when missing; its notice on standard error (even with `--quiet`: a key file written, or
    /// no key at all, is for the user to know).
    pub fn key(
        &self,
        configured: Option<PathBuf>,
    ) -> Result<Option<rig::Key>, ops::measurement::Error> {
        let (key, insecure) = (self.key.as_deref(), self.insecure);
        crate::rig::shared_key(key, configured, insecure, ops::key::Side::Rig, "emulator: ")
    }

    /// Where the emulator's news goes: its sessions and timeouts on standard output (not with
    /// `--quiet`), its faults on standard error (always: they are errors of the session).
    pub fn newsroom(&self) -> ops::emulate::Newsroom {
        let quiet = self.quiet;
        Arc::new(move |news: News<'_>| match news {
            News::Note(text) if !quiet => eprintln!("note: {text}"),
            News::Note(_) => {}
            News::PayloadFailed(e) => eprintln!("emulator: cannot change the payload: {e}"),
            News::Session(start, on) if !quiet => println!(
                "session {} from {}: payload {}",
                start.number,
                start.peer,
                if on { "on" } else { "off (tare)" }
            ),
            News::Session(..) => {}
            News::Event(event @ EmulatorEvent::Fault { .. }) => eprintln!("{}", event_line(event)),
            News::Event(event @ EmulatorEvent::SessionTimedOut { .. }) if !quiet => {
                println!("{}", event_line(event))
            }
            News::Event(EmulatorEvent::SessionTimedOut { .. }) => {}
        })
    }

    /// The emulator of these flags, bound (nothing runs yet).
    pub fn prepare(&self) -> Result<ops::emulate::Prepared, CommandError> {
        ops::emulate::prepare(
            &self.options(),
            &mut |configured| self.key(configured),
            self.newsroom(),
        )
    }
}

/// Runs `stewart emulate` until `stop` is set. Returns the emulator's counters.
pub fn emulate(args: &EmulateArgs, stop: &AtomicBool) -> Result<EmulatorStats, CommandError> {
    let prepared = args.prepare()?;
    if !args.quiet {
        println!(
            "emulating the rig of {} on {} (payload: {}); Ctrl-C stops",
            prepared.loaded.source,
            prepared.address,
            match args.payload {
                PayloadMode::TareFirst => "off for the first session, then on",
                PayloadMode::On => "on",
                PayloadMode::Off => "off",
            }
        );
    }
    prepared.run(stop)
}

/// `stewart emulate` from the command line; returns the exit code.
pub fn main(args: &EmulateArgs, stop: &AtomicBool) -> u8 {
    if !args.no_realtime {
        let granted = rig::realtime::request();
        match granted.refusal_line() {
            Some(line) => eprintln!("emulator: warning: {line}"),
            None if !args.quiet => eprintln!("emulator: {}", granted.granted_line()),
            None => {}
        }
    }
    match emulate(args, stop) {
        Ok(stats) => {
            if !args.quiet {
                println!("stopped: {}", summary(&stats, !args.lockstep));
            }
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}
