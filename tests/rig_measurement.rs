//! A whole `stewart rig` measurement (tare session, payload on, loaded session) against
//! `stewart emulate` on loopback UDP, compared with `stewart simulate` on the same scenario:
//! the rig's estimate must agree with the emulator's truth as well as the simulation's does.

use crate::support;

use measure::End;
use runlog::rig_record::LINK;
use support::*;

/// (name, estimate, sigma) of every reported quantity.
fn quantities(report: &serde_json::Value) -> Vec<(String, f64, f64)> {
    let e = &report["estimate"];
    let s = &report["sigma"];
    let mut out = vec![(
        "mass".to_string(),
        e["mass"].as_f64().unwrap(),
        s["mass"].as_f64().unwrap(),
    )];
    for i in 0..3 {
        out.push((
            format!("com[{i}]"),
            e["com"][i].as_f64().unwrap(),
            s["com"][i].as_f64().unwrap(),
        ));
    }
    for (r, c) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
        out.push((
            format!("J_C[{r}][{c}]"),
            e["inertia_com"][r][c].as_f64().unwrap(),
            s["inertia_com"][r][c].as_f64().unwrap(),
        ));
    }
    out
}

fn truth_values(scenario: &std::path::Path) -> Vec<f64> {
    let (m, c, j) = truth(scenario);
    let mut out = vec![m, c[0], c[1], c[2]];
    for (r, k) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
        out.push(j[r][k]);
    }
    out
}

#[test]
fn a_rig_measurement_agrees_with_truth_as_well_as_simulate() {
    let _lock = real_time();
    let scratch = Scratch::new(RIG_SHORT);
    let truth = truth_values(&scratch.config);

    // The reference: simulate on the same scenario.
    let sim_report = scratch.path("sim.json");
    let sim_args = simulate_args(Some(scratch.config.clone()), scratch.path("sim.mcap"));
    let sim = support::run_simulate(&sim_args).unwrap();
    let sim_json = serde_json::to_value(sim.report.as_ref().unwrap()).unwrap();
    std::fs::write(&sim_report, sim_json.to_string()).unwrap();

    // The rig, against the emulator: tare session, payload on, loaded session.
    let emulator = start(&emulate_args_fast(&scratch));
    let log = scratch.path("rig.mcap");
    let args = rig_against(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::Both,
    );
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(outcome.exit_code(), ops::exit::DONE);
    // The rig's log draws as simulate's does (`--plot`).
    let figures = figures::plot_log(&log, &scratch.path("figures")).unwrap();
    assert!(!figures.is_empty(), "the rig's log drew no figures");
    // Two sessions from one host: the tare with the fixture empty, then loaded.
    assert_eq!(sessions.len(), 2, "{sessions:?}");
    assert_eq!(sessions[0].peer, sessions[1].peer);
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());

    // The report: simulate's shape, no truth, plus the link of both measurements.
    let report: serde_json::Value =
        serde_json::from_str(&outcome.report_json().expect("a report")).unwrap();
    assert!(report.get("truth").is_none());
    assert_eq!(report["run"]["backend"], "rig");
    let link = report["link"].as_array().unwrap();
    assert_eq!(link.len(), 2);
    assert_eq!(link[0]["run"], "tare");
    assert_eq!(link[1]["run"], "loaded");
    for l in link {
        let c = &l["counters"];
        assert!(c["accepted"].as_u64().unwrap() > 5000, "{c}");
        assert_eq!(c["corrupt"], 0);
        assert_eq!(c["foreign"], 0);
        assert!(l["timing"]["median_period_s"].as_f64().unwrap() > 0.0);
    }
    let (rig_samples, sim_samples) = (
        report["samples"].as_u64().unwrap() as f64,
        sim_json["samples"].as_u64().unwrap() as f64,
    );
    assert!((rig_samples - sim_samples).abs() <= 0.02 * sim_samples);

    // The same world weighs the same through the emulated rig: the payload's mass within half
    // a sigma of simulate's (regression: the emulator put the payload on at the session's
    // start, so the brake hold took the plate's sag onto its brakes into the accelerometer's
    // offset: 1.1 kg apart, and 3.3 kg off the truth under load).
    let mass = |r: &serde_json::Value| r["estimate"]["mass"].as_f64().unwrap();
    let sim_mass_sigma = sim_json["sigma"]["mass"].as_f64().unwrap();
    assert!(
        (mass(&report) - mass(&sim_json)).abs() <= 0.5 * sim_mass_sigma,
        "the rig weighs {} kg, simulate {} kg (sigma {sim_mass_sigma})",
        mass(&report),
        mass(&sim_json)
    );

    // As well as simulate: every quantity within 4 of simulate's error or sigma, whichever
    // is larger, and within 4 of its own sigma.
    let rig_q = quantities(&report);
    let sim_q = quantities(&sim_json);
    for (((name, rig, rig_sigma), (_, sim, sim_sigma)), truth) in
        rig_q.iter().zip(&sim_q).zip(&truth)
    {
        let rig_error = (rig - truth).abs();
        let sim_error = (sim - truth).abs();
        eprintln!(
            "{name:8} truth {truth:10.4}  rig {rig:10.4} ± {rig_sigma:.4}  sim {sim:10.4} ± {sim_sigma:.4}"
        );
        assert!(
            rig_error <= 4.0 * sim_error.max(*sim_sigma),
            "{name}: rig error {rig_error} against simulate's {sim_error} (sigma {sim_sigma})"
        );
        assert!(
            rig_error <= 4.0 * rig_sigma,
            "{name}: rig error {rig_error} is {:.1} of its sigma {rig_sigma}",
            rig_error / rig_sigma
        );
    }

    // The log: a rig run, no truth, the link records of both sessions.
    let messages = read_log(&log);
    let metadata = on(&messages, "/run/metadata");
    assert_eq!(metadata[0]["backend"], "rig");
    assert_eq!(metadata[0]["command"], "rig");
    assert!(on(&messages, "/run/truth").is_empty());
    let records = on(&messages, LINK);
    let events: Vec<(&str, &str)> = records
        .iter()
        .map(|r| (r["run"].as_str().unwrap(), r["event"].as_str().unwrap()))
        .collect();
    assert_eq!(
        events,
        [
            ("tare", "session"),
            ("tare", "end"),
            ("loaded", "session"),
            ("loaded", "end")
        ]
    );
    assert!(records[3]["fault"].is_null());
    let sensors = support::sensor_frames(&log);
    let tare_frames = sensors.iter().filter(|s| s.run == "tare").count();
    assert!(tare_frames > 5000 && sensors.len() > 2 * 5000);
}

