use super::*;
use crate::wire::*;
use proptest::prelude::*;

pub(crate) fn example_sensor() -> Sensor {
    Sensor {
        sequence: 1,
        time_ns: 1_000_000,
        leg_lengths_m: [0.5; LEG_COUNT],
        leg_forces_n: [100.0, 100.0, 100.0, 100.0, 100.0, 100.0],
        gyro_rad_s: [0.0, 0.0, 0.0],
        accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
        status: 0b11,
    }
}

pub(crate) fn example_command() -> Command {
    Command {
        sequence: 1,
        sensor_sequence: 1,
        leg_forces_n: [-12.5, 0.0, 250.0, 1.0, 2.0, 3.0],
        enable: true,
    }
}

fn example_ack() -> HelloAck {
    HelloAck {
        host_nonce: 0x0102_0304_0506_0708,
        session_id: 42,
        identity: identity_from_str("emulator"),
        layout: SensorLayout {
            leg_count: 6,
            imu_present: true,
            accel_position_m: [0.0, 0.0, 0.05],
        },
        sample_period_ns: 1_000_000,
        watchdog_ns: 20_000_000,
        limits: Limits {
            stroke_min_m: 0.4,
            stroke_max_m: 0.7,
            speed_max_m_s: 0.5,
            force_min_n: -2000.0,
            force_max_n: 2000.0,
        },
    }
}

fn all_examples() -> [Message; 5] {
    [
        Message::Hello(Hello {
            host_nonce: 7,
            key_id: Some(0xDEAD_BEEF),
        }),
        Message::HelloAck(example_ack()),
        Message::Sensor(example_sensor()),
        Message::Command(example_command()),
        Message::Fault(Fault {
            code: FaultCode::FORCE_LIMIT,
            leg: 3,
            value: 2500.0,
            command_sequence: 99,
        }),
    ]
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[test]
fn crc_is_crc32_iso_hdlc() {
    // The catalogue's check value: anyone implementing the same CRC gets this.
    assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
}

#[test]
fn every_message_round_trips_with_and_without_key() {
    let key = b"0123456789abcdef0123456789abcdef";
    for message in all_examples() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&message, None, &mut buf).unwrap();
        assert_eq!(decode(&buf[..n], None), Ok(message));

        let auth = Auth { key, session_id: 5 };
        let m = encode(&message, Some(&auth), &mut buf).unwrap();
        assert_eq!(m, n + TAG_LEN);
        assert_eq!(decode(&buf[..m], Some(&auth)), Ok(message));
    }
}

#[test]
fn largest_messages_fit_the_buffers() {
    let auth = Auth {
        key: b"k",
        session_id: u64::MAX,
    };
    let big_sensor = Sensor {
        sequence: u64::MAX,
        time_ns: u64::MAX,
        status: u32::MAX,
        ..example_sensor()
    };
    let big_ack = HelloAck {
        host_nonce: u64::MAX,
        session_id: u64::MAX,
        sample_period_ns: u32::MAX,
        watchdog_ns: u32::MAX,
        ..example_ack()
    };
    for message in [Message::Sensor(big_sensor), Message::HelloAck(big_ack)] {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&message, Some(&auth), &mut buf).unwrap();
        assert!(n <= 215, "{} needs {n} bytes", message.kind_name());
        let mut cobs_buf = [0u8; MAX_COBS_LEN];
        let c = cobs_encode(&buf[..n], &mut cobs_buf).unwrap();
        assert!(c <= MAX_COBS_LEN);
    }
}

#[test]
fn a_short_buffer_is_an_error_not_a_panic() {
    let message = Message::Sensor(example_sensor());
    for len in 0..60 {
        let mut buf = vec![0u8; len];
        assert_eq!(
            encode(&message, None, &mut buf),
            Err(CodecError::BufferTooSmall)
        );
    }
}

#[test]
fn every_single_bit_flip_is_caught() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&Message::Command(example_command()), None, &mut buf).unwrap();
    let mut caught = 0;
    for bit in 0..n * 8 {
        let mut frame = buf[..n].to_vec();
        frame[bit / 8] ^= 1 << (bit % 8);
        assert_eq!(decode(&frame, None), Err(CodecError::BadCrc), "bit {bit}");
        caught += 1;
    }
    assert_eq!(caught, n * 8);
}

