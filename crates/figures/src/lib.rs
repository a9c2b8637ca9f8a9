//! `--plot DIR`: figures for a test report, as SVG and PNG, in the manner of the paper's
//! Figures 3–8, drawn ([`write_figures`]) from the series of [`series`].
#![warn(missing_docs)]

mod draw;
pub mod series;

use std::path::{Path, PathBuf};

use anyhow::Result;
use runlog::read::LogContents;

use crate::series::*;
pub use draw::{write_figures, COURSE_SIZE, FIGURE_SIZE, OVERVIEW_SIZE};

/// Reads the finished (or cut short) log at `log_path` and writes its figures into `dir`; what
/// `simulate --plot` and `rig --plot` call after the run. Returns the files written.
pub fn plot_log(log_path: &Path, dir: &Path) -> Result<Vec<PathBuf>> {
    let log = LogContents::read(log_path)?;
    write_figures(dir, &figures_from_log(&log)?)
}
