//! The rig core alone: no sockets, no threads, an injected clock. The host's side is written
//! here from the codec, not from the crate's host backend.

use proptest::prelude::*;
use stewart_types::{CommandFrame, SensorFrame, Status};

use super::*;
use crate::codec::{self, Auth, MAX_FRAME_LEN};
use crate::wire::{
    identity_from_str, Command, FaultCode, Hello, Limits, Message, SensorLayout, LEG_COUNT,
};

const MS: u64 = 1_000_000;
const HOST: u8 = 1;
const OTHER: u8 = 2;
const KEY: &[u8; 32] = b"0123456789abcdef0123456789abcdef";

fn limits() -> Limits {
    Limits {
        stroke_min_m: 0.4,
        stroke_max_m: 0.7,
        speed_max_m_s: 0.5,
        force_min_n: -100.0,
        force_max_n: 100.0,
    }
}

fn config() -> CoreConfig {
    CoreConfig {
        identity: identity_from_str("rig-core-test"),
        layout: SensorLayout {
            leg_count: LEG_COUNT as u8,
            imu_present: true,
            accel_position_m: [0.0; 3],
        },
        limits: limits(),
        sample_period_ns: MS,
        watchdog_ns: 20 * MS,
        session_timeout_ns: 1000 * MS,
        key: None,
        enforce_motion_limits: true,
        speed_window: 10,
        seed: 5,
    }
}

fn keyed() -> CoreConfig {
    CoreConfig {
        key: Some(CoreKey::new(KEY).unwrap()),
        ..config()
    }
}

fn sensors(length_m: f64) -> SensorFrame {
    SensorFrame {
        time_s: 0.25,
        leg_lengths_m: [length_m; LEG_COUNT],
        leg_forces_n: [10.0; LEG_COUNT],
        accel_m_s2: [0.0, 0.0, 9.8],
        ..SensorFrame::default()
    }
}

fn encode(message: Message, auth: Option<Auth<'_>>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = codec::encode(&message, auth.as_ref(), &mut out).unwrap();
    out[..n].to_vec()
}

fn hello(nonce: u64, key: Option<&[u8]>) -> Vec<u8> {
    let message = Message::Hello(Hello {
        host_nonce: nonce,
        key_id: key.map(codec::key_id),
    });
    encode(message, key.map(|key| Auth { key, session_id: 0 }))
}

fn command(sequence: u64, force: f64, enable: bool) -> Message {
    Message::Command(Command {
        sequence,
        sensor_sequence: 0,
        leg_forces_n: [force; LEG_COUNT],
        enable,
    })
}

/// The frames of `out` decoded as the host would (with `auth` when given), then cleared.
fn drain(out: &mut Outbox<u8>, auth: Option<Auth<'_>>) -> Vec<(u8, FrameKind, Message)> {
    let frames = out
        .frames()
        .map(|f| {
            let auth = match f.kind {
                FrameKind::Refusal => None,
                FrameKind::HelloAck => auth.map(|a| Auth { session_id: 0, ..a }),
                _ => auth,
            };
            (
                f.to,
                f.kind,
                codec::decode(f.bytes(), auth.as_ref()).unwrap(),
            )
        })
        .collect();
    out.clear();
    frames
}

/// Opens a session for HOST at `now`; returns the session id.
fn open(rig: &mut RigCore<u8>, now: u64, nonce: u64, key: Option<&[u8]>) -> u64 {
    let mut out = Outbox::new();
    rig.receive(now, HOST, &hello(nonce, key), &mut out);
    let auth = key.map(|key| Auth { key, session_id: 0 });
    match drain(&mut out, auth).as_slice() {
        [(HOST, FrameKind::HelloAck, Message::HelloAck(ack))] => {
            assert_eq!(ack.host_nonce, nonce);
            assert_ne!(ack.session_id, 0);
            ack.session_id
        }
        other => panic!("no HelloAck: {other:?}"),
    }
}

fn faults_of(frames: &[(u8, FrameKind, Message)]) -> Vec<Fault> {
    frames
        .iter()
        .filter_map(|(_, _, m)| match m {
            Message::Fault(f) => Some(*f),
            _ => None,
        })
        .collect()
}