/// Re-stamps a frame's CRC after editing it, as a peer with a different version would send.
fn restamp(frame: &mut [u8]) {
    let n = frame.len() - CRC_LEN;
    let crc = CRC32.checksum(&frame[..n]);
    frame[n..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn another_version_is_named_not_misread() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&Message::Sensor(example_sensor()), None, &mut buf).unwrap();
    let frame = &mut buf[..n];
    frame[1] = PROTOCOL_VERSION + 1;
    restamp(frame);
    assert_eq!(
        decode(frame, None),
        Err(CodecError::VersionMismatch(PROTOCOL_VERSION + 1))
    );
    frame[0] = b'X';
    restamp(frame);
    assert_eq!(decode(frame, None), Err(CodecError::BadMagic(b'X')));
}

#[test]
fn tags_bind_key_and_session() {
    let message = Message::Command(example_command());
    let good = Auth {
        key: b"the right key...",
        session_id: 9,
    };
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&message, Some(&good), &mut buf).unwrap();
    let wrong_key = Auth {
        key: b"the wrong key...",
        ..good
    };
    let old_session = Auth {
        session_id: 8,
        ..good
    };
    assert_eq!(decode(&buf[..n], Some(&wrong_key)), Err(CodecError::BadTag));
    assert_eq!(
        decode(&buf[..n], Some(&old_session)),
        Err(CodecError::BadTag)
    );
    assert_eq!(decode(&buf[..n], None), Err(CodecError::UnexpectedTag));

    let m = encode(&message, None, &mut buf).unwrap();
    assert_eq!(decode(&buf[..m], Some(&good)), Err(CodecError::MissingTag));

    // A forger who sets the flag and appends 32 bytes of guesswork, with a valid CRC.
    let mut forged = buf[..m - CRC_LEN].to_vec();
    forged[2] = FLAG_TAGGED;
    forged.extend_from_slice(&[0xA5; TAG_LEN]);
    forged.extend_from_slice(&[0; CRC_LEN]);
    restamp(&mut forged);
    assert_eq!(decode(&forged, Some(&good)), Err(CodecError::BadTag));
}

#[test]
fn trailing_bytes_and_bad_bodies_are_refused() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&Message::Command(example_command()), None, &mut buf).unwrap();
    let mut longer = buf[..n - CRC_LEN].to_vec();
    longer.push(0);
    longer.extend_from_slice(&[0; CRC_LEN]);
    restamp(&mut longer);
    assert_eq!(decode(&longer, None), Err(CodecError::TrailingBytes));

    // Variant index 5 does not exist.
    let mut unknown = vec![MAGIC, PROTOCOL_VERSION, 0, 5, 0, 0, 0, 0];
    restamp(&mut unknown);
    assert_eq!(decode(&unknown, None), Err(CodecError::BadBody));
    // `enable` must be 0 or 1.
    let mut bad_bool = buf[..n].to_vec();
    let enable_at = n - CRC_LEN - 1;
    bad_bool[enable_at] = 2;
    restamp(&mut bad_bool);
    assert_eq!(decode(&bad_bool, None), Err(CodecError::BadBody));
}

#[test]
fn cobs_round_trip_has_no_zero_but_the_delimiter() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&Message::Sensor(example_sensor()), None, &mut buf).unwrap();
    assert!(
        buf[..n].contains(&0),
        "the example should exercise zero bytes"
    );
    let mut wire = [0u8; MAX_COBS_LEN];
    let c = cobs_encode(&buf[..n], &mut wire).unwrap();
    assert_eq!(wire[c - 1], 0);
    assert!(!wire[..c - 1].contains(&0));
    let mut back = [0u8; MAX_FRAME_LEN];
    let m = cobs_decode(&wire[..c], &mut back).unwrap();
    assert_eq!(&back[..m], &buf[..n]);
    assert_eq!(
        decode(&back[..m], None),
        Ok(Message::Sensor(example_sensor()))
    );
}

#[test]
fn key_id_is_a_stable_fingerprint() {
    // SHA-256("abc") starts ba 78 16 bf (FIPS 180-2 test vector).
    assert_eq!(key_id(b"abc"), u32::from_le_bytes([0xba, 0x78, 0x16, 0xbf]));
}

