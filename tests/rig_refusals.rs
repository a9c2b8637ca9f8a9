//! Who may talk to the rig, and what `stewart rig` refuses before anything moves: another
//! protocol version, a rig whose layout does not fit the scenario, a missing or wrong key; a
//! second sender cannot move the platform while a session runs; with a key, unkeyed and
//! wrongly keyed frames from the session's own address are dropped.

use crate::support;

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use measure::End;
use rig::codec::{self, Auth, CRC32, MAX_FRAME_LEN};
use rig::transport::Peer;
use rig::wire::{Command, FaultCode, Hello, Message, PROTOCOL_VERSION};
use rig::{Key, RigBackend, RigOptions};
use support::*;

fn socket_of(address: &str) -> SocketAddr {
    address.trim_start_matches("udp://").parse().unwrap()
}

/// A hand-driven peer speaking the protocol from its own socket.
struct RawPeer {
    socket: UdpSocket,
}

impl RawPeer {
    fn new() -> Self {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket
            .set_read_timeout(Some(Duration::from_millis(500)))
            .unwrap();
        Self { socket }
    }

    fn send(&self, to: SocketAddr, message: &Message, auth: Option<&Auth<'_>>) {
        let mut out = [0u8; MAX_FRAME_LEN];
        let n = codec::encode(message, auth, &mut out).unwrap();
        self.socket.send_to(&out[..n], to).unwrap();
    }

    /// The next frame that decodes (with `auth`), skipping others, within 500 ms.
    fn recv(&self, auth: Option<&Auth<'_>>) -> Option<Message> {
        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let until = Instant::now() + Duration::from_millis(500);
        while Instant::now() < until {
            let Ok((n, _)) = self.socket.recv_from(&mut buf) else {
                continue;
            };
            if let Ok(m) = codec::decode(&buf[..n], auth) {
                return Some(m);
            }
        }
        None
    }
}

fn command(sequence: u64, force_n: f64) -> Message {
    Message::Command(Command {
        sequence,
        sensor_sequence: 0,
        leg_forces_n: [force_n; 6],
        enable: true,
    })
}

#[test]
fn a_protocol_version_mismatch_is_refused_before_any_motion() {
    let scratch = Scratch::new(&quick());
    // A rig of protocol version 2: it answers every Hello in its own version.
    let fake = UdpSocket::bind("127.0.0.1:0").unwrap();
    fake.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let address = format!("udp://{}", fake.local_addr().unwrap());
    let rig = std::thread::spawn(move || {
        let mut kinds = Vec::new();
        let mut buf = [0u8; MAX_FRAME_LEN + 1];
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            let Ok((n, host)) = fake.recv_from(&mut buf) else {
                continue;
            };
            kinds.push(codec::decode_unverified(&buf[..n]).map(|(m, _)| m.kind_name()));
            let fault = Message::Fault(rig::wire::Fault {
                code: FaultCode::VERSION_MISMATCH,
                leg: rig::wire::NO_LEG,
                value: 2.0,
                command_sequence: 0,
            });
            let mut out = [0u8; MAX_FRAME_LEN];
            let n = codec::encode(&fault, None, &mut out).unwrap();
            out[1] = 2;
            let crc = CRC32.checksum(&out[..n - 4]);
            out[n - 4..n].copy_from_slice(&crc.to_le_bytes());
            fake.send_to(&out[..n], host).unwrap();
        }
        kinds
    });
    let args = rig_tare(&scratch, &address);
    let error = run_rig(&args).expect_err("refused");
    let heard = rig.join().unwrap();
    let message = error.to_string();
    assert!(message.contains("protocol version mismatch"), "{message}");
    assert!(message.contains("v2") && message.contains(&format!("v{PROTOCOL_VERSION}")));
    assert_eq!(
        error.exit_code(),
        ops::exit::REFUSED,
        "refused before anything ran"
    );
    // The rig heard Hellos only: not one command.
    assert!(!heard.is_empty());
    assert!(
        heard.iter().all(|k| k.as_ref().ok() == Some(&"Hello")),
        "{heard:?}"
    );
    assert!(
        !scratch.path("rig.mcap").exists(),
        "no log for a refused session"
    );
}

