//! How a command ends, as its exit status: one table for every command, the same in
//! docs/exit-codes.md (a test reads it back).
//!
//! | code | meaning |
//! |-----:|---------|
//! | 0 | done: the measurement (or the command's work) completed and passed its quality checks |
//! | 1 | failed while running: the backend, the log, a file that could not be written, a fit |
//! | 2 | refused before anything moved: a flag, the rig description, an input file, the rig's handshake; no log |
//! | 3 | fault: the supervisor or the link stopped the run; a safe stop was sent and the log finished |
//! | 4 | not measured: the run completed but measured nothing trustworthy ([`measure::quality`]) |
//! | 130 | interrupted (Ctrl-C, SIGTERM, SIGHUP, SIGQUIT): parked (twice: braked at once), the log finished |

use measure::End;

use crate::measurement::{Error, Outcome};

/// Done.
pub const DONE: u8 = 0;
/// Failed while running.
pub const FAILED: u8 = 1;
/// Refused before anything moved.
pub const REFUSED: u8 = 2;
/// A fault stopped the run (safe stop sent, log finished).
pub const FAULT: u8 = 3;
/// The run completed but measured nothing trustworthy.
pub const NOT_MEASURED: u8 = 4;
/// Interrupted by the operator or a signal (128 + SIGINT, as shells report Ctrl-C).
pub const INTERRUPTED: u8 = 130;

/// Every code with its one-line meaning, in the order of the table.
pub const TABLE: [(u8, &str); 6] = [
    (DONE, "done"),
    (FAILED, "failed while running"),
    (REFUSED, "refused before anything moved"),
    (FAULT, "fault"),
    (NOT_MEASURED, "not measured"),
    (INTERRUPTED, "interrupted"),
];

/// The exit status of a run that ended as `end`.
pub fn of_end(end: &End) -> u8 {
    match end {
        End::Completed => DONE,
        End::Interrupted => INTERRUPTED,
        End::Fault(_) => FAULT,
    }
}

impl Error {
    /// The exit status of this error: [`REFUSED`] before anything ran, [`FAILED`] after.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::Config(_) | Self::Input(_) => REFUSED,
            Self::Run(_) => FAILED,
        }
    }
}

impl Outcome {
    /// The exit status of this measurement: how it ended ([`of_end`]), and a completed run whose
    /// report fails its quality checks is [`NOT_MEASURED`]. Writing the outcome's files (the
    /// report, figures) can only raise it, to [`FAILED`] or above.
    pub fn exit_code(&self) -> u8 {
        let code = of_end(&self.end);
        match &self.report {
            Some(report) if report.check_quality().is_err() => code.max(NOT_MEASURED),
            _ => code,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/exit-codes.md holds the same codes, in the same order, as [`TABLE`].
    #[test]
    fn the_documented_table_is_this_table() {
        let doc = include_str!("../../../docs/exit-codes.md");
        let rows: Vec<(u8, String)> = doc
            .lines()
            .filter_map(|l| {
                let cells: Vec<&str> = l.split('|').map(str::trim).collect();
                let code = cells.get(1)?.parse().ok()?;
                Some((code, cells.get(2)?.to_lowercase()))
            })
            .collect();
        assert_eq!(rows.len(), TABLE.len(), "{rows:?}");
        for ((code, meaning), (doc_code, doc_meaning)) in TABLE.iter().zip(&rows) {
            assert_eq!(code, doc_code);
            assert!(
                doc_meaning.starts_with(meaning),
                "code {code}: the docs say {doc_meaning:?}, the table {meaning:?}"
            );
        }
    }

    #[test]
    fn errors_before_anything_ran_are_refusals() {
        assert_eq!(crate::measurement::refuse("no").exit_code(), REFUSED);
        assert_eq!(Error::Run(anyhow::anyhow!("disk full")).exit_code(), FAILED);
        assert_eq!(of_end(&End::Fault("x".into())), FAULT);
        assert_eq!(of_end(&End::Interrupted), INTERRUPTED);
    }
}
