//! The host and the emulator over a scripted link: a [`Transport`] whose arriving frames the
//! test writes (from any address it likes: a spoofed sender is one line) and whose sent frames
//! it reads back. Deterministic where loopback UDP is not: a host stalled at a chosen instant,
//! a datagram captured and sent again.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use control::io::{Backend, Status};

use crate::codec::{self, Auth, MAX_FRAME_LEN};
use crate::emulator::{Emulator, EmulatorConfig, EmulatorEvent};
use crate::loopback_tests::{limits, FakeBackend};
use crate::transport::{Peer, Recv, Transport};
use crate::wire::*;
use crate::{Key, RigBackend, RigError, RigOptions};

/// Frames with their sender or destination.
type Frames = Vec<(Vec<u8>, Peer)>;

/// Answers to a sent frame.
type Responder = Box<dyn FnMut(&[u8]) -> Vec<Vec<u8>> + Send>;

/// What happens on a scripted link, shared between the test and the side using it.
#[derive(Default)]
struct Script {
    /// Frames waiting to be received, with their (claimed) sender.
    inbox: VecDeque<(Vec<u8>, Peer)>,
    /// Frames sent, with their destination.
    sent: Frames,
    /// The next `recv` sleeps this long, then the frames of `arrive_during_stall` arrive and it
    /// returns `Timeout`: a process descheduled between its wait and its deadline check.
    stall: Option<(Duration, Frames)>,
    /// Answers to sent frames: called with each sent frame, its answers are queued.
    responder: Option<Responder>,
    /// The address answers come from.
    answers_from: Option<Peer>,
}

#[derive(Clone, Default)]
struct Scripted(Arc<Mutex<Script>>);

impl Scripted {
    fn script(&self) -> std::sync::MutexGuard<'_, Script> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn arrive(&self, frame: Vec<u8>, from: Peer) {
        self.script().inbox.push_back((frame, from));
    }

    fn sent(&self) -> Frames {
        self.script().sent.clone()
    }
}