#[test]
fn a_rig_that_does_not_fit_the_scenario_is_refused_before_any_motion() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    // The host's scenario: other legs; then another sample rate.
    let longer = Scratch::new(&format!(
        "{}\n[platform]\nmax_leg_length_m = 2.35\n",
        quick()
    ));
    let error = run_rig(&rig_tare(&longer, emulator.address()))
        .err()
        .unwrap();
    assert!(error.to_string().contains("stroke"), "{error}");
    assert!(
        error.to_string().contains("platform.max_leg_length_m"),
        "{error}"
    );
    assert_eq!(error.exit_code(), ops::exit::REFUSED);
    let faster =
        Scratch::new(&quick().replace("sample_rate_hz = 500.0", "sample_rate_hz = 1000.0"));
    let error = run_rig(&rig_tare(&faster, emulator.address()))
        .err()
        .unwrap();
    assert!(
        error.to_string().contains("samples every 0.002 s"),
        "{error}"
    );
    assert_eq!(error.exit_code(), ops::exit::REFUSED);
    let stopped = emulator.stop().unwrap();
    assert_eq!(stopped.stats().core.sessions, 2);
    // At most the safe stop of the host that got as far as checking the limits.
    assert!(
        stopped.stats().core.commands_accepted <= 1,
        "{:?}",
        stopped.stats()
    );
    assert!(stopped.last_command().is_none_or(|c| !c.enable));
}