/// The hex examples in docs/protocol.md are produced here; the test fails when they drift.
#[test]
fn protocol_doc_examples_match_the_codec() {
    let doc = include_str!("../../../../docs/protocol.md");
    let mut buf = [0u8; MAX_FRAME_LEN];
    let mut examples = Vec::new();
    for message in all_examples() {
        let n = encode(&message, None, &mut buf).unwrap();
        examples.push((message.kind_name().to_string(), hex(&buf[..n])));
    }
    let auth = Auth {
        key: b"0123456789abcdef0123456789abcdef",
        session_id: 42,
    };
    let n = encode(&Message::Command(example_command()), Some(&auth), &mut buf).unwrap();
    examples.push(("tagged Command".into(), hex(&buf[..n])));
    let mut wire = [0u8; MAX_COBS_LEN];
    let n = encode(&Message::Sensor(example_sensor()), None, &mut buf).unwrap();
    let c = cobs_encode(&buf[..n], &mut wire).unwrap();
    examples.push(("COBS Sensor".into(), hex(&wire[..c])));
    let report: String = examples
        .iter()
        .map(|(name, line)| format!("{name}: {line}\n"))
        .collect();
    println!("{report}");
    for (name, line) in &examples {
        assert!(
            doc.contains(line.as_str()),
            "docs/protocol.md lacks the {name} example:\n{report}"
        );
    }
}

fn any_sensor() -> impl Strategy<Value = Sensor> {
    (any::<u64>(), any::<u64>(), any::<[u64; 18]>(), any::<u32>()).prop_map(
        |(sequence, time_ns, bits, status)| {
            let f = |i: usize| f64::from_bits(bits[i]);
            Sensor {
                sequence,
                time_ns,
                leg_lengths_m: core::array::from_fn(f),
                leg_forces_n: core::array::from_fn(|i| f(6 + i)),
                gyro_rad_s: core::array::from_fn(|i| f(12 + i)),
                accel_m_s2: core::array::from_fn(|i| f(15 + i)),
                status,
            }
        },
    )
}

fn bits(s: &Sensor) -> Vec<u64> {
    s.leg_lengths_m
        .iter()
        .chain(&s.leg_forces_n)
        .chain(&s.gyro_rad_s)
        .chain(&s.accel_m_s2)
        .map(|v| v.to_bits())
        .collect()
}

proptest! {
    #[test]
    fn random_bytes_never_panic_the_decoder(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let auth = Auth { key: b"k", session_id: 1 };
        // Random bytes pass a 32-bit CRC with probability 2^-32: expect an error.
        prop_assert!(decode(&bytes, None).is_err());
        prop_assert!(decode(&bytes, Some(&auth)).is_err());
        let mut out = [0u8; MAX_FRAME_LEN];
        let _ = cobs_decode(&bytes, &mut out);
    }

    #[test]
    fn random_bodies_with_valid_crc_never_panic(body in proptest::collection::vec(any::<u8>(), 0..220), tagged in any::<bool>()) {
        let mut frame = vec![MAGIC, PROTOCOL_VERSION, u8::from(tagged)];
        frame.extend_from_slice(&body);
        frame.extend_from_slice(&[0; CRC_LEN]);
        restamp(&mut frame);
        let auth = Auth { key: b"k", session_id: 1 };
        let _ = decode(&frame, None);
        let _ = decode(&frame, Some(&auth));
    }

    #[test]
    fn sensor_frames_round_trip_bit_for_bit(sensor in any_sensor(), session_id in any::<u64>()) {
        let auth = Auth { key: b"secret", session_id };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&Message::Sensor(sensor), Some(&auth), &mut buf).unwrap();
        let mut wire = [0u8; MAX_COBS_LEN];
        let c = cobs_encode(&buf[..n], &mut wire).unwrap();
        let mut back = [0u8; MAX_FRAME_LEN];
        let m = cobs_decode(&wire[..c], &mut back).unwrap();
        match decode(&back[..m], Some(&auth)) {
            Ok(Message::Sensor(got)) => {
                prop_assert_eq!(got.sequence, sensor.sequence);
                prop_assert_eq!(got.time_ns, sensor.time_ns);
                prop_assert_eq!(got.status, sensor.status);
                prop_assert_eq!(bits(&got), bits(&sensor));
            }
            other => prop_assert!(false, "decoded {:?}", other),
        }
    }
}