#[test]
fn a_scripted_session_handshakes_takes_commands_and_streams_sensor_frames() {
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    // Before a session: braked, nothing sent.
    assert!(!rig.tick(0, &sensors(0.5), &mut out).enable);
    assert!(out.is_empty());
    let id = open(&mut rig, 0, 77, None);
    let session = rig.session().unwrap();
    assert_eq!(
        (session.number, session.session_id, session.peer),
        (1, id, HOST)
    );
    // No command yet: braked, and the frame says so.
    let applied = rig.tick(MS, &sensors(0.5), &mut out);
    assert!(!applied.enable);
    match drain(&mut out, None).as_slice() {
        [(HOST, FrameKind::Sensor { sequence: 1 }, Message::Sensor(s))] => {
            assert_eq!(s.sequence, 1);
            assert_eq!(s.time_ns, 250_000_000);
            assert!(Status(s.status).has(Status::BRAKED));
            assert_eq!(s.leg_lengths_m, [0.5; LEG_COUNT]);
        }
        other => panic!("{other:?}"),
    }
    for k in 1..=5u64 {
        let now = (k + 1) * MS;
        rig.receive(
            now,
            HOST,
            &encode(command(k, 10.0 * k as f64, true), None),
            &mut out,
        );
        assert!(out.is_empty());
        let applied = rig.tick(now, &sensors(0.5), &mut out);
        assert!(applied.enable);
        assert_eq!(applied.leg_forces_n, [10.0 * k as f64; LEG_COUNT]);
        assert_eq!(applied.sequence, k);
        let frames = drain(&mut out, None);
        // The report came before this tick's output: frame k+1 carries the output of k-1.
        let expected_bit = if k == 1 {
            Status::BRAKED
        } else {
            Status::ENABLED
        };
        match frames.as_slice() {
            [(_, FrameKind::Sensor { sequence }, Message::Sensor(s))] => {
                assert_eq!(*sequence, k + 1);
                assert!(Status(s.status).has(expected_bit), "{k}: {:#x}", s.status);
            }
            other => panic!("{other:?}"),
        }
    }
    let stats = rig.stats();
    assert_eq!(stats.commands_accepted, 5);
    assert_eq!(stats.sessions, 1);
    assert_eq!(stats.sensor_frames, 6);
    assert_eq!(stats.faults_sent, 0);
}

#[test]
fn the_watchdog_trips_exactly_after_the_configured_time() {
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    open(&mut rig, 0, 1, None);
    let t0 = 3 * MS + 17;
    rig.receive(t0, HOST, &encode(command(1, 5.0, true), None), &mut out);
    // quiet = watchdog: still driven.
    assert!(rig.actuate(t0 + 20 * MS, &mut out).enable);
    assert!(out.is_empty());
    // quiet = watchdog + 1 ns: braked and reported.
    assert!(!rig.actuate(t0 + 20 * MS + 1, &mut out).enable);
    let events: Vec<_> = out.events().copied().collect();
    let faults = faults_of(&drain(&mut out, None));
    assert_eq!(faults.len(), 1);
    assert_eq!(faults[0].code, FaultCode::WATCHDOG);
    assert_eq!(faults[0].command_sequence, 1);
    assert_eq!(faults[0].value, (20 * MS + 1) as f64 / 1e9);
    assert!(matches!(
        events.as_slice(),
        [CoreEvent::Fault {
            session: 1,
            peer: HOST,
            ..
        }]
    ));
    // Latched: a fresh command does not release the brakes.
    rig.receive(
        t0 + 21 * MS,
        HOST,
        &encode(command(2, 5.0, true), None),
        &mut out,
    );
    assert!(!rig.actuate(t0 + 21 * MS, &mut out).enable);
    assert_eq!(rig.stats().faults_sent, 1);
}

