//! `--live`: a Foxglove WebSocket client connects to `stewart simulate --live` while the
//! simulation runs, reads the server's `serverInfo` and `advertise`, subscribes to `/estimate`,
//! `/tf` and the run's metadata, and decodes what it receives: the server's messages with the
//! Foxglove SDK's own protocol parser, `/tf` with the SDK's `FrameTransform` type, `/estimate`
//! as the JSON its channel says it is. Every message received is also in the log, byte for
//! byte, at the same log time: the live view and the log are two sinks of one message.

mod support;

use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::ws_protocol::server::ServerMessage;
use measure::End;
use support::{simulate_args, Scratch, SHORT};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

/// A short run: the shortest excitation the fades allow, for the tare run and the loaded one.
const LIVE: &str = "[run]\nduration_s = 4.0\ntare_duration_s = 4.0\n";

/// The subprotocol the SDK's server speaks (the Foxglove app offers it).
const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// A loopback port nobody listens on now.
fn free_port() -> SocketAddr {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap()
}

/// Connects to the live view at `addr`, retrying until the run has bound it (or `deadline`,
/// or the run ended).
fn connect<T>(
    addr: SocketAddr,
    deadline: Instant,
    run: &std::thread::JoinHandle<T>,
) -> WebSocket<TcpStream> {
    loop {
        if let Ok(stream) = TcpStream::connect(addr) {
            stream
                .set_read_timeout(Some(Duration::from_secs(20)))
                .unwrap();
            let mut request = format!("ws://{addr}").into_client_request().unwrap();
            request
                .headers_mut()
                .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
            let (socket, response) = tungstenite::client(request, stream)
                .unwrap_or_else(|e| panic!("WebSocket handshake with {addr}: {e}"));
            assert_eq!(
                response.headers()["sec-websocket-protocol"],
                SUBPROTOCOL,
                "the server's subprotocol"
            );
            return socket;
        }
        assert!(
            Instant::now() < deadline && !run.is_finished(),
            "nothing listens on {addr}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// What the client received on one subscription.
#[derive(Default)]
struct Received {
    /// (log time, payload) in arrival order.
    messages: Vec<(u64, Vec<u8>)>,
}

/// Every message of the log at `path` as (topic, log time) → payload.
fn log_payloads(path: &Path) -> HashMap<(String, u64), Vec<Vec<u8>>> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: HashMap<(String, u64), Vec<Vec<u8>>> = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        out.entry((m.channel.topic.clone(), m.log_time))
            .or_default()
            .push(m.data.to_vec());
    }
    out
}

#[test]
fn a_foxglove_client_watches_a_simulation_live() {
    let scratch = Scratch::new(LIVE);
    let log = scratch.path("run.mcap");
    let addr = free_port();
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    args.measure.shared.live = Some(addr);
    // Watched live, the simulation keeps to the wall clock: the client has time to connect,
    // and Ctrl-C (the interrupt flag) ends the run once the client has what it checks.
    let interrupt = Arc::new(AtomicBool::new(false));
    let run = {
        let interrupt = Arc::clone(&interrupt);
        std::thread::spawn(move || {
            let started = Instant::now();
            let outcome = stewart_cli::simulate::simulate(&args, &interrupt)
                .unwrap_or_else(|e| panic!("simulate --live failed: {e}"));
            (outcome, started.elapsed())
        })
    };

    let deadline = Instant::now() + Duration::from_secs(60);
    let mut socket = connect(addr, deadline, &run);
    let wanted = [
        runlog::messages::ESTIMATE,
        runlog::messages::TF,
        runlog::messages::METADATA,
    ];
    let catalogue = runlog::messages::channels();
    // channel id → topic, from the advertisements; subscription id → topic once subscribed.
    let mut advertised: HashMap<u64, String> = HashMap::new();
    let mut subscribed: HashMap<u32, String> = HashMap::new();
    let mut received: HashMap<String, Received> = HashMap::new();
    let mut server_name = None;
    let finite_mass = |r: &Received| {
        r.messages.iter().any(|(_, bytes)| {
            let v: serde_json::Value = serde_json::from_slice(bytes).unwrap();
            v["body"]["mass_kg"].as_f64().is_some_and(f64::is_finite)
        })
    };
    loop {
        let done = wanted.iter().all(|t| received.contains_key(*t))
            && received
                .get(runlog::messages::ESTIMATE)
                .is_some_and(finite_mass)
            && received[runlog::messages::TF].messages.len() >= 3;
        if done {
            break;
        }
        assert!(
            !run.is_finished() && Instant::now() < deadline,
            "the run ended before the client had /estimate and /tf: subscribed {subscribed:?}, \
             received {:?}",
            received
                .iter()
                .map(|(t, r)| (t.clone(), r.messages.len()))
                .collect::<Vec<_>>()
        );
        let message = socket.read().unwrap_or_else(|e| panic!("reading: {e}"));
        match message {
            Message::Text(text) => match ServerMessage::parse_json(text.as_str()).unwrap() {
                ServerMessage::ServerInfo(info) => server_name = Some(info.name),
                ServerMessage::Advertise(a) => {
                    let mut subscriptions = Vec::new();
                    for c in &a.channels {
                        let spec = catalogue
                            .iter()
                            .find(|s| s.topic == c.topic)
                            .unwrap_or_else(|| panic!("{} is not a log channel", c.topic));
                        assert_eq!(c.schema_name, spec.schema_name, "{}", c.topic);
                        assert_eq!(c.encoding, spec.encoding.message_encoding(), "{}", c.topic);
                        assert_eq!(
                            c.schema_encoding.as_deref(),
                            Some(spec.encoding.schema_encoding()),
                            "{}",
                            c.topic
                        );
                        advertised.insert(c.id, c.topic.to_string());
                        if wanted.contains(&c.topic.as_ref()) {
                            let id = subscribed.len() as u32 + 1;
                            subscribed.insert(id, c.topic.to_string());
                            subscriptions.push(serde_json::json!({"id": id, "channelId": c.id}));
                        }
                    }
                    if !subscriptions.is_empty() {
                        let subscribe =
                            serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
                        socket.send(Message::text(subscribe.to_string())).unwrap();
                    }
                }
                _ => {}
            },
            Message::Binary(bytes) => {
                if let ServerMessage::MessageData(m) = ServerMessage::parse_binary(&bytes).unwrap()
                {
                    let topic = subscribed[&m.subscription_id].clone();
                    received
                        .entry(topic)
                        .or_default()
                        .messages
                        .push((m.log_time, m.data.to_vec()));
                }
            }
            _ => {}
        }
    }
    drop(socket);
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
    for (_, bytes) in &received[runlog::messages::TF].messages {
        let tf = <foxglove::messages::FrameTransform as prost::Message>::decode(&bytes[..])
            .unwrap_or_else(|e| panic!("/tf is not a foxglove.FrameTransform: {e}"));
        assert_eq!(tf.parent_frame_id, runlog::foxglove::BASE_FRAME);
        assert_eq!(tf.child_frame_id, runlog::foxglove::PLATFORM_FRAME);
        let q = tf.rotation.expect("rotation");
        let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
        assert!((norm - 1.0).abs() < 1e-9, "|q| = {norm}");
        let p = tf.translation.expect("translation");
        assert!(p.z > 0.5 && p.z < 5.0, "plate height {} m", p.z);
        assert!(tf.timestamp.is_some());
    }
    // /estimate is the log's JSON: θ's mass is the body's mass.
    for (_, bytes) in &received[runlog::messages::ESTIMATE].messages {
        let v: serde_json::Value = serde_json::from_slice(bytes).unwrap();
        assert!(v["run"] == "tare" || v["run"] == "loaded", "{v}");
        if let Some(m) = v["body"]["mass_kg"].as_f64() {
            assert_eq!(v["theta"][0].as_f64(), Some(m));
            assert!(m > 0.0, "mass {m} kg");
        }
    }
    // The run's metadata reached a client that connected after it was written.
    let meta: serde_json::Value =
        serde_json::from_slice(&received[runlog::messages::METADATA].messages[0].1).unwrap();
    assert_eq!(meta["command"], "simulate");

    // Each message received is the log's message at the same log time, byte for byte.
    let in_log = log_payloads(&log);
    for (topic, r) in &received {
        for (time, bytes) in &r.messages {
            let same = in_log
                .get(&(topic.clone(), *time))
                .is_some_and(|all| all.contains(bytes));
            assert!(same, "{topic} at {time} ns is not the log's message");
        }
    }
}

#[test]
fn a_taken_live_address_refuses_the_run_before_the_log() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let scratch = Scratch::new(SHORT);
    let log = scratch.path("run.mcap");
    let mut args = simulate_args(Some(scratch.config.clone()), log.clone());
    args.measure.shared.live = Some(addr);
    let err = stewart_cli::simulate::simulate(&args, &AtomicBool::new(false))
        .expect_err("a taken port refuses the run");
    assert_eq!(err.exit_code(), 2, "refused before anything ran: {err}");
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
    args.measure.shared.live = Some(addr);
    let run = std::thread::spawn(move || {
        let started = Instant::now();
        let outcome = stewart_cli::simulate::simulate(&args, &AtomicBool::new(false))
            .unwrap_or_else(|e| panic!("simulate --live failed: {e}"));
        (outcome, started.elapsed())
    });
    let mut socket = connect(addr, Instant::now() + Duration::from_secs(60), &run);
    // Subscribe to everything advertised, then stop reading.
    let mut subscriptions = Vec::new();
    while subscriptions.is_empty() {
        if let Message::Text(text) = socket.read().unwrap() {
            if let ServerMessage::Advertise(a) = ServerMessage::parse_json(text.as_str()).unwrap() {
                for (i, c) in a.channels.iter().enumerate() {
                    subscriptions.push(serde_json::json!({"id": i, "channelId": c.id}));
                }
            }
        }
    }
    let subscribe = serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
    socket.send(Message::text(subscribe.to_string())).unwrap();
    let (outcome, took) = run.join().unwrap();
    drop(socket);
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
