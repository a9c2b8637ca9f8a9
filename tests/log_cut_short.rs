//! A log cut short, as after a crash, still opens up to its last complete chunk, and
//! `stewart estimate` uses what is there: the estimate it makes at the last logged `/estimate`
//! instant is the one the run logged there.

use crate::support;

use ops::estimate::{reestimate_run, rig_description, EstimateOptions, SettingsOverride};
use runlog::LogContents;
use support::close;

#[test]
fn a_log_cut_short_opens_and_estimate_uses_what_is_there() {
    let run = support::simulate();
    let bytes = std::fs::read(&run.log).unwrap();
    let full = LogContents::from_bytes(&bytes).unwrap();
    let loaded_end_s = full.settings_of("loaded").unwrap().window_end_s.unwrap();

    // Cut inside the loaded run's excitation, mid-chunk: try shorter and shorter files.
    let mut cut = None;
    for percent in (50..95).rev().step_by(3) {
        let n = bytes.len() * percent / 100 + 1234;
        let log = LogContents::from_bytes(&bytes[..n]).unwrap();
        let last = log.estimates.iter().rev().find(|e| e.run == "loaded");
        if last.is_some_and(|e| e.time_s < loaded_end_s - 1.0) {
            cut = Some((n, log));
            break;
        }
    }
    let (n, log) = cut.expect("a cut inside the loaded excitation");
    assert!(
        log.truncated.is_some(),
        "the reader says the log ends early"
    );
    assert!(log.sensors.len() < full.sensors.len());
    assert!(!log.sensors.is_empty());
    // What is read is exactly the start of the full log.
    assert_eq!(log.sensors[..], full.sensors[..log.sensors.len()]);
    assert_eq!(
        log.metadata.as_ref().unwrap().seed,
        full.metadata.unwrap().seed
    );

    // The mcap crate's own stream gives the same messages before the cut chunk, and also those
    // it decompresses from the cut chunk's start before its error; the reader keeps only
    // chunks whose CRC it checked, so it gives fewer, by less than a chunk (160 KiB).
    let ok = support::readable_records(&bytes[..n]);
    let read = log.channels.values().map(|c| c.count).sum::<u64>();
    assert!(
        read <= ok && ok - read < 2000,
        "{read} read, {ok} by the mcap crate"
    );

    // Re-estimating the cut loaded run reproduces its last logged estimate.
    let last = log
        .estimates
        .iter()
        .rev()
        .find(|e| e.run == "loaded")
        .unwrap();
    let rig = rig_description(&log, None).unwrap();
    let offline = reestimate_run(&log, &rig, "loaded", &SettingsOverride::default()).unwrap();
    let at = offline
        .replay
        .trace
        .iter()
        .find(|p| p.time_s == last.time_s)
        .expect("an offline estimate at the logged instant");
    assert_eq!(at.estimate.counts.used, last.samples);
    let theta = at.estimate.parameters.to_vector();
    let sigma = at.estimate.parameter_sigma;
    for i in 0..10 {
        assert!(close(theta[i], last.theta[i], 1e-9), "θ[{i}]");
        assert!(close(sigma[i], last.theta_sigma[i], 1e-9), "σ[{i}]");
    }

    // The command itself opens the cut file and reports on the part that is there.
    let path = run.dir.path().join("cut.mcap");
    std::fs::write(&path, &bytes[..n]).unwrap();
    let outcome = ops::estimate::run(&EstimateOptions {
        log: path,
        ..EstimateOptions::default()
    })
    .unwrap();
    assert!(outcome.report.samples < run.report.samples);
    assert!(outcome.report.samples >= last.samples);
    assert!(close(
        outcome.report.estimate.mass,
        run.report.estimate.mass,
        0.05
    ));
}
