//! What a measurement command leaves on the terminal and on disk when it ends: the table, the
//! report file, where the log is, the figures.

use std::path::Path;

use measure::Report;

use crate::common::MeasureArgs;

/// Prints the table, writes the report (`json`, the report's JSON with any extras), says where
/// the log is and draws the figures; returns the exit code after `code`.
pub fn finish_measurement(
    args: &MeasureArgs,
    report: Option<(&Report, String)>,
    log: &Path,
    mut code: u8,
) -> u8 {
    if let Some((report, json)) = report {
        if !args.shared.quiet {
            print!("{}", crate::table::render(report));
        }
        if let Some(path) = &args.report {
            if let Err(e) = std::fs::write(path, json) {
                eprintln!("error: cannot write the report {}: {e}", path.display());
                code = code.max(1);
            } else if !args.shared.quiet {
                println!("report: {}", path.display());
            }
        }
    }
    println!("log: {}", log.display());
    if let Some(dir) = &args.shared.plot {
        match crate::plot::plot_log(log, dir) {
            Ok(files) => println!("figures: {} ({} files)", dir.display(), files.len()),
            Err(e) => {
                eprintln!("error: cannot plot the log: {e:#}");
                code = code.max(1);
            }
        }
    }
    code
}
