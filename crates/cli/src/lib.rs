//! The `stewart` command line: one module per command, each turning its flags into the options
//! of an operation of the `ops` library, calling it and printing its outcome; the terminal's
//! own concerns (table, progress bar, the operator's prompt, the stopping signals) in modules of their own.
//! The figures of `--plot` are crate `figures`'.
#![warn(missing_docs)]

pub mod bench;
pub mod calibrate;
pub mod campaign;
pub mod common;
pub mod emulate;
pub mod estimate;
pub mod export;
pub mod import;
pub mod key;
pub mod output;
pub mod plan;
pub mod progress;
pub mod prompt;
pub mod report;
pub mod rig;
pub mod signals;
pub mod simulate;
pub mod table;

use clap::{Parser, Subcommand};

pub use common::{CommandError, EXIT_FAULT, EXIT_INTERRUPTED};

pub use signals::{ABORT, INTERRUPT};

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
    /// The shared key that authenticates `rig` and `emulate` to each other: `key new`.
    Key(key::KeyArgs),
    /// Re-run the estimator on a log of `simulate`, `rig` or `import` (its settings, or
    /// others) and print the same table and report.
    Estimate(estimate::EstimateArgs),
    /// Write another rig's sensor samples (CSV with the columns of docs/import.md) as a log
    /// that `estimate` measures, with that rig's description.
    Import(import::ImportArgs),
    /// Write a report's payload inertial element (mass, centre of mass, inertia about it) for a
    /// model: URDF, SDF, MJCF or CSV, sigmas as comments (docs/export.md).
    Export(export::ExportArgs),
    /// Hand a report over as one self-contained HTML page (`--html FILE`): results with
    /// expanded uncertainty (k = 2), principal axes, budget, convergence, rig; prints on A4.
    Report(report::ReportArgs),
    /// Can this computer run the loop? Times the full control-and-estimation tick (median,
    /// p99) and the simulator on the configured scenario, and says whether the rate fits.
    Bench(bench::BenchArgs),
    /// Design the excitation before anything moves: the motion within the rig's limits that
    /// measures the payload's prior best, its predicted sigma per quantity and the limit that
    /// binds; `--out FILE` writes it for `simulate`/`rig --excitation FILE`.
    Plan(plan::PlanArgs),
}

/// Entry point of the `stewart` binary: parses the arguments, runs the command. Exit codes: 0
/// done, 1 run failed, 2 input refused (nothing ran), 3 fault (platform safe-stopped), 4 nothing
/// measured (no samples used, or most rejected), 130 interrupted (parked).
pub fn main_entry() -> std::process::ExitCode {
    use std::process::ExitCode;

    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // clap echoes a bad value whole; a 50 MB argument must not become a 50 MB message.
            let text = e.render().to_string();
            let text = rig_description::load::abbreviate_echo(&text);
            if e.use_stderr() {
                eprint!("{text}");
            } else {
                print!("{text}");
            }
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    let drives_hardware = matches!(cli.command, Command::Rig(_));
    let stopping = match &cli.command {
        Command::Rig(_) => "parking the platform and finishing the log",
        Command::Simulate(a) if a.runs.is_some() => "stopping the campaign",
        Command::Simulate(_) => "parking and finishing the log",
        Command::Emulate(_) => "stopping the emulator",
        _ => "stopping",
    };
    if let Err(e) = signals::listen(drives_hardware, stopping) {
        eprintln!("warning: cannot catch Ctrl-C, SIGTERM, SIGHUP or SIGQUIT ({e}): they end the command at once");
    }
    ExitCode::from(match cli.command {
        Command::Rig(a) => rig::main(&a, &INTERRUPT, &ABORT),
        Command::Emulate(a) => emulate::main(&a, &INTERRUPT),
        Command::Key(a) => key::main(&a),
        Command::Estimate(a) => estimate::main(&a),
        Command::Import(a) => import::main(&a),
        Command::Export(a) => export::main(&a),
        Command::Report(a) => report::main(&a),
        Command::Bench(a) => bench::main(&a),
        Command::Plan(a) => plan::main(&a),
        Command::Simulate(a) if a.runs.is_some() => campaign::main(&a, &INTERRUPT),
        Command::Simulate(a) => simulate::main(&a, &INTERRUPT),
    })
}
