use prost::Message as _;
use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, ReflectMessage, Value};
use serde::Serialize;
use serde_json::{json, Value as Json};

use super::descriptor::{file_descriptor_set_bytes, proto_text, MESSAGES, PACKAGE};
use super::*;
use crate::compact::{CommandBlock, CommandCounts, SensorBlock, SensorCounts};
use crate::messages::{LegsMsg, PidMsg, PoseMsg, PoseValue};
use crate::read::records::{FromProto, LegsRecord, PoseRecord};

const PROTO_FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/proto/stewart.proto");

#[test]
fn the_proto_file_in_the_repository_is_the_descriptor() {
    let text = proto_text();
    let file = std::fs::read_to_string(PROTO_FILE).unwrap_or_default();
    if file != text && std::env::var_os("STEWART_WRITE_PROTO").is_some() {
        std::fs::write(PROTO_FILE, &text).unwrap();
        return;
    }
    assert!(
        file == text,
        "{PROTO_FILE} differs from crates/runlog/src/proto/descriptor.rs; \
         STEWART_WRITE_PROTO=1 cargo test -p runlog proto rewrites it"
    );
}

fn pool() -> DescriptorPool {
    DescriptorPool::decode(file_descriptor_set_bytes().as_slice()).expect("a valid descriptor set")
}

/// A decoded protobuf value as the JSON writer would give it (non-finite numbers as `null`).
fn to_json(v: &Value) -> Json {
    match v {
        Value::F64(x) if x.is_finite() => json!(x),
        Value::F64(_) => Json::Null,
        Value::F32(x) if x.is_finite() => json!(f64::from(*x)),
        Value::F32(_) => Json::Null,
        Value::I64(x) => json!(x),
        Value::U64(x) => json!(x),
        Value::U32(x) => json!(x),
        Value::Bool(x) => json!(x),
        Value::String(x) => json!(x),
        Value::List(l) => Json::Array(l.iter().map(to_json).collect()),
        Value::Message(m) => Json::Object(
            m.descriptor()
                .fields()
                .map(|f| (f.name().to_string(), to_json(&m.get_field(&f))))
                .collect(),
        ),
        other => panic!("no such type in the log's schema: {other:?}"),
    }
}

fn encode<T: Encode>(m: &T) -> Vec<u8> {
    let mut buf = Vec::new();
    m.encode(&mut Encoder::new(&mut buf));
    buf
}

/// `m`'s bytes, decoded with the descriptor by prost-reflect: every field known, nothing left
/// over, and the same JSON as the message's JSON form.
fn check_against_descriptor<T: Encode + Serialize>(m: &T) -> Vec<u8> {
    let bytes = encode(m);
    let desc: MessageDescriptor = pool()
        .get_message_by_name(T::NAME)
        .unwrap_or_else(|| panic!("{} not in the descriptor", T::NAME));
    let dm = DynamicMessage::decode(desc, bytes.as_slice()).expect("decodes");
    assert_eq!(
        dm.unknown_fields().count(),
        0,
        "{}: unknown fields",
        T::NAME
    );
    assert_eq!(
        to_json(&Value::Message(dm)),
        serde_json::to_value(m).unwrap(),
        "{}",
        T::NAME
    );
    bytes
}

fn awkward(i: usize) -> f64 {
    [
        f64::NAN,
        -0.0,
        f64::INFINITY,
        0.0,
        f64::NEG_INFINITY,
        1.0 / 3.0,
        -1e-300,
        f64::MAX,
        f64::MIN_POSITIVE,
        5e-324,
    ][i % 10]
}

fn bits<const N: usize>(v: &[f64; N]) -> [u64; N] {
    v.map(f64::to_bits)
}

/// Values exactly representable in `f32` (the display channels' `float`), and the
/// non-finite ones.
fn float_ok(i: usize) -> f64 {
    [f64::NAN, -0.0, f64::INFINITY, 0.0, f64::NEG_INFINITY, 1.5][i % 6]
}

