//! What the end-to-end tests share, in one place: scenario files and the configurations built
//! from them, the reference geometry, the simulator's and the rig's measurements run through the
//! operations library, an in-process emulator, and the one MCAP reader of the tests.
//!
//! Real-time tests on a busy two-core machine: the emulator runs in lockstep (it waits for the
//! host's answer to each frame before simulating the next, so a descheduled host pauses the
//! emulated world instead of letting the platform run on a stale command), and link-silence
//! and watchdog limits are generous except in the test about silence. Tests that run the
//! emulator in real time take a process-wide lock so that they do not compete with each other.

#![allow(dead_code)]

pub mod live;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Mutex, MutexGuard};

pub use ops::emulate::EmulateOptions;
use ops::emulate::RunningEmulator;
pub use ops::measurement::{MeasureOptions, Outcome, Silent};
pub use ops::simulate::SimulateOptions;
use rig_description::LoadedConfig;
use sim::scenario::Scenario;
use sim::NoisePreset;

// ---------------------------------------------------------------------------------------------
// Scenarios and configurations

/// A short simulate scenario for the log, estimate and plot tests: 6 s of excitation, 4 s of
/// tare, the datasheet's (realistic) noise.
pub const SHORT: &str = "[run]\nduration_s = 6.0\ntare_duration_s = 4.0\n";

/// Rigid, massless legs with frictionless joints, described and built so: for tests of the
/// ideal world's exactness (the default rig's legs are heavy, and built off their description).
pub const IDEAL_LEGS: &str = "[legs]\ncylinder_mass_kg = 0.0\ncylinder_inertia_kg_m2 = 0.0\n\
    rod_mass_kg = 0.0\nrod_inertia_kg_m2 = 0.0\njoint_coulomb_torque_nm = 0.0\n\
    joint_viscous_nm_s_per_rad = 0.0\n";

/// The rig tests' scenario: 500 Hz, a 10 s multi-sine for the tare and the loaded run, two
/// physics substeps, generous link limits. `[rig]` comes last so that keys appended to the
/// text land in it.
pub const RIG_SHORT: &str = r#"
[sensors]
sample_rate_hz = 500.0

[world]
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
key_file = "rig.key"
"#;

/// The shared key every [`Scratch`] directory holds as `rig.key` (the rig scenarios name it in
/// `rig.key_file`), so that the rig tests run authenticated, as a rig does by default, without
/// touching the user's own key file.
pub const TEST_KEY_HEX: &str = "00112233445566778899aabbccddeeff0123456789abcdef0123456789abcdef";

/// As [`RIG_SHORT`] with 4 s excitations: for tests about the link, not the estimate.
pub fn quick() -> String {
    RIG_SHORT
        .replace("duration_s = 10.0", "duration_s = 4.0")
        .replace("fade_s = 1.0", "fade_s = 0.5")
}

/// The embedded default rig description (configs/default.toml).
pub fn default_config() -> LoadedConfig {
    rig_description::load::load(None).expect("the embedded default loads")
}

/// `text` laid over the default, as a scenario file named `name` would be.
pub fn config_str(text: &str, name: &str) -> LoadedConfig {
    rig_description::load::load_str(text, name).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// One measurement of `scenario`'s world through `measure::measure`, told to `observer`: the
/// tare run's excitation on the empty fixture, or the configured one (`run.duration_s`) with
/// the payload on; no tare subtracted. Panics on anything but a completed run.
pub fn measure_run<O: measure::Observer>(
    scenario: &Scenario,
    measurement: measure::Measurement,
    observer: &mut O,
) -> measure::MeasureOutcome {
    let loaded = &scenario.loaded;
    let geometry = measure::setup::geometry(loaded).expect("geometry");
    let trajectory = match measurement {
        measure::Measurement::Tare => measure::setup::tare_trajectory(loaded, &geometry),
        measure::Measurement::Loaded => {
            measure::setup::trajectory(loaded, &geometry, loaded.config.run.duration_s)
        }
    }
    .expect("trajectory");
    let controller =
        measure::setup::controller(loaded, &geometry, trajectory, measurement).expect("controller");
    let payload_on = measurement == measure::Measurement::Loaded;
    let mut backend = scenario.simulator(geometry, payload_on).expect("simulator");
    let setup = measure::MeasureSetup {
        config: &loaded.config,
        geometry,
        measurement,
        tare: None,
    };
    let outcome = measure::measure(
        &mut backend,
        &setup,
        controller,
        observer,
        &AtomicBool::new(false),
    )
    .expect("the measurement runs");
    assert_eq!(outcome.end, measure::End::Completed);
    outcome
}

/// The simulated world of `loaded` at the given grade (seed from the file).
pub fn world(loaded: LoadedConfig, noise: Option<NoisePreset>) -> Scenario {
    Scenario::new(loaded, None, noise).unwrap_or_else(|e| panic!("world: {e}"))
}

/// The default scenario: the default rig description with its simulated world, realistic noise.
pub fn default_world() -> Scenario {
    world(default_config(), None)
}

/// The reference geometry: the default rig description's platform, as every command builds it.
pub fn geometry() -> kinematics::Geometry {
    measure::setup::geometry(&default_config()).expect("the default platform is valid")
}

/// The payload of the scenario file at `path` (what the simulator and the emulator carry):
/// mass, com, J_C.
pub fn truth(path: &Path) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let loaded = rig_description::load::load(Some(path)).unwrap_or_else(|e| panic!("{e}"));
    let p = world(loaded, None).world.payload;
    (p.mass_kg, p.com_m, p.inertia_com_kg_m2)
}

