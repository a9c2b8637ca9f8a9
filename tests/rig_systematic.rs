//! The systematic part of a `stewart rig` report (accelerometer bias and load-cell zero
//! offsets, the payload's share: loaded effect minus the tare's) is the one `stewart estimate`
//! computes on the run's log, both with the tare measured in the same invocation and with a
//! saved tare (`rig measure --tare FILE`, whose file keeps the tare run's sensitivities).

use crate::support;

use measure::report::{Quantities, Report};
use measure::End;
use measure::TareFile;
use ops::estimate::{reestimate, SettingsOverride};
use runlog::LogContents;
use std::path::Path;
use support::*;

fn numbers(q: &Quantities) -> Vec<f64> {
    let mut v = vec![q.mass];
    v.extend(q.com);
    v.extend(q.inertia_com.iter().flatten());
    v
}

/// Every number of the error budget, line by line.
fn budget_numbers(r: &Report) -> Vec<f64> {
    r.error_budget
        .iter()
        .flat_map(|l| numbers(&l.sigma))
        .collect()
}

/// Runs the rig session `plan` against the rig at `address` with the scenario `config`,
/// logged to `log` ([`rig_against`]), the measured tare saved to `save_tare` (or the saved
/// tare subtracted, with [`ops::rig::RigPlan::MeasureOnly`]), to completion and returns its
/// report.
fn rig_report(
    config: &Path,
    address: &str,
    log: &Path,
    plan: ops::rig::RigPlan,
    tare: Option<&Path>,
) -> Report {
    let mut run = rig_against(config, address, log, plan.clone());
    match plan {
        ops::rig::RigPlan::MeasureOnly => run.options.measure.tare = tare.map(Path::to_path_buf),
        _ => run.options.measure.save_tare = tare.map(Path::to_path_buf),
    }
    let outcome = run_rig(&run).unwrap_or_else(|e| panic!("rig: {e}"));
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    outcome
        .report
        .expect("a completed measurement has a report")
}

/// The rig's systematic sigma (and so its sigma) equals `estimate`'s on the same log.
fn assert_systematic_as_estimate(rig: &Report, log: &Path) {
    let log = LogContents::read(log).unwrap();
    let (offline, ..) = reestimate(&log, &SettingsOverride::default(), None, None).unwrap();
    eprintln!(
        "{} tare: systematic sigma mass {:.4e} kg, com z {:.4e} m, J_C xx {:.4e} kg·m² \
         (estimate {:.4e}, {:.4e}, {:.4e})",
        rig.tare.source,
        rig.systematic.sigma.mass,
        rig.systematic.sigma.com[2],
        rig.systematic.sigma.inertia_com[0][0],
        offline.systematic.sigma.mass,
        offline.systematic.sigma.com[2],
        offline.systematic.sigma.inertia_com[0][0],
    );
    assert_eq!(rig.tare.source, offline.tare.source);
    assert_eq!(
        rig.systematic.load_cell_bias_sigma_n,
        offline.systematic.load_cell_bias_sigma_n
    );
    for (part, online, offline) in [
        (
            "systematic",
            &rig.systematic.sigma,
            &offline.systematic.sigma,
        ),
        ("sigma", &rig.sigma, &offline.sigma),
    ] {
        for (i, (a, b)) in numbers(online).iter().zip(numbers(offline)).enumerate() {
            assert!(close(*a, b, 1e-9), "{part}[{i}]: rig {a:e}, estimate {b:e}");
        }
    }
    // The whole error budget alike.
    let (a, b) = (budget_numbers(rig), budget_numbers(&offline));
    assert_eq!(a.len(), b.len());
    for (i, (a, b)) in a.iter().zip(&b).enumerate() {
        assert!(
            close(*a, *b, 1e-9),
            "error_budget[{i}]: rig {a:e}, estimate {b:e}"
        );
    }
}

