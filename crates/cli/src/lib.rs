//! The `stewart` command line: one module per command, each turning its flags into the options
//! of an operation of the `ops` library, calling it and printing its outcome; the terminal's
//! own concerns (table, progress bar, the operator's prompt, Ctrl-C) in modules of their own.
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
pub mod simulate;
pub mod table;

use clap::{Parser, Subcommand};

pub use common::{CommandError, EXIT_FAULT, EXIT_INTERRUPTED};

/// Set by the first Ctrl-C; the run loop parks the platform when it sees it.
pub static INTERRUPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set by the second Ctrl-C of a command that drives hardware (`rig`): brakes at once (no park
/// ramp), the log is finished, then the command exits.
pub static ABORT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Ctrl-C presses so far.
static PRESSES: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

/// What one Ctrl-C does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CtrlC {
    /// Park the platform (ramp home, brakes), finish the log.
    Park,
    /// Brake at once, finish the log, exit.
    StopNow,
    /// Exit at once (nothing that moves hardware is left to stop, or the operator insists).
    Exit,
}

/// The `press`-th Ctrl-C (1-based) of a command; `drives_hardware`: it commands a rig, which
/// must get a safe stop however the command ends. A simulation has nothing to stop, so its
/// second press exits; a rig's second press brakes at once and finishes the log, and only a
/// third exits without waiting (the rig's command watchdog then brakes it).
pub fn on_ctrl_c(press: u32, drives_hardware: bool) -> CtrlC {
    match press {
        0 | 1 => CtrlC::Park,
        2 if drives_hardware => CtrlC::StopNow,
        _ => CtrlC::Exit,
    }
}

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
    use std::sync::atomic::Ordering;

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
    let _ = ctrlc::set_handler(move || {
        let press = PRESSES.fetch_add(1, Ordering::SeqCst) + 1;
        match on_ctrl_c(press, drives_hardware) {
            CtrlC::Park => {
                INTERRUPT.store(true, Ordering::SeqCst);
                eprintln!(
                    "\ninterrupted: parking the platform and finishing the log (Ctrl-C again to \
                     brake at once)"
                );
            }
            CtrlC::StopNow => {
                INTERRUPT.store(true, Ordering::SeqCst);
                ABORT.store(true, Ordering::SeqCst);
                eprintln!(
                    "\nbraking now and finishing the log (Ctrl-C again to exit without waiting)"
                );
            }
            CtrlC::Exit => std::process::exit(i32::from(EXIT_INTERRUPTED)),
        }
    });
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A second Ctrl-C on `rig` brakes and finishes the log (an exit at once
    /// would leave an enabled command on the wire and the log without its footer).
    #[test]
    fn a_second_ctrl_c_on_a_rig_brakes_and_only_a_third_exits() {
        assert_eq!(on_ctrl_c(1, true), CtrlC::Park);
        assert_eq!(on_ctrl_c(2, true), CtrlC::StopNow);
        assert_eq!(on_ctrl_c(3, true), CtrlC::Exit);
        assert_eq!(on_ctrl_c(1, false), CtrlC::Park);
        assert_eq!(on_ctrl_c(2, false), CtrlC::Exit);
    }
}
