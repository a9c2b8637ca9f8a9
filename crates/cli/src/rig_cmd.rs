//! `stewart rig`: the measurement on a rig behind the wire protocol (a real platform's I/O
//! controller, or `stewart emulate`), with the same procedure, log and report as `simulate`
//! minus the truth, plus the link's counters and the loop's timing.
//!
//! Modes: `rig` (tare run, the operator puts the payload on, loaded run), `rig tare --out FILE`
//! (tare only) and `rig measure --tare FILE` (loaded run with a saved tare; `rig --tare FILE`
//! is the same). Each measurement is one session of the protocol: the tare's session ends
//! braked, and the loaded run opens a new one once the operator confirms the payload is on.
//!
//! Before anything moves: the configuration, the trajectories, the tare file and the key are
//! checked, then the handshake (protocol version, sensor layout, sample period, accelerometer
//! position, and the rig's stroke and speed limits against the configuration). After that,
//! any link silence longer than `rig.link_silence_ms`, an invalid sensor value, a fault
//! reported by the rig or a supervisor limit ends the measurement with a safe stop, a message
//! naming the cause, the log finished, and exit code 3. Ctrl-C parks, finishes the log and
//! exits with 130. Commands are clamped to the tighter of the rig's force limits and
//! `control.max_force_n` whatever the controller computes.

pub mod link;
mod outcome;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::anyhow;
use clap::{Args, Subcommand};
use control::controller::Controller;
use control::io::Backend;
use rig::{Key, RigBackend, RigOptions};
use serde::{Deserialize, Serialize};

use crate::args::RunArgs;
use crate::config_load::{ConfigError, ConfigIssue, LoadedConfig, DEFAULT_CONFIG_NAME};
use crate::foxglove::SceneGeometry;
use crate::log_messages::{self as topics, SupervisorMsg};
use crate::mcap_log::{default_log_path, Delivery};
use crate::metadata::RunMetadata;
use crate::preflight::{self, Measurement};
use crate::run::{self, End, Hooks, MeasureOutcome, MeasureSetup};
use crate::run_log::RunLog;
use crate::simulate::{self, CommandError};
use crate::tare::TareFile;

pub use outcome::{finish, link_lines, LinkReport, RigOutcome};

use link::{Failure, Link, LinkCounters, LinkMsg, LoopTiming, Monitored, TimingSummary, LINK};

/// Where `stewart rig` looks for the rig and `stewart emulate` listens, unless the
/// configuration's `rig.address` or `--connect`/`--listen` say otherwise.
pub const DEFAULT_ADDRESS: &str = "udp://127.0.0.1:7700";

/// The `[rig]` table of the scenario file: the link to the rig. Every key is optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigLinkConfig {
    /// The rig's address: `udp://HOST:PORT` or `serial:///dev/DEVICE?baud=N`.
    pub address: String,
    /// File holding the shared key in hex (HMAC-SHA256 on every frame, docs/protocol.md
    /// section 3), relative to the scenario file; absent: no key.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub key_file: Option<String>,
    /// The host faults when no valid sensor frame arrived for this long, ms.
    pub link_silence_ms: f64,
    /// The emulator brakes when no valid command arrived for this long, ms (a real rig sends
    /// its own in the handshake).
    pub watchdog_ms: f64,
    /// How long the host tries the handshake, s.
    pub handshake_timeout_s: f64,
}

impl Default for RigLinkConfig {
    fn default() -> Self {
        Self {
            address: DEFAULT_ADDRESS.into(),
            key_file: None,
            link_silence_ms: 50.0,
            watchdog_ms: 20.0,
            handshake_timeout_s: 2.0,
        }
    }
}

