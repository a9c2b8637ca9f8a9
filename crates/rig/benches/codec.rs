//! Cost of one sensor frame through the codec: encode and decode, with and without a key, and
//! COBS framing. Tells a firmware author what a 1 kHz link costs on the host.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use rig::codec::{self, Auth, MAX_COBS_LEN, MAX_FRAME_LEN};
use rig::wire::{Message, Sensor, LEG_COUNT};

fn sensor() -> Message {
    Message::Sensor(Sensor {
        sequence: 123_456,
        time_ns: 123_456_000_000,
        leg_lengths_m: [0.55; LEG_COUNT],
        leg_forces_n: [1234.5; LEG_COUNT],
        gyro_rad_s: [0.01, -0.02, 0.03],
        accel_m_s2: [0.1, 0.2, 9.8],
        status: 1,
    })
}

fn bench(c: &mut Criterion) {
    let message = sensor();
    let auth = Auth {
        key: b"0123456789abcdef0123456789abcdef",
        session_id: 42,
    };
    let mut plain = [0u8; MAX_FRAME_LEN];
    let n_plain = codec::encode(&message, None, &mut plain).unwrap();
    let mut tagged = [0u8; MAX_FRAME_LEN];
    let n_tagged = codec::encode(&message, Some(&auth), &mut tagged).unwrap();

    c.bench_function("encode sensor", |b| {
        let mut out = [0u8; MAX_FRAME_LEN];
        b.iter(|| codec::encode(black_box(&message), None, &mut out))
    });
    c.bench_function("decode sensor", |b| {
        b.iter(|| codec::decode(black_box(&plain[..n_plain]), None))
    });
    c.bench_function("encode sensor + HMAC", |b| {
        let mut out = [0u8; MAX_FRAME_LEN];
        b.iter(|| codec::encode(black_box(&message), Some(&auth), &mut out))
    });
    c.bench_function("decode sensor + HMAC", |b| {
        b.iter(|| codec::decode(black_box(&tagged[..n_tagged]), Some(&auth)))
    });
    c.bench_function("COBS encode + decode sensor", |b| {
        let mut wire = [0u8; MAX_COBS_LEN];
        let mut back = [0u8; MAX_FRAME_LEN];
        b.iter(|| {
            let n = codec::cobs_encode(black_box(&plain[..n_plain]), &mut wire).unwrap();
            codec::cobs_decode(&wire[..n], &mut back)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
