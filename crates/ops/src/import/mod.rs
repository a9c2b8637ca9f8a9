//! `stewart import`'s work: another rig's data into a log `stewart estimate` measures
//! ([`run`], docs/import.md):
//! the sensor frames of a CSV table ([`table`]) with the rig description that says what the
//! rig is.
//!
//! The log is written with the same [`RunLog`] and messages as `simulate` and `rig` write it:
//! `/run/metadata` (command `import`, backend `rig`, the rig description's effective TOML),
//! `/run/tare` when a tare file is given, and per measurement its `/run/estimator` settings at
//! the fit window's first row, then `/sensors` for every row. What a CSV cannot hold is absent:
//! commands, the controller's channels, the estimate along the way and the truth.
//!
//! The estimator's settings are those a measurement on this rig would use, all from the rig
//! description: [`measure::setup::estimator_config`] with the fit window of the table's
//! `window` column — from its first row with 1 to its last, the rows before it warming the
//! conditioning, the rows after it not fed — or, without the column, from the run's first row
//! to its end; the pose's forward-kinematics options are the controller's
//! ([`measure::setup::controller_config`]).
//!
//! The table is read twice: once to check every row and find each run's window, once to write
//! the log, so memory does not grow with its length.

pub mod table;
#[cfg(test)]
mod tests;

use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use measure::{setup, Measurement, TareFile};
use rig_description::LoadedConfig;

use runlog::messages::{self as topics};
use runlog::metadata::{EstimatorSettings, RunMetadata};
use runlog::run_log::{unix_now_ns, RunLog};
use table::{Row, Table};

/// What to import.
#[derive(Clone, Copy, Debug)]
pub struct ImportPlan<'a> {
    /// The rig description of the rig the data comes from.
    pub rig: &'a LoadedConfig,
    /// The CSV table.
    pub csv: &'a Path,
    /// A saved tare (JSON) subtracted from the loaded run, instead of a tare section.
    pub tare: Option<&'a Path>,
    /// The log to write.
    pub out: &'a Path,
}

/// One measurement of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunSummary {
    /// `tare` or `loaded`.
    pub run: Measurement,
    /// Rows.
    pub rows: u64,
    /// Lines of its first and last row.
    pub lines: [u64; 2],
    /// Time of its first and last row, s.
    pub time_s: [f64; 2],
    /// The fit window's first and last row's time, s. Without a `window` column, from the
    /// first row where the plate moved ([`measure::weigh::RestWatch`]: a leg's length
    /// changed from the run's first row by more than its threshold) to the run's end; the
    /// rows before it are the run's rest.
    pub window_s: [f64; 2],
    /// Time steps of about one sample period (within half a period, per counter step when
    /// the table has a `sequence` column), of `rows − 1`.
    pub steps_on_period: u64,
}

/// What [`import`] wrote.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The log.
    pub log: PathBuf,
    /// Its measurements, in order.
    pub runs: Vec<RunSummary>,
    /// The tare file it carries (`/run/tare`), if given.
    pub tare: Option<TareFile>,
}

/// The longest row a table may have, bytes. A row is a few dozen numbers, under 2 KiB; the
/// table is streamed whatever its length, but the CSV reader holds a whole row, so a source
/// without line ends (`/dev/zero`, a binary file) would grow it without bound.
pub const MAX_ROW_BYTES: usize = 64 * 1024;

/// `inner` read with every line at most [`MAX_ROW_BYTES`] long; a longer one is an error of
/// kind `InvalidData`.
struct RowCapped<R> {
    inner: R,
    /// Bytes since the last line end.
    line: usize,
}

impl<R> RowCapped<R> {
    fn new(inner: R) -> Self {
        Self { inner, line: 0 }
    }
}

impl<R: Read> Read for RowCapped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in buf.iter().take(n) {
            self.line = if b == b'\n' { 0 } else { self.line + 1 };
            if self.line > MAX_ROW_BYTES {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!(
                        "a row runs past {} KiB without a line end: not a CSV table of this \
                         format (is it the right file?)",
                        MAX_ROW_BYTES / 1024
                    ),
                ));
            }
        }
        Ok(n)
    }
}

/// Reads the table at `path`, refusals named with the file.
fn open(path: &Path) -> Result<Table<impl Read>> {
    if path.is_dir() {
        anyhow::bail!(
            "{} is a directory, not a table: name the CSV file in it",
            path.display()
        );
    }
    let file = std::fs::File::open(path)
        .with_context(|| format!("cannot read the table {}", path.display()))?;
    Table::new(RowCapped::new(std::io::BufReader::with_capacity(
        1 << 16,
        file,
    )))
    .with_context(|| format!("{} is refused", path.display()))
}

