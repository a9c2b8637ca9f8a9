//! The CSV table `stewart import` reads (docs/import.md): a header naming every column with its
//! unit, then one row per sensor frame. Columns are found by name, in any order; a column
//! whose name has the right quantity but another unit is refused, not guessed at.
//!
//! | column | what | unit |
//! |---|---|---|
//! | `time_s` | the frame's instant on the data acquisition's clock, strictly increasing | s |
//! | `run` | `tare` (empty fixture) or `loaded`; the tare rows come first | — |
//! | `leg_length_m_1` … `leg_length_m_6` | leg i, joint centre to joint centre | m |
//! | `leg_force_n_1` … `leg_force_n_6` | leg i's axial force, positive pushing the plate away | N |
//! | `gyro_rad_s_x`, `_y`, `_z` | the IMU's rate, in its own axes | rad/s |
//! | `accel_m_s2_x`, `_y`, `_z` | the IMU's specific force a − g, in its own axes | m/s² |
//! | `sequence` (optional) | the frame counter, one per sample period | — |
//! | `window` (optional) | 1 on the rows of the fit window (the excitation), else 0 | — |
//!
//! Names are compared after trimming spaces and in lower case (`leg_force_N_1` is
//! `leg_force_n_1`); other columns are ignored. A sensor cell may be `NaN` (passed to the
//! estimator, which rejects that sample as it rejects a rig's invalid reading); an empty or
//! non-numeric cell is refused with its line and column.

use std::io::Read;

use control::io::{SensorFrame, Status};
use measure::Measurement;

/// The time column.
pub const TIME: &str = "time_s";
/// The run column (`tare` or `loaded`).
pub const RUN: &str = "run";
/// The optional frame counter column.
pub const SEQUENCE: &str = "sequence";
/// The optional fit-window column (0 or 1).
pub const WINDOW: &str = "window";

/// A measured quantity's columns: `{stem}_{unit}_{suffix}` for each suffix.
struct Quantity {
    stem: &'static str,
    unit: &'static str,
    suffixes: &'static [&'static str],
}

const LEGS: &[&str] = &["1", "2", "3", "4", "5", "6"];
const AXES: &[&str] = &["x", "y", "z"];

/// Leg lengths, leg forces, gyro, accelerometer, in the order of [`Columns::sensors`].
const QUANTITIES: [Quantity; 4] = [
    Quantity {
        stem: "leg_length",
        unit: "m",
        suffixes: LEGS,
    },
    Quantity {
        stem: "leg_force",
        unit: "n",
        suffixes: LEGS,
    },
    Quantity {
        stem: "gyro",
        unit: "rad_s",
        suffixes: AXES,
    },
    Quantity {
        stem: "accel",
        unit: "m_s2",
        suffixes: AXES,
    },
];

/// Sensor columns per frame: 6 leg lengths, 6 leg forces, 3 gyro, 3 accelerometer.
const SENSOR_COLUMNS: usize = 18;

/// The names of every required column, in the documented order.
pub fn required_columns() -> Vec<String> {
    let mut names = vec![TIME.to_string(), RUN.to_string()];
    for q in &QUANTITIES {
        for s in q.suffixes {
            names.push(format!("{}_{}_{s}", q.stem, q.unit));
        }
    }
    names
}

/// Why the table is refused. Lines are the file's (the header is line 1), columns 1-based.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TableError {
    /// The file is not CSV (or a row has another number of cells than the header).
    #[error("line {line}: {message}")]
    Csv {
        /// Line of the record.
        line: u64,
        /// The csv crate's words.
        message: String,
    },
    /// A required column is not in the header.
    #[error("line 1: no column `{column}` (the header must name {required})")]
    MissingColumn {
        /// The missing column's name.
        column: String,
        /// Every required column.
        required: String,
    },
    /// A column names a quantity with another unit than the one required.
    #[error(
        "line 1, column {column} `{header}`: unit `{unit}`, expected `{expected}` (convert the \
         values to SI and name the column so)"
    )]
    WrongUnit {
        /// 1-based column.
        column: usize,
        /// The header cell.
        header: String,
        /// The unit it names.
        unit: String,
        /// The required column name.
        expected: String,
    },
    /// Two columns have the same name.
    #[error("line 1, column {column} `{header}`: the name is already column {first}")]
    DuplicateColumn {
        /// 1-based column.
        column: usize,
        /// The header cell.
        header: String,
        /// The first column with that name.
        first: usize,
    },
    /// A cell is not what its column holds.
    #[error("line {line}, column {column} `{header}`: `{cell}` is not {expected}")]
    BadCell {
        /// Line of the row.
        line: u64,
        /// 1-based column.
        column: usize,
        /// The column's name.
        header: String,
        /// The cell as written.
        cell: String,
        /// What the column holds.
        expected: &'static str,
    },
    /// Time does not increase from the previous row.
    #[error(
        "line {line}, column {column} `time_s`: {time_s} s is not after the previous row's \
         {previous_s} s (time must increase strictly from row to row)"
    )]
    TimeNotIncreasing {
        /// Line of the row.
        line: u64,
        /// 1-based column.
        column: usize,
        /// This row's time, s.
        time_s: f64,
        /// The previous row's, s.
        previous_s: f64,
    },
    /// The frame counter does not increase within a run.
    #[error(
        "line {line}, column {column} `sequence`: {sequence} is not above the previous row's \
         {previous} (the counter must increase within a run)"
    )]
    SequenceNotIncreasing {
        /// Line of the row.
        line: u64,
        /// 1-based column.
        column: usize,
        /// This row's counter.
        sequence: u64,
        /// The previous row's.
        previous: u64,
    },
    /// A tare row after the loaded rows.
    #[error(
        "line {line}, column {column} `run`: a tare row after the loaded rows (the tare \
         section comes first)"
    )]
    TareAfterLoaded {
        /// Line of the row.
        line: u64,
        /// 1-based column.
        column: usize,
    },
    /// A second block of window rows in a run.
    #[error(
        "line {line}, column {column} `window`: the {run} run's window closed on an earlier \
         row (the fit window is one block of rows)"
    )]
    WindowReopened {
        /// Line of the row.
        line: u64,
        /// 1-based column.
        column: usize,
        /// `tare` or `loaded`.
        run: &'static str,
    },
    /// The header is there but no row.
    #[error("the table has a header but no rows")]
    NoRows,
}