impl Transport for Scripted {
    fn send(&mut self, frame: &[u8], to: &Peer) -> Result<(), RigError> {
        let mut script = self.script();
        script.sent.push((frame.to_vec(), *to));
        let from = script.answers_from.unwrap_or(*to);
        let answers = script
            .responder
            .as_mut()
            .map(|respond| respond(frame))
            .unwrap_or_default();
        for answer in answers {
            script.inbox.push_back((answer, from));
        }
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout: Duration) -> Result<Recv, RigError> {
        let stall = self.script().stall.take();
        if let Some((pause, arriving)) = stall {
            std::thread::sleep(pause);
            self.script().inbox.extend(arriving);
            return Ok(Recv::Timeout);
        }
        let until = Instant::now() + timeout;
        loop {
            if let Some((frame, from)) = self.script().inbox.pop_front() {
                buf[..frame.len()].copy_from_slice(&frame);
                return Ok(Recv::Frame {
                    len: frame.len(),
                    from,
                });
            }
            if Instant::now() >= until {
                return Ok(Recv::Timeout);
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    }

    fn local_addr(&self) -> Option<SocketAddr> {
        None
    }
}

fn encode(message: &Message, auth: Option<&Auth<'_>>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = codec::encode(message, auth, &mut out).unwrap();
    out[..n].to_vec()
}

fn rig_peer() -> Peer {
    Peer::Udp("10.0.0.1:7700".parse().unwrap())
}

fn host_peer() -> Peer {
    Peer::Udp("10.0.0.2:50000".parse().unwrap())
}

fn sensor(sequence: u64, status: u32) -> Message {
    Message::Sensor(Sensor {
        sequence,
        time_ns: sequence * 1_000_000,
        leg_lengths_m: [0.55; 6],
        leg_forces_n: [0.0; 6],
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, 9.80665],
        status,
    })
}

/// The scripted rig's answer to the `Hello` of `host_nonce`: session 42, six legs, an IMU,
/// 1 kHz, a 20 ms watchdog.
fn scripted_ack(host_nonce: u64) -> HelloAck {
    HelloAck {
        host_nonce,
        session_id: 42,
        identity: identity_from_str("scripted"),
        layout: SensorLayout {
            leg_count: 6,
            imu_present: true,
            accel_position_m: [0.0; 3],
        },
        sample_period_ns: 1_000_000,
        watchdog_ns: 20_000_000,
        limits: limits(),
    }
}

/// A scripted rig that answers every `Hello` with a `HelloAck` (no key), and a host connected
/// to it.
fn connected_host() -> (Scripted, RigBackend) {
    connected_host_answering(1)
}

/// As [`connected_host`], the rig answering each `Hello` `answers` times.
fn connected_host_answering(answers: usize) -> (Scripted, RigBackend) {
    let link = Scripted::default();
    link.script().responder = Some(Box::new(move |frame| {
        let Ok(Message::Hello(hello)) = codec::decode(frame, None) else {
            return Vec::new();
        };
        vec![encode(&Message::HelloAck(scripted_ack(hello.host_nonce)), None); answers]
    }));
    let host = RigBackend::connect_over(
        Box::new(link.clone()),
        rig_peer(),
        "scripted".into(),
        RigOptions::default(),
    )
    .unwrap();
    (link, host)
}

/// A host stalled 100 ms with the rig's WATCHDOG fault already waiting in its socket reports
/// that fault, the one that happened first, not "link silent".
#[test]
fn a_stalled_host_reports_the_rigs_waiting_fault_not_silence() {
    let (link, mut host) = connected_host();
    for sequence in 1..=3 {
        link.arrive(encode(&sensor(sequence, 0), None), rig_peer());
    }
    assert_eq!(host.read().unwrap().sequence, 3);
    // The host goes away for 100 ms (twice the silence limit). Meanwhile the rig sends on,
    // its watchdog trips after 20 ms, and it reports the fault and sends faulted frames.
    let mut arriving: Frames = (4..=23)
        .map(|s| (encode(&sensor(s, 0), None), rig_peer()))
        .collect();
    let fault = Fault {
        code: FaultCode::WATCHDOG,
        leg: NO_LEG,
        value: 0.021,
        command_sequence: 3,
    };
    arriving.push((encode(&Message::Fault(fault), None), rig_peer()));
    arriving.extend((24..=100).map(|s| {
        (
            encode(&sensor(s, Status::FAULT | Status::BRAKED), None),
            rig_peer(),
        )
    }));
    link.script().stall = Some((Duration::from_millis(100), arriving));
    let error = host.read().expect_err("the rig faulted");
    match error {
        RigError::RigFault { code, .. } => assert_eq!(code, FaultCode::WATCHDOG),
        other => panic!("expected the rig's WATCHDOG fault, got: {other}"),
    }
    // And the host braked.
    let (last, to) = link.sent().pop().unwrap();
    assert_eq!(to, rig_peer());
    assert!(matches!(
        codec::decode(&last, None),
        Ok(Message::Command(c)) if !c.enable
    ));
}

/// A host that repeats its Hello while the rig's answer is on its way gets the same HelloAck
/// twice; the second, after the handshake, counts as a duplicate, not as an unexpected frame
/// (which would fail a session over a slow serial line).
#[test]
fn a_repeated_hello_ack_after_the_handshake_is_a_duplicate() {
    let (link, mut host) = connected_host_answering(2);
    link.arrive(encode(&sensor(1, 0), None), rig_peer());
    assert_eq!(host.read().unwrap().sequence, 1);
    let stats = *host.stats();
    assert_eq!((stats.unexpected, stats.duplicate), (0, 1), "{stats}");
}

/// Silence is still silence: with nothing waiting after the stall, the read fails by name.
#[test]
fn a_stalled_host_with_nothing_waiting_reports_link_silence() {
    let (link, mut host) = connected_host();
    link.arrive(encode(&sensor(1, 0), None), rig_peer());
    host.read().unwrap();
    link.script().stall = Some((Duration::from_millis(100), Vec::new()));
    let error = host.read().expect_err("silent");
    assert!(matches!(error, RigError::LinkSilent { .. }), "{error}");
}

/// An emulator with `key` on a scripted link, running on its own thread.
struct KeyedRig {
    link: Scripted,
    events: Arc<Mutex<Vec<EmulatorEvent>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<Emulator<FakeBackend>>>,
}

impl KeyedRig {
    fn start(key: &Key) -> Self {
        // Long: the test is about who may command, not about time.
        Self::start_timed(key, Duration::from_secs(5), Duration::from_secs(5))
    }

    fn start_timed(key: &Key, watchdog: Duration, session_timeout: Duration) -> Self {
        let link = Scripted::default();
        let config = EmulatorConfig {
            key: Some(key.clone()),
            watchdog,
            session_timeout,
            seed: 11,
            ..EmulatorConfig::new(limits())
        };
        let mut emulator =
            Emulator::new(FakeBackend::default(), Box::new(link.clone()), config).unwrap();
        let events = Arc::new(Mutex::new(Vec::new()));
        let seen = Arc::clone(&events);
        emulator.set_event_hook(Box::new(move |e| seen.lock().unwrap().push(*e)));
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::spawn(move || {
            emulator.run(&flag).unwrap();
            emulator
        });
        Self {
            link,
            events,
            stop,
            thread: Some(thread),
        }
    }

