//! What the measurement commands (`simulate`, `rig`) share: their common flags, the error type
//! of every command and its exit codes, and the end of a command (table, report, log, figures).

use std::path::{Path, PathBuf};

use clap::Args;
use measure::load::{ConfigError, LoadedConfig, Overrides};
use measure::End;

/// Exit code after Ctrl-C (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: u8 = 130;
/// Exit code after a supervisor fault.
pub const EXIT_FAULT: u8 = 3;
/// Exit code when a measurement measured nothing trustworthy ([`measure::quality`]: no
/// samples used, or most rejected).
pub const EXIT_NOT_MEASURED: u8 = 4;

/// The flags of every run, whatever it measures (`rig tare` takes only these and `--out`).
#[derive(Clone, Debug, Default, Args)]
pub struct SharedArgs {
    /// Rig description / scenario TOML, laid over the embedded default (configs/default.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// 10: mass, centre of mass and inertia; 6: the paper's inertia-only model (estimator.params).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["10", "6"]))]
    pub params: Option<String>,
    /// Move along this excitation, tare run included (an `[excitation]` table, as `stewart plan --out` writes it)
    /// instead of the rig description's.
    #[arg(long, value_name = "FILE.toml")]
    pub excitation: Option<PathBuf>,
    /// MCAP log file (default: runs/<UTC time>.mcap).
    #[arg(long, value_name = "FILE.mcap")]
    pub log: Option<PathBuf>,
    /// No progress bar and no table.
    #[arg(long)]
    pub quiet: bool,
    /// Write SVG and PNG figures (estimates with ±σ, tracking error, excitation) here.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Serve the log's channels live to Foxglove (WebSocket) at IP:PORT while the run goes
    /// [default: 127.0.0.1:8765]; the log is written as well (docs/live.md).
    #[arg(long, value_name = "IP:PORT", num_args = 0..=1,
          default_missing_value = live::DEFAULT_ADDR)]
    pub live: Option<std::net::SocketAddr>,
}

/// Flags of every measurement (`simulate`, `rig`, `rig measure`): the shared ones and those of
/// a loaded run.
#[derive(Clone, Debug, Default, Args)]
pub struct MeasureArgs {
    /// Flags of every run.
    #[command(flatten)]
    pub shared: SharedArgs,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Use this saved tare (JSON) instead of a tare run.
    #[arg(long, value_name = "FILE")]
    pub tare: Option<PathBuf>,
    /// Save the measured tare (JSON) for later `--tare` runs.
    #[arg(long, value_name = "FILE")]
    pub save_tare: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Write the report as one self-contained HTML page here (results with expanded
    /// uncertainty k = 2, principal axes, budget, convergence, rig; prints on A4).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Also print the error budget: one row per error source (noise, accelerometer bias,
    /// load-cell offset, scale and crosstalk, IMU misalignment and lever arm, time skew,
    /// timestamp jitter, frame loss, leg dynamics, joint friction, geometry) with its one
    /// sigma of the mass, the centre of mass and each J_C entry, from the rig description's
    /// figures and the run's own data; the total row is the printed sigma (the rows added in
    /// quadrature).
    #[arg(long)]
    pub budget: bool,
}

impl MeasureArgs {
    /// The rig description of `--config` with `--excitation`, `--duration` and `--params`
    /// applied, validated.
    pub fn load_config(&self) -> Result<LoadedConfig, ConfigError> {
        let mut loaded = measure::load::load(self.shared.config.as_deref())?;
        if let Some(path) = &self.shared.excitation {
            loaded = loaded.with_excitation_file(path)?;
        }
        loaded.with_overrides(&Overrides {
            duration_s: self.duration,
            params: self.shared.params.as_deref().map(parse_params),
        })
    }
}

/// `--params` as the schema's value (the parser admits only "10" and "6").
pub fn parse_params(p: &str) -> measure::config::ParamCount {
    if p == "6" {
        measure::config::ParamCount::Six
    } else {
        measure::config::ParamCount::Ten
    }
}

/// The parser of `--noise`: `none`, `realistic` or `harsh` (listed in `--help`).
pub fn noise_preset() -> impl clap::builder::TypedValueParser<Value = sim::NoisePreset> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(sim::NoisePreset::ALL.map(sim::NoisePreset::name))
        .map(|name| name.parse().unwrap_or(sim::NoisePreset::Realistic))
}

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The configuration was refused before anything ran.
    #[error("{0}")]
    Config(ConfigError),
    /// An input other than the configuration (a tare file, a key, the rig's handshake) was
    /// refused before anything moved.
    #[error("{0:#}")]
    Input(anyhow::Error),
    /// The run failed (backend, log).
    #[error("{0:#}")]
    Run(anyhow::Error),
}

impl CommandError {
    /// Process exit code: 2 for refused inputs (nothing ran), 1 for a failed run.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Config(_) | Self::Input(_) => 2,
            Self::Run(_) => 1,
        }
    }
}

impl From<ConfigError> for CommandError {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

/// The session's tare: the saved tare of `--tare FILE` (checked against the design), or a tare
/// run whose controller is built and checked now, before anything moves.
pub fn tare_plan(
    loaded: &LoadedConfig,
    geometry: &kinematics::Geometry,
    tare: Option<&Path>,
) -> Result<measure::TarePlan, CommandError> {
    Ok(match tare {
        Some(path) => {
            let (base, plate) = measure::session::joints(geometry);
            let file = measure::TareFile::load(path, &base, &plate).map_err(CommandError::Input)?;
            measure::TarePlan::File(Box::new(file), path.display().to_string())
        }
        None => {
            let t = measure::setup::tare_trajectory(loaded, geometry)?;
            measure::TarePlan::Measure(Box::new(measure::setup::controller(
                loaded,
                geometry,
                t,
                measure::Measurement::Tare,
            )?))
        }
    })
}

/// A refusal of an input, in words.
pub fn refuse(message: String) -> CommandError {
    CommandError::Input(anyhow::anyhow!(message))
}

/// `--log`, or `runs/<UTC time>.mcap`.
pub fn log_path(args: &MeasureArgs, start_ns: u64) -> PathBuf {
    match &args.shared.log {
        Some(p) => p.clone(),
        None => runlog::mcap_log::default_log_path(Path::new("runs"), start_ns / 1_000_000_000),
    }
}

/// The exit code of `end`, with its message on standard error.
pub fn end_code(end: &End, fault_detail: &str) -> u8 {
    match end {
        End::Completed => 0,
        End::Interrupted => {
            eprintln!("interrupted: the platform was parked and braked; no report");
            EXIT_INTERRUPTED
        }
        End::Fault(cause) => {
            eprintln!("fault: {cause}{fault_detail}; a safe stop was commanded; no report");
            EXIT_FAULT
        }
    }
}

/// Says where `--live` serves the run (standard error, unless `quiet`): the address a Foxglove
/// client opens (docs/live.md).
pub fn announce_live(addr: Option<std::net::SocketAddr>, quiet: bool) {
    if let (Some(addr), false) = (addr, quiet) {
        eprintln!("live view: ws://{addr} (Foxglove: Open connection → Foxglove WebSocket)");
    }
}

/// Warns on standard error about each applied calibration older than the rig description's
/// `calibration.max_age_days`.
pub fn warn_old_calibrations(config: &measure::Config) {
    let now_s = runlog::run_log::unix_now_ns() / 1_000_000_000;
    for w in config.calibration.age_warnings(now_s) {
        eprintln!("warning: {w}");
    }
}