/// Where each column is (0-based cell index).
#[derive(Clone, Debug)]
struct Columns {
    time: usize,
    run: usize,
    sensors: [usize; SENSOR_COLUMNS],
    sequence: Option<usize>,
    window: Option<usize>,
}

/// When `header` names one of [`QUANTITIES`] (or time) in another unit than required: that
/// unit and the required column's name.
fn wrong_unit(header: &str) -> Option<(String, String)> {
    if let Some(unit) = header.strip_prefix("time_") {
        return (header != TIME).then(|| (unit.to_string(), TIME.to_string()));
    }
    for q in &QUANTITIES {
        let Some(rest) = header
            .strip_prefix(q.stem)
            .and_then(|r| r.strip_prefix('_'))
        else {
            continue;
        };
        for s in q.suffixes {
            if let Some(unit) = rest.strip_suffix(s).and_then(|u| u.strip_suffix('_')) {
                if unit != q.unit && !unit.is_empty() {
                    return Some((unit.to_string(), format!("{}_{}_{s}", q.stem, q.unit)));
                }
            }
        }
    }
    None
}

impl Columns {
    fn of(header: &csv::StringRecord) -> Result<Self, TableError> {
        let names: Vec<String> = header.iter().map(|h| h.trim().to_lowercase()).collect();
        for (i, name) in names.iter().enumerate() {
            if let Some(first) = names[..i].iter().position(|n| n == name) {
                return Err(TableError::DuplicateColumn {
                    column: i + 1,
                    header: header.get(i).unwrap_or_default().to_string(),
                    first: first + 1,
                });
            }
        }
        let find = |name: &str| names.iter().position(|n| n == name);
        let required = required_columns();
        // A missing column is a wrong unit when another column names its quantity in another
        // unit (`leg_length_mm_1` for `leg_length_m_1`); columns the import does not read are
        // not looked at otherwise.
        let need = |name: &str| {
            find(name).ok_or_else(|| {
                let other = names.iter().enumerate().find_map(|(i, n)| {
                    wrong_unit(n)
                        .and_then(|(unit, expected)| (expected == name).then_some((i, unit)))
                });
                match other {
                    Some((i, unit)) => TableError::WrongUnit {
                        column: i + 1,
                        header: header.get(i).unwrap_or_default().to_string(),
                        unit,
                        expected: name.to_string(),
                    },
                    None => TableError::MissingColumn {
                        column: name.to_string(),
                        required: required.join(", "),
                    },
                }
            })
        };
        let mut sensors = [0; SENSOR_COLUMNS];
        for (slot, name) in sensors.iter_mut().zip(&required[2..]) {
            *slot = need(name)?;
        }
        Ok(Self {
            time: need(TIME)?,
            run: need(RUN)?,
            sensors,
            sequence: find(SEQUENCE),
            window: find(WINDOW),
        })
    }
}

/// One row: its line, run, frame and, when the table has a `window` column, its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Line in the file.
    pub line: u64,
    /// `tare` or `loaded`.
    pub run: Measurement,
    /// The frame (sequence 0 on every row when the table has no `sequence` column: the
    /// estimator then places the samples by their timestamps; status 0).
    pub frame: SensorFrame,
    /// In the fit window (`None`: the table has no `window` column).
    pub window: Option<bool>,
}

/// The table read row by row, each checked against the rows before it.
pub struct Table<R> {
    reader: csv::Reader<R>,
    columns: Columns,
    record: csv::StringRecord,
    header: Vec<String>,
    previous: Option<Row>,
    /// The current run's window rows began (and, with the previous row outside, ended).
    window_seen: bool,
}