#[test]
fn a_second_sender_cannot_move_the_platform_during_a_session() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let rig_addr = socket_of(emulator.address());
    let args = rig_tare(&scratch, emulator.address());
    let host = std::thread::spawn({
        let args = args.clone();
        move || run_rig(&args)
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    while emulator.sessions().is_empty() {
        assert!(Instant::now() < deadline, "no session");
        std::thread::sleep(Duration::from_millis(10));
    }

    // Another host asking for the rig is told it is busy.
    let other = RigBackend::connect(
        emulator.address(),
        RigOptions {
            handshake_timeout: Duration::from_millis(300),
            ..RigOptions::default()
        },
    )
    .err()
    .expect("refused");
    assert!(other.to_string().contains("another host holds"), "{other}");
    // A stranger speaking the protocol correctly: Hello, then full-force commands in order.
    let stranger = RawPeer::new();
    stranger.send(
        rig_addr,
        &Message::Hello(Hello {
            host_nonce: 99,
            key_id: None,
        }),
        None,
    );
    let answer = stranger.recv(None);
    assert!(
        matches!(answer, Some(Message::Fault(f)) if f.code == FaultCode::BUSY),
        "{answer:?}"
    );
    for sequence in 1..=1000 {
        stranger.send(rig_addr, &command(sequence, 19_000.0), None);
        std::thread::sleep(Duration::from_micros(500));
    }

    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    let stats = stopped.stats().core;
    assert!(stats.foreign_sender >= 1000, "{stats:?}");
    // Every command the rig accepted came from the session's host, and every one the host
    // sent reached it (or is a sequence gap the rig counted). The host's count is over the
    // whole link: a measurement's own counters miss the brake heartbeats sent outside its
    // window, e.g. while the log is finished (regression: 3753 accepted against 3752 + 1).
    assert_eq!(
        stats.commands_accepted + stats.commands_lost,
        outcome.link_total.commands_sent,
        "{stats:?} against {:?}",
        outcome.link_total
    );
    assert!(outcome.link_total.commands_sent > outcome.link[0].counters.commands_sent);
}

#[test]
fn with_a_key_only_correctly_keyed_frames_count() {
    let _lock = real_time();
    let key_hex = TEST_KEY_HEX;
    // The scenario names the key file next to it (every scratch holds the test key).
    let scratch = Scratch::new(&quick());
    std::fs::write(scratch.path("wrong.key"), "ff".repeat(32)).unwrap();
    let emulator = start(&emulate_args(&scratch));
    let rig_addr = socket_of(emulator.address());

    // No key (--insecure), or the wrong one: refused by name, saying how to pair.
    let plain = Scratch::new(&quick().replace("key_file = \"rig.key\"\n", ""));
    let insecure = RigRun {
        insecure: true,
        ..rig_tare(&plain, emulator.address())
    };
    let error = run_rig(&insecure).err().unwrap();
    assert!(
        error.to_string().contains("requires a shared key"),
        "{error}"
    );
    assert!(
        error.to_string().contains("copy the rig's key file"),
        "{error}"
    );
    assert_eq!(error.exit_code(), ops::exit::REFUSED);
    let wrong = scratch.path("wrong.key");
    let wrongly_keyed = RigRun {
        key: Some(wrong.clone()),
        ..rig_tare(&plain, emulator.address())
    };
    let error = run_rig(&wrongly_keyed).err().unwrap();
    assert!(error.to_string().contains("key differs"), "{error}");
    assert!(error.to_string().contains("stewart key new"), "{error}");

    // A keyed session opened by hand, so that bad frames come from the session's own address.
    let key = Key::from_hex(key_hex).unwrap();
    let other = Key::from_hex(&"ff".repeat(32)).unwrap();
    let peer = RawPeer::new();
    let hello = Message::Hello(Hello {
        host_nonce: 5,
        key_id: Some(key.id()),
    });
    peer.send(
        rig_addr,
        &hello,
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
    );
    let Some(Message::HelloAck(ack)) = peer.recv(Some(&Auth {
        key: key.bytes(),
        session_id: 0,
    })) else {
        panic!("no HelloAck")
    };
    let good = Auth {
        key: key.bytes(),
        session_id: ack.session_id,
    };
    let wrong_key = Auth {
        key: other.bytes(),
        session_id: ack.session_id,
    };
    peer.send(rig_addr, &command(1, 10.0), Some(&good));
    peer.send(rig_addr, &command(2, 19_000.0), None);
    peer.send(rig_addr, &command(3, 19_000.0), Some(&wrong_key));
    peer.send(
        rig_addr,
        &command(4, 19_000.0),
        Some(&Auth {
            key: key.bytes(),
            session_id: 0,
        }),
    );
    // Sensor frames come back tagged for this session only.
    assert!(matches!(peer.recv(Some(&good)), Some(Message::Sensor(_))));
    // The hand-made session ends when its host goes quiet (the rig's session timeout), before
    // the CLI's keyed run below: the rig's frames to it stop (`recv` gives up after 500 ms).
    let deadline = Instant::now() + Duration::from_secs(10);
    while peer.recv(Some(&good)).is_some() {
        assert!(
            Instant::now() < deadline,
            "the hand-made session did not end"
        );
    }

    // The CLI with the scenario's key: a whole run.
    let outcome =
        run_rig(&rig_tare(&scratch, emulator.address())).unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(outcome.link[0].counters.auth_failed, 0);
    let stats = stopped.stats().core;
    // Two refused Hellos and three bad commands.
    assert!(stats.auth_failed >= 5, "{stats:?}");
    // No fault of the CLI's session: any fault is the hand-made session's watchdog on its one
    // applied command. The list is empty in every run here (`faults_sent` 0: the hand-made
    // session's driven command 1 does not trip the rig's watchdog before the session times
    // out), so these two checks hold vacuously; the watchdog's part is not shown by this test.
    let faults = stopped.faults();
    assert!(
        faults.iter().all(|f| f.code == FaultCode::WATCHDOG),
        "{faults:?}"
    );
    assert!(faults.iter().all(|f| f.command_sequence == 1), "{faults:?}");
    let peer_addr = peer.socket.local_addr().unwrap();
    let sessions = stopped.session_peer();
    assert_ne!(sessions, Some(Peer::Udp(peer_addr)));
}
