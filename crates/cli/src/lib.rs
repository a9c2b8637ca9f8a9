//! The `stewart` command line: scenario configuration, the measurement run (settle, tare,
//! excitation, park) generic over a [`control::io::Backend`], MCAP logging, the result table and
//! the JSON report.
#![warn(missing_docs)]

pub mod args;
pub mod bench;
pub mod campaign;
pub mod config;
pub mod config_load;
pub mod emulate;
pub mod estimate;
pub mod foxglove;
pub mod log_messages;
pub mod log_read;
pub mod mcap_log;
pub mod metadata;
pub mod plot;
pub mod preflight;
pub mod report;
pub mod rig_cmd;
pub mod run;
pub mod run_log;
pub mod schema;
pub mod simulate;
pub mod systematic;
pub mod table;
pub mod tare;
pub mod validate;

/// Set by the Ctrl-C handler; the run loop parks the platform when it sees it.
pub static INTERRUPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Exit code after Ctrl-C (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: u8 = 130;
/// Exit code after a supervisor fault.
pub const EXIT_FAULT: u8 = 3;

/// Entry point of the `stewart` binary: parses the arguments, runs the command, prints the table
/// and the log path. Exit codes: 0 done, 1 run failed, 2 input refused (nothing ran), 3 fault
/// (platform safe-stopped), 130 interrupted (parked).
pub fn main_entry() -> std::process::ExitCode {
    use clap::Parser;
    use std::process::ExitCode;

    let cli = args::Cli::parse();
    // A second Ctrl-C while parking exits at once (the log is lost up to its last chunk).
    let _ = ctrlc::set_handler(|| {
        if INTERRUPT.swap(true, std::sync::atomic::Ordering::SeqCst) {
            std::process::exit(i32::from(EXIT_INTERRUPTED));
        }
        eprintln!(
            "\ninterrupted: parking the platform and finishing the log (Ctrl-C again to abort)"
        );
    });
    match cli.command {
        args::Command::Rig(a) => ExitCode::from(rig_cmd::main(&a, &INTERRUPT)),
        args::Command::Emulate(a) => ExitCode::from(emulate::main(&a, &INTERRUPT)),
        args::Command::Estimate(a) => match estimate::estimate(&a) {
            Ok(_) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(2)
            }
        },
        args::Command::Bench(a) => ExitCode::from(bench::main(&a)),
        args::Command::Simulate(run_args) if run_args.runs.is_some() => {
            ExitCode::from(campaign::main(&run_args, &INTERRUPT))
        }
        args::Command::Simulate(run_args) => match simulate::simulate(&run_args, &INTERRUPT) {
            Ok(outcome) => {
                let code = finish(&run_args, &outcome);
                ExitCode::from(code)
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(e.exit_code())
            }
        },
    }
}

/// Prints the outcome, writes the report; returns the exit code.
fn finish(args: &args::RunArgs, outcome: &simulate::SimulateOutcome) -> u8 {
    let mut code = 0;
    match &outcome.end {
        run::End::Completed => {}
        run::End::Interrupted => {
            eprintln!("interrupted: the platform was parked; no report");
            code = EXIT_INTERRUPTED;
        }
        run::End::Fault(f) => {
            eprintln!("fault: {f}; the platform was stopped; no report");
            code = EXIT_FAULT;
        }
    }
    if let Some(report) = &outcome.report {
        if !args.quiet {
            print!("{}", table::render(report));
        }
        if let Some(path) = &args.report {
            if let Err(e) = std::fs::write(path, report.to_json()) {
                eprintln!("error: cannot write the report {}: {e}", path.display());
                code = 1;
            } else if !args.quiet {
                println!("report: {}", path.display());
            }
        }
    }
    if let (Some(path), Some(_)) = (&args.save_tare, &outcome.tare) {
        if !args.quiet {
            println!("tare: {}", path.display());
        }
    }
    println!("log: {}", outcome.log_path.display());
    if let Some(dir) = &args.plot {
        match plot::plot_log(&outcome.log_path, dir) {
            Ok(files) => println!("figures: {} ({} files)", dir.display(), files.len()),
            Err(e) => {
                eprintln!("error: cannot plot the log: {e:#}");
                code = code.max(1);
            }
        }
    }
    code
}