/// A host that ends with a safe stop (a braking command) and falls silent ends the session
/// normally: the rig stays braked, no WATCHDOG fault, and the session times out; a driving
/// command after the brake arms the watchdog again.
#[test]
fn a_session_ended_with_a_safe_stop_does_not_trip_the_watchdog() {
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    open(&mut rig, 0, 1, None);
    rig.receive(MS, HOST, &encode(command(1, 5.0, true), None), &mut out);
    assert!(rig.actuate(2 * MS, &mut out).enable);
    rig.receive(
        3 * MS,
        HOST,
        &encode(command(2, 0.0, false), None),
        &mut out,
    );
    out.clear();
    for t in [4 * MS, 50 * MS, 500 * MS, 1003 * MS] {
        assert!(!rig.actuate(t, &mut out).enable, "{t}");
    }
    assert!(faults_of(&drain(&mut out, None)).is_empty());
    assert_eq!(rig.stats().faults_sent, 0);
    assert!(rig.session().is_some_and(|s| s.fault.is_none()));
    assert!(!rig.actuate(1003 * MS + 1, &mut out).enable);
    assert!(matches!(
        out.events().next(),
        Some(CoreEvent::SessionTimedOut { session: 1, .. })
    ));
    assert!(rig.session().is_none());

    // Brake, then drive again, then silence: the watchdog trips as ever.
    open(&mut rig, 2000 * MS, 2, None);
    rig.receive(
        2001 * MS,
        HOST,
        &encode(command(1, 0.0, false), None),
        &mut out,
    );
    rig.receive(
        2040 * MS,
        HOST,
        &encode(command(2, 5.0, true), None),
        &mut out,
    );
    assert!(rig.actuate(2041 * MS, &mut out).enable);
    out.clear();
    assert!(!rig.actuate(2060 * MS + 1, &mut out).enable);
    let faults = faults_of(&drain(&mut out, None));
    assert_eq!(faults.len(), 1);
    assert_eq!(faults[0].code, FaultCode::WATCHDOG);
}

#[test]
fn forged_unauthenticated_and_replayed_commands_are_dropped_and_counted() {
    let mut rig = RigCore::new(keyed()).unwrap();
    let mut out = Outbox::new();
    let id = open(&mut rig, 0, 9, Some(KEY));
    let good = Auth {
        key: KEY,
        session_id: id,
    };
    let wrong_key = Auth {
        key: b"fedcba9876543210fedcba9876543210",
        session_id: id,
    };
    let old_session = Auth {
        key: KEY,
        session_id: id ^ 1,
    };
    for (k, auth) in [None, Some(wrong_key), Some(old_session)]
        .into_iter()
        .enumerate()
    {
        rig.receive(
            MS,
            HOST,
            &encode(command(k as u64 + 1, 50.0, true), auth),
            &mut out,
        );
        assert_eq!(rig.stats().auth_failed, k as u64 + 1);
    }
    assert!(out.is_empty());
    assert_eq!(rig.stats().commands_accepted, 0);
    assert!(!rig.actuate(MS, &mut out).enable);
    // The same command, tagged for the session, is taken.
    rig.receive(
        MS,
        HOST,
        &encode(command(1, 50.0, true), Some(good)),
        &mut out,
    );
    assert_eq!(rig.stats().commands_accepted, 1);
    assert!(rig.actuate(2 * MS, &mut out).enable);
    // Its sensor frames are tagged for the session.
    rig.report(&sensors(0.5), &mut out);
    assert!(matches!(
        drain(&mut out, Some(good)).as_slice(),
        [(_, _, Message::Sensor(_))]
    ));
    // A command from another sender, even well tagged, is foreign.
    rig.receive(
        2 * MS,
        OTHER,
        &encode(command(2, 0.0, true), Some(good)),
        &mut out,
    );
    assert_eq!(rig.stats().foreign_sender, 1);
    assert_eq!(rig.last_command().map(|c| c.sequence), Some(1));
}

/// A replayed `Hello` of an earlier session (its tag, made with session 0, stays valid) from
/// the host's own address opened a new session and silenced the host's running one: the rig
/// drops it unanswered and counts it, and the running session keeps its id; the host's next
/// fresh `Hello` still opens a session.
#[test]
fn a_replayed_hello_opens_no_session_and_ends_none() {
    let mut rig = RigCore::new(keyed()).unwrap();
    let mut out = Outbox::new();
    let tare = open(&mut rig, 0, 11, Some(KEY));
    let loaded = open(&mut rig, MS, 12, Some(KEY));
    assert_ne!(tare, loaded);
    // The tare's Hello again, byte for byte, from the host's address.
    rig.receive(2 * MS, HOST, &hello(11, Some(KEY)), &mut out);
    let answered = drain(
        &mut out,
        Some(Auth {
            key: KEY,
            session_id: 0,
        }),
    );
    assert!(answered.is_empty(), "{answered:?}");
    assert_eq!(rig.stats().replayed_hellos, 1);
    assert_eq!(rig.stats().sessions, 2);
    assert_eq!(rig.session().map(|s| s.session_id), Some(loaded));
    // The running session's own retry is answered again, not taken as a replay.
    rig.receive(3 * MS, HOST, &hello(12, Some(KEY)), &mut out);
    assert_eq!(
        drain(
            &mut out,
            Some(Auth {
                key: KEY,
                session_id: 0
            })
        )
        .len(),
        1
    );
    assert_eq!(rig.stats().replayed_hellos, 1);
    assert_eq!(rig.session().map(|s| s.session_id), Some(loaded));
    // A fresh nonce is a reconnecting host.
    let next = open(&mut rig, 4 * MS, 13, Some(KEY));
    assert_ne!(next, loaded);
}