impl<R: Read> Table<R> {
    /// Reads and checks the header of the CSV `input`.
    pub fn new(input: R) -> Result<Self, TableError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .from_reader(input);
        let header = reader.headers().map_err(csv_error)?.clone();
        let columns = Columns::of(&header)?;
        Ok(Self {
            reader,
            columns,
            record: csv::StringRecord::new(),
            header: header.iter().map(str::to_string).collect(),
            previous: None,
            window_seen: false,
        })
    }

    /// The table has a `sequence` column.
    pub fn has_sequence(&self) -> bool {
        self.columns.sequence.is_some()
    }

    /// The next row, `None` after the last. The first call that finds no row at all gives
    /// [`TableError::NoRows`].
    pub fn next_row(&mut self) -> Result<Option<Row>, TableError> {
        if !self
            .reader
            .read_record(&mut self.record)
            .map_err(csv_error)?
        {
            return match self.previous {
                None => Err(TableError::NoRows),
                Some(_) => Ok(None),
            };
        }
        let row = self.parse()?;
        if self.previous.is_none_or(|p| p.run != row.run) {
            self.window_seen = false;
        }
        if row.window == Some(true) {
            let closed = self
                .previous
                .is_some_and(|p| p.run == row.run && p.window == Some(false));
            if closed && self.window_seen {
                return Err(TableError::WindowReopened {
                    line: row.line,
                    column: self.columns.window.map_or(0, |i| i + 1),
                    run: row.run.name(),
                });
            }
            self.window_seen = true;
        }
        self.previous = Some(row);
        Ok(Some(row))
    }

    fn cell(&self, index: usize) -> &str {
        self.record.get(index).unwrap_or_default()
    }

    fn bad(&self, index: usize, expected: &'static str) -> TableError {
        TableError::BadCell {
            line: self.line(),
            column: index + 1,
            header: self.header.get(index).cloned().unwrap_or_default(),
            cell: self.cell(index).to_string(),
            expected,
        }
    }

    fn line(&self) -> u64 {
        self.record.position().map_or(0, |p| p.line())
    }

    fn parse(&self) -> Result<Row, TableError> {
        let c = &self.columns;
        let line = self.line();
        let time_s: f64 = match self.cell(c.time).parse::<f64>() {
            Ok(t) if t.is_finite() => t,
            _ => return Err(self.bad(c.time, "a finite time in seconds")),
        };
        let run = match self.cell(c.run).to_lowercase().as_str() {
            "tare" => Measurement::Tare,
            "loaded" => Measurement::Loaded,
            _ => return Err(self.bad(c.run, "`tare` or `loaded`")),
        };
        let mut v = [0.0; SENSOR_COLUMNS];
        for (value, &i) in v.iter_mut().zip(&c.sensors) {
            // `NaN` and `inf` parse: the rig's invalid readings pass through to the estimator.
            *value = self
                .cell(i)
                .parse()
                .map_err(|_| self.bad(i, "a number (or NaN)"))?;
        }
        let sequence = match c.sequence {
            Some(i) => self
                .cell(i)
                .parse::<u64>()
                .map_err(|_| self.bad(i, "a whole number ≥ 0"))?,
            None => 0,
        };
        let window = match c.window.map(|i| (i, self.cell(i))) {
            None => None,
            Some((_, "1")) => Some(true),
            Some((_, "0")) => Some(false),
            Some((i, _)) => return Err(self.bad(i, "0 or 1")),
        };
        if let Some(p) = &self.previous {
            if time_s <= p.frame.time_s {
                return Err(TableError::TimeNotIncreasing {
                    line,
                    column: c.time + 1,
                    time_s,
                    previous_s: p.frame.time_s,
                });
            }
            if p.run == Measurement::Loaded && run == Measurement::Tare {
                return Err(TableError::TareAfterLoaded {
                    line,
                    column: c.run + 1,
                });
            }
            if let Some(i) = c.sequence {
                if p.run == run && sequence <= p.frame.sequence {
                    return Err(TableError::SequenceNotIncreasing {
                        line,
                        column: i + 1,
                        sequence,
                        previous: p.frame.sequence,
                    });
                }
            }
        }
        let take = |k: usize| -> [f64; 3] { [v[k], v[k + 1], v[k + 2]] };
        let frame = SensorFrame {
            sequence,
            time_s,
            leg_lengths_m: [v[0], v[1], v[2], v[3], v[4], v[5]],
            leg_forces_n: [v[6], v[7], v[8], v[9], v[10], v[11]],
            gyro_rad_s: take(12),
            accel_m_s2: take(15),
            status: Status(0),
        };
        Ok(Row {
            line,
            run,
            frame,
            window,
        })
    }
}

fn csv_error(e: csv::Error) -> TableError {
    TableError::Csv {
        line: e.position().map_or(0, |p| p.line()),
        message: match e.kind() {
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => format!("{len} cells, the header has {expected_len}"),
            _ => e.to_string(),
        },
    }
}