/// |a − b| ≤ tol·max(|a|, |b|), NaN only with NaN.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    if a.is_nan() || b.is_nan() {
        return a.is_nan() && b.is_nan();
    }
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

/// A scratch directory under cargo's per-target temporary directory, so that what a shared
/// fixture (a `static`, never dropped) leaves behind goes with `cargo clean`, not into `/tmp`.
pub fn scratch_dir() -> tempfile::TempDir {
    tempfile::tempdir_in(env!("CARGO_TARGET_TMPDIR")).unwrap()
}

/// A scratch directory with a scenario file.
pub struct Scratch {
    pub dir: tempfile::TempDir,
    pub config: PathBuf,
}

impl Scratch {
    pub fn new(scenario: &str) -> Self {
        let dir = scratch_dir();
        let config = dir.path().join("scenario.toml");
        std::fs::write(&config, scenario).unwrap();
        std::fs::write(dir.path().join("rig.key"), format!("{TEST_KEY_HEX}\n")).unwrap();
        Self { dir, config }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    pub fn config_str(&self) -> &str {
        self.config.to_str().unwrap()
    }
}

// ---------------------------------------------------------------------------------------------
// `stewart simulate`

/// The simulation's options for `config`, logging to `log`.
pub fn simulate_args(config: Option<PathBuf>, log: PathBuf) -> SimulateOptions {
    SimulateOptions {
        measure: MeasureOptions {
            config,
            log: Some(log),
            ..MeasureOptions::default()
        },
        ..SimulateOptions::default()
    }
}

/// Runs the simulation of `options`, watched by nobody.
pub fn run_simulate(options: &SimulateOptions) -> Result<Outcome, ops::measurement::Error> {
    ops::simulate::run(options, &mut Silent, &AtomicBool::new(false))
}

/// A finished simulate run: its directory (kept alive), log and report.
pub struct Simulated {
    pub dir: tempfile::TempDir,
    pub log: PathBuf,
    pub report: measure::Report,
}

/// Runs the simulation of `scenario` with `extra` applied to the options.
pub fn simulate_with(scenario: &str, extra: impl FnOnce(&mut SimulateOptions, &Path)) -> Simulated {
    let scratch = Scratch::new(scenario);
    let log = scratch.path("run.mcap");
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    extra(&mut args, scratch.dir.path());
    let outcome = run_simulate(&args).unwrap_or_else(|e| panic!("simulate failed: {e}"));
    let report = outcome.report.expect("a completed run has a report");
    Simulated {
        dir: scratch.dir,
        log,
        report,
    }
}

/// The short default run.
pub fn simulate() -> Simulated {
    simulate_with(SHORT, |_, _| {})
}

// ---------------------------------------------------------------------------------------------
// `stewart emulate` and `stewart rig`

static REAL_TIME: Mutex<()> = Mutex::new(());

/// Serialises the real-time tests of one test binary.
pub fn real_time() -> MutexGuard<'static, ()> {
    REAL_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Emulator options for `scratch`'s scenario on a free loopback port, in lockstep.
pub fn emulate_args(scratch: &Scratch) -> EmulateOptions {
    EmulateOptions {
        listen: Some("udp://127.0.0.1:0".into()),
        config: Some(scratch.config.clone()),
        lockstep: true,
        ..EmulateOptions::default()
    }
}

/// [`emulate_args`], fast-forwarding (`--fast-forward`): the run takes as long as host and
/// emulator compute. For tests whose other threads do not act on the run's real time.
pub fn emulate_args_fast(scratch: &Scratch) -> EmulateOptions {
    EmulateOptions {
        fast_forward: true,
        ..emulate_args(scratch)
    }
}

/// The shared key of the test's rig: the file the scenario names (`rig.key_file`, a
/// [`Scratch`]'s `rig.key`), none when it names none.
pub fn scenario_key(
    configured: Option<PathBuf>,
) -> Result<Option<::rig::Key>, ops::measurement::Error> {
    configured
        .map(|path| ::rig::Key::from_file(&path).map_err(ops::measurement::refuse))
        .transpose()
}

/// Starts an emulator of `options` on its own thread, with the scenario's key, saying nothing.
pub fn start(options: &EmulateOptions) -> RunningEmulator {
    let prepared = ops::emulate::prepare(options, &mut scenario_key, std::sync::Arc::new(|_| {}))
        .unwrap_or_else(|e| panic!("emulator: {e}"));
    ops::emulate::spawn(prepared).unwrap_or_else(|e| panic!("emulator: {e}"))
}

/// A rig measurement as the end-to-end rig tests run it through the library: its options and
/// how the host's key is chosen.
#[derive(Clone, Debug)]
pub struct RigRun {
    /// The measurement's options.
    pub options: ops::rig::RigOptions,
    /// A key file instead of the scenario's `rig.key_file` (`--key`).
    pub key: Option<PathBuf>,
    /// No key at all (`--insecure`).
    pub insecure: bool,
}

/// The rig measurement `plan` against the rig at `address` as every end-to-end rig test starts
/// it: the scenario `config` (a [`Scratch`]'s, which names the shared key [`TEST_KEY_HEX`]),
/// logged to `log`, the payload change between a tare and a loaded run at once (no operator).
pub fn rig_against(config: &Path, address: &str, log: &Path, plan: ops::rig::RigPlan) -> RigRun {
    RigRun {
        options: ops::rig::RigOptions {
            plan,
            measure: MeasureOptions {
                config: Some(config.to_path_buf()),
                log: Some(log.to_path_buf()),
                ..MeasureOptions::default()
            },
            link: ops::rig::LinkOptions {
                connect: Some(address.into()),
                link_silence_ms: None,
            },
        },
        key: None,
        insecure: false,
    }
}

/// The tare-only measurement (saved to `tare.json`) against the rig at `address`, logged to
/// `rig.mcap`, both in `scratch` ([`rig_against`]).
pub fn rig_tare(scratch: &Scratch, address: &str) -> RigRun {
    rig_against(
        &scratch.config,
        address,
        &scratch.path("rig.mcap"),
        ops::rig::RigPlan::TareOnly(scratch.path("tare.json")),
    )
}

/// The attendant of the tests: the payload on at once, the key chosen as `stewart rig`
/// chooses it ([`ops::key::choose`]: `--key`, `rig.key_file`, the user's key file).
struct NoOperator<'a>(&'a RigRun);