/// The first pass: every row checked, each run's rows, times and window; `rest` tells the
/// rest from the motion in a table without a `window` column.
pub fn scan(
    path: &Path,
    sample_period_s: f64,
    rest: &measure::weigh::RestWatch,
) -> Result<Vec<RunSummary>> {
    let mut t = open(path)?;
    let mut runs: Vec<RunSummary> = Vec::new();
    let mut window_seen = false;
    // The run's first leg lengths, until the plate moved (tables without a window column).
    let mut resting: Option<[f64; 6]> = None;
    let mut previous: Option<Row> = None;
    while let Some(row) = t
        .next_row()
        .with_context(|| format!("{} is refused", path.display()))?
    {
        let (f, time_s) = (&row.frame, row.frame.time_s);
        match runs.last_mut() {
            Some(r) if r.run == row.run => {
                r.rows += 1;
                r.lines[1] = row.line;
                r.time_s[1] = time_s;
                if let Some(p) = previous {
                    let slots = if t.has_sequence() {
                        (f.sequence - p.frame.sequence) as f64
                    } else {
                        1.0
                    };
                    let step = (time_s - p.frame.time_s) / slots / sample_period_s;
                    if (0.5..1.5).contains(&step) {
                        r.steps_on_period += 1;
                    }
                }
            }
            _ => {
                window_seen = false;
                resting = Some(f.leg_lengths_m);
                runs.push(RunSummary {
                    run: row.run,
                    rows: 1,
                    lines: [row.line; 2],
                    time_s: [time_s; 2],
                    window_s: [time_s, f64::INFINITY],
                    steps_on_period: 0,
                });
            }
        }
        if let (Some(r), Some(true)) = (runs.last_mut(), row.window) {
            if !window_seen {
                r.window_s[0] = time_s;
                window_seen = true;
            }
            r.window_s[1] = time_s;
        }
        if let (Some(r), None, Some(first)) = (runs.last_mut(), row.window, resting) {
            let moved = f
                .leg_lengths_m
                .iter()
                .zip(first)
                .any(|(l, l0)| (l - l0).abs() > rest.threshold_m);
            if moved {
                r.window_s[0] = time_s;
                resting = None;
            }
        }
        if row.window == Some(false) && !window_seen {
            if let Some(r) = runs.last_mut() {
                // Not yet in the window: it starts on a later row (or nowhere, refused below).
                r.window_s[0] = f64::INFINITY;
            }
        }
        previous = Some(row);
    }
    for r in &runs {
        check_run(path, r, sample_period_s)?;
    }
    Ok(runs)
}

/// A run's window exists and its rows come at the rig description's sample rate.
fn check_run(path: &Path, r: &RunSummary, period_s: f64) -> Result<()> {
    let (name, [a, b]) = (r.run.name(), r.lines);
    if !r.window_s[0].is_finite() {
        bail!(
            "{}: the {name} run (lines {a}–{b}) has no row with window = 1: its fit window is \
             empty",
            path.display()
        );
    }
    let steps = r.rows - 1;
    // Most steps are one period on any rig that loses or delays a few frames; a table at
    // another rate (or a rig description with the wrong `sensors.sample_rate_hz`) has none.
    if steps >= 10 && 2 * r.steps_on_period < steps {
        bail!(
            "{}: the {name} run (lines {a}–{b}) is not sampled at the rig description's rate: \
             {} of its {steps} time steps are one sample period ({period_s} s, from \
             sensors.sample_rate_hz) within half a period",
            path.display(),
            r.steps_on_period
        );
    }
    Ok(())
}

/// The log's metadata for the rig description `rig` of geometry `geometry`.
fn metadata(
    plan: &ImportPlan<'_>,
    geometry: &kinematics::Geometry,
    runs: &[RunSummary],
) -> RunMetadata {
    RunMetadata {
        noise: "rig".into(),
        runs: runs.iter().map(|r| r.run.name().to_string()).collect(),
        tare_file: plan.tare.map(|p| p.display().to_string()),
        ..RunMetadata::describing(plan.rig, geometry, "import", "rig")
    }
}

