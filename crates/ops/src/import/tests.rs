//! The table's refusals, each with its line and column, and what it passes.

use super::table::{required_columns, Table, TableError};
use measure::Measurement;

/// The documented header, with `extra` columns appended.
fn header(extra: &[&str]) -> String {
    let mut h = required_columns();
    h.extend(extra.iter().map(|s| s.to_string()));
    h.join(",")
}

/// A row of `run` at `time_s` with plausible values, `extra` cells appended.
fn row(time_s: &str, run: &str, extra: &[&str]) -> String {
    let mut cells = vec![time_s.to_string(), run.to_string()];
    cells.extend((0..6).map(|_| "2.0".to_string()));
    cells.extend((0..6).map(|i| format!("{}", 2000 + i)));
    cells.extend(["0.01", "-0.02", "0.03", "0.1", "0.2", "9.8"].map(String::from));
    cells.extend(extra.iter().map(|s| s.to_string()));
    cells.join(",")
}

/// Every row of `text`, or the first refusal.
fn read(text: &str) -> Result<Vec<super::table::Row>, TableError> {
    let mut t = Table::new(text.as_bytes())?;
    let mut rows = Vec::new();
    while let Some(r) = t.next_row()? {
        rows.push(r);
    }
    Ok(rows)
}

#[test]
fn columns_are_found_by_name_in_any_order_and_nan_passes() {
    let mut names = required_columns();
    names.reverse();
    let text = format!("{}\n{}\n", names.join(", "), {
        let mut cells: Vec<String> = row("0.5", "tare", &[])
            .split(',')
            .map(String::from)
            .collect();
        cells[8] = "NaN".into(); // leg_force_n_1 in the documented order
        cells.reverse();
        cells.join(",")
    });
    let rows = read(&text).unwrap();
    assert_eq!(rows.len(), 1);
    let f = rows[0].frame;
    assert_eq!(f.time_s, 0.5);
    assert_eq!(rows[0].run, Measurement::Tare);
    assert!(f.leg_forces_n[0].is_nan());
    assert_eq!(f.leg_forces_n[1], 2001.0);
    assert_eq!(f.accel_m_s2, [0.1, 0.2, 9.8]);
    assert_eq!(f.sequence, 0);
    assert_eq!(rows[0].line, 2);
}

#[test]
fn a_missing_column_is_named() {
    let text = header(&[]).replace(",gyro_rad_s_y", "") + "\n";
    match Table::new(text.as_bytes()) {
        Err(TableError::MissingColumn { column, .. }) => assert_eq!(column, "gyro_rad_s_y"),
        other => panic!("{:?}", other.err()),
    }
}

#[test]
fn a_wrong_unit_is_refused_with_its_column() {
    let text = header(&[]).replace("leg_length_m_3", "leg_length_mm_3") + "\n";
    match Table::new(text.as_bytes()) {
        Err(TableError::WrongUnit {
            column,
            unit,
            expected,
            ..
        }) => {
            assert_eq!((column, unit.as_str()), (5, "mm"));
            assert_eq!(expected, "leg_length_m_3");
        }
        other => panic!("{:?}", other.err()),
    }
    let text = header(&[]).replace("time_s", "time_ms") + "\n";
    assert!(matches!(
        Table::new(text.as_bytes()),
        Err(TableError::WrongUnit { column: 1, .. })
    ));
    let text = header(&[]).replace("gyro_rad_s_z", "gyro_deg_s_z") + "\n";
    let e = Table::new(text.as_bytes()).err().unwrap();
    assert!(
        e.to_string()
            .contains("column 17 `gyro_deg_s_z`: unit `deg_s`"),
        "{e}"
    );
}

#[test]
fn a_duplicate_column_is_refused() {
    let text = header(&["time_s"]) + "\n";
    assert!(matches!(
        Table::new(text.as_bytes()),
        Err(TableError::DuplicateColumn {
            column: 21,
            first: 1,
            ..
        })
    ));
}

#[test]
fn a_non_numeric_cell_is_refused_with_line_and_column() {
    let bad = row("0.002", "tare", &[]).replace("0.03", "x");
    let text = format!("{}\n{}\n{}\n", header(&[]), row("0.001", "tare", &[]), bad);
    let e = read(&text).unwrap_err();
    assert_eq!(
        e,
        TableError::BadCell {
            line: 3,
            column: 17,
            header: "gyro_rad_s_z".into(),
            cell: "x".into(),
            expected: "a number (or NaN)",
        }
    );
    assert!(
        e.to_string()
            .starts_with("line 3, column 17 `gyro_rad_s_z`"),
        "{e}"
    );
    let empty = row("0.002", "tare", &[]).replacen("2.0", "", 1);
    let text = format!("{}\n{}\n", header(&[]), empty);
    assert!(matches!(
        read(&text),
        Err(TableError::BadCell { column: 3, .. })
    ));
    let text = format!("{}\n{}\n", header(&[]), row("NaN", "tare", &[]));
    assert!(matches!(
        read(&text),
        Err(TableError::BadCell { column: 1, .. })
    ));
    let text = format!("{}\n{}\n", header(&[]), row("0.1", "payload", &[]));
    assert!(matches!(
        read(&text),
        Err(TableError::BadCell { column: 2, .. })
    ));
}