#[test]
fn the_rig_reports_the_systematic_part_estimate_computes() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args_fast(&scratch));
    let tare_path = scratch.path("tare.json");

    // Tare session, payload on, loaded session; the tare saved on the way.
    let log = scratch.path("rig.mcap");
    let report = rig_report(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::Both,
        Some(&tare_path),
    );
    assert!(report.systematic.load_cell_bias_sigma_n > 0.0);
    assert!(report.systematic.accel_bias_sigma_m_s2 > 0.0);
    assert_eq!(report.tare.source, "measured");
    assert_systematic_as_estimate(&report, &log);

    // The saved tare keeps the tare run's sensitivities ...
    let saved: TareFile =
        serde_json::from_str(&std::fs::read_to_string(&tare_path).unwrap()).unwrap();
    let sensitivity = saved
        .load_cell_offset_sensitivity
        .expect("the saved tare keeps its load-cell sensitivity");
    assert!(sensitivity.iter().flatten().any(|v| *v != 0.0));
    assert!(saved.accel_bias_sensitivity.is_some());

    // ... so a measurement with it counts the tare's share as `estimate` does (the emulator's
    // third session: the payload stays on).
    let log = scratch.path("measure.mcap");
    let with_file = rig_report(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::MeasureOnly,
        Some(&tare_path),
    );
    assert_eq!(with_file.tare.source, "file");
    assert_systematic_as_estimate(&with_file, &log);
    // Without the tare's share the payload's systematic sigma would be the loaded run's
    // effect alone: for the mass, much larger (most of the cells' offset cancels).
    let mut old = saved.clone();
    old.accel_bias_sensitivity = None;
    old.load_cell_offset_sensitivity = None;
    old.budget = None;
    let old_path = scratch.path("old-tare.json");
    std::fs::write(&old_path, serde_json::to_string(&old).unwrap()).unwrap();
    let log = LogContents::read(&log).unwrap();
    let (zero_share, ..) =
        reestimate(&log, &SettingsOverride::default(), Some(&old_path), None).unwrap();
    eprintln!(
        "file tare without sensitivities: systematic sigma mass {:.4e} kg",
        zero_share.systematic.sigma.mass
    );
    assert!(
        zero_share.systematic.sigma.mass > with_file.systematic.sigma.mass,
        "zero share {} against {}",
        zero_share.systematic.sigma.mass,
        with_file.systematic.sigma.mass
    );
    emulator.stop().unwrap();
}

/// The rig's report takes its sensor figures from the rig description, not from any simulator
/// preset: a worse accelerometer bias figure widens its systematic sigma, and its gyro noise
/// density reaches the estimator's logged settings. (The emulated gyro stays as the scratch
/// scenario says, so the figure changes only a little: the estimator's errors-in-variables
/// correction assumes what it is told.)
#[test]
fn a_datasheet_figure_in_the_rig_description_reaches_the_rig_report() {
    let _lock = real_time();
    // The accelerometer's offset left in the readings, so that its datasheet bias is the
    // budget's line in both.
    let base = format!("{}\n[estimator]\nlocal_gravity_m_s2 = 0.0\n", quick());
    let scratch = Scratch::new(&base);
    let worse = scratch.path("worse.toml");
    std::fs::write(
        &worse,
        format!(
            "{base}\n[sensors.accelerometer]\nbias_m_s2 = 0.01\n\
             [sensors.gyro]\nnoise_density_rad_s_sqrt_hz = 6.0e-5\n"
        ),
    )
    .unwrap();
    let mut reports = Vec::new();
    for (name, config) in [("base", &scratch.config), ("worse", &worse)] {
        // A fresh emulator each: its first session is the empty fixture, the second loaded.
        let emulator = start(&emulate_args_fast(&scratch));
        let log = scratch.path(&format!("{name}.mcap"));
        let report = rig_report(
            config,
            emulator.address(),
            &log,
            ops::rig::RigPlan::Both,
            None,
        );
        let settings = LogContents::read(&log).unwrap();
        let gyro = settings.settings_of("loaded").unwrap().gyro_noise_rad_s;
        reports.push((report, gyro));
        emulator.stop().unwrap();
    }
    let ((base, base_gyro), (worse, worse_gyro)) = (&reports[0], &reports[1]);
    assert_eq!(base.systematic.accel_bias_sigma_m_s2, 1e-3);
    assert_eq!(worse.systematic.accel_bias_sigma_m_s2, 1e-2);
    // The bias's own line of the budget: ten times the figure, about ten times it.
    let bias = |r: &Report| r.budget_line("accel_bias").map_or(0.0, |q| q.mass);
    let ratio = bias(worse) / bias(base);
    assert!(
        (5.0..20.0).contains(&ratio),
        "accelerometer bias's mass sigma ratio {ratio}"
    );
    // Per-sample noise: density × √(500 Hz).
    assert!(
        close(*base_gyro, 5e-5 * 500f64.sqrt(), 1e-12),
        "{base_gyro}"
    );
    assert!(
        close(*worse_gyro, 6e-5 * 500f64.sqrt(), 1e-12),
        "{worse_gyro}"
    );
}