/// Writes the log of `plan` (see the [module docs](self)). Refused, with the file, line and
/// column: a table [`table`] refuses, a run without window rows or at another sample rate than
/// the rig description's, a table with both a tare section and `plan.tare`, or with loaded
/// rows and neither; a tare file measured on other joints.
pub fn import(plan: &ImportPlan<'_>) -> Result<Imported> {
    let config = &plan.rig.config;
    let geometry = setup::geometry(plan.rig).map_err(|e| anyhow::anyhow!("{e}"))?;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let runs = scan(plan.csv, period_s, &measure::weigh::RestWatch::of(config))?;
    let has = |m: Measurement| runs.iter().any(|r| r.run == m);
    let csv = plan.csv.display();
    let tare = match plan.tare {
        Some(_) if has(Measurement::Tare) => bail!(
            "{csv} has a tare section (rows with run = tare) and --tare gives a tare file: \
             give one of them"
        ),
        Some(path) => {
            let (base, plate) = measure::sequence::joints(&geometry);
            Some(TareFile::load(path, &base, &plate)?)
        }
        None if !has(Measurement::Tare) => bail!(
            "{csv} has no tare section (rows with run = tare): give the tare's rows or a saved \
             tare with --tare FILE"
        ),
        None => None,
    };
    let start_ns = unix_now_ns();
    let mut log = RunLog::create(plan.out, start_ns)?;
    let mut meta = metadata(plan, &geometry, &runs);
    meta.start_unix_ns = start_ns;
    log.write_metadata(&meta)?;
    if let Some(t) = &tare {
        log.write_now(topics::TARE, t)?;
    }
    let fk = setup::controller_config(config).fk;
    let mut t = open(plan.csv)?;
    let mut current: Option<(Measurement, bool)> = None;
    while let Some(row) = t.next_row().with_context(|| format!("{csv} is refused"))? {
        let run = row.run;
        let Some(r) = runs.iter().find(|r| r.run == run) else {
            bail!("{csv} changed while it was imported");
        };
        if current.is_none_or(|(m, _)| m != run) {
            current = Some((run, false));
        }
        let time_s = row.frame.time_s;
        // The settings are logged when the window opens, as the online run logs them.
        if let Some((_, started @ false)) = &mut current {
            if time_s >= r.window_s[0] {
                let mut c =
                    setup::estimator_config(config, &geometry, run, r.window_s[0], r.window_s[1]);
                // As a measurement does: a short window gets half-blocks short enough for a
                // sigma, from the excitation's length — the window's span from its first
                // frame to its last, plus the last frame's period.
                c.covariance_half_block_samples = measure::quality::half_block_samples_for(
                    c.covariance_half_block_samples,
                    r.window_s[1] - r.window_s[0] + c.sample_period_s,
                    c.sample_period_s,
                );
                let settings = EstimatorSettings::from_config(run.name(), &c, &fk);
                log.write_settings(time_s, &settings)?;
                *started = true;
            }
        }
        log.write_sensor(run.name(), &row.frame)?;
    }
    log.finish()?;
    Ok(Imported {
        log: plan.out.to_path_buf(),
        runs,
        tare,
    })
}

/// The line `stewart import` prints for a measurement: its rows, times and fit window.
impl std::fmt::Display for RunSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b] = self.time_s;
        let [ws, we] = self.window_s;
        let end = if we.is_finite() {
            format!("{we} s")
        } else {
            "the end".into()
        };
        write!(
            f,
            "{}: {} rows, {a} s to {b} s, fit window {ws} s to {end}",
            self.run.name(),
            self.rows
        )
    }
}

/// Options of `stewart import`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImportOptions {
    /// The sensor table (docs/import.md).
    pub csv: PathBuf,
    /// The rig description of the rig that recorded it, laid over the embedded default.
    pub rig: PathBuf,
    /// The log to write (`None`: DATA.mcap beside the table).
    pub out: Option<PathBuf>,
    /// A saved tare (JSON) for a table with loaded rows only.
    pub tare: Option<PathBuf>,
}

/// Why no log was written.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The rig description was refused.
    #[error("{0}")]
    Rig(#[from] rig_description::load::ConfigError),
    /// The table, the tare or the log was refused or could not be written.
    #[error("{0:#}")]
    Import(anyhow::Error),
}

/// Runs `import`: writes the log of `options`.
pub fn run(options: &ImportOptions) -> Result<Imported, Error> {
    let rig = rig_description::load::load_scoped(
        Some(&options.rig),
        rig_description::validate::Scope::Estimation,
    )?;
    let out = options
        .out
        .clone()
        .unwrap_or_else(|| options.csv.with_extension("mcap"));
    import(&ImportPlan {
        rig: &rig,
        csv: &options.csv,
        tare: options.tare.as_deref(),
        out: &out,
    })
    .map_err(Error::Import)
}