impl ops::rig::Attendant for NoOperator<'_> {
    fn put_on(&mut self, _body: &str, _stop: &AtomicBool) -> anyhow::Result<bool> {
        Ok(true)
    }

    fn shared_key(
        &mut self,
        configured: Option<PathBuf>,
    ) -> Result<Option<::rig::Key>, ops::measurement::Error> {
        let chosen = ops::key::choose(
            self.0.key.as_deref(),
            configured,
            ops::key::user_key_path,
            self.0.insecure,
            ops::key::Side::Host,
        )
        .map_err(ops::measurement::refuse)?;
        Ok(chosen.key)
    }
}

/// Runs the rig measurement `run` through the library, `interrupt` and `abort` its Ctrl-C flags.
pub fn run_rig_with(
    run: &RigRun,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<Outcome, ops::measurement::Error> {
    ops::rig::run(
        &run.options,
        &mut Silent,
        &mut NoOperator(run),
        interrupt,
        abort,
    )
}

/// Runs the rig measurement `run` through the library with `operator` watching, never
/// interrupted.
pub fn run_rig_as(
    run: &RigRun,
    operator: &mut dyn ops::measurement::Operator,
) -> Result<Outcome, ops::measurement::Error> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    ops::rig::run(&run.options, operator, &mut NoOperator(run), &NEVER, &NEVER)
}

/// [`run_rig_with`], never interrupted.
pub fn run_rig(run: &RigRun) -> Result<Outcome, ops::measurement::Error> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    run_rig_with(run, &NEVER, &NEVER)
}

/// A free UDP port's address on loopback nobody listens on.
pub fn dead_address() -> String {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = socket.local_addr().unwrap();
    drop(socket);
    format!("udp://{addr}")
}

