//! The `stewart` command line: scenario configuration, the measurement run (settle, tare,
//! excitation, park) generic over a [`control::io::Backend`], MCAP logging, the result table and
//! the JSON report.
#![warn(missing_docs)]

pub mod config;
pub mod config_load;
pub mod foxglove;
pub mod log_messages;
pub mod mcap_log;
pub mod metadata;
pub mod report;
pub mod schema;
pub mod table;
pub mod tare;
pub mod validate;

/// Entry point of the `stewart` binary.
pub fn main_entry() -> std::process::ExitCode {
    std::process::ExitCode::SUCCESS
}
