//! Replays and forgeries during a keyed tare → loaded measurement leave it whole: the tare
//! session's Hello replayed from the host's own address during the loaded run (its tag, made
//! with session 0, stays valid) opened a new session on the rig and lost the run; a forged
//! untagged refusal during the loaded run's handshake aborted it with "key mismatch" although
//! the keys matched.

use crate::support;

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use measure::End;
use rig::codec;
use rig::wire::{Fault, FaultCode, Message, NO_LEG};
use support::*;

/// A UDP relay between the host and the rig that plays the attacker on the host's path: it
/// records the host's first Hello, answers the host's second Hello (the loaded run's) with a
/// forged untagged KEY_MISMATCH before forwarding it, and replays the first Hello to the rig,
/// from the address the rig knows as the host's, once the loaded run has sent `replay_after`
/// frames.
struct Attacker {
    address: String,
    replays: Arc<AtomicU64>,
    forged: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

fn is_hello(frame: &[u8]) -> bool {
    matches!(codec::decode_unverified(frame), Ok((Message::Hello(_), _)))
}

impl Attacker {
    fn new(rig: &str, replay_after: u64) -> Self {
        let rig: SocketAddr = rig.trim_start_matches("udp://").parse().unwrap();
        let front = UdpSocket::bind("127.0.0.1:0").unwrap();
        let back = UdpSocket::bind("127.0.0.1:0").unwrap();
        back.connect(rig).unwrap();
        for s in [&front, &back] {
            s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        }
        let address = format!("udp://{}", front.local_addr().unwrap());
        let (replays, forged) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
        let stop = Arc::new(AtomicBool::new(false));
        let host: Arc<Mutex<Option<SocketAddr>>> = Arc::default();
        let hellos: Arc<Mutex<Vec<Vec<u8>>>> = Arc::default();
        let loaded_frames = Arc::new(AtomicU64::new(0));
        let (front2, back2) = (front.try_clone().unwrap(), back.try_clone().unwrap());
        let to_rig = std::thread::spawn({
            let (stop, host, hellos, forged) = (
                Arc::clone(&stop),
                Arc::clone(&host),
                Arc::clone(&hellos),
                Arc::clone(&forged),
            );
            move || {
                let mut buf = [0u8; 2048];
                while !stop.load(Ordering::SeqCst) {
                    let Ok((n, from)) = front.recv_from(&mut buf) else {
                        continue;
                    };
                    *host.lock().unwrap() = Some(from);
                    let frame = &buf[..n];
                    if is_hello(frame) {
                        let mut seen = hellos.lock().unwrap();
                        if !seen.iter().any(|h| h == frame) {
                            seen.push(frame.to_vec());
                        }
                        if seen.len() == 2 && forged.load(Ordering::SeqCst) == 0 {
                            // The loaded run's handshake: a forged refusal "from the rig" first.
                            let fault = Message::Fault(Fault {
                                code: FaultCode::KEY_MISMATCH,
                                leg: NO_LEG,
                                value: 0.0,
                                command_sequence: 0,
                            });
                            let mut out = [0u8; codec::MAX_FRAME_LEN];
                            let len = codec::encode(&fault, None, &mut out).unwrap();
                            let _ = front.send_to(&out[..len], from);
                            forged.fetch_add(1, Ordering::SeqCst);
                        }
                    }
                    let _ = back.send(frame);
                }
            }
        });
        let to_host = std::thread::spawn({
            let (stop, replays) = (Arc::clone(&stop), Arc::clone(&replays));
            move || {
                let mut buf = [0u8; 2048];
                while !stop.load(Ordering::SeqCst) {
                    let Ok(n) = back2.recv(&mut buf) else {
                        continue;
                    };
                    if let Some(to) = *host.lock().unwrap() {
                        let _ = front2.send_to(&buf[..n], to);
                    }
                    let seen = hellos.lock().unwrap().clone();
                    if seen.len() >= 2 {
                        let frames = loaded_frames.fetch_add(1, Ordering::SeqCst) + 1;
                        if frames == replay_after {
                            // The tare's Hello, byte for byte, from the host's address.
                            for _ in 0..3 {
                                let _ = back2.send(&seen[0]);
                            }
                            replays.fetch_add(3, Ordering::SeqCst);
                        }
                    }
                }
            }
        });
        Self {
            address,
            replays,
            forged,
            stop,
            threads: vec![to_rig, to_host],
        }
    }
}

impl Drop for Attacker {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[test]
fn a_replayed_hello_and_a_forged_refusal_leave_a_keyed_measurement_whole() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args_fast(&scratch));
    // 1 s into the loaded run at 500 Hz.
    let attacker = Attacker::new(emulator.address(), 500);
    let log = scratch.path("rig.mcap");
    let args = rig_against(
        &scratch.config,
        &attacker.address,
        &log,
        ops::rig::RigPlan::Both,
    );
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    let stopped = emulator.stop().unwrap();
    let (replays, forged) = (
        attacker.replays.load(Ordering::SeqCst),
        attacker.forged.load(Ordering::SeqCst),
    );
    drop(attacker);

    assert_eq!((replays, forged), (3, 1), "the attacks were made");
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert!(outcome.repeated.is_empty(), "{:?}", outcome.repeated);
    assert!(outcome.report.is_some());
    // The tare's session and the loaded run's: the replay opened none.
    assert_eq!(sessions.len(), 2, "{sessions:?}");
    assert_eq!(stopped.stats().core.replayed_hellos, 3);
}