// ---------------------------------------------------------------------------------------------
// Reading MCAP logs

/// One message of a log, as the `mcap` crate gives it.
pub struct LogMessage {
    pub topic: String,
    pub schema_name: String,
    pub schema_encoding: String,
    pub message_encoding: String,
    pub log_time: u64,
    pub value: serde_json::Value,
}

/// Every message of a finished MCAP log with its channel, in file order; panics if any record
/// fails to read (the log must be readable to its last frame), if a channel has no schema, or
/// if the file has no summary (it was not finished).
///
/// A `json` message is parsed as it is. A `protobuf` message is decoded by `prost-reflect` with
/// the `FileDescriptorSet` its channel's schema carries (so the schema in the file is proved to
/// describe the bytes, by a decoder the project did not write) and given as the JSON the JSON
/// writer would have written: the proto field names, every field (defaults included), a
/// non-finite number as `null`. A field the descriptor does not know fails.
pub fn read_messages(path: &Path) -> Vec<LogMessage> {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes).expect("summary readable");
    assert!(
        summary.is_some(),
        "the log {} was not finished",
        path.display()
    );
    let mut descriptors = std::collections::HashMap::new();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap_or_else(|e| panic!("unreadable record in {}: {e}", path.display()));
            let topic = &m.channel.topic;
            let schema = m
                .channel
                .schema
                .as_ref()
                .unwrap_or_else(|| panic!("{topic} has no schema"));
            let value = match m.channel.message_encoding.as_str() {
                "json" => serde_json::from_slice(&m.data)
                    .unwrap_or_else(|e| panic!("{topic}: not JSON: {e}")),
                "protobuf" => {
                    assert_eq!(schema.encoding, "protobuf", "{topic}");
                    let desc = descriptors
                        .entry(schema.id)
                        .or_insert_with(|| {
                            prost_reflect::DescriptorPool::decode(&schema.data[..])
                                .unwrap_or_else(|e| panic!("{topic}: not a descriptor set: {e}"))
                                .get_message_by_name(&schema.name)
                                .unwrap_or_else(|| {
                                    panic!("{topic}: {} not in its descriptor set", schema.name)
                                })
                        })
                        .clone();
                    let message = prost_reflect::DynamicMessage::decode(desc, &m.data[..])
                        .unwrap_or_else(|e| panic!("{topic}: does not decode: {e}"));
                    assert_eq!(
                        message.unknown_fields().count(),
                        0,
                        "{topic}: fields its descriptor does not know"
                    );
                    proto_json(&prost_reflect::Value::Message(message))
                }
                other => panic!("{topic}: message encoding {other}"),
            };
            LogMessage {
                topic: topic.clone(),
                schema_name: schema.name.clone(),
                schema_encoding: schema.encoding.clone(),
                message_encoding: m.channel.message_encoding.clone(),
                log_time: m.log_time,
                value,
            }
        })
        .collect()
}

/// A decoded protobuf value as the JSON writer writes it (see [`read_messages`]).
fn proto_json(v: &prost_reflect::Value) -> serde_json::Value {
    use prost_reflect::{ReflectMessage, Value};
    use serde_json::json;
    match v {
        Value::F64(x) if x.is_finite() => json!(x),
        Value::F64(_) => serde_json::Value::Null,
        // The display channels' `float`.
        Value::F32(x) if x.is_finite() => json!(f64::from(*x)),
        Value::F32(_) => serde_json::Value::Null,
        Value::U64(x) => json!(x),
        Value::U32(x) => json!(x),
        // The counts of /sensors and /commands; the Foxglove SDK's descriptors:
        // google.protobuf.Timestamp's seconds and nanos, and enums (a line's type) by number.
        Value::I64(x) => json!(x),
        Value::I32(x) | Value::EnumNumber(x) => json!(x),
        Value::Bool(x) => json!(x),
        Value::String(x) => json!(x),
        Value::List(l) => serde_json::Value::Array(l.iter().map(proto_json).collect()),
        Value::Message(m) => serde_json::Value::Object(
            m.descriptor()
                .fields()
                .map(|f| (f.name().to_string(), proto_json(&m.get_field(&f))))
                .collect(),
        ),
        other => panic!("a type the log's schema does not use: {other:?}"),
    }
}

/// Every message of a finished MCAP log as (topic, JSON), in file order (see
/// [`read_messages`]).
pub fn read_log(path: &Path) -> Vec<(String, serde_json::Value)> {
    read_messages(path)
        .into_iter()
        .map(|m| (m.topic, m.value))
        .collect()
}