#[test]
fn hellos_are_refused_by_reason() {
    let mut rig = RigCore::new(keyed()).unwrap();
    let mut out = Outbox::new();
    rig.receive(0, HOST, &hello(1, None), &mut out);
    rig.receive(
        0,
        HOST,
        &hello(2, Some(b"another key of sixteen+ bytes")),
        &mut out,
    );
    let codes: Vec<_> = faults_of(&drain(&mut out, None))
        .iter()
        .map(|f| f.code)
        .collect();
    assert_eq!(codes, [FaultCode::KEY_REQUIRED, FaultCode::KEY_MISMATCH]);
    assert!(rig.session().is_none());
    open(&mut rig, 0, 3, Some(KEY));
    rig.receive(0, OTHER, &hello(4, Some(KEY)), &mut out);
    let frames = drain(&mut out, None);
    assert_eq!(frames[0].0, OTHER);
    assert_eq!(faults_of(&frames)[0].code, FaultCode::BUSY);
    // A repeated Hello of the session's handshake gets the same answer, not a new session.
    let id = rig.session().unwrap().session_id;
    assert_eq!(open(&mut rig, MS, 3, Some(KEY)), id);
    assert_eq!(rig.stats().sessions, 1);
}

#[test]
fn a_command_beyond_the_force_limit_faults_and_brakes() {
    for force in [100.5, -100.5, f64::NAN, f64::INFINITY] {
        let mut rig = RigCore::new(config()).unwrap();
        let mut out = Outbox::new();
        open(&mut rig, 0, 1, None);
        rig.receive(0, HOST, &encode(command(1, 99.0, true), None), &mut out);
        assert!(rig.actuate(MS, &mut out).enable);
        let mut over = [99.0; LEG_COUNT];
        over[4] = force;
        let message = Message::Command(Command {
            sequence: 2,
            sensor_sequence: 1,
            leg_forces_n: over,
            enable: true,
        });
        rig.receive(MS, HOST, &encode(message, None), &mut out);
        let faults = faults_of(&drain(&mut out, None));
        assert_eq!(faults.len(), 1, "{force}");
        assert_eq!(faults[0].code, FaultCode::FORCE_LIMIT);
        assert_eq!(faults[0].leg, 4);
        assert_eq!(faults[0].command_sequence, 2);
        assert!(faults[0].value == force || force.is_nan() && faults[0].value.is_nan());
        assert_eq!(rig.actuate(2 * MS, &mut out), CommandFrame::safe_stop(0, 0));
    }
    // Braking commands' forces are not checked (a host may send NaN with enable = false).
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    open(&mut rig, 0, 1, None);
    rig.receive(
        0,
        HOST,
        &encode(command(1, f64::NAN, false), None),
        &mut out,
    );
    assert_eq!(rig.actuate(MS, &mut out), CommandFrame::safe_stop(1, 0));
    assert!(out.is_empty());
}

