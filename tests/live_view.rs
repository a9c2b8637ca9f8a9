//! `--live`: a Foxglove WebSocket client connects to `stewart simulate --live` while the
//! simulation runs, reads the server's `serverInfo` and `advertise`, subscribes to `/estimate`,
//! `/tf` and the run's metadata, and decodes what it receives: the server's messages with the
//! Foxglove SDK's own protocol parser, `/tf` with the SDK's `FrameTransform` type, `/estimate`
//! as the JSON its channel says it is. Every message received is also in the log, byte for
//! byte, at the same log time: the live view and the log are two sinks of one message.

use crate::support;

use std::collections::HashMap;
use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use measure::End;
use support::live::{assert_in_log, free_port, plate_transform, LiveClient, LiveMessage};
use support::{simulate_args, Scratch, SHORT};

/// A short run: the shortest excitation the fades allow, for the tare run and the loaded one.
const LIVE: &str = "[run]\nduration_s = 4.0\ntare_duration_s = 4.0\n";

#[test]
fn a_foxglove_client_watches_a_simulation_live() {
    let scratch = Scratch::new(LIVE);
    let log = scratch.path("run.mcap");
    let addr = free_port();
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    args.measure.live = Some(addr);
    // Watched live, the simulation keeps to the wall clock: the client has time to connect,
    // and Ctrl-C (the interrupt flag) ends the run once the client has what it checks.
    let interrupt = Arc::new(AtomicBool::new(false));
    let run = {
        let interrupt = Arc::clone(&interrupt);
        std::thread::spawn(move || {
            let started = Instant::now();
            let outcome = ops::simulate::run(&args, &mut support::Silent, &interrupt)
                .unwrap_or_else(|e| panic!("simulate --live failed: {e}"));
            (outcome, started.elapsed())
        })
    };

    let deadline = Instant::now() + Duration::from_secs(60);
    let wanted = [
        runlog::messages::ESTIMATE,
        runlog::messages::TF,
        runlog::messages::METADATA,
    ];
    let mut client = LiveClient::connect(addr, deadline, &run, Some(&wanted));
    // docs/live.md's first lines: a client offering only the older subprotocol is refused.
    assert_eq!(
        support::live::handshake_status(addr, "foxglove.websocket.v1"),
        400,
        "docs/live.md says the SDK's server refuses foxglove.websocket.v1"
    );
    let catalogue = runlog::messages::channels();
    let mut received: HashMap<String, Vec<LiveMessage>> = HashMap::new();
    let finite_mass = |r: &Vec<LiveMessage>| {
        r.iter().any(|m| {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            v["body"]["mass_kg"].as_f64().is_some_and(f64::is_finite)
        })
    };
    loop {
        let done = wanted.iter().all(|t| received.contains_key(*t))
            && received
                .get(runlog::messages::ESTIMATE)
                .is_some_and(finite_mass)
            && received[runlog::messages::TF].len() >= 3;
        if done {
            break;
        }
        assert!(
            !run.is_finished() && Instant::now() < deadline,
            "the run ended before the client had /estimate and /tf: subscribed {:?}, \
             received {:?}",
            client.subscribed,
            received
                .iter()
                .map(|(t, r)| (t.clone(), r.len()))
                .collect::<Vec<_>>()
        );
        let m = client
            .next_message()
            .expect("the server closed the connection during the run");
        received.entry(m.topic.clone()).or_default().push(m);
    }
    let server_name = client.server_name.clone();
    let advertised = client.advertised.clone();
    drop(client);
    interrupt.store(true, Ordering::SeqCst);
    let (outcome, took) = run.join().unwrap();
    assert!(
        matches!(outcome.end, End::Interrupted | End::Completed),
        "{:?}",
        outcome.end
    );
    // The log's last message is no later on the wall clock than the run's end: the view was
    // held to real time (a free simulation runs this in a fraction of its duration).
    let last_ns = support::read_messages(&log)
        .iter()
        .map(|m| m.log_time)
        .max()
        .unwrap();
    let end_ns = runlog::run_log::unix_now_ns();
    assert!(last_ns <= end_ns, "the log ran ahead of the wall clock");
    eprintln!("live run: {took:?}");

    assert!(
        server_name
            .as_deref()
            .is_some_and(|n| n.starts_with("stewart")),
        "serverInfo names the tool: {server_name:?}"
    );
    // Every log channel is advertised, once.
    let mut topics: Vec<_> = advertised.values().cloned().collect();
    topics.sort();
    let mut expected: Vec<_> = catalogue.iter().map(|s| s.topic.to_string()).collect();
    expected.sort();
    assert_eq!(topics, expected);

    // /tf decodes as the SDK's FrameTransform: base → platform, a unit quaternion, the plate
    // above the base.
    for m in &received[runlog::messages::TF] {
        plate_transform(&m.data);
    }
    // /estimate is the log's JSON: θ's mass is the body's mass.
    for m in &received[runlog::messages::ESTIMATE] {
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        assert!(v["run"] == "tare" || v["run"] == "loaded", "{v}");
        if let Some(m) = v["body"]["mass_kg"].as_f64() {
            assert_eq!(v["theta"][0].as_f64(), Some(m));
            assert!(m > 0.0, "mass {m} kg");
        }
    }
    // The run's metadata reached a client that connected after it was written.
    let meta: serde_json::Value =
        serde_json::from_slice(&received[runlog::messages::METADATA][0].data).unwrap();
    assert_eq!(meta["command"], "simulate");

    // Each message received is the log's message at the same log time, byte for byte.
    let all: Vec<LiveMessage> = received.into_values().flatten().collect();
    assert_in_log(&all, &log);
}