impl RigLinkConfig {
    /// Range problems as (key, problem), like [`crate::validate::validate`].
    pub fn problems(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let mut check = |key: &str, value: f64, min: f64, max: f64, unit: &str| {
            if !(value.is_finite() && value >= min && value <= max) {
                out.push((
                    format!("rig.{key}"),
                    format!("must be between {min} and {max} {unit}, got {value}"),
                ));
            }
        };
        check("link_silence_ms", self.link_silence_ms, 1.0, 10_000.0, "ms");
        check("watchdog_ms", self.watchdog_ms, 1.0, 10_000.0, "ms");
        check(
            "handshake_timeout_s",
            self.handshake_timeout_s,
            0.1,
            600.0,
            "s",
        );
        if let Err(e) = self.address.parse::<rig::transport::Address>() {
            out.push(("rig.address".into(), e.to_string()));
        }
        out
    }

    /// The key file, relative paths taken from the scenario file's directory (`source`, the
    /// name [`LoadedConfig::source`] gives; the working directory for the embedded default).
    pub fn key_path(&self, source: &str) -> Option<PathBuf> {
        let file = Path::new(self.key_file.as_ref()?);
        if file.is_absolute() || source == DEFAULT_CONFIG_NAME {
            return Some(file.to_path_buf());
        }
        let dir = Path::new(source).parent().unwrap_or(Path::new(""));
        Some(dir.join(file))
    }
}

/// The link flags of `stewart rig`.
#[derive(Clone, Debug, Default, Args)]
pub struct LinkArgs {
    /// The rig's address: udp://HOST:PORT or serial:///dev/DEVICE?baud=N [default: rig.address,
    /// udp://127.0.0.1:7700].
    #[arg(long, value_name = "ADDR")]
    pub connect: Option<String>,
    /// Shared-key file (hex), instead of rig.key_file.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Fault when no valid sensor frame arrived for this long, ms (rig.link_silence_ms,
    /// default 50).
    #[arg(long, value_name = "MS")]
    pub link_silence_ms: Option<f64>,
    /// Start the loaded run right after the tare run, without waiting for the operator to put
    /// the payload on and press Enter (scripts, the emulator).
    #[arg(long)]
    pub no_prompt: bool,
}

/// Link and run flags, accepted by `rig`, `rig tare` and `rig measure`.
#[derive(Clone, Debug, Default, Args)]
pub struct RigRunArgs {
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// The run flags shared with `simulate`.
    #[command(flatten)]
    pub run: RunArgs,
}

/// `stewart rig`.
#[derive(Clone, Debug, Default, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct RigArgs {
    /// Tare only or measurement only; without one: tare run, payload on, loaded run.
    #[command(subcommand)]
    pub mode: Option<RigMode>,
    /// Flags of the two-run mode.
    #[command(flatten)]
    pub common: RigRunArgs,
}

/// The single-run modes of `stewart rig`.
#[derive(Clone, Debug, Subcommand)]
pub enum RigMode {
    /// Measure the empty fixture (tare) and save it for `rig measure --tare FILE`.
    Tare(RigTareArgs),
    /// Measure the payload, subtracting a saved tare (`--tare FILE`, required).
    Measure(RigRunArgs),
}

/// `stewart rig tare`.
#[derive(Clone, Debug, Args)]
pub struct RigTareArgs {
    /// Save the tare here (JSON).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Link and run flags.
    #[command(flatten)]
    pub common: RigRunArgs,
}

/// `stewart rig ARGS` parsed as the command line parses it (for tests and tools).
pub fn parse(args: &[&str]) -> Result<RigArgs, clap::Error> {
    use clap::Parser;
    let all = ["stewart", "rig"].iter().chain(args);
    match crate::args::Cli::try_parse_from(all)?.command {
        crate::args::Command::Rig(a) => Ok(*a),
        _ => Err(clap::Error::raw(
            clap::error::ErrorKind::InvalidSubcommand,
            "not a rig command",
        )),
    }
}

/// What a `stewart rig` invocation will do.
#[derive(Clone, Debug, PartialEq)]
pub enum Plan {
    /// Tare run, payload on, loaded run.
    Both,
    /// Tare run only, saved to the path.
    TareOnly(PathBuf),
    /// Loaded run with the saved tare of `--tare`.
    MeasureOnly,
}