    /// Waits until the rig has sent a frame matching `pick` (decoded with `auth`).
    fn wait_for<T>(&self, auth: Option<&Auth<'_>>, pick: impl Fn(Message) -> Option<T>) -> T {
        let until = Instant::now() + Duration::from_secs(5);
        loop {
            let found = self
                .link
                .sent()
                .iter()
                .filter_map(|(f, _)| codec::decode(f, auth).ok())
                .find_map(&pick);
            if let Some(found) = found {
                return found;
            }
            assert!(Instant::now() < until, "the rig never sent it");
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// Lets the rig take everything waiting.
    fn settle(&self) {
        let until = Instant::now() + Duration::from_secs(5);
        while !self.link.script().inbox.is_empty() {
            assert!(Instant::now() < until, "the rig stopped reading");
            std::thread::sleep(Duration::from_millis(2));
        }
        std::thread::sleep(Duration::from_millis(10));
    }

    fn stop(mut self) -> Emulator<FakeBackend> {
        self.stop.store(true, Ordering::SeqCst);
        self.thread.take().unwrap().join().unwrap()
    }
}

fn hello(nonce: u64, key: &Key) -> Vec<u8> {
    encode(
        &Message::Hello(Hello {
            host_nonce: nonce,
            key_id: Some(key.id()),
        }),
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
    )
}

fn command(sequence: u64, force_n: f64) -> Message {
    Message::Command(Command {
        sequence,
        sensor_sequence: 0,
        leg_forces_n: [force_n; 6],
        enable: true,
    })
}

/// Anyone who can put a datagram on the rig's network can give it the host's source address.
/// With the shared key, commands forged that way (untagged, tagged with another key, tagged
/// for another session) and commands captured and sent again (in their session or in a later
/// one) are dropped and counted; only the host's own commands move the platform.
#[test]
fn forged_and_replayed_commands_from_a_spoofed_host_are_rejected() {
    let key = Key::from_hex(&"5a".repeat(32)).unwrap();
    let other = Key::from_hex(&"a5".repeat(32)).unwrap();
    let rig = KeyedRig::start(&key);
    let ack_of = |nonce: u64| {
        move |m: Message| match m {
            Message::HelloAck(a) if a.host_nonce == nonce => Some(a),
            _ => None,
        }
    };

    // Session 1: the host's own commands, the last one captured by an eavesdropper.
    rig.link.arrive(hello(1, &key), host_peer());
    let first = rig.wait_for(
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
        ack_of(1),
    );
    let auth1 = Auth {
        key: key.bytes(),
        session_id: first.session_id,
    };
    for sequence in 1..=5 {
        rig.link
            .arrive(encode(&command(sequence, 10.0), Some(&auth1)), host_peer());
    }
    let captured = encode(&command(6, 400.0), Some(&auth1));
    rig.link.arrive(captured.clone(), host_peer());
    rig.settle();

    // Forged with the host's address: no tag, another key, the handshake's session 0.
    let forged = [
        encode(&command(7, 19_000.0), None),
        encode(
            &command(8, 19_000.0),
            Some(&Auth {
                key: other.bytes(),
                session_id: first.session_id,
            }),
        ),
        encode(
            &command(9, 19_000.0),
            Some(&Auth {
                key: key.bytes(),
                session_id: 0,
            }),
        ),
    ];
    for frame in &forged {
        rig.link.arrive(frame.clone(), host_peer());
    }
    // Replayed in its own session: a duplicate.
    rig.link.arrive(captured.clone(), host_peer());
    rig.settle();

    // Session 2 (the host reconnects); the captured frame replayed into it fails its tag.
    rig.link.arrive(hello(2, &key), host_peer());
    let second = rig.wait_for(
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
        ack_of(2),
    );
    assert_ne!(second.session_id, first.session_id);
    rig.link.arrive(captured, host_peer());
    rig.settle();

    let emulator = rig.stop();
    let stats = emulator.stats().core;
    // The emulator reports its rig core's counters as they are.
    assert_eq!(stats, *emulator.core().stats());
    assert_eq!(stats.sessions, 2, "{stats:?}");
    assert_eq!(stats.commands_accepted, 6, "{stats:?}");
    // Three forged, one replayed into a later session.
    assert_eq!(stats.auth_failed, 4, "{stats:?}");
    assert_eq!(stats.duplicate, 1, "{stats:?}");
    assert!(emulator.faults().is_empty(), "{:?}", emulator.faults());
    // Nothing but the host's commands reached the actuators (6 × 10 N and one 400 N).
    assert_eq!(emulator.inner().max_enabled_force(), 400.0);
    assert!(
        emulator.last_command().is_none(),
        "session 2 got no command"
    );
}

/// The emulator's watchdog tripping and a session timing out are each an event (which
/// `stewart emulate` prints as one line) naming the session and cause; the timed-out session's
/// last command stays known.
#[test]
fn a_watchdog_trip_and_a_session_timeout_are_told() {
    let key = Key::from_hex(&"5a".repeat(32)).unwrap();
    let rig = KeyedRig::start_timed(&key, Duration::from_millis(30), Duration::from_millis(300));
    rig.link.arrive(hello(1, &key), host_peer());
    let ack = rig.wait_for(
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
        |m| match m {
            Message::HelloAck(a) => Some(a),
            _ => None,
        },
    );
    let auth = Auth {
        key: key.bytes(),
        session_id: ack.session_id,
    };
    rig.link
        .arrive(encode(&command(1, 10.0), Some(&auth)), host_peer());
    // Then the host goes quiet: the watchdog trips, later the session times out.
    let until = Instant::now() + Duration::from_secs(5);
    while rig.events.lock().unwrap().len() < 2 {
        assert!(Instant::now() < until, "{:?}", rig.events.lock().unwrap());
        std::thread::sleep(Duration::from_millis(10));
    }
    let events = rig.events.lock().unwrap().clone();
    let emulator = rig.stop();
    // The timed-out session's last command stays known (what the end-to-end tests check the
    // host's last word with, however long after the session the emulator is stopped).
    assert_eq!(emulator.last_command().map(|c| c.sequence), Some(1));
    match events[0] {
        EmulatorEvent::Fault {
            session,
            peer,
            fault,
        } => {
            assert_eq!((session, peer), (1, host_peer()));
            assert_eq!(fault.code, FaultCode::WATCHDOG);
            assert_eq!(fault.command_sequence, 1);
        }
        other => panic!("{other:?}"),
    }
    match events[1] {
        EmulatorEvent::SessionTimedOut {
            session,
            peer,
            silent_for,
        } => {
            assert_eq!((session, peer), (1, host_peer()));
            assert!(silent_for > Duration::from_millis(300));
        }
        other => panic!("{other:?}"),
    }
}

/// A keyed host connecting to a scripted keyed rig whose every answer to a `Hello` is
/// `before_ack` (frames from the rig's address, untagged: anyone's forgery) followed, if
/// `ack`, by the rig's tagged `HelloAck`.
fn keyed_handshake(before_ack: Vec<Message>, ack: bool) -> Result<RigBackend, RigError> {
    let key = Key::from_hex(&"5a".repeat(32)).unwrap();
    let link = Scripted::default();
    let rig_key = key.clone();
    link.script().responder = Some(Box::new(move |frame| {
        let auth = Auth {
            key: rig_key.bytes(),
            session_id: 0,
        };
        let Ok(Message::Hello(hello)) = codec::decode(frame, Some(&auth)) else {
            return Vec::new();
        };
        let mut answers: Vec<Vec<u8>> = before_ack.iter().map(|m| encode(m, None)).collect();
        if ack {
            let ack = Message::HelloAck(scripted_ack(hello.host_nonce));
            answers.push(encode(&ack, Some(&auth)));
        }
        answers
    }));
    RigBackend::connect_over(
        Box::new(link),
        rig_peer(),
        "scripted".into(),
        RigOptions {
            key: Some(key),
            handshake_timeout: Duration::from_millis(300),
            ..RigOptions::default()
        },
    )
}

fn refusal(code: FaultCode) -> Message {
    Message::Fault(Fault {
        code,
        leg: NO_LEG,
        value: 0.0,
        command_sequence: 0,
    })
}

/// A spoofed untagged KEY_MISMATCH (or BUSY, or a frame of another protocol version) ahead of
/// the rig's HelloAck aborted a keyed host's handshake with "key mismatch… copy the key"
/// although the keys matched: a keyed host believes an untagged refusal only when no HelloAck
/// proving the key arrives.
#[test]
fn a_spoofed_refusal_does_not_abort_a_keyed_handshake() {
    for spoofed in [
        refusal(FaultCode::KEY_MISMATCH),
        refusal(FaultCode::KEY_REQUIRED),
        refusal(FaultCode::BUSY),
    ] {
        let host = keyed_handshake(vec![spoofed], true);
        assert!(host.is_ok(), "{spoofed:?}: {:?}", host.err());
    }
}

/// The rig's genuine refusal (no HelloAck follows) is still reported, by its reason, once the
/// handshake time is up.
#[test]
fn an_unanswered_keyed_handshake_reports_the_refusal_it_heard() {
    let error = keyed_handshake(vec![refusal(FaultCode::KEY_MISMATCH)], false)
        .err()
        .expect("refused");
    assert!(
        matches!(error, RigError::Refused { code, .. } if code == FaultCode::KEY_MISMATCH),
        "{error}"
    );
}
