//! `stewart rig --live` against `stewart emulate` on loopback UDP: a Foxglove WebSocket client
//! (`support::live`) connects while the rig runs its tare and loaded sessions, subscribes to
//! `/estimate`, `/tf` and the run's metadata, and decodes what it receives as the rig moves.
//! The rig serves the view from its log's writer thread (crate `live`), never from the
//! control loop; what the client gets is the log's messages byte for byte, the log is complete
//! (no message dropped, every sequence number), and the view kept up with the run instead of
//! arriving at its end.

use crate::support;

use std::time::{Duration, Instant};

use measure::End;
use support::live::{assert_in_log, free_port, plate_transform, LiveClient};
use support::*;

#[test]
fn a_foxglove_client_watches_a_rig_run_live() {
    let _lock = real_time();
    // The link tests' short run, with the shortest holds: the view is under test, not the
    // estimate.
    let scenario = quick()
        .replace("brake_hold_s = 2.0", "brake_hold_s = 0.2")
        .replace("settle_s = 0.5", "settle_s = 0.2")
        .replace("park_s = 1.0", "park_s = 0.5");
    let scratch = Scratch::new(&scenario);
    let emulator = start(&emulate_args(&scratch));
    let log = scratch.path("rig.mcap");
    let addr = free_port();
    let mut args = rig_against(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::Both,
    );
    args.options.measure.live = Some(addr);
    let started = Instant::now();
    let run = std::thread::spawn(move || run_rig(&args).map_err(|e| e.to_string()));

    let wanted = [
        runlog::messages::ESTIMATE,
        runlog::messages::TF,
        runlog::messages::METADATA,
    ];
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut client = LiveClient::connect(addr, deadline, &run, Some(&wanted));
    // Everything until the rig ends and its server closes the connection, with the arrival.
    let mut received = Vec::new();
    while let Some(m) = client.next_message() {
        received.push((Instant::now(), m));
    }
    let outcome = run
        .join()
        .unwrap()
        .unwrap_or_else(|e| panic!("rig --live: {e}"));
    let stopped = emulator.stop().unwrap();
    eprintln!("rig --live: {:?}", started.elapsed());
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    assert!(
        client
            .server_name
            .as_deref()
            .is_some_and(|n| n.starts_with("stewart")),
        "{:?}",
        client.server_name
    );

    let on = |topic: &str| {
        received
            .iter()
            .filter(move |(_, m)| m.topic == topic)
            .collect::<Vec<_>>()
    };
    // /tf: the SDK's FrameTransform of the plate, in log-time order, and the plate moved.
    let tf = on(runlog::messages::TF);
    assert!(tf.len() >= 50, "{} /tf messages", tf.len());
    assert!(tf.windows(2).all(|w| w[0].1.log_time < w[1].1.log_time));
    let heights: Vec<f64> = tf
        .iter()
        .map(|(_, m)| plate_transform(&m.data).translation.unwrap().z)
        .collect();
    let (low, high) = heights
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), z| {
            (l.min(*z), h.max(*z))
        });
    assert!(high - low > 1e-3, "the plate did not move: {low}..{high} m");
    // The view kept up: the /tf messages arrived over at least half the time they span in the
    // log (a view handed over at the run's end would arrive all at once).
    let arrival_span = tf.last().unwrap().0 - tf[0].0;
    let log_span = Duration::from_nanos(tf.last().unwrap().1.log_time - tf[0].1.log_time);
    assert!(
        arrival_span * 2 >= log_span,
        "/tf spanning {log_span:?} of log arrived within {arrival_span:?}"
    );
    // /estimate: the log's JSON, from both sessions (the view outlives the tare's session).
    let runs: Vec<String> = on(runlog::messages::ESTIMATE)
        .iter()
        .map(|(_, m)| {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            v["run"].as_str().unwrap_or_default().to_string()
        })
        .collect();
    assert!(runs.iter().any(|r| r == "tare"), "{runs:?}");
    assert!(runs.iter().any(|r| r == "loaded"), "{runs:?}");
    // The run's metadata, whenever the client subscribed.
    let meta = on(runlog::messages::METADATA);
    let meta: serde_json::Value = serde_json::from_slice(&meta[0].1.data).unwrap();
    assert_eq!(meta["command"], "rig");

    // Every message received is the log's, and the log is whole: finished and readable to its
    // last message, and no message dropped (the writer numbers the messages 1, 2, 3, …).
    let messages: Vec<_> = received.iter().map(|(_, m)| m.clone()).collect();
    assert_in_log(&messages, &log);
    let in_log = read_messages(&log);
    let log_tf = in_log
        .iter()
        .filter(|m| m.topic == runlog::messages::TF)
        .count();
    assert!(log_tf >= tf.len(), "{log_tf} /tf in the log");
    let bytes = std::fs::read(&log).unwrap();
    let sequences: Vec<u32> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap().sequence)
        .collect();
    assert!(
        sequences.iter().zip(1..).all(|(s, i)| *s == i),
        "a gap in the log's sequence numbers"
    );
    assert_eq!(sequences.len(), in_log.len());
}