#[test]
fn time_must_increase_strictly() {
    let text = format!(
        "{}\n{}\n{}\n{}\n",
        header(&[]),
        row("0.001", "tare", &[]),
        row("0.002", "tare", &[]),
        row("0.002", "loaded", &[])
    );
    assert_eq!(
        read(&text).unwrap_err(),
        TableError::TimeNotIncreasing {
            line: 4,
            column: 1,
            time_s: 0.002,
            previous_s: 0.002
        }
    );
}

#[test]
fn the_tare_section_comes_first_and_the_counter_increases() {
    let text = format!(
        "{}\n{}\n{}\n",
        header(&[]),
        row("0.001", "loaded", &[]),
        row("0.002", "tare", &[])
    );
    assert!(matches!(
        read(&text),
        Err(TableError::TareAfterLoaded { line: 3, column: 2 })
    ));
    let text = format!(
        "{}\n{}\n{}\n{}\n",
        header(&["sequence"]),
        row("0.001", "tare", &["7"]),
        row("0.002", "loaded", &["3"]),
        row("0.003", "loaded", &["3"])
    );
    assert!(matches!(
        read(&text),
        Err(TableError::SequenceNotIncreasing {
            line: 4,
            column: 21,
            ..
        })
    ));
}

#[test]
fn the_window_is_one_block_of_zeros_and_ones() {
    let rows = |w: [&str; 4]| {
        let mut text = header(&["window"]) + "\n";
        for (i, w) in w.iter().enumerate() {
            text += &row(&format!("0.00{}", i + 1), "loaded", &[w]);
            text += "\n";
        }
        read(&text)
    };
    let ok = rows(["0", "1", "1", "0"]).unwrap();
    assert_eq!(ok[1].window, Some(true));
    assert!(matches!(
        rows(["1", "0", "1", "0"]),
        Err(TableError::WindowReopened {
            line: 4,
            column: 21,
            ..
        })
    ));
    assert!(matches!(
        rows(["0", "1", "yes", "0"]),
        Err(TableError::BadCell {
            line: 4,
            column: 21,
            ..
        })
    ));
}

#[test]
fn ragged_rows_and_empty_tables_are_refused() {
    let text = format!("{}\n{}\n", header(&[]), "0.1,tare,1.0");
    match read(&text) {
        Err(TableError::Csv { line: 2, message }) => {
            assert!(message.contains("3 cells"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(read(&(header(&[]) + "\n")).unwrap_err(), TableError::NoRows);
}

/// A table of `rows` rows of `run` every `step_s`, `window` the window column's cells (none:
/// no column), written to a file in `dir`.
fn table_file(
    dir: &std::path::Path,
    runs: &[(&str, usize)],
    step_s: f64,
    window: Option<&str>,
) -> std::path::PathBuf {
    let extra: &[&str] = if window.is_some() { &["window"] } else { &[] };
    let mut text = header(extra) + "\n";
    let mut k = 0;
    for (run, rows) in runs {
        for _ in 0..*rows {
            k += 1;
            let cells: Vec<&str> = window.into_iter().collect();
            text += &row(&format!("{}", k as f64 * step_s), run, &cells);
            text += "\n";
        }
    }
    let path = dir.join("data.csv");
    std::fs::write(&path, text).unwrap();
    path
}

/// The import's refusals of a readable table: no window rows, another sample rate, no tare
/// or two tares.
#[test]
fn the_import_refuses_what_the_estimate_could_not_use() {
    let dir = tempfile::tempdir().unwrap();
    let rig = rig_description::load::load(None).unwrap();
    let out = dir.path().join("out.mcap");
    let run = |csv: &std::path::Path, tare: Option<&std::path::Path>| {
        super::import(&super::ImportPlan {
            rig: &rig,
            csv,
            tare,
            out: &out,
        })
        .map(|_| ())
        .map_err(|e| format!("{e:#}"))
    };
    let period = 1.0 / rig.config.sensors.sample_rate_hz;
    let ok = table_file(dir.path(), &[("tare", 20), ("loaded", 20)], period, None);
    run(&ok, None).unwrap();
    let tare = dir.path().join("tare.json");
    let e = run(&ok, Some(&tare)).unwrap_err();
    assert!(
        e.contains("has a tare section") && e.contains("give one of them"),
        "{e}"
    );
    let slow = table_file(
        dir.path(),
        &[("tare", 20), ("loaded", 20)],
        2.0 * period,
        None,
    );
    let e = run(&slow, None).unwrap_err();
    assert!(
        e.contains("tare run (lines 2–21) is not sampled") && e.contains("0 of its 19"),
        "{e}"
    );
    let loaded = table_file(dir.path(), &[("loaded", 20)], period, None);
    let e = run(&loaded, None).unwrap_err();
    assert!(e.contains("no tare section"), "{e}");
    let never = table_file(
        dir.path(),
        &[("tare", 20), ("loaded", 20)],
        period,
        Some("0"),
    );
    let e = run(&never, None).unwrap_err();
    assert!(
        e.contains("the tare run (lines 2–21) has no row with window = 1"),
        "{e}"
    );
}