#[test]
fn a_taken_live_address_refuses_the_run_before_the_log() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let scratch = Scratch::new(SHORT);
    let log = scratch.path("run.mcap");
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    args.measure.live = Some(addr);
    let err = support::run_simulate(&args).expect_err("a taken port refuses the run");
    assert!(
        matches!(err, ops::measurement::Error::Input(_)),
        "refused before anything ran: {err}"
    );
    let text = err.to_string();
    assert!(text.contains(&addr.to_string()), "{text}");
    assert!(!log.exists(), "no log is started for a refused run");
}

/// A client that subscribes to every channel, the 1 kHz ones included, and then never reads:
/// the run neither waits for it nor fails. Its queue fills and the SDK drops the oldest
/// messages; the run keeps the wall clock's pace and the log is complete.
#[test]
fn a_client_that_stops_reading_does_not_hold_the_run() {
    let scratch = Scratch::new(LIVE);
    let log = scratch.path("run.mcap");
    let addr = free_port();
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    args.measure.live = Some(addr);
    let run = std::thread::spawn(move || {
        let started = Instant::now();
        let outcome =
            support::run_simulate(&args).unwrap_or_else(|e| panic!("simulate --live failed: {e}"));
        (outcome, started.elapsed())
    });
    // Subscribe to everything advertised, then stop reading.
    let mut client =
        LiveClient::connect(addr, Instant::now() + Duration::from_secs(60), &run, None);
    client.wait_subscribed();
    let (outcome, took) = run.join().unwrap();
    drop(client);
    assert_eq!(outcome.end, End::Completed);
    let messages = support::read_messages(&log);
    let first = messages.iter().map(|m| m.log_time).min().unwrap();
    let last = messages.iter().map(|m| m.log_time).max().unwrap();
    let span = Duration::from_nanos(last - first);
    // Held to the wall clock, the run takes its log's span; a run waiting on the client would
    // take longer, a run that was not held far less.
    assert!(
        took + Duration::from_millis(10) >= span && took < span + Duration::from_secs(5),
        "the run took {took:?} for {span:?} of log"
    );
    // Every message is in the log: the writer numbers the messages it is given 1, 2, 3, …
    // and a message dropped on the way would leave a gap.
    let bytes = std::fs::read(&log).unwrap();
    let sequences: Vec<u32> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap().sequence)
        .collect();
    assert!(
        sequences.iter().zip(1..).all(|(s, i)| *s == i),
        "a gap in the log's sequence numbers"
    );
    assert!(sequences.len() > 10_000, "{} messages", sequences.len());
}