fn refuse(message: String) -> CommandError {
    CommandError::Input(anyhow!(message))
}

/// The plan and flags of `args`, or why they do not go together.
pub fn resolve(args: &RigArgs) -> Result<(Plan, &RigRunArgs), CommandError> {
    let (plan, common) = match &args.mode {
        None if args.common.run.tare.is_some() => (Plan::MeasureOnly, &args.common),
        None => (Plan::Both, &args.common),
        Some(RigMode::Tare(t)) => (Plan::TareOnly(t.out.clone()), &t.common),
        Some(RigMode::Measure(m)) => (Plan::MeasureOnly, m),
    };
    let run = &common.run;
    if run.seed.is_some() || run.noise.is_some() {
        return Err(refuse(
            "--seed and --noise configure the simulator, not a rig: give them to `stewart emulate`"
                .into(),
        ));
    }
    match &plan {
        Plan::TareOnly(_) => {
            if run.tare.is_some() {
                return Err(refuse(
                    "`rig tare` measures the tare: --tare does not apply".into(),
                ));
            }
            if run.save_tare.is_some() {
                return Err(refuse(
                    "`rig tare` saves the tare with --out: drop --save-tare".into(),
                ));
            }
            if run.report.is_some() {
                return Err(refuse(
                    "`rig tare` writes its result with --out; --report belongs to a measurement"
                        .into(),
                ));
            }
        }
        Plan::MeasureOnly if run.tare.is_none() => {
            return Err(refuse(
                "`rig measure` needs --tare FILE (saved by `rig tare --out FILE`)".into(),
            ))
        }
        Plan::MeasureOnly if run.save_tare.is_some() => {
            return Err(refuse(
                "--save-tare needs a tare run; this run uses --tare".into(),
            ))
        }
        _ => {}
    }
    Ok((plan, common))
}

/// The link settings of a run: the address and the host's options.
#[derive(Clone, Debug)]
pub struct LinkSettings {
    /// The rig's address.
    pub address: String,
    /// The host's options (key loaded).
    pub options: RigOptions,
}

/// The `[rig]` table with the flags applied, checked, and the key read.
pub fn link_settings(
    loaded: &LoadedConfig,
    flags: &LinkArgs,
) -> Result<LinkSettings, CommandError> {
    let config = &loaded.config;
    let mut rig_config = config.rig.clone();
    let mut issues = Vec::new();
    if let Some(address) = &flags.connect {
        if let Err(e) = address.parse::<rig::transport::Address>() {
            issues.push(flag_issue("--connect", e.to_string()));
        }
        rig_config.address = address.clone();
    }
    if let Some(ms) = flags.link_silence_ms {
        if !(ms.is_finite() && (1.0..=10_000.0).contains(&ms)) {
            issues.push(flag_issue(
                "--link-silence-ms",
                format!("must be between 1 and 10000 ms, got {ms}"),
            ));
        }
        rig_config.link_silence_ms = ms;
    }
    if issues.is_empty() {
        issues.extend(
            rig_config
                .problems()
                .into_iter()
                .map(|(key, problem)| loaded.issue(&key, problem)),
        );
    }
    if !issues.is_empty() {
        return Err(CommandError::Config(ConfigError { issues }));
    }
    let key_path = match &flags.key {
        Some(path) => Some(path.clone()),
        None => rig_config.key_path(&loaded.source),
    };
    let key = match key_path {
        Some(path) => Some(Key::from_file(&path).map_err(|e| refuse(format!("shared key: {e}")))?),
        None => None,
    };
    let options = RigOptions {
        link_silence: Duration::from_secs_f64(rig_config.link_silence_ms * 1e-3),
        handshake_timeout: Duration::from_secs_f64(rig_config.handshake_timeout_s),
        key,
        require_imu: true,
        accel_position_m: Some(config.sensors.imu_position_m),
        sample_period_s: Some(1.0 / config.sensors.sample_rate_hz),
        force_limit_n: Some(config.control.max_force_n),
        ..RigOptions::default()
    };
    Ok(LinkSettings {
        address: rig_config.address,
        options,
    })
}

