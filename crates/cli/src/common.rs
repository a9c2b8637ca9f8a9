//! What the measurement commands (`simulate`, `rig`) share: their common flags, the error type
//! of every command and its exit codes, and the end of a command (table, report, log, figures).

use std::path::PathBuf;

use clap::Args;
use measure::End;
use rig_description::load::{ConfigError, LoadedConfig};

pub use ops::exit::{
    FAULT as EXIT_FAULT, INTERRUPTED as EXIT_INTERRUPTED, NOT_MEASURED as EXIT_NOT_MEASURED,
};

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
    /// The measurement's options: the flags that act on the run (not on what is printed).
    pub fn options(&self) -> ops::measurement::MeasureOptions {
        ops::measurement::MeasureOptions {
            config: self.shared.config.clone(),
            params: self.shared.params.as_deref().map(parse_params),
            excitation: self.shared.excitation.clone(),
            duration_s: self.duration,
            log: self.shared.log.clone(),
            live: self.shared.live,
            tare: self.tare.clone(),
            save_tare: self.save_tare.clone(),
        }
    }

    /// The rig description of `--config` with `--excitation`, `--duration` and `--params`
    /// applied, validated.
    pub fn load_config(&self) -> Result<LoadedConfig, ConfigError> {
        self.options().load_config()
    }
}

/// `--params` as the schema's value (the parser admits only "10" and "6").
pub fn parse_params(p: &str) -> rig_description::config::ParamCount {
    if p == "6" {
        rig_description::config::ParamCount::Six
    } else {
        rig_description::config::ParamCount::Ten
    }
}

/// The parser of `--noise`: `none`, `realistic` or `harsh` (listed in `--help`).
pub fn noise_preset() -> impl clap::builder::TypedValueParser<Value = sim::NoisePreset> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(sim::NoisePreset::ALL.map(sim::NoisePreset::name))
        .map(|name| name.parse().unwrap_or(sim::NoisePreset::Realistic))
}

/// Why a command failed: the operations' error ([`ops::measurement::Error`]), its exit code
/// from [`ops::exit`].
pub type CommandError = ops::measurement::Error;

/// A refusal of an input, in words.
pub fn refuse(message: String) -> CommandError {
    ops::measurement::refuse(message)
}

/// The exit code of `end`, with its message on standard error.
pub fn end_code(end: &End, fault_detail: &str) -> u8 {
    match end {
        End::Completed => ops::exit::DONE,
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
