//! `stewart estimate` on a `simulate` log: with the recorded settings it reproduces the online
//! report to 1e-9 relative (in practice bit for bit: the simulator's frames are read at the
//! log's resolution, so the estimator saw the numbers the log holds), the same log with
//! `/sensors` in JSON is refused clearly, other settings change the estimate, and a log without
//! a needed channel is refused with the channel's name.

use crate::support;

use measure::report::{Quantities, Report};
use ops::estimate::{reestimate, EstimateOptions, SettingsOverride, Window};
use runlog::LogContents;
use support::close;

fn numbers(q: &Quantities) -> Vec<f64> {
    let mut v = vec![q.mass];
    v.extend(q.com);
    v.extend(q.inertia_com.iter().flatten());
    v
}

/// Every number of the report that comes from the estimator.
fn report_numbers(r: &Report) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    let mut add = |name: &str, vals: Vec<f64>| {
        for (i, v) in vals.into_iter().enumerate() {
            out.push((format!("{name}[{i}]"), v));
        }
    };
    add("estimate", numbers(&r.estimate));
    add("sigma", numbers(&r.sigma));
    add("principal.moments", r.principal.moments.to_vec());
    add(
        "principal.axes",
        r.principal.axes.iter().flatten().copied().collect(),
    );
    add("excitation_s", vec![r.excitation_s]);
    add("residual.force", r.residual_rms.force_n.to_vec());
    add("residual.torque", r.residual_rms.torque_nm.to_vec());
    add("tare.theta", r.tare.theta.to_vec());
    add("tare.sigma", r.tare.sigma.to_vec());
    add("systematic.sigma", numbers(&r.systematic.sigma));
    add("systematic.bias", vec![r.systematic.accel_bias_sigma_m_s2]);
    for line in &r.error_budget {
        add(
            &format!("error_budget.{}", line.source),
            numbers(&line.sigma),
        );
    }
    out
}

fn assert_reproduces(online: &Report, offline: &Report) {
    let (online_numbers, offline_numbers) = (report_numbers(online), report_numbers(offline));
    // Same names in the same order (the budget's lines included), so the zip below pairs every
    // number with its counterpart and leaves none out.
    let names = |v: &[(String, f64)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&online_numbers), names(&offline_numbers));
    for ((name, a), (_, b)) in online_numbers.iter().zip(offline_numbers) {
        assert!(close(*a, b, 1e-9), "{name}: online {a:e}, offline {b:e}");
    }
    assert_eq!(online.samples, offline.samples);
    assert_eq!(online.rejected_samples, offline.rejected_samples);
    assert_eq!(online.convergence, offline.convergence);
    assert_eq!(online.consistency, offline.consistency);
    assert_eq!(online.truth, offline.truth);
    assert_eq!(online.tare.source, offline.tare.source);
}

#[test]
fn estimate_reproduces_the_online_report_and_refuses_a_missing_channel() {
    let run = support::simulate();
    let dir = run.dir.path();
    let report_path = dir.join("offline.json");
    let outcome = ops::estimate::run(&EstimateOptions {
        log: run.log.clone(),
        report: Some(report_path.clone()),
        ..EstimateOptions::default()
    })
    .unwrap();
    assert_reproduces(&run.report, &outcome.report);
    // The report file is the same report.
    let written: Report =
        serde_json::from_str(&std::fs::read_to_string(&report_path).unwrap()).unwrap();
    assert_eq!(written, outcome.report);
    // The same log in JSON (an encoding this version does not read for /sensors): refused,
    // naming the channel, what it is and what this version reads.
    let json_log = dir.join("json.mcap");
    support::copy_as_json(&run.log, &json_log);
    let err = ops::estimate::run(&EstimateOptions {
        log: json_log,
        ..EstimateOptions::default()
    })
    .unwrap_err();
    let text = format!("{err:#}");
    assert!(
        text.contains("/sensors channel is stewart.SensorBlock in json encoding")
            && text.contains("reads stewart.SensorBlock in protobuf"),
        "{text}"
    );
    // Other settings give another estimate (the option reaches the estimator).
    let log = LogContents::read(&run.log).unwrap();
    let (other, ..) = reestimate(
        &log,
        &SettingsOverride {
            cutoff_hz: Some(8.0),
            window: Some(Window {
                start_s: Some(1.0),
                end_s: None,
            }),
            ..SettingsOverride::default()
        },
        None,
        None,
    )
    .unwrap();
    assert!(other.samples < run.report.samples);
    assert!(other.estimate.mass != run.report.estimate.mass);
    assert!(close(other.estimate.mass, run.report.estimate.mass, 0.05));
    // A window shorter than the run's gets half-blocks short enough for a measured sigma, as
    // a measurement of that length would (2.5 s: 0.25 s half-blocks and seven windows, where
    // the recorded 0.4 s would give three and refuse the report).
    let (short, ..) = reestimate(
        &log,
        &SettingsOverride {
            window: Some(Window {
                start_s: Some(0.5),
                end_s: Some(3.0),
            }),
            ..SettingsOverride::default()
        },
        None,
        None,
    )
    .unwrap_or_else(|e| panic!("a 2.5 s window: {e:#}"));
    let basis = &short.covariance_basis;
    assert!(
        (basis.half_block_s - 0.25).abs() < 1e-9 && basis.loaded_windows >= 6,
        "{basis:?}"
    );
    assert!((run.report.covariance_basis.half_block_s - 0.4).abs() < 1e-9);

    // Without /sensors, or without the estimator's settings, the log is refused by name.
    for topic in ["/sensors", "/run/estimator", "/run/metadata"] {
        let cut = dir.join(format!("without{}.mcap", topic.replace('/', "_")));
        support::copy_without(&run.log, &cut, topic);
        let err = ops::estimate::run(&EstimateOptions {
            log: cut,
            ..EstimateOptions::default()
        })
        .unwrap_err();
        let text = format!("{err:#}");
        assert!(text.contains(topic), "{topic}: {text}");
    }
}
