//! `stewart import` round trip: a `simulate` run's sensor channel exported to CSV (the columns
//! of docs/import.md), imported with that run's rig description, gives the same estimate under
//! `stewart estimate` as the original log, to 1e-9 relative. The same through a tare-only
//! table, `estimate --save-tare` and a loaded-only table with `import --tare`; a NaN cell is
//! one rejected sample.

use crate::support;

use std::fmt::Write as _;
use std::path::Path;

use measure::report::{Quantities, Report};
use ops::estimate::stream::reestimate_file;
use ops::estimate::{EstimateOptions, SettingsOverride};
use ops::import::table::required_columns;
use ops::import::ImportOptions;
use runlog::LogContents;
use support::close;

/// Which optional columns the exported table has.
#[derive(Clone, Copy)]
struct Export {
    sequence: bool,
    window: bool,
    /// Seconds of rest kept before each run's excitation, the rows before left out (a table
    /// whose rest before the motion is shorter than the brake hold); all rows with `None`.
    rest_s: Option<f64>,
}

/// The sensor frames of `runs` in `log` as a CSV table. Numbers in Rust's shortest form that
/// parses back to the same f64, so the table loses nothing.
fn export(log: &LogContents, runs: &[&str], e: Export, to: &Path) {
    let mut header = required_columns();
    if e.sequence {
        header.push("sequence".into());
    }
    if e.window {
        header.push("window".into());
    }
    let mut text = header.join(",") + "\n";
    for run in runs {
        let settings = log.settings_of(run).expect("the run's settings");
        let start = settings.window_start_s.unwrap_or(f64::NEG_INFINITY);
        let end = settings.window_end_s.unwrap_or(f64::INFINITY);
        let from_s = e.rest_s.map_or(f64::NEG_INFINITY, |r| start - r);
        for f in log.sensors_of(run).filter(|f| f.time_s >= from_s) {
            let _ = write!(text, "{},{run}", f.time_s);
            let values = f.leg_lengths_m.iter().chain(&f.leg_forces_n);
            for v in values.chain(&f.gyro_rad_s).chain(&f.accel_m_s2) {
                let _ = write!(text, ",{v}");
            }
            if e.sequence {
                let _ = write!(text, ",{}", f.sequence);
            }
            if e.window {
                let inside = (start..=end).contains(&f.time_s);
                let _ = write!(text, ",{}", u8::from(inside));
            }
            text.push('\n');
        }
    }
    std::fs::write(to, text).unwrap();
}

fn numbers(q: &Quantities) -> Vec<f64> {
    let mut v = vec![q.mass];
    v.extend(q.com);
    v.extend(q.inertia_com.iter().flatten());
    v
}

/// The estimate, its sigma and the tare: what must not change.
fn figures(r: &Report) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    let groups = [
        ("estimate", numbers(&r.estimate)),
        ("sigma", numbers(&r.sigma)),
        ("tare.theta", r.tare.theta.to_vec()),
        ("residual.force", r.residual_rms.force_n.to_vec()),
        ("residual.torque", r.residual_rms.torque_nm.to_vec()),
        ("excitation_s", vec![r.excitation_s]),
    ];
    for (name, vals) in groups {
        for (i, v) in vals.into_iter().enumerate() {
            out.push((format!("{name}[{i}]"), v));
        }
    }
    out
}

fn assert_same(original: &Report, imported: &Report, tol: f64) {
    for ((name, a), (_, b)) in figures(original).iter().zip(figures(imported)) {
        assert!(close(*a, b, tol), "{name}: original {a:e}, imported {b:e}");
    }
    assert_eq!(original.samples, imported.samples);
    assert_eq!(original.rejected_samples, imported.rejected_samples);
}

fn estimate(log: &Path) -> Report {
    reestimate_file(log, &SettingsOverride::default(), None, None)
        .unwrap_or_else(|e| panic!("{}: {e:#}", log.display()))
        .report
}

fn import(csv: &Path, rig: &Path, tare: Option<&Path>, out: &Path) {
    ops::import::run(&ImportOptions {
        csv: csv.to_path_buf(),
        rig: rig.to_path_buf(),
        out: Some(out.to_path_buf()),
        tare: tare.map(Path::to_path_buf),
    })
    .unwrap_or_else(|e| panic!("import {}: {e:#}", csv.display()));
}

