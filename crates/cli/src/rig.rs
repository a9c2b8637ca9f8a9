//! `stewart rig`: the measurement on a rig behind the wire protocol (a real platform's I/O
//! controller, or `stewart emulate`), with the same procedure, log and report as `simulate`
//! minus the truth, plus the link's counters and the loop's timing.
//!
//! Modes: `rig` (tare run, the operator puts the payload on, loaded run), `rig tare --out FILE`
//! (tare only) and `rig measure --tare FILE` (loaded run with a saved tare; `rig --tare FILE`
//! is the same); the calibrations `rig calibrate-imu --out FILE` (the empty fixture's run) and
//! `rig calibrate-load-cells --out FILE` (tare run, the operator puts the reference weight on,
//! loaded run; docs/calibration.md). Each measurement is one session of the protocol: the tare's session ends
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

mod outcome;
mod station;

use measure::calibration::CalibrationDocument;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use clap::{Args, Subcommand};
use control::io::Backend;
use measure::load::{ConfigError, ConfigIssue, LoadedConfig};
use measure::report::RunInfo;
use measure::session::{self, SessionPlan, TarePlan};
use measure::setup;
use rig::{RigBackend, RigOptions};
use runlog::mcap_log::Delivery;
use runlog::metadata::RunMetadata;
use runlog::{LogObserver, RunLog};

use crate::common::{self, refuse, CommandError, MeasureArgs, SharedArgs};
use crate::progress::Progress;

pub use outcome::{finish, link_lines, LinkReport, RigOutcome};

use rig::link::Link;

/// The link flags of `stewart rig`.
#[derive(Clone, Debug, Default, Args)]
pub struct LinkArgs {
    /// The rig's address: udp://HOST:PORT or serial:///dev/DEVICE?baud=N [default: rig.address,
    /// udp://127.0.0.1:7700].
    #[arg(long, value_name = "ADDR")]
    pub connect: Option<String>,
    /// Shared-key file (hex), instead of rig.key_file and the user's key file
    /// ($XDG_CONFIG_HOME/stewart/rig.key, else ~/.config/stewart/rig.key).
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// No shared key: commands go untagged and anyone on the network can forge them. The rig
    /// must run without a key too (`emulate --insecure`). For isolated networks only.
    #[arg(long)]
    pub insecure: bool,
    /// Stay at normal priority: do not ask for SCHED_FIFO and locked memory.
    #[arg(long)]
    pub no_realtime: bool,
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
    /// The measurement's flags.
    #[command(flatten)]
    pub run: MeasureArgs,
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
    Measure(RigMeasureArgs),
    /// Calibrate the IMU: the empty fixture moves through the tare run's excitation and the
    /// IMU's alignment against the forward kinematics (axes, gyro scales, the accelerometer's
    /// position, the delay) is fitted and written with its uncertainty to `--out FILE`, which
    /// `[calibration] imu = "FILE"` in the rig description then applies (docs/calibration.md).
    CalibrateImu(RigTareArgs),
    /// Calibrate the load cells' gains: a tare run of the empty fixture, then the operator puts
    /// the reference weight on (`calibration.reference_mass_kg`, its certificate's sigma
    /// `reference_mass_tolerance_kg`) and confirms (`--no-prompt`: at once), then the loaded
    /// run; the gains are fitted with their covariance and written to `--out FILE`, which
    /// `[calibration] load_cells = "FILE"` in the rig description then applies
    /// (docs/calibration.md). A load-cell file the rig description names is left out of these
    /// runs; its IMU calibration is applied as in a measurement.
    CalibrateLoadCells(RigTareArgs),
}

/// `stewart rig tare`: only the flags that act on a tare run.
#[derive(Clone, Debug, Args)]
pub struct RigTareArgs {
    /// Save the tare here (JSON).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// Flags of every run.
    #[command(flatten)]
    pub shared: SharedArgs,
}

/// `stewart rig measure`: only the flags that act on a loaded run with a saved tare.
#[derive(Clone, Debug, Args)]
pub struct RigMeasureArgs {
    /// The saved tare (JSON) to subtract, from `rig tare --out FILE`.
    #[arg(long, value_name = "FILE")]
    pub tare: PathBuf,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Write the report as one self-contained HTML page here (see `stewart rig --help`).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Also print the error budget (one row per error source; see `stewart rig --help`).
    #[arg(long)]
    pub budget: bool,
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// Flags of every run.
    #[command(flatten)]
    pub shared: SharedArgs,
}

