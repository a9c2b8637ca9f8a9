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
/// done, 1 run failed, 2 input refused (nothing ran), 3 fault (platform safe-stopped), 4 nothing
/// measured (no samples used, or most rejected), 130 interrupted (parked).
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
        Command::Estimate(a) => estimate::main(&a),
        Command::Bench(a) => bench::main(&a),
        Command::Simulate(a) if a.runs.is_some() => campaign::main(&a, &INTERRUPT),
        Command::Simulate(a) => simulate::main(&a, &INTERRUPT),
    })
}