/// The `enable` flag of the last command the finished log at `path` holds on `/commands` (in
/// file order: the order the host sent them), read with the `mcap` crate and the log's own
/// protobuf descriptor.
pub fn last_logged_enable(path: &Path) -> bool {
    let log = read_log(path);
    let block = on(&log, "/commands")
        .into_iter()
        .next_back()
        .expect("the log holds commands");
    block["enable"]
        .as_array()
        .and_then(|e| e.last())
        .and_then(serde_json::Value::as_bool)
        .unwrap_or_else(|| panic!("a command block without enable: {block}"))
}

/// How many records of the MCAP bytes `bytes` (possibly cut short) the `mcap` crate reads
/// before its first error.
pub fn readable_records(bytes: &[u8]) -> u64 {
    mcap::MessageStream::new(bytes)
        .unwrap()
        .take_while(|m| m.is_ok())
        .count() as u64
}

/// Copies a log without one channel's messages (channels and schemas are kept).
pub fn copy_without(from: &Path, to: &Path, topic: &str) {
    let bytes = std::fs::read(from).unwrap();
    let mut out =
        mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(to).unwrap())).unwrap();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic != topic {
            out.write(&m).unwrap();
        }
    }
    out.finish().unwrap();
}

/// A copy of the log at `from` as the JSON-only writer wrote logs: every channel `json`, each
/// protobuf message as [`read_messages`] decodes it (a non-finite number as `null`).
pub fn copy_as_json(from: &Path, to: &Path) {
    let specs: Vec<_> = runlog::messages::channels()
        .into_iter()
        .map(|mut c| {
            c.encoding = runlog::mcap_log::Encoding::Json;
            c
        })
        .collect();
    let mut log = runlog::mcap_log::McapLog::create(to, &specs).unwrap();
    for m in read_messages(from) {
        log.write(&m.topic, m.log_time, &m.value).unwrap();
    }
    log.finish().unwrap();
}

/// The `/sensors` frames of the log at `path`, decoded from their blocks, in order.
pub fn sensor_frames(path: &Path) -> Vec<runlog::read::records::SensorRecord> {
    runlog::LogContents::read(path).unwrap().sensors
}

/// Copies the log at `from` to `to` with every `/sensors` block's frames passed through
/// `edit` (which may drop or change them), every other message's bytes untouched.
pub fn rewrite_sensor_frames(
    from: &Path,
    to: &Path,
    mut edit: impl FnMut(Vec<control::io::SensorFrame>) -> Vec<control::io::SensorFrame>,
) {
    use prost::Message as _;
    let bytes = std::fs::read(from).unwrap();
    let file = std::io::BufWriter::new(std::fs::File::create(to).unwrap());
    let mut out = mcap::Writer::new(file).unwrap();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let mut m = m.unwrap();
        if m.channel.topic == "/sensors" {
            let p = runlog::proto::SensorBlock::decode(&m.data[..]).unwrap();
            let run = match p.run.as_str() {
                "tare" => "tare",
                _ => "loaded",
            };
            let frames = edit(runlog::compact::sensor_frames(&p).unwrap());
            if frames.is_empty() {
                continue;
            }
            let block = runlog::compact::SensorBlock::of_frames(run, &frames);
            m.data = runlog::proto::to_bytes(&block).into();
        }
        out.write(&m).unwrap();
    }
    out.finish().unwrap();
}

/// The messages on `topic`.
pub fn on<'a>(log: &'a [(String, serde_json::Value)], topic: &str) -> Vec<&'a serde_json::Value> {
    log.iter()
        .filter(|(t, _)| t == topic)
        .map(|(_, v)| v)
        .collect()
}

// ---------------------------------------------------------------------------------------------
// The binary under limits

/// Runs `stewart ARGS` in `dir` under a 2 GiB address-space limit, killed after a minute;
/// (exit code, -1 when killed; stderr). For refusals, which take milliseconds: a read or an
/// allocation without a bound fails the test at the limit instead of growing until the kernel
/// kills it, and a count without a bound fails it at the minute instead of running on.
pub fn stewart_limited(dir: &Path, args: &[&str]) -> (i32, String) {
    let mut child = std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2097152 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_stewart"))
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("sh runs the stewart binary");
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("the child can be waited for") {
            break Some(status);
        }
        if start.elapsed() > std::time::Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut stderr = String::new();
    if let Some(mut pipe) = child.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut pipe, &mut stderr);
    }
    (status.and_then(|s| s.code()).unwrap_or(-1), stderr)
}