/// `stewart rig ARGS` parsed as the command line parses it (for tests and tools).
pub fn parse(args: &[&str]) -> Result<RigArgs, clap::Error> {
    use clap::Parser;
    let all = ["stewart", "rig"].iter().chain(args);
    match crate::Cli::try_parse_from(all)?.command {
        crate::Command::Rig(a) => Ok(*a),
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
    /// The empty fixture's run, fitted as the IMU calibration written to the path.
    CalibrateImu(PathBuf),
    /// Tare run, reference weight on, loaded run, fitted as the load-cell calibration written
    /// to the path.
    CalibrateLoadCells(PathBuf),
    /// Loaded run with the saved tare of `--tare`.
    MeasureOnly,
}

/// The plan and flags of `args`, or why they do not go together.
pub fn resolve(args: &RigArgs) -> Result<(Plan, RigRunArgs), CommandError> {
    let (plan, common) = match &args.mode {
        None if args.common.run.tare.is_some() => (Plan::MeasureOnly, args.common.clone()),
        None => (Plan::Both, args.common.clone()),
        Some(RigMode::Tare(t)) => (
            Plan::TareOnly(t.out.clone()),
            RigRunArgs {
                link: t.link.clone(),
                run: MeasureArgs {
                    shared: t.shared.clone(),
                    ..MeasureArgs::default()
                },
            },
        ),
        Some(RigMode::CalibrateImu(t) | RigMode::CalibrateLoadCells(t)) => (
            match &args.mode {
                Some(RigMode::CalibrateImu(_)) => Plan::CalibrateImu(t.out.clone()),
                _ => Plan::CalibrateLoadCells(t.out.clone()),
            },
            RigRunArgs {
                link: t.link.clone(),
                run: MeasureArgs {
                    shared: t.shared.clone(),
                    ..MeasureArgs::default()
                },
            },
        ),
        Some(RigMode::Measure(m)) => (
            Plan::MeasureOnly,
            RigRunArgs {
                link: m.link.clone(),
                run: MeasureArgs {
                    tare: Some(m.tare.clone()),
                    duration: m.duration,
                    report: m.report.clone(),
                    html: m.html.clone(),
                    shared: m.shared.clone(),
                    save_tare: None,
                    budget: m.budget,
                },
            },
        ),
    };
    if plan == Plan::MeasureOnly && common.run.save_tare.is_some() {
        return Err(refuse(
            "--save-tare needs a tare run; this run uses --tare".into(),
        ));
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
    let chosen = crate::key::choose(
        flags.key.as_deref(),
        rig_config.key_path(&loaded.directory()),
        crate::key::user_key_path,
        flags.insecure,
        crate::key::Side::Host,
    )?;
    if let Some(notice) = &chosen.notice {
        eprintln!("{notice}");
    }
    let key = chosen.key;
    let options = RigOptions {
        link_silence: Duration::from_secs_f64(rig_config.link_silence_ms * 1e-3),
        handshake_timeout: Duration::from_secs_f64(rig_config.handshake_timeout_s),
        key,
        require_imu: true,
        accel_position_m: Some(config.sensors.imu.position_m),
        sample_period_s: Some(1.0 / config.sensors.sample_rate_hz),
        force_limit_n: Some(config.control.max_force_n),
        ..RigOptions::default()
    };
    Ok(LinkSettings {
        address: rig_config.address,
        options,
    })
}

/// A problem with a command-line flag, blamed on the flag (not on a line of a file).
pub(crate) fn flag_issue(flag: &str, problem: String) -> ConfigIssue {
    ConfigIssue {
        file: measure::load::COMMAND_LINE_NAME.into(),
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

/// Runs `stewart rig`. `interrupt` is the Ctrl-C flag: when set, the platform parks, the log
/// is finished and the outcome says [`measure::End::Interrupted`]. A refused input or handshake
/// is an error (nothing moved); a fault is an outcome with [`measure::End::Fault`] naming the
/// cause.
pub fn rig(args: &RigArgs, interrupt: &AtomicBool) -> Result<RigOutcome, CommandError> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    rig_with_abort(args, interrupt, &NEVER)
}

/// [`rig`], and when `abort` is set (a second Ctrl-C) the rig brakes at once instead of
/// parking: the safe stop goes out within a sample period, the log is finished, and the
/// outcome says [`measure::End::Interrupted`].
pub fn rig_with_abort(
    args: &RigArgs,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<RigOutcome, CommandError> {
    let (plan, common) = resolve(args)?;
    let common = &common;
    let mut loaded = common.run.load_config()?;
    let calibrating = matches!(plan, Plan::CalibrateImu(_));
    let calibrating_cells = matches!(plan, Plan::CalibrateLoadCells(_));
    if calibrating {
        // The calibration fits the raw readings: nothing of an older calibration applied.
        loaded.config.calibration.imu = None;
        loaded.config.calibration.imu_file = None;
    } else if calibrating_cells {
        // The gains are fitted on the raw readings, against the reference's known mass.
        crate::calibrate::reference_mass_kg(&loaded)?;
        loaded.config.calibration.load_cells = None;
        loaded.config.calibration.load_cells_file = None;
    } else if loaded.config.calibration.calibrates_imu_each_run() && !common.run.shared.quiet {
        eprintln!(
            "note: calibration.measure_imu calibrates the IMU in `stewart simulate` only; on a \
             rig, run `stewart rig calibrate-imu --out FILE` once and set calibration.imu = \
             \"FILE\" (the budget counts the IMU's datasheet figures until then)"
        );
    }
    if !calibrating_cells
        && loaded.config.calibration.calibrates_load_cells_each_run()
        && !common.run.shared.quiet
    {
        eprintln!(
            "note: calibration.measure_load_cells calibrates the load cells in `stewart \
             simulate` only; on a rig, run `stewart rig calibrate-load-cells --out FILE` with the \
             reference weight and set calibration.load_cells = \"FILE\" (the budget counts the \
             cells' datasheet gains until then)"
        );
    }
    let loaded = loaded;
    let config = &loaded.config;
    crate::common::warn_old_calibrations(config);
    let link = link_settings(&loaded, &common.link)?;
    let geometry = setup::geometry(&loaded)?;
    // The controllers are built (and their trajectories checked) here, before the rig is even
    // contacted: nothing slow remains between samples once a session runs.
    let loaded_controller = if plan == Plan::MeasureOnly || plan == Plan::Both || calibrating_cells
    {
        let t = setup::trajectory(&loaded, &geometry, config.run.duration_s)?;
        Some(setup::controller(&loaded, &geometry, t)?)
    } else {
        None
    };
    let tare = common::tare_plan(&loaded, &geometry, common.run.tare.as_deref())?;

    // The handshake: refusals end here, before the log and before any command.
    let backend = RigBackend::connect(&link.address, link.options.clone())
        .map_err(|e| refuse(format!("{e}")))?;
    check_rig(backend.info(), &loaded)?;
    let rig_link = Link::start(backend);

    let start_ns = runlog::run_log::unix_now_ns();
    let log_path = common::log_path(&common.run, start_ns);
    // The log's writer thread must never stall the control loop: when it falls behind (a disk
    // that blocks), messages are dropped and counted instead.
    let live = runlog::live::serve(common.run.shared.live, runlog::live::Pace::AsRun)
        .map_err(CommandError::Input)?;
    // The live view is served from the log's writer thread: the control loop never calls it.
    let mut log = RunLog::create_live(&log_path, start_ns, Delivery::DropWhenFull, live)
        .map_err(CommandError::Run)?;
    common::announce_live(&log, common.run.shared.quiet);
    let mut runs = Vec::new();
    if matches!(tare, TarePlan::Measure(_)) {
        runs.push("tare".to_string());
    }
    if loaded_controller.is_some() {
        runs.push("loaded".to_string());
    }
    let total = match &tare {
        TarePlan::Measure(c) => measure::measurement::expected_samples(config, c.trajectory()),
        TarePlan::File(..) => 0,
    } + loaded_controller.as_ref().map_or(0, |c| {
        measure::measurement::expected_samples(config, c.trajectory())
    });
    let command = if calibrating_cells {
        "rig calibrate-load-cells"
    } else {
        "rig"
    };
    let header = log.write_metadata(&RunMetadata {
        noise: outcome::NOISE.into(),
        sample_period_s: rig_link.lock().rig.sample_period_s(),
        start_unix_ns: log.start_unix_ns(),
        runs,
        tare_file: common.run.tare.as_ref().map(|p| p.display().to_string()),
        ..RunMetadata::describing(&loaded, &geometry, command, "rig")
    });
    let save_tare = match &plan {
        Plan::TareOnly(out) => Some(out.as_path()),
        Plan::CalibrateImu(_) | Plan::CalibrateLoadCells(_) => None,
        _ => common.run.save_tare.as_deref(),
    };
    let mut progress = Progress::new(total, common.run.shared.quiet);
    let mut station = station::RigStation::new(
        &rig_link,
        &loaded,
        progress.handle(),
        (
            if calibrating_cells {
                "the reference weight (calibration.reference_mass_kg)"
            } else {
                "the payload"
            },
            common.link.no_prompt,
        ),
        abort,
    );
    let result = header.and_then(|()| {
        let mut observer =
            measure::observer::Both(LogObserver::new(&mut log, &geometry, config), &mut progress);
        session::run(
            SessionPlan {
                config: &loaded,
                geometry,
                tare,
                loaded: loaded_controller,
                save_tare,
                backend: "rig",
            },
            &mut station,
            &mut observer,
            interrupt,
        )
    });
    let (link_reports, failure) = station.into_reports();
    progress.finish();
    if !matches!(result, Ok(ref o) if o.end == measure::End::Completed) {
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
    // The rig is braked and the link closed before anything else can fail: the fits below
    // are the host's work alone.
    let (info, link_total) = rig_link.close();
    let outcome = result.map_err(CommandError::Run)?;
    finished.map_err(CommandError::Run)?;
    let completed = outcome.end == measure::End::Completed;
    let calibration = match &plan {
        Plan::CalibrateImu(path) if completed => {
            let file =
                crate::calibrate::imu_calibration(&outcome, &loaded, "rig", start_ns, &log_path)
                    .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Some(file)
        }
        _ => None,
    };
    let load_cell_calibration = match &plan {
        Plan::CalibrateLoadCells(path) if completed => {
            let file = crate::calibrate::load_cell_calibration(
                &outcome, &loaded, "rig", start_ns, &log_path,
            )
            .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Some(file)
        }
        _ => None,
    };
    // A calibration measures no payload: the reference's run is in the log, not reported.
    let report = outcome
        .report(
            config,
            RunInfo {
                config: loaded.source.clone(),
                seed: 0,
                noise: outcome::NOISE.into(),
                params: config.estimator.params.into(),
                log: Some(log_path.display().to_string()),
                backend: "rig".into(),
                tool: measure::calibration::tool(),
                calibrations: config.calibration.applied(),
            },
            None,
        )
        .filter(|_| !calibrating_cells);
    Ok(RigOutcome {
        report,
        log_path,
        end: outcome.end.clone(),
        tare: outcome.measured_tare().cloned(),
        link: link_reports,
        failure,
        rig: info,
        link_total,
        calibration,
        load_cell_calibration,
    })
}

/// `stewart rig` from the command line: runs, prints, writes the report; returns the exit
/// code (0 done, 1 failed, 2 refused before anything moved, 3 fault, 130 interrupted).
pub fn main(args: &RigArgs, interrupt: &AtomicBool, abort: &AtomicBool) -> u8 {
    if let Ok((_, common)) = resolve(args) {
        if !common.link.no_realtime {
            // On this (the loop's) thread, before the log writer and the heartbeat start.
            let granted = rig::realtime::request();
            match granted.refusal_line() {
                Some(line) => eprintln!("warning: {line}"),
                None if !common.run.shared.quiet => eprintln!("{}", granted.granted_line()),
                None => {}
            }
        }
    }
    match rig_with_abort(args, interrupt, abort) {
        Ok(outcome) => outcome::finish(args, &outcome),
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
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
        assert!(resolve(&a).unwrap().1.run.shared.quiet);
        assert_eq!(
            resolve(&a).unwrap().0,
            Plan::TareOnly(PathBuf::from("t.json"))
        );
        let a = parse(&["measure", "--tare", "t.json", "--report", "r.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, Plan::MeasureOnly);
        let a = parse(&["--tare", "t.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, Plan::MeasureOnly);
        let a = parse(&["calibrate-load-cells", "--out", "c.toml", "--no-prompt"]).unwrap();
        let (plan, c) = resolve(&a).unwrap();
        assert_eq!(plan, Plan::CalibrateLoadCells(PathBuf::from("c.toml")));
        assert!(c.link.no_prompt);
        assert!(
            parse(&["calibrate-load-cells"]).is_err(),
            "--out is required"
        );
        assert!(parse(&["calibrate-load-cells", "--out", "c", "--tare", "t"]).is_err());
    }

    #[test]
    fn contradictions_are_refused_by_name() {
        let message = |args: &[&str]| match resolve(&parse(args).unwrap()) {
            Err(e) => e.to_string(),
            Ok(_) => String::new(),
        };
        assert!(message(&["--tare", "t", "--save-tare", "s"]).contains("--save-tare"));
        // Flags that would not act are not offered: `rig measure` needs its tare, `rig tare`
        // takes no tare, no report and no loaded-run duration.
        assert!(parse(&["measure"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--tare", "x"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--report", "r"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--duration", "5"]).is_err());
        assert!(parse(&["measure", "--tare", "t", "--save-tare", "s"]).is_err());
        // The simulator's flags are not the rig's: `rig --help` does not offer them.
        assert!(parse(&["--seed", "3"]).is_err());
        assert!(parse(&["measure", "--tare", "t", "--noise", "harsh"]).is_err());
        assert!(parse(&["--runs", "3"]).is_err());
        assert!(parse(&["tare"]).is_err(), "--out is required");
        assert!(parse(&["--duration", "5", "tare", "--out", "t"]).is_err());
    }
}