/// A surveyed rig off the symmetric layout (configs/surveyed-noise-only.toml: unequal pair
/// separations, every joint 1-3 cm off) measures through the emulated link as it simulates:
/// the emulator builds the world on those joints, the host's kinematics and estimator use
/// them, and the payload's mass and centre of mass land within 4 sigma of the world's.
#[test]
fn a_surveyed_irregular_rig_measures_through_the_link() {
    let _lock = real_time();
    let surveyed = include_str!("../configs/surveyed-noise-only.toml");
    let scratch = Scratch::new(&format!("{surveyed}\n{RIG_SHORT}"));
    let truth = truth_values(&scratch.config);
    let emulator = start(&emulate_args_fast(&scratch));
    let log = scratch.path("rig.mcap");
    let args = rig_against(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::Both,
    );
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    let report: serde_json::Value =
        serde_json::from_str(&outcome.report_json().expect("a report")).unwrap();
    for ((name, got, sigma), want) in quantities(&report).iter().zip(&truth).take(4) {
        assert!(
            (got - want).abs() <= 4.0 * sigma,
            "{name}: {got} ± {sigma} against the world's {want}"
        );
    }
    // The log records the surveyed joints, and re-estimating it gives the rig's report.
    let again = ops::estimate::run(&ops::estimate::EstimateOptions {
        log: log.clone(),
        ..Default::default()
    })
    .unwrap_or_else(|e| panic!("estimate: {e}"));
    let mass = report["estimate"]["mass"].as_f64().unwrap();
    assert!(
        (again.report.estimate.mass - mass).abs() <= 1e-9 * mass,
        "estimate {} kg, the rig {mass} kg",
        again.report.estimate.mass
    );
}