#[test]
fn an_imported_simulate_run_gives_the_same_estimate() {
    let sim = support::simulate();
    let dir = sim.dir.path();
    let log = LogContents::read(&sim.log).unwrap();
    let meta = log.require_metadata().unwrap();
    // The run's own rig description, as the lab that owns the rig would write it.
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, &meta.config_toml).unwrap();
    let original = estimate(&sim.log);

    // Every column: the same frames, counter and window, so the same estimate bit for bit.
    let csv = dir.join("all.csv");
    let all = Export {
        sequence: true,
        window: true,
        rest_s: None,
    };
    export(&log, &["tare", "loaded"], all, &csv);
    let imported_log = dir.join("all.mcap");
    import(&csv, &rig, None, &imported_log);
    let imported = estimate(&imported_log);
    assert_same(&original, &imported, 1e-9);
    assert!(imported.truth.is_none(), "a CSV has no truth");

    // A NaN force in the loaded run's window passes to the estimator, which rejects the sample.
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let last_in_window = lines
        .iter()
        .rposition(|l| l.contains(",loaded,") && l.ends_with(",1"))
        .expect("a loaded window row");
    let mut cells: Vec<&str> = lines[last_in_window].split(',').collect();
    cells[8] = "NaN"; // leg_force_n_1
    lines[last_in_window] = cells.join(",");
    let nan_csv = dir.join("nan.csv");
    std::fs::write(&nan_csv, lines.join("\n") + "\n").unwrap();
    let nan_log = dir.join("nan.mcap");
    import(&nan_csv, &rig, None, &nan_log);
    let with_nan = estimate(&nan_log);
    assert_eq!(with_nan.rejected_samples, original.rejected_samples + 1);
    assert_eq!(with_nan.samples + 1, original.samples);

    // No counter: the estimator places the samples by their timestamps, exact while the
    // jitter stays under a quarter period, so the same samples on the same grid.
    let csv = dir.join("no-sequence.csv");
    let timestamps = Export {
        sequence: false,
        ..all
    };
    export(&log, &["tare", "loaded"], timestamps, &csv);
    let imported_log = dir.join("no-sequence.mcap");
    import(&csv, &rig, None, &imported_log);
    assert_same(&original, &estimate(&imported_log), 1e-9);

    // The tare on its own: a tare-only table, `estimate --save-tare`, a loaded-only table.
    let tare_csv = dir.join("tare.csv");
    export(&log, &["tare"], all, &tare_csv);
    let tare_log = dir.join("tare.mcap");
    import(&tare_csv, &rig, None, &tare_log);
    let tare_file = dir.join("tare.json");
    let saved = ops::estimate::save_tare(
        &EstimateOptions {
            log: tare_log,
            ..EstimateOptions::default()
        },
        &tare_file,
    )
    .unwrap();
    assert!(!saved.has_loaded);
    let loaded_csv = dir.join("loaded.csv");
    export(&log, &["loaded"], all, &loaded_csv);
    let loaded_log = dir.join("loaded.mcap");
    import(&loaded_csv, &rig, Some(&tare_file), &loaded_log);
    let with_file = estimate(&loaded_log);
    for ((name, a), (_, b)) in figures(&original).iter().zip(figures(&with_file)) {
        if name.starts_with("estimate") || name.starts_with("tare") {
            assert!(
                close(*a, b, 1e-9),
                "{name}: original {a:e}, with the tare file {b:e}"
            );
        }
    }
}

/// A table whose motion starts 1 s in, sooner than the rig description's brake hold (2 s):
/// the static weighing takes the rest the data holds, not the hold's length of rows, with a
/// `window` column and without one (the rows before the first motion are then the rest), and
/// agrees with the dynamic fit and with the simulated world's payload.
#[test]
fn a_table_with_one_second_of_rest_weighs_its_rest_only() {
    let sim = support::simulate();
    let dir = sim.dir.path();
    let log = LogContents::read(&sim.log).unwrap();
    let meta = log.require_metadata().unwrap();
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, &meta.config_toml).unwrap();
    let truth = sim.report.truth.as_ref().expect("a simulation's truth");
    for window in [true, false] {
        let e = Export {
            sequence: true,
            window,
            rest_s: Some(1.0),
        };
        let csv = dir.join(format!("rest-{window}.csv"));
        export(&log, &["tare", "loaded"], e, &csv);
        let imported = dir.join(format!("rest-{window}.mcap"));
        import(&csv, &rig, None, &imported);
        let report = estimate(&imported);
        let w = report
            .static_weighing
            .as_ref()
            .unwrap_or_else(|| panic!("window column {window}: no static weighing"));
        let p = &w.payload;
        let rows = [
            ("mass", p.mass_kg, p.sigma_mass_kg, truth.mass),
            ("c_x", p.com_xy_m[0], p.sigma_com_xy_m[0], truth.com[0]),
            ("c_y", p.com_xy_m[1], p.sigma_com_xy_m[1], truth.com[1]),
        ];
        for (name, got, sigma, want) in rows {
            assert!(
                (got - want).abs() <= 3.0 * sigma,
                "window column {window}, {name}: static {got} ± {sigma}, world {want} ({:.1} σ)",
                (got - want) / sigma
            );
        }
        assert!(
            w.check.is_some_and(|c| c.agrees),
            "window column {window}: static and dynamic disagree: {:?}",
            w.check
        );
    }
}

/// A surveyed rig off the symmetric layout (configs/surveyed-noise-only.toml) imports as the
/// default does: its run's table and its rig description, as the lab that surveyed it would
/// write them, give the same estimate as the log.
#[test]
fn a_surveyed_irregular_rigs_table_gives_the_same_estimate() {
    let surveyed = include_str!("../configs/surveyed-noise-only.toml");
    let sim = support::simulate_with(&format!("{surveyed}\n{}", support::SHORT), |_, _| {});
    let dir = sim.dir.path();
    let log = LogContents::read(&sim.log).unwrap();
    let rig = dir.join("surveyed.toml");
    std::fs::write(&rig, &log.require_metadata().unwrap().config_toml).unwrap();
    let csv = dir.join("surveyed.csv");
    let all = Export {
        sequence: true,
        window: true,
        rest_s: None,
    };
    export(&log, &["tare", "loaded"], all, &csv);
    let imported_log = dir.join("surveyed.mcap");
    import(&csv, &rig, None, &imported_log);
    assert_same(&estimate(&sim.log), &estimate(&imported_log), 1e-9);
}
