//! The `stewart` command line: one module per command, each turning its arguments into the
//! options of a library operation (the measurement in `measure`, the log in `runlog`, the
//! simulator in `sim`, the link in `rig`), and the terminal's own concerns (table, progress,
//! plots, the operator's prompt) in modules of their own.
#![warn(missing_docs)]

pub mod bench;
pub mod campaign;
pub mod common;
pub mod emulate;
pub mod estimate;
pub mod output;
pub mod plot;
pub mod progress;
pub mod prompt;
pub mod rig;
pub mod simulate;
pub mod table;

use clap::{Parser, Subcommand};

pub use common::{CommandError, EXIT_FAULT, EXIT_INTERRUPTED};

/// Set by the Ctrl-C handler; the run loop parks the platform when it sees it.
pub static INTERRUPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

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
    Simulate(simulate::SimulateArgs),
    /// Measure on a rig over the wire protocol (default udp://127.0.0.1:7700): tare run,
    /// payload on, loaded run; or `rig tare --out FILE`, `rig measure --tare FILE`.
    Rig(Box<rig::RigArgs>),
    /// Play the rig: the simulator behind the wire protocol in real time, for `stewart rig`.
    Emulate(emulate::EmulateArgs),
    /// Re-run the estimator on a log of `simulate` or `rig` (its settings, or others) and print
    /// the same table and report.
    Estimate(estimate::EstimateArgs),
    /// Can this computer run the loop? Times the full control-and-estimation tick (median,
    /// p99) and the simulator on the configured scenario, and says whether the rate fits.
    Bench(bench::BenchArgs),
}

/// Entry point of the `stewart` binary: parses the arguments, runs the command. Exit codes: 0
/// done, 1 run failed, 2 input refused (nothing ran), 3 fault (platform safe-stopped), 130
/// interrupted (parked).
pub fn main_entry() -> std::process::ExitCode {
    use std::process::ExitCode;

    let cli = Cli::parse();
    // A second Ctrl-C while parking exits at once (the log is lost up to its last chunk).
    let _ = ctrlc::set_handler(|| {
        if INTERRUPT.swap(true, std::sync::atomic::Ordering::SeqCst) {
            std::process::exit(i32::from(EXIT_INTERRUPTED));
        }
        eprintln!(
            "\ninterrupted: parking the platform and finishing the log (Ctrl-C again to abort)"
        );
    });
    ExitCode::from(match cli.command {
        Command::Rig(a) => rig::main(&a, &INTERRUPT),
        Command::Emulate(a) => emulate::main(&a, &INTERRUPT),
        Command::Estimate(a) => match estimate::estimate(&a) {
            Ok(_) => 0,
            Err(e) => {
                eprintln!("error: {e:#}");
                2
            }
        },
        Command::Bench(a) => bench::main(&a),
        Command::Simulate(a) if a.runs.is_some() => campaign::main(&a, &INTERRUPT),
        Command::Simulate(a) => simulate::main(&a, &INTERRUPT),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn parses_every_simulate_flag() {
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
        assert_eq!(a.measure.duration, Some(12.5));
        assert_eq!(a.seed, Some(7));
        assert_eq!(a.noise, Some(sim::NoisePreset::Harsh));
        assert_eq!(a.measure.params.as_deref(), Some("6"));
        assert!(a.measure.quiet);
        assert_eq!(a.measure.log, Some(PathBuf::from("l.mcap")));
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
        assert!(a.measure.config.is_none() && a.measure.duration.is_none());
    }

    /// Each command's `--help` lists only the options that act on it.
    #[test]
    fn each_command_offers_only_its_own_options() {
        use clap::CommandFactory;
        let cli = Cli::command();
        let long = |name: &str| -> Vec<String> {
            let mut c = cli.find_subcommand(name).expect("subcommand").clone();
            c.build();
            c.get_arguments()
                .filter_map(|a| a.get_long().map(str::to_string))
                .collect()
        };
        let rig = long("rig");
        for simulator_only in ["seed", "noise", "runs", "jobs"] {
            assert!(
                !rig.iter().any(|l| l == simulator_only),
                "rig offers --{simulator_only}"
            );
        }
        assert!(rig.iter().any(|l| l == "connect"));
        let simulate = long("simulate");
        for rig_only in ["connect", "key", "no-prompt", "link-silence-ms"] {
            assert!(
                !simulate.iter().any(|l| l == rig_only),
                "simulate offers --{rig_only}"
            );
        }
        assert!(simulate.iter().any(|l| l == "seed"));
        let estimate = long("estimate");
        assert!(estimate.iter().any(|l| l == "rig"));
        assert!(!estimate.iter().any(|l| l == "seed"));
    }
}