#[test]
fn stroke_and_speed_faults_latch_until_a_new_session() {
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    open(&mut rig, 0, 1, None);
    rig.receive(0, HOST, &encode(command(1, 1.0, true), None), &mut out);
    assert!(rig.actuate(0, &mut out).enable);
    let mut beyond = sensors(0.5);
    beyond.leg_lengths_m[2] = 0.75;
    let applied = rig.tick(MS, &beyond, &mut out);
    assert!(!applied.enable);
    let frames = drain(&mut out, None);
    let faults = faults_of(&frames);
    assert_eq!(faults.len(), 1);
    assert_eq!(
        (faults[0].code, faults[0].leg, faults[0].value),
        (FaultCode::STROKE_LIMIT, 2, 0.75)
    );
    // The fault repeats every FAULT_REPEAT_FRAMES frames and the FAULT bit stays set, while
    // fresh commands and sane sensors do not release the brakes.
    let mut repeats = 0;
    for k in 2..=41u64 {
        rig.receive(k * MS, HOST, &encode(command(k, 1.0, true), None), &mut out);
        assert!(!rig.tick(k * MS, &sensors(0.5), &mut out).enable);
        for (_, kind, message) in drain(&mut out, None) {
            match message {
                Message::Fault(_) => repeats += 1,
                Message::Sensor(s) => assert!(Status(s.status).has(Status::FAULT | Status::BRAKED)),
                _ => panic!("{kind:?}"),
            }
        }
    }
    assert_eq!(repeats, 2, "sensor frames 20 and 40");
    // A new session (new nonce) releases them.
    open(&mut rig, 42 * MS, 2, None);
    rig.receive(
        42 * MS,
        HOST,
        &encode(command(1, 1.0, true), None),
        &mut out,
    );
    assert!(rig.actuate(42 * MS, &mut out).enable);

    // Speed: 0.5 m/s over 10 samples of 1 ms is 5 mm; 6 mm trips, on the first leg over.
    let mut rig = RigCore::new(config()).unwrap();
    open(&mut rig, 0, 1, None);
    rig.receive(0, HOST, &encode(command(1, 1.0, true), None), &mut out);
    rig.actuate(0, &mut out);
    let mut faults = Vec::new();
    for k in 0..=10u64 {
        let mut s = sensors(0.5);
        s.leg_lengths_m[1] = 0.5 + 0.0006 * k as f64;
        s.leg_lengths_m[3] = 0.5 + 0.0006 * k as f64;
        rig.receive(
            k * MS,
            HOST,
            &encode(command(k + 2, 1.0, true), None),
            &mut out,
        );
        let driven = rig.tick(k * MS, &s, &mut out).enable;
        assert_eq!(driven, k < 10, "{k}");
        faults.extend(faults_of(&drain(&mut out, None)));
    }
    assert_eq!(faults.len(), 1);
    assert_eq!((faults[0].code, faults[0].leg), (FaultCode::SPEED_LIMIT, 1));
    assert!((faults[0].value - 0.6).abs() < 1e-9, "{}", faults[0].value);
    open(&mut rig, 20 * MS, 2, None);
    assert!(rig.session().unwrap().fault.is_none());
}

#[test]
fn a_silent_host_loses_its_session_and_another_may_connect() {
    let mut rig = RigCore::new(config()).unwrap();
    let mut out = Outbox::new();
    open(&mut rig, 0, 1, None);
    rig.receive(0, HOST, &encode(command(1, 1.0, true), None), &mut out);
    rig.actuate(1000 * MS, &mut out);
    assert!(rig.session().is_some());
    out.clear();
    assert!(!rig.actuate(1000 * MS + 1, &mut out).enable);
    assert!(matches!(
        out.events().next(),
        Some(CoreEvent::SessionTimedOut { session: 1, peer: HOST, silent_for_ns })
            if *silent_for_ns == 1000 * MS + 1
    ));
    assert!(rig.session().is_none());
    assert_eq!(rig.last_command().map(|c| c.sequence), Some(1));
    out.clear();
    rig.receive(1001 * MS, OTHER, &hello(5, None), &mut out);
    assert_eq!(rig.session().map(|s| s.peer), Some(OTHER));
}

#[test]
fn long_keys_tag_as_hmac_does_with_the_key_itself() {
    let long = [7u8; 100];
    let config = CoreConfig {
        key: Some(CoreKey::new(&long).unwrap()),
        ..config()
    };
    let mut rig = RigCore::new(config).unwrap();
    let id = open(&mut rig, 0, 1, Some(&long));
    let mut out = Outbox::new();
    let auth = Auth {
        key: &long,
        session_id: id,
    };
    rig.receive(
        0,
        HOST,
        &encode(command(1, 1.0, true), Some(auth)),
        &mut out,
    );
    assert_eq!(rig.stats().commands_accepted, 1);
    assert_eq!(CoreKey::new(&[1; 15]), Err(ConfigError::KeyTooShort(15)));
}

