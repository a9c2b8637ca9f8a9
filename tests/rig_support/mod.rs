//! Shared by the `rig_*` tests: short scenarios, an in-process emulator on a free loopback
//! port, `stewart rig` run through the CLI library (arguments parsed as on the command line),
//! and reading the MCAP log back.
//!
//! Real-time tests on a busy two-core machine: the emulator runs in lockstep (it waits for the
//! host's answer to each frame before simulating the next, so a descheduled host pauses the
//! emulated world instead of letting the platform run on a stale command), and link-silence
//! and watchdog limits are generous except in the test about silence. Tests that run the
//! emulator in real time take a process-wide lock so that they do not compete with each other.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Mutex, MutexGuard};

pub use stewart_cli::emulate::EmulateArgs;
use stewart_cli::emulate::{self, RunningEmulator};
use stewart_cli::rig_cmd::{self, RigArgs, RigOutcome};
use stewart_cli::simulate::CommandError;

/// 500 Hz, a 10 s multi-sine for the tare and the loaded run, generous link limits.
pub const SHORT: &str = r#"
[sensors]
sample_rate_hz = 500.0
physics_substeps = 2

[control]
max_sample_gap_s = 0.5

[excitation]
fade_s = 1.0

[run]
brake_hold_s = 0.5
settle_s = 0.5
duration_s = 10.0
tare_duration_s = 10.0
park_s = 1.0

[rig]
link_silence_ms = 1000.0
watchdog_ms = 1000.0
"#;

/// As [`SHORT`] with 4 s excitations: for tests about the link, not the estimate.
pub fn quick() -> String {
    SHORT
        .replace("duration_s = 10.0", "duration_s = 4.0")
        .replace("fade_s = 1.0", "fade_s = 0.5")
}

static REAL_TIME: Mutex<()> = Mutex::new(());

/// Serialises the real-time tests of one test binary.
pub fn real_time() -> MutexGuard<'static, ()> {
    REAL_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// A scratch directory with a scenario file.
pub struct Scratch {
    pub dir: tempfile::TempDir,
    pub config: PathBuf,
}

impl Scratch {
    pub fn new(scenario: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("scenario.toml");
        std::fs::write(&config, scenario).unwrap();
        Self { dir, config }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    pub fn config_str(&self) -> &str {
        self.config.to_str().unwrap()
    }
}

/// Emulator flags for `scratch`'s scenario on a free loopback port, in lockstep, quiet.
pub fn emulate_args(scratch: &Scratch) -> EmulateArgs {
    EmulateArgs {
        listen: Some("udp://127.0.0.1:0".into()),
        config: Some(scratch.config.clone()),
        lockstep: true,
        quiet: true,
        ..EmulateArgs::default()
    }
}

/// Starts an emulator on its own thread.
pub fn start(args: &EmulateArgs) -> RunningEmulator {
    emulate::spawn(args).unwrap_or_else(|e| panic!("emulator: {e}"))
}

/// `stewart rig ARGS` parsed as the command line would be.
pub fn rig_args(args: &[&str]) -> RigArgs {
    rig_cmd::parse(args).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `stewart rig` through the library.
pub fn run_rig(args: &RigArgs) -> Result<RigOutcome, CommandError> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    rig_cmd::rig(args, &NEVER)
}

/// Every message of a finished MCAP log as (topic, JSON), in file order; panics if any
/// record fails to read (the log must be readable to its last frame) or the file has no
/// summary (it was not finished).
pub fn read_log(path: &Path) -> Vec<(String, serde_json::Value)> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes).expect("summary readable");
    assert!(
        summary.is_some(),
        "the log {} was not finished",
        path.display()
    );
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap_or_else(|e| panic!("unreadable record in {}: {e}", path.display()));
            let value = serde_json::from_slice(&m.data).unwrap();
            (m.channel.topic.clone(), value)
        })
        .collect()
}

/// The messages on `topic`.
pub fn on<'a>(log: &'a [(String, serde_json::Value)], topic: &str) -> Vec<&'a serde_json::Value> {
    log.iter()
        .filter(|(t, _)| t == topic)
        .map(|(_, v)| v)
        .collect()
}

/// The payload of the scenario (what the emulator's simulator carries): mass, com, J_C.
pub fn truth(scenario_path: &Path) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let loaded = stewart_cli::config_load::load(Some(scenario_path)).unwrap();
    let p = &loaded.config.payload;
    (p.mass_kg, p.com_m, p.inertia_com_kg_m2)
}

/// A free UDP port's address on loopback nobody listens on.
pub fn dead_address() -> String {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = socket.local_addr().unwrap();
    drop(socket);
    format!("udp://{addr}")
}
