//! Time of the rig core's work per sample period (`cargo bench -p rig --bench rig_core`): one
//! `tick` (stroke and speed checks, a sensor frame encoded, the actuator output chosen) and one
//! received command (decoded, checked), without and with a key (HMAC-SHA256 on every frame).
//! docs/firmware.md quotes the medians.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use rig::codec::{self, Auth, MAX_FRAME_LEN};
use rig::firmware::{CoreConfig, CoreKey, Outbox, RigCore};
use rig::wire::{identity_from_str, Command, Hello, Limits, Message, SensorLayout, LEG_COUNT};
use stewart_types::SensorFrame;

const KEY: &[u8] = b"0123456789abcdef0123456789abcdef";
const MS: u64 = 1_000_000;

fn config(key: bool) -> CoreConfig {
    CoreConfig {
        identity: identity_from_str("bench"),
        layout: SensorLayout {
            leg_count: LEG_COUNT as u8,
            imu_present: true,
            accel_position_m: [0.0; 3],
        },
        limits: Limits {
            stroke_min_m: 0.4,
            stroke_max_m: 0.7,
            speed_max_m_s: 0.5,
            force_min_n: -1000.0,
            force_max_n: 1000.0,
        },
        sample_period_ns: MS,
        watchdog_ns: 20 * MS,
        session_timeout_ns: u64::MAX,
        key: key.then(|| CoreKey::new(KEY).unwrap()),
        enforce_motion_limits: true,
        speed_window: 10,
        seed: 1,
    }
}

fn frame(message: &Message, auth: Option<Auth<'_>>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = codec::encode(message, auth.as_ref(), &mut out).unwrap();
    out[..n].to_vec()
}

/// A rig core in a session with one command taken, and that command's frame.
fn session(key: bool) -> (RigCore<u8>, Outbox<u8>, Vec<u8>) {
    let mut rig = RigCore::new(config(key)).unwrap();
    let mut out = Outbox::new();
    let auth = |session_id| {
        key.then_some(Auth {
            key: KEY,
            session_id,
        })
    };
    let hello = Message::Hello(Hello {
        host_nonce: 1,
        key_id: key.then(|| codec::key_id(KEY)),
    });
    rig.receive(0, 1, &frame(&hello, auth(0)), &mut out);
    let id = rig.session().unwrap().session_id;
    let command = Message::Command(Command {
        sequence: u64::MAX - 1,
        sensor_sequence: 1,
        leg_forces_n: [250.0; LEG_COUNT],
        enable: true,
    });
    let command = frame(&command, auth(id));
    rig.receive(0, 1, &command, &mut out);
    out.clear();
    (rig, out, command)
}

fn bench(c: &mut Criterion) {
    let sensors = SensorFrame {
        leg_lengths_m: [0.55; LEG_COUNT],
        leg_forces_n: [1234.5; LEG_COUNT],
        gyro_rad_s: [0.01, -0.02, 0.03],
        accel_m_s2: [0.1, 0.2, 9.8],
        ..SensorFrame::default()
    };
    for key in [false, true] {
        let name = if key { " + HMAC" } else { "" };
        let (mut rig, mut out, command) = session(key);
        c.bench_function(&format!("rig core tick{name}"), |b| {
            b.iter(|| {
                // The clock stands still so the watchdog never trips: every tick drives.
                let applied = rig.tick(0, black_box(&sensors), &mut out);
                out.clear();
                applied
            })
        });
        assert!(rig.session().unwrap().fault.is_none());
        c.bench_function(&format!("rig core receive command{name}"), |b| {
            // A repeated sequence: decoded, authenticated, then counted as a duplicate.
            b.iter(|| rig.receive(0, 1, black_box(&command), &mut out))
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