fn flag_issue(flag: &str, problem: String) -> ConfigIssue {
    ConfigIssue {
        file: crate::config_load::COMMAND_LINE_NAME.into(),
        line: None,
        key: flag.into(),
        problem,
    }
}

/// Refuses a rig whose limits do not fit the configuration the trajectories were checked
/// against (before any command is sent).
pub fn check_rig(info: &rig::host::RigInfo, loaded: &LoadedConfig) -> Result<(), CommandError> {
    let c = &loaded.config;
    let l = &info.limits;
    let (min_m, max_m) = (c.platform.min_leg_length_m, c.platform.max_leg_length_m);
    if (l.stroke_min_m - min_m).abs() > 1e-3 || (l.stroke_max_m - max_m).abs() > 1e-3 {
        return Err(refuse(format!(
            "rig layout mismatch: the rig's legs stroke from {} to {} m, the configuration's \
             from {min_m} to {max_m} m (platform.min_leg_length_m, platform.max_leg_length_m); \
             refusing the session",
            l.stroke_min_m, l.stroke_max_m
        )));
    }
    let speed = c.excitation.max_leg_speed_m_s;
    if l.speed_max_m_s < speed {
        return Err(refuse(format!(
            "rig layout mismatch: the excitation may move a leg at {speed} m/s \
             (excitation.max_leg_speed_m_s) but the rig allows {} m/s; refusing the session",
            l.speed_max_m_s
        )));
    }
    Ok(())
}

fn rename_duration(mut e: ConfigError, key: &str) -> ConfigError {
    for issue in &mut e.issues {
        if issue.key == "run.duration_s" {
            issue.key = key.to_string();
        }
    }
    e
}

fn progress_bar(total: u64, quiet: bool) -> indicatif::ProgressBar {
    use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(10));
    if let Ok(style) =
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
    {
        bar.set_style(style);
    }
    bar
}

fn unix_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// Runs `stewart rig`. `interrupt` is the Ctrl-C flag: when set, the platform parks, the log
/// is finished and the outcome says [`End::Interrupted`]. A refused input or handshake is an
/// error (nothing moved); a fault is an outcome with [`End::Fault`] naming the cause.
pub fn rig(args: &RigArgs, interrupt: &AtomicBool) -> Result<RigOutcome, CommandError> {
    let (plan, common) = resolve(args)?;
    let loaded = simulate::load_config(&common.run)?;
    let config = &loaded.config;
    let link = link_settings(&loaded, &common.link)?;
    let geometry = preflight::geometry(&loaded)?;
    // The controllers are built (and their trajectories checked) here, before the rig is even
    // contacted: nothing slow remains between samples once a session runs.
    let loaded_controller = if plan == Plan::MeasureOnly || plan == Plan::Both {
        let t = preflight::trajectory(&loaded, &geometry, config.run.duration_s)?;
        Some(preflight::controller(&loaded, &geometry, t)?)
    } else {
        None
    };
    let (base_joints, plate_joints) = outcome::joints(&geometry);
    let tare_file = match &common.run.tare {
        Some(path) => {
            Some(TareFile::load(path, &base_joints, &plate_joints).map_err(CommandError::Input)?)
        }
        None => None,
    };
    let tare_controller = if tare_file.is_none() {
        let t = preflight::trajectory(&loaded, &geometry, config.run.tare_duration_s)
            .map_err(|e| rename_duration(e, "run.tare_duration_s"))?;
        Some(preflight::controller(&loaded, &geometry, t)?)
    } else {
        None
    };

    // The handshake: refusals end here, before the log and before any command.
    let backend = RigBackend::connect(&link.address, link.options.clone())
        .map_err(|e| refuse(format!("{e}")))?;
    check_rig(backend.info(), &loaded)?;
    let rig_link = Link::start(backend);

    let start_ns = unix_ns();
    let log_path = match &common.run.log {
        Some(p) => p.clone(),
        None => default_log_path(Path::new("runs"), start_ns / 1_000_000_000),
    };
    // The log's writer thread must never stall the control loop: when it falls behind (a disk
    // that blocks), messages are dropped and counted instead.
    let mut log = RunLog::create_with(&log_path, start_ns, Delivery::DropWhenFull)
        .map_err(CommandError::Run)?;
    let mut state = Session {
        common,
        plan: &plan,
        loaded: &loaded,
        geometry,
        link: &rig_link,
        log: &mut log,
        interrupt,
        produced: outcome::Produced::default(),
    };
    let result = state.run(tare_file, tare_controller, loaded_controller);
    let produced = std::mem::take(&mut state.produced);
    if !matches!(produced.end, Some(End::Completed)) || result.is_err() {
        // Whatever happened, leave the rig braked.
        let _ = rig_link.lock().safe_stop();
    }
    let dropped = log.dropped();
    let finished = log.finish();
    if dropped > 0 {
        eprintln!(
            "warning: the log's writer fell behind; {dropped} log messages were dropped rather \
             than stall the control loop (the gaps show in the MCAP sequence numbers)"
        );
    }
    result.map_err(CommandError::Run)?;
    finished.map_err(CommandError::Run)?;
    let info = rig_link.lock().rig.info().clone();
    Ok(produced.into_outcome(log_path, info))
}