fn sensor_block() -> SensorBlock {
    let mut b = SensorBlock::new("loaded");
    let mut last = SensorCounts::default();
    for k in 0..3u64 {
        let f = control::io::SensorFrame {
            sequence: u64::MAX - 2 + k,
            time_s: 0.001 * k as f64,
            leg_lengths_m: core::array::from_fn(|i| awkward(i + k as usize)),
            leg_forces_n: core::array::from_fn(|i| awkward(i + 6)),
            gyro_rad_s: [0.1, -0.2, f64::NAN],
            accel_m_s2: [0.0, 0.0, 9.80665],
            status: control::io::Status(u32::MAX),
        };
        b.push(&f, &mut last);
    }
    b.finish();
    b
}

#[test]
fn a_sensor_block_matches_the_descriptor_and_reads_back() {
    let b = sensor_block();
    let bytes = check_against_descriptor(&b);
    let p = super::SensorBlock::decode(bytes.as_slice()).unwrap();
    let frames = crate::compact::sensor_frames(&p).unwrap();
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[2].sequence, u64::MAX);
    assert_eq!(frames[0].status.0, u32::MAX);
    assert!(frames[0].leg_lengths_m[0].is_nan() && frames[2].gyro_rad_s[2].is_nan());
    assert_eq!(frames[1].accel_m_s2[2], 9.80665);
}

#[test]
fn the_other_channels_match_the_descriptor_and_read_back() {
    let mut c = CommandBlock::new("tare");
    let command = control::io::CommandFrame {
        sequence: 7,
        sensor_sequence: 6,
        leg_forces_n: core::array::from_fn(awkward),
        enable: true,
    };
    c.push(1.5, &command, &mut CommandCounts::default());
    c.finish();
    let bytes = check_against_descriptor(&c);
    let p = crate::proto::CommandBlock::decode(bytes.as_slice()).unwrap();
    let r = crate::compact::command_frames(&p).unwrap();
    assert_eq!(r[0].time_s, 1.5);
    assert!(r[0].command.enable);
    assert!(r[0].command.leg_forces_n[0].is_nan());

    let pose = PoseMsg {
        run: "loaded",
        time_s: 2.0,
        desired: PoseValue {
            position_m: [0.0, 0.0, 1.25],
            rpy_rad: [f64::NAN, -0.0, 0.125],
        },
        measured: PoseValue::default(),
    };
    let bytes = check_against_descriptor(&pose);
    let r = PoseRecord::from_proto(PoseState::decode(bytes.as_slice()).unwrap()).unwrap();
    assert_eq!(bits(&r.desired.rpy_rad), bits(&pose.desired.rpy_rad));
    assert_eq!(r.measured.position_m, [0.0; 3]);

    let legs = LegsMsg {
        run: "loaded",
        time_s: 3.0,
        desired_length_m: core::array::from_fn(float_ok),
        measured_length_m: [1.875; 6],
        error_m: [-0.0; 6],
        command_force_n: [f64::INFINITY; 6],
        measured_force_n: [2.0; 6],
    };
    let bytes = check_against_descriptor(&legs);
    let r = LegsRecord::from_proto(Legs::decode(bytes.as_slice()).unwrap()).unwrap();
    assert_eq!(bits(&r.desired_length_m), bits(&legs.desired_length_m));
    assert_eq!(bits(&r.error_m), bits(&legs.error_m));

    let pid = PidMsg {
        run: "tare",
        time_s: 4.0,
        p_n: [1.0; 6],
        i_n: [f64::NAN; 6],
        d_n: [-0.0; 6],
        feedforward_n: [3.0; 6],
        output_n: [4.0; 6],
        saturated: [true, false, true, false, false, true],
    };
    let bytes = check_against_descriptor(&pid);
    let p = PidTerms::decode(bytes.as_slice()).unwrap();
    assert_eq!(p.saturated, pid.saturated.to_vec());
}

#[test]
fn every_message_of_the_table_is_in_the_pool_and_every_writer_names_one() {
    let pool = pool();
    for m in MESSAGES {
        let d = pool
            .get_message_by_name(&format!("{PACKAGE}.{}", m.name))
            .unwrap();
        assert_eq!(d.fields().count(), m.fields.len(), "{}", m.name);
    }
    for name in [
        SensorBlock::NAME,
        CommandBlock::NAME,
        PoseMsg::NAME,
        LegsMsg::NAME,
        PidMsg::NAME,
    ] {
        assert!(pool.get_message_by_name(name).is_some(), "{name}");
    }
}