#[test]
fn unusable_configurations_are_refused() {
    let zero_period = CoreConfig {
        sample_period_ns: 0,
        ..config()
    };
    assert!(RigCore::<u8>::new(zero_period).is_err());
    let wide = CoreConfig {
        speed_window: MAX_SPEED_WINDOW + 1,
        ..config()
    };
    assert!(RigCore::<u8>::new(wide).is_err());
    let nan = CoreConfig {
        limits: Limits {
            speed_max_m_s: f64::NAN,
            ..limits()
        },
        ..config()
    };
    assert!(RigCore::<u8>::new(nan).is_err());
}

/// The memory a firmware gives a rig core and its outbox (docs/firmware.md quotes them).
#[test]
fn a_rig_core_and_its_outbox_fit_in_a_few_kilobytes() {
    let rig = core::mem::size_of::<RigCore<()>>();
    let outbox = core::mem::size_of::<Outbox<()>>();
    println!("RigCore<()>: {rig} bytes, Outbox<()>: {outbox} bytes");
    assert!(rig <= 2816, "{rig}");
    assert!(outbox <= 1536, "{outbox}");
}

/// What a test drives a rig core with: frames (garbage, damaged or valid) and ticks.
#[derive(Clone, Debug)]
enum Step {
    Bytes(u8, Vec<u8>),
    Flip(u8, usize),
    Hello(u8, u64),
    Command(u64, f64, bool),
    Garbled,
    Tick(u64, f64),
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        (0u8..3, proptest::collection::vec(any::<u8>(), 0..300))
            .prop_map(|(p, b)| Step::Bytes(p, b)),
        (0u8..3, any::<usize>()).prop_map(|(p, bit)| Step::Flip(p, bit)),
        (0u8..3, 0u64..3).prop_map(|(p, n)| Step::Hello(p, n)),
        (0u64..8, -200.0f64..200.0, any::<bool>()).prop_map(|(s, f, e)| Step::Command(s, f, e)),
        Just(Step::Garbled),
        (0u64..50 * MS, 0.3f64..0.8).prop_map(|(dt, l)| Step::Tick(dt, l)),
    ]
}

proptest! {
    #[test]
    fn any_bytes_and_any_tick_sequence_leave_the_rig_core_sane(
        keyed_core in any::<bool>(),
        steps in proptest::collection::vec(step(), 1..60),
    ) {
        let config = if keyed_core { keyed() } else { config() };
        let mut rig = RigCore::new(config).unwrap();
        let mut out = Outbox::new();
        let mut now = 0u64;
        let key = keyed_core.then_some(&KEY[..]);
        for step in steps {
            match step {
                Step::Bytes(peer, bytes) => rig.receive(now, peer, &bytes, &mut out),
                Step::Flip(peer, bit) => {
                    let mut frame = encode(command(1, 1.0, true), None);
                    let n = frame.len() * 8;
                    frame[(bit % n) / 8] ^= 1 << (bit % 8);
                    rig.receive(now, peer, &frame, &mut out);
                }
                Step::Hello(peer, nonce) => rig.receive(now, peer, &hello(nonce, key), &mut out),
                Step::Command(sequence, force, enable) => {
                    let session_id = rig.session().map_or(0, |s| s.session_id);
                    let auth = key.map(|key| Auth { key, session_id });
                    let frame = encode(command(sequence, force, enable), auth);
                    rig.receive(now, HOST, &frame, &mut out);
                }
                Step::Garbled => rig.receive_garbled(),
                Step::Tick(dt, length) => {
                    now += dt;
                    let applied = rig.tick(now, &sensors(length), &mut out);
                    // Never driven beyond the limits or without a session, never driven
                    // with a fault latched.
                    if applied.enable {
                        let session = rig.session();
                        prop_assert!(session.is_some_and(|s| s.fault.is_none()));
                        prop_assert!(applied.leg_forces_n.iter().all(|f| f.abs() <= 100.0));
                    }
                }
            }
            prop_assert_eq!(out.overflow(), 0);
            for frame in out.frames() {
                prop_assert!(codec::decode_unverified(frame.bytes()).is_ok());
            }
            out.clear();
        }
    }
}
