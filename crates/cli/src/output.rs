//! What a measurement command leaves on the terminal and on disk when it ends: the table, the
//! report file, where the log is, the figures.

use std::path::Path;

use measure::Report;

use crate::common::{MeasureArgs, EXIT_NOT_MEASURED};

/// Prints the table, writes the report (`json`, the report's JSON with any extras), says where
/// the log is and draws the figures; returns the exit code after `code`. A report that
/// measured nothing ([`measure::quality`]) is neither printed nor written: the reason is, with
/// [`EXIT_NOT_MEASURED`].
pub fn finish_measurement(
    args: &MeasureArgs,
    report: Option<(&Report, String)>,
    log: &Path,
    mut code: u8,
) -> u8 {
    let report = report.filter(|(r, _)| match r.check_quality() {
        Ok(()) => true,
        Err(e) => {
            eprintln!("error: {e}; no table or report");
            code = code.max(EXIT_NOT_MEASURED);
            false
        }
    });
    if let Some((report, json)) = report {
        if !args.shared.quiet {
            print!("{}", crate::table::render(report));
            if args.budget {
                print!("{}", crate::table::render_budget(report));
            }
        }
        crate::table::warn_rigid_body(report);
        if let Some(path) = &args.report {
            if let Err(e) = std::fs::write(path, &json) {
                eprintln!("error: cannot write the report {}: {e}", path.display());
                code = code.max(1);
            } else if !args.shared.quiet {
                println!("report: {}", path.display());
            }
        }
        if let Some(path) = &args.html {
            // The page lists the rig description the run was measured with (the same flags).
            let rig = args.load_config().ok();
            let source = match &args.report {
                Some(p) => p.display().to_string(),
                None => "written with the page (no --report)".into(),
            };
            match ops::report::write_page(&json, path, &source, rig.as_ref()) {
                Ok(()) if !args.shared.quiet => println!("page: {}", path.display()),
                Ok(()) => {}
                Err(e) => {
                    eprintln!("error: cannot write the page {}: {e}", path.display());
                    code = code.max(1);
                }
            }
        }
    }
    println!("log: {}", log.display());
    if let Some(dir) = &args.shared.plot {
        match figures::plot_log(log, dir) {
            Ok(files) => println!("figures: {} ({} files)", dir.display(), files.len()),
            Err(e) => {
                eprintln!("error: cannot plot the log: {e:#}");
                code = code.max(1);
            }
        }
    }
    code
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::common::SharedArgs;

    /// A measurement that used no samples prints no table of NaN and does not
    /// exit 0.
    #[test]
    fn a_report_that_measured_nothing_is_an_error_and_not_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        let args = MeasureArgs {
            shared: SharedArgs {
                quiet: true,
                ..SharedArgs::default()
            },
            report: Some(path.clone()),
            ..MeasureArgs::default()
        };
        let empty = Report {
            samples: 0,
            rejected_samples: 60_000,
            ..Report::default()
        };
        let code = finish_measurement(
            &args,
            Some((&empty, "{}".into())),
            &dir.path().join("x.mcap"),
            0,
        );
        assert_eq!(code, EXIT_NOT_MEASURED);
        assert!(!path.exists());
        let fine = Report {
            samples: 60_000,
            rejected_samples: 3,
            covariance_basis: measure::report::CovarianceBasis {
                loaded_windows: 149,
                tare_windows: Some(74),
                half_block_s: 0.4,
                loaded_degrees_of_freedom: [None; 10],
            },
            ..Report::default()
        };
        let code = finish_measurement(
            &args,
            Some((&fine, "{}".into())),
            &dir.path().join("x.mcap"),
            0,
        );
        assert_eq!(code, 0);
        assert!(path.exists());
    }
}
