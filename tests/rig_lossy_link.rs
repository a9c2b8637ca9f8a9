//! A damaged link: 10 % of the sensor frames dropped and 1 % corrupted, or random datagrams
//! (and well-formed frames from a stranger) sprayed at both sockets. The run completes, the
//! damage is counted and reported, nothing panics.

use crate::support;

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use measure::End;
use rig::codec::{self, CRC32, MAX_FRAME_LEN};
use rig::transport::Peer;
use rig::wire::{Command, Message, Sensor};
use support::*;

/// xorshift64*: enough randomness for junk datagrams, without a dependency.
struct Junk(u64);

impl Junk {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A datagram: random bytes of random length (0..=300), or a frame of this protocol with
    /// a valid CRC around a random body, or a valid sensor / command frame with an absurd
    /// sequence number.
    fn datagram(&mut self) -> Vec<u8> {
        match self.next() % 4 {
            0 => {
                let mut out = [0u8; MAX_FRAME_LEN];
                let sensor = Sensor {
                    sequence: 1 << 40,
                    time_ns: 0,
                    leg_lengths_m: [1.9; 6],
                    leg_forces_n: [0.0; 6],
                    gyro_rad_s: [0.0; 3],
                    accel_m_s2: [0.0, 0.0, 9.8],
                    status: 0,
                };
                let n = codec::encode(&Message::Sensor(sensor), None, &mut out).unwrap();
                out[..n].to_vec()
            }
            1 => {
                let mut out = [0u8; MAX_FRAME_LEN];
                let command = Command {
                    sequence: 1 << 40,
                    sensor_sequence: 0,
                    leg_forces_n: [15_000.0; 6],
                    enable: true,
                };
                let n = codec::encode(&Message::Command(command), None, &mut out).unwrap();
                out[..n].to_vec()
            }
            2 => {
                let len = 8 + (self.next() % 200) as usize;
                let mut frame: Vec<u8> = (0..len).map(|_| self.next() as u8).collect();
                frame[0] = codec::MAGIC;
                frame[1] = rig::wire::PROTOCOL_VERSION;
                frame[2] = 0;
                let crc = CRC32.checksum(&frame[..len - 4]);
                frame[len - 4..].copy_from_slice(&crc.to_le_bytes());
                frame
            }
            _ => {
                let len = (self.next() % 301) as usize;
                (0..len).map(|_| self.next() as u8).collect()
            }
        }
    }
}

fn socket_of(address: &str) -> SocketAddr {
    address.trim_start_matches("udp://").parse().unwrap()
}

#[test]
fn dropped_and_corrupted_frames_are_counted_and_the_run_completes() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&EmulateOptions {
        drop: 0.10,
        corrupt: 0.01,
        ..emulate_args_fast(&scratch)
    });
    let args = rig_tare(&scratch, emulator.address());
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(outcome.exit_code(), ops::exit::DONE);
    assert!(scratch.path("tare.json").exists());

    let c = outcome.link[0].counters;
    let injected = stopped.stats();
    eprintln!("host: {c:?}\nemulator: {injected:?}");
    let produced = (c.accepted + c.lost) as f64;
    let lost = c.lost as f64 / produced;
    assert!((0.06..0.15).contains(&lost), "lost fraction {lost}");
    // A corrupted frame arrives, fails its CRC, and its sequence number counts as lost too.
    assert!(
        c.corrupt > 0 && c.corrupt <= injected.corrupted_injected,
        "{c:?}"
    );
    let corrupt = c.corrupt as f64 / produced;
    assert!(
        (0.002..0.03).contains(&corrupt),
        "corrupt fraction {corrupt}"
    );
    assert!(c.lost >= c.corrupt);
    assert_eq!(c.foreign, 0);
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());

    // Reported: in the printed lines and in the log.
    let lines = ops::rig::link_lines(&outcome.link);
    assert!(
        lines[0].contains(&format!("lost {}", c.lost)),
        "{}",
        lines[0]
    );
    assert!(
        lines[0].contains(&format!("corrupt {}", c.corrupt)),
        "{}",
        lines[0]
    );
    let messages = read_log(&scratch.path("rig.mcap"));
    let end = on(&messages, runlog::rig_record::LINK)
        .last()
        .copied()
        .unwrap()
        .clone();
    assert_eq!(end["counters"]["lost"].as_u64(), Some(c.lost));
    assert_eq!(end["counters"]["corrupt"].as_u64(), Some(c.corrupt));
}

#[test]
fn random_datagrams_at_both_sockets_are_counted_and_harmless() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let rig_addr = socket_of(emulator.address());
    let args = rig_tare(&scratch, emulator.address());
    let host = std::thread::spawn({
        let args = args.clone();
        move || run_rig(&args)
    });

    // Wait for the session, then spray both ends from a stranger's socket for 3 s.
    let deadline = Instant::now() + Duration::from_secs(10);
    let host_addr = loop {
        if let Some(s) = emulator.sessions().first() {
            let Peer::Udp(addr) = s.peer else {
                panic!("not UDP")
            };
            break addr;
        }
        assert!(Instant::now() < deadline, "no session");
        std::thread::sleep(Duration::from_millis(10));
    };
    let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut junk = Junk(0x9e37_79b9_7f4a_7c15);
    let mut sent = 0u64;
    let spray_until = Instant::now() + Duration::from_secs(3);
    while Instant::now() < spray_until {
        for to in [host_addr, rig_addr] {
            let datagram = junk.datagram();
            let _ = stranger.send_to(&datagram, to);
        }
        sent += 1;
        std::thread::sleep(Duration::from_micros(500));
    }

    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    let c = outcome.link[0].counters;
    eprintln!(
        "sprayed {sent} datagrams at each end\nhost: {c:?}\nemulator: {:?}",
        stopped.stats()
    );
    // Everything from the stranger is refused by address, before any decoding: not one frame
    // of the run was lost to it or taken out of sequence by its absurd sequence numbers.
    assert!(c.foreign > sent / 2, "{c:?}");
    assert_eq!(c.out_of_sequence, 0);
    assert_eq!(c.corrupt, 0);
    // The emulator decodes before it looks at the sender (it must answer strangers' Hellos),
    // so the stranger's junk shows there as corrupt, foreign or another version.
    let e = stopped.stats().core;
    assert!(
        e.foreign_sender + e.corrupt + e.version_mismatch > sent / 2,
        "{e:?}"
    );
    assert!(e.foreign_sender > 0, "{e:?}");
    // Every command the host sent over the whole link (brake heartbeats and the closing safe
    // stop included) reached the rig, or is a sequence gap it counted.
    assert_eq!(
        e.commands_accepted + e.commands_lost,
        outcome.link_total.commands_sent,
        "{e:?} against {:?}",
        outcome.link_total
    );
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    assert_eq!(outcome.exit_code(), ops::exit::DONE);
}