/// The state of one `stewart rig` run once the rig answered.
struct Session<'a> {
    common: &'a RigRunArgs,
    plan: &'a Plan,
    loaded: &'a LoadedConfig,
    geometry: kinematics::Geometry,
    link: &'a Link,
    log: &'a mut RunLog,
    interrupt: &'a AtomicBool,
    produced: outcome::Produced,
}

/// One measurement's result on the rig.
struct Measured {
    outcome: Option<MeasureOutcome>,
    end: End,
}

impl Session<'_> {
    fn run(
        &mut self,
        tare_file: Option<TareFile>,
        tare_controller: Option<Controller>,
        loaded_controller: Option<Controller>,
    ) -> anyhow::Result<()> {
        let config = &self.loaded.config;
        let (base_joints, plate_joints) = outcome::joints(&self.geometry);
        let stroke = self.geometry.stroke();
        let mut runs = Vec::new();
        if tare_controller.is_some() {
            runs.push("tare".to_string());
        }
        if loaded_controller.is_some() {
            runs.push("loaded".to_string());
        }
        self.log.write_now(
            topics::METADATA,
            &RunMetadata {
                tool_version: env!("CARGO_PKG_VERSION").into(),
                command: "rig".into(),
                backend: "rig".into(),
                config_source: self.loaded.source.clone(),
                config_text: self.loaded.text.clone(),
                config_toml: self.loaded.effective_toml(),
                seed: config.run.seed,
                noise: outcome::NOISE.into(),
                params: config.estimator.params.into(),
                sample_period_s: self.link.lock().rig.sample_period_s(),
                start_unix_ns: self.log.start_unix_ns(),
                runs,
                tare_file: self
                    .common
                    .run
                    .tare
                    .as_ref()
                    .map(|p| p.display().to_string()),
                base_joints_m: base_joints,
                plate_joints_m: plate_joints,
                stroke_m: [stroke.min_length_m, stroke.max_length_m],
            },
        )?;
        let scene = SceneGeometry {
            base_joints_m: *self.geometry.base_joints_m(),
            plate_joints_m: *self.geometry.plate_joints_m(),
            base_radius_m: config.platform.base_radius_m,
            plate_radius_m: config.platform.plate_radius_m,
            force_scale_n: config.control.max_force_n,
        };
        let total = tare_controller
            .as_ref()
            .map_or(0, |c| run::expected_samples(config, c.trajectory()))
            + loaded_controller
                .as_ref()
                .map_or(0, |c| run::expected_samples(config, c.trajectory()));
        let progress = progress_bar(total, self.common.run.quiet);
        let mut command_sequence = 0u64;

        let tare = match (tare_file, tare_controller) {
            (Some(file), _) => {
                self.log.write_now(topics::TARE, &file)?;
                outcome::TareSource::File(file)
            }
            (None, Some(controller)) => {
                let m = self.measure(
                    Measurement::Tare,
                    controller,
                    None,
                    &scene,
                    &progress,
                    &mut command_sequence,
                )?;
                if m.end != End::Completed {
                    progress.finish_and_clear();
                    self.produced.end = Some(m.end);
                    return Ok(());
                }
                let tare_outcome = m
                    .outcome
                    .ok_or_else(|| anyhow!("the tare run produced no estimate"))?;
                let estimate = tare_outcome
                    .estimate
                    .as_ref()
                    .ok_or_else(|| anyhow!("the tare run produced no estimate"))?;
                // Its bias effects go with it, to the loaded run's report and the tare file.
                let effects = outcome::TareEffects::of(&tare_outcome);
                let file = outcome::tare_file_of(
                    estimate,
                    &effects,
                    self.loaded,
                    &base_joints,
                    &plate_joints,
                );
                self.log.write_now(topics::TARE, &file)?;
                let save = match self.plan {
                    Plan::TareOnly(out) => Some(out),
                    _ => self.common.run.save_tare.as_ref(),
                };
                if let Some(path) = save {
                    file.save(path)?;
                }
                self.produced.tare = Some(file.clone());
                outcome::TareSource::Measured(file, Box::new(effects))
            }
            (None, None) => return Err(anyhow!("neither a tare file nor a tare run")),
        };
        let Some(loaded_controller) = loaded_controller else {
            progress.finish_and_clear();
            self.produced.end = Some(End::Completed);
            return Ok(());
        };

        if matches!(tare, outcome::TareSource::Measured(..)) {
            // The tare's session ends braked; the payload goes on; a new session begins.
            self.link.lock().safe_stop()?;
            let confirmed = progress
                .suspend(|| operator_loads_payload(self.common.link.no_prompt, self.interrupt))?;
            if !confirmed {
                progress.finish_and_clear();
                self.produced.end = Some(End::Interrupted);
                return Ok(());
            }
            let mut held = self.link.lock();
            held.rig
                .restart_session()
                .map_err(|e| anyhow!("cannot open the loaded run's session: {e}"))?;
            check_rig(held.rig.info(), self.loaded).map_err(|e| anyhow!("{e}"))?;
        }

        let tare_params = (tare.file().parameters(), tare.file().covariance_matrix());
        let m = self.measure(
            Measurement::Loaded,
            loaded_controller,
            Some(tare_params),
            &scene,
            &progress,
            &mut command_sequence,
        )?;
        progress.finish_and_clear();
        self.produced.end = Some(m.end.clone());
        if m.end != End::Completed {
            return Ok(());
        }
        let outcome = m
            .outcome
            .ok_or_else(|| anyhow!("the loaded run produced no outcome"))?;
        let report = outcome::build_report(
            &self.common.run,
            self.loaded,
            &outcome,
            &tare,
            &tare_params,
            self.log,
        )?;
        self.produced.report = Some(report);
        Ok(())
    }

    /// One measurement in the current session: the run procedure on the monitored backend,
    /// then the link record (and the fault, when the link or the rig ended it).
    fn measure(
        &mut self,
        measurement: Measurement,
        controller: Controller,
        tare: Option<(
            estimator::InertialParameters,
            estimator::ParameterCovariance,
        )>,
        scene: &SceneGeometry,
        progress: &indicatif::ProgressBar,
        command_sequence: &mut u64,
    ) -> anyhow::Result<Measured> {
        let run_name = measurement.name();
        let (info, before) = {
            let held = self.link.lock();
            (held.rig.info().clone(), *held.rig.stats())
        };
        self.log.write_now(
            LINK,
            &LinkMsg {
                run: run_name,
                time_s: 0.0,
                event: "session",
                address: info.address.clone(),
                identity: info.identity.clone(),
                session_id: info.session_id,
                counters: LinkCounters::default(),
                timing: None,
                log_dropped: self.log.dropped(),
                fault: None,
            },
        )?;
        let mut timing = LoopTiming::default();
        let (result, failure, last_time_s) = {
            let mut monitored = Monitored::new(self.link, &mut timing);
            let result = run::measure_with(
                &mut monitored,
                &MeasureSetup {
                    config: &self.loaded.config,
                    geometry: self.geometry,
                    measurement,
                    trajectory: *controller.trajectory(),
                    tare,
                },
                controller,
                &mut Hooks {
                    log: self.log,
                    progress,
                    interrupt: self.interrupt,
                    scene,
                    command_sequence,
                },
            );
            (
                result,
                monitored.failure().cloned(),
                monitored.last_time_s(),
            )
        };
        let (counters, period_s) = {
            let held = self.link.lock();
            (
                LinkCounters::from(held.rig.stats().since(&before)),
                held.rig.sample_period_s(),
            )
        };
        let summary = timing.summary(period_s);
        let (outcome, end) = match result {
            Ok(o) => {
                let end = o.end.clone();
                (Some(o), end)
            }
            // The link, the sensors or the rig failed: the backend has sent a safe stop.
            Err(e) => match &failure {
                Some(f) => (None, End::Fault(f.cause.clone())),
                None => {
                    let _ = self.link.lock().safe_stop();
                    return Err(e);
                }
            },
        };
        if end != End::Completed {
            self.link.lock().safe_stop()?;
        }
        let time_s = last_time_s.unwrap_or(0.0);
        if let (Some(f), End::Fault(cause)) = (&failure, &end) {
            self.log.write(
                topics::SUPERVISOR,
                time_s,
                &SupervisorMsg {
                    run: run_name,
                    time_s,
                    phase: "fault".into(),
                    fault: Some(cause.clone()),
                    clamped: false,
                    interrupted: self.interrupt.load(Ordering::SeqCst),
                },
            )?;
            self.produced.failure = Some(f.clone());
        }
        self.log.write(
            LINK,
            time_s,
            &LinkMsg {
                run: run_name,
                time_s,
                event: "end",
                address: info.address,
                identity: info.identity,
                session_id: info.session_id,
                counters,
                timing: Some(summary),
                log_dropped: self.log.dropped(),
                fault: match &end {
                    End::Fault(cause) => Some(cause.clone()),
                    _ => None,
                },
            },
        )?;
        self.log.flush()?;
        self.produced.link.push(outcome::LinkReport {
            run: run_name.to_string(),
            counters,
            timing: summary,
        });
        Ok(Measured { outcome, end })
    }
}

