//! Command-line arguments (clap derive).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::config::NoisePreset;

/// Measure a vehicle's mass, centre of mass and inertia tensor on a Stewart platform.
#[derive(Debug, Parser)]
#[command(name = "stewart", version, about, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Measure a simulated payload: tare run (empty fixture), loaded run, park; print the table.
    Simulate(RunArgs),
    /// Measure on a rig over the wire protocol (default udp://127.0.0.1:7700): tare run,
    /// payload on, loaded run; or `rig tare --out FILE`, `rig measure --tare FILE`.
    Rig(Box<crate::rig_cmd::RigArgs>),
    /// Play the rig: the simulator behind the wire protocol in real time, for `stewart rig`.
    Emulate(crate::emulate::EmulateArgs),
    /// Re-run the estimator on a log of `simulate` or `rig` (its settings, or others) and print
    /// the same table and report.
    Estimate(crate::estimate::EstimateArgs),
    /// Can this computer run the loop? Times the full control-and-estimation tick (median,
    /// p99) and the simulator on the configured scenario, and says whether the rate fits.
    Bench(crate::bench::BenchArgs),
}

/// Flags shared by the measurement commands (`simulate`, and `rig` later).
#[derive(Clone, Debug, Default, Args)]
pub struct RunArgs {
    /// Scenario TOML, laid over the embedded default (configs/default.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Random seed of the simulation (run.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Sensor noise preset (sensors.noise).
    #[arg(long, value_enum)]
    pub noise: Option<NoisePreset>,
    /// 10: mass, centre of mass and inertia; 6: the paper's inertia-only model (estimator.params).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["10", "6"]))]
    pub params: Option<String>,
    /// Use this saved tare (JSON) instead of a tare run.
    #[arg(long, value_name = "FILE")]
    pub tare: Option<PathBuf>,
    /// Save the measured tare (JSON) for later `--tare` runs.
    #[arg(long, value_name = "FILE")]
    pub save_tare: Option<PathBuf>,
    /// MCAP log file (default: runs/<UTC time>.mcap).
    #[arg(long, value_name = "FILE.mcap")]
    pub log: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// No progress bar and no table.
    #[arg(long)]
    pub quiet: bool,
    /// Write SVG and PNG figures (estimates with ±σ and truth, tracking error, excitation) here.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Accuracy campaign: this many runs with seeds seed, seed+1, …, then per-parameter error
    /// statistics (`--report` writes them as JSON).
    #[arg(long, value_name = "N")]
    pub runs: Option<u32>,
    /// Runs in parallel with `--runs` (default: one per CPU).
    #[arg(long, value_name = "J", requires = "runs")]
    pub jobs: Option<usize>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_flag() {
        let cli = Cli::try_parse_from([
            "stewart",
            "simulate",
            "--config",
            "c.toml",
            "--duration",
            "12.5",
            "--seed",
            "7",
            "--noise",
            "harsh",
            "--params",
            "6",
            "--tare",
            "t.json",
            "--save-tare",
            "s.json",
            "--log",
            "l.mcap",
            "--report",
            "r.json",
            "--quiet",
        ])
        .unwrap();
        let Command::Simulate(a) = cli.command else {
            panic!("not simulate")
        };
        assert_eq!(a.duration, Some(12.5));
        assert_eq!(a.seed, Some(7));
        assert_eq!(a.noise, Some(NoisePreset::Harsh));
        assert_eq!(a.params.as_deref(), Some("6"));
        assert!(a.quiet);
        assert_eq!(a.log, Some(PathBuf::from("l.mcap")));
    }

    #[test]
    fn refuses_bad_values() {
        assert!(Cli::try_parse_from(["stewart", "simulate", "--params", "7"]).is_err());
        assert!(Cli::try_parse_from(["stewart", "simulate", "--noise", "loud"]).is_err());
        assert!(Cli::try_parse_from(["stewart", "simulate", "--bogus"]).is_err());
    }

    #[test]
    fn no_arguments_is_enough() {
        let cli = Cli::try_parse_from(["stewart", "simulate"]).unwrap();
        let Command::Simulate(a) = cli.command else {
            panic!("not simulate")
        };
        assert!(a.config.is_none() && a.duration.is_none());
    }
}
