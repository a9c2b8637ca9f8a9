use prost::Message as _;
use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, ReflectMessage, Value};
use serde::Serialize;
use serde_json::{json, Value as Json};

use super::descriptor::{file_descriptor_set_bytes, proto_text, MESSAGES, PACKAGE};
use super::*;
use crate::messages::{CommandMsg, LegsMsg, PidMsg, PoseMsg, PoseValue, SensorMsg};
use crate::read::records::{FromProto, LegsRecord, PoseRecord, SensorRecord};

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

fn sensor() -> SensorMsg {
    SensorMsg {
        run: "loaded",
        sequence: u64::MAX,
        time_s: -0.0,
        leg_lengths_m: core::array::from_fn(awkward),
        leg_forces_n: core::array::from_fn(|i| awkward(i + 6)),
        gyro_rad_s: [0.1, -0.2, f64::NAN],
        accel_m_s2: [0.0, 0.0, 9.80665],
        status: u32::MAX,
    }
}

#[test]
fn a_sensor_frame_round_trips_bit_for_bit() {
    let m = sensor();
    let bytes = check_against_descriptor(&m);
    let r = SensorRecord::from_proto(SensorFrame::decode(bytes.as_slice()).unwrap()).unwrap();
    assert_eq!(r.run, "loaded");
    assert_eq!(r.sequence, u64::MAX);
    assert_eq!(r.time_s.to_bits(), (-0.0f64).to_bits());
    assert_eq!(bits(&r.leg_lengths_m), bits(&m.leg_lengths_m));
    assert_eq!(bits(&r.leg_forces_n), bits(&m.leg_forces_n));
    assert_eq!(bits(&r.gyro_rad_s), bits(&m.gyro_rad_s));
    assert_eq!(bits(&r.accel_m_s2), bits(&m.accel_m_s2));
    assert_eq!(r.status, u32::MAX);
}

#[test]
fn a_frame_of_defaults_reads_back_whole() {
    let frame = control::io::SensorFrame::default();
    let m = SensorMsg::new("", &frame);
    let bytes = check_against_descriptor(&m);
    assert!(bytes.len() > 4 * 2, "the arrays are written even when zero");
    let r = SensorRecord::from_proto(SensorFrame::decode(bytes.as_slice()).unwrap()).unwrap();
    assert_eq!(r.to_frame(), frame);
}

#[test]
fn an_array_of_the_wrong_length_is_refused() {
    let mut bytes = encode(&sensor());
    let mut e = Encoder::new(&mut bytes);
    // A seventh leg length appended: a packed field's entries concatenate.
    e.doubles(4, &[1.0]);
    let err = SensorRecord::from_proto(SensorFrame::decode(bytes.as_slice()).unwrap()).unwrap_err();
    assert!(
        err.contains("leg_lengths_m holds 7 numbers, not 6"),
        "{err}"
    );
}

#[test]
fn the_other_channels_match_the_descriptor_and_read_back() {
    let c = CommandMsg {
        run: "tare",
        time_s: 1.5,
        sequence: 7,
        sensor_sequence: 6,
        leg_forces_n: core::array::from_fn(awkward),
        enable: true,
    };
    let bytes = check_against_descriptor(&c);
    let p = CommandFrame::decode(bytes.as_slice()).unwrap();
    assert_eq!(
        p.leg_forces_n
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>(),
        bits(&c.leg_forces_n).to_vec()
    );
    assert!(p.enable);

    let pose = PoseMsg {
        run: "loaded",
        time_s: 2.0,
        desired: PoseValue {
            position_m: [0.0, 0.0, 1.2],
            rpy_rad: [f64::NAN, -0.0, 0.1],
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
        desired_length_m: core::array::from_fn(awkward),
        measured_length_m: [1.9; 6],
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
        SensorMsg::NAME,
        CommandMsg::NAME,
        PoseMsg::NAME,
        LegsMsg::NAME,
        PidMsg::NAME,
    ] {
        assert!(pool.get_message_by_name(name).is_some(), "{name}");
    }
}