/// Between the tare and the loaded run: asks the operator to put the payload on and waits for
/// Enter (or goes straight on with `no_prompt`). `Ok(false)`: Ctrl-C while waiting.
fn operator_loads_payload(no_prompt: bool, interrupt: &AtomicBool) -> anyhow::Result<bool> {
    if no_prompt {
        return Ok(!interrupt.load(Ordering::SeqCst));
    }
    eprintln!(
        "tare done; the platform is braked. Put the payload on the fixture, then press Enter \
         (Ctrl-C stops here)."
    );
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let read = std::io::stdin().read_line(&mut line);
        let _ = tx.send(read.map(|n| n > 0));
    });
    loop {
        if interrupt.load(Ordering::SeqCst) {
            return Ok(false);
        }
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(Ok(true)) => return Ok(true),
            Ok(Ok(false)) | Ok(Err(_)) | Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(anyhow!(
                    "no operator on standard input to confirm that the payload is on; \
                     pass --no-prompt to start the loaded run right after the tare"
                ))
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
        }
    }
}

/// `stewart rig` from the command line: runs, prints, writes the report; returns the exit
/// code (0 done, 1 failed, 2 refused before anything moved, 3 fault, 130 interrupted).
pub fn main(args: &RigArgs, interrupt: &AtomicBool) -> u8 {
    match rig(args, interrupt) {
        Ok(outcome) => outcome::finish(args, &outcome),
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

/// Failures seen by the host, for callers that time them.
pub fn failure_of(outcome: &RigOutcome) -> Option<&Failure> {
    outcome.failure.as_ref()
}

/// The timing summary of measurement `run` (`"tare"` or `"loaded"`).
pub fn timing_of<'a>(outcome: &'a RigOutcome, run: &str) -> Option<&'a TimingSummary> {
    outcome
        .link
        .iter()
        .find(|l| l.run == run)
        .map(|l| &l.timing)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        rig: RigArgs,
    }

    fn parse(args: &[&str]) -> Result<RigArgs, clap::Error> {
        let mut all = vec!["rig"];
        all.extend_from_slice(args);
        Cli::try_parse_from(all).map(|c| c.rig)
    }

    #[test]
    fn modes_and_flags_parse() {
        let a = parse(&[]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, Plan::Both);
        let a = parse(&[
            "--connect",
            "udp://10.0.0.2:7700",
            "--duration",
            "5",
            "--no-prompt",
        ])
        .unwrap();
        let (plan, c) = resolve(&a).unwrap();
        assert_eq!(plan, Plan::Both);
        assert_eq!(c.link.connect.as_deref(), Some("udp://10.0.0.2:7700"));
        assert!(c.link.no_prompt);
        assert_eq!(c.run.duration, Some(5.0));
        let a = parse(&["tare", "--out", "t.json", "--quiet"]).unwrap();
        assert_eq!(
            resolve(&a).unwrap().0,
            Plan::TareOnly(PathBuf::from("t.json"))
        );
        let a = parse(&["measure", "--tare", "t.json", "--report", "r.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, Plan::MeasureOnly);
        let a = parse(&["--tare", "t.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, Plan::MeasureOnly);
    }

    #[test]
    fn contradictions_are_refused_by_name() {
        let message = |args: &[&str]| match resolve(&parse(args).unwrap()) {
            Err(e) => e.to_string(),
            Ok(_) => String::new(),
        };
        assert!(message(&["measure"]).contains("--tare FILE"));
        assert!(message(&["tare", "--out", "t", "--tare", "x"]).contains("--tare does not apply"));
        assert!(message(&["tare", "--out", "t", "--report", "r"]).contains("--report"));
        assert!(message(&["--seed", "3"]).contains("stewart emulate"));
        assert!(
            message(&["measure", "--tare", "t", "--noise", "harsh"]).contains("stewart emulate")
        );
        assert!(parse(&["tare"]).is_err(), "--out is required");
        assert!(parse(&["--duration", "5", "tare", "--out", "t"]).is_err());
    }

    #[test]
    fn link_config_defaults_and_ranges() {
        let c = RigLinkConfig::default();
        assert!(c.problems().is_empty());
        assert_eq!(c.address, DEFAULT_ADDRESS);
        let bad = RigLinkConfig {
            link_silence_ms: 0.0,
            address: "tcp://x:1".into(),
            ..RigLinkConfig::default()
        };
        let keys: Vec<String> = bad.problems().into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["rig.link_silence_ms", "rig.address"]);
    }

    #[test]
    fn key_files_are_found_next_to_the_scenario() {
        let c = RigLinkConfig {
            key_file: Some("rig.key".into()),
            ..RigLinkConfig::default()
        };
        assert_eq!(
            c.key_path("configs/lab.toml"),
            Some(PathBuf::from("configs/rig.key"))
        );
        assert_eq!(c.key_path("lab.toml"), Some(PathBuf::from("rig.key")));
        assert_eq!(
            c.key_path(DEFAULT_CONFIG_NAME),
            Some(PathBuf::from("rig.key"))
        );
        let abs = RigLinkConfig {
            key_file: Some("/etc/rig.key".into()),
            ..RigLinkConfig::default()
        };
        assert_eq!(
            abs.key_path("configs/lab.toml"),
            Some(PathBuf::from("/etc/rig.key"))
        );
        assert_eq!(RigLinkConfig::default().key_path("x.toml"), None);
    }
}
