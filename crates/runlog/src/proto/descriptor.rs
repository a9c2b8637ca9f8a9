//! The protobuf schema of the log's 1 kHz channels, in one table ([`MESSAGES`]) from which both
//! the `FileDescriptorSet` the log carries ([`file_descriptor_set`]) and the `.proto` text kept
//! in the repository ([`proto_text`], `crates/runlog/proto/stewart.proto`) are made, so that
//! neither needs `protoc`.
//!
//! Field names, units and shapes are those of the JSON form of each message
//! (docs/log-schema.md); fixed-length arrays are `repeated` fields (packed, proto3).

use prost::Message as _;
use prost_types::field_descriptor_proto::{Label, Type};
use prost_types::{DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet};

/// The protobuf package: message `SensorFrame` is `stewart.SensorFrame`.
pub const PACKAGE: &str = "stewart";

/// The file name inside the descriptor set.
pub const FILE_NAME: &str = "stewart.proto";

/// A field's protobuf type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `double`: every f64 exactly, NaN and infinities included.
    Double,
    /// `float`: an f64 rounded to the nearest f32 (display channels).
    Float,
    /// `sint64`: a signed count, zigzag varint.
    Sint64,
    /// `uint64`.
    Uint64,
    /// `uint32`.
    Uint32,
    /// `bool`.
    Bool,
    /// `string`.
    String,
    /// A message of this package, by its short name.
    Message(&'static str),
}

/// One field of a message.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    /// Field name (as in the JSON form).
    pub name: &'static str,
    /// Field number.
    pub number: u32,
    /// Type.
    pub kind: Kind,
    /// `repeated` (a fixed-length array in the JSON form).
    pub repeated: bool,
    /// What it holds, with its unit.
    pub doc: &'static str,
}

/// One message of the package.
#[derive(Clone, Copy, Debug)]
pub struct MessageSpec {
    /// Short name (`SensorFrame`).
    pub name: &'static str,
    /// What it is.
    pub doc: &'static str,
    /// Its fields.
    pub fields: &'static [Field],
}

const fn f(name: &'static str, number: u32, kind: Kind, doc: &'static str) -> Field {
    Field {
        name,
        number,
        kind,
        repeated: false,
        doc,
    }
}

const fn r(name: &'static str, number: u32, kind: Kind, doc: &'static str) -> Field {
    Field {
        name,
        number,
        kind,
        repeated: true,
        doc,
    }
}

use Kind::{Bool, Double, Float, Sint64, String as Str, Uint32};

const RUN: &str = "measurement this belongs to: \"tare\" or \"loaded\"";
const TIME: &str = "backend sample time, s";

/// Every message of the package, in the order of the `.proto` file.
pub const MESSAGES: &[MessageSpec] = &[
    MessageSpec {
        name: "SensorBlock",
        doc: "Consecutive sensor frames of one measurement (/sensors), as counts: element i of \
              a field with w values a frame is the count minus the one w elements before \
              (i >= w), the count itself in the first frame (docs/log-schema.md).",
        fields: &[
            f("run", 1, Str, RUN),
            r(
                "sequence",
                2,
                Sint64,
                "backend sample counters, delta-coded",
            ),
            r("time_ns", 3, Sint64, "sample instants, ns, delta-coded"),
            r(
                "leg_lengths_nm",
                4,
                Sint64,
                "6 leg lengths a frame, joint centre to joint centre, nm, delta-coded",
            ),
            r(
                "leg_forces_mn",
                5,
                Sint64,
                "6 axial leg forces a frame at the plate joints, mN; positive pushes the plate \
                 away; delta-coded",
            ),
            r(
                "gyro_urad_s",
                6,
                Sint64,
                "3 angular rates a frame of the plate in the IMU's axes, urad/s, delta-coded",
            ),
            r(
                "accel_um_s2",
                7,
                Sint64,
                "3 components a frame of the specific force (a - g) at the accelerometer, IMU \
                 axes, um/s^2, delta-coded",
            ),
            r(
                "status",
                8,
                Uint32,
                "backend status bits (control::io::Status), one a frame",
            ),
            r(
                "raw_index",
                9,
                Uint32,
                "positions of the values without a count (time 0..n, lengths n..7n, forces \
                 7n..13n, gyro 13n..16n, accel 16n..19n for n frames)",
            ),
            r(
                "raw_value",
                10,
                Double,
                "those values, exactly (NaN, infinities)",
            ),
        ],
    },
    MessageSpec {
        name: "CommandBlock",
        doc: "Consecutive force commands of one measurement (/commands), as counts, \
              delta-coded as in SensorBlock.",
        fields: &[
            f("run", 1, Str, RUN),
            r(
                "time_ns",
                2,
                Sint64,
                "time of the sensor frame each command answers, ns, delta-coded",
            ),
            r("sequence", 3, Sint64, "host command counters, delta-coded"),
            r(
                "sensor_sequence",
                4,
                Sint64,
                "sensor sequence each command was computed from, delta-coded",
            ),
            r(
                "leg_forces_mn",
                5,
                Sint64,
                "6 axial force commands a frame, mN; positive extends; delta-coded",
            ),
            r(
                "enable",
                6,
                Bool,
                "actuators follow the forces; false = brake; one a frame",
            ),
            r(
                "raw_index",
                7,
                Uint32,
                "positions of the values without a count (time 0..n, forces n..7n)",
            ),
            r(
                "raw_value",
                8,
                Double,
                "those values, exactly (NaN, infinities)",
            ),
        ],
    },
    MessageSpec {
        name: "Pose",
        doc: "A pose of the platform frame P in the base frame B.",
        fields: &[
            r(
                "position_m",
                1,
                Float,
                "3 coordinates of the P origin in B, m",
            ),
            r(
                "rpy_rad",
                2,
                Float,
                "roll, pitch, yaw with R = Rx·Ry·Rz, rad",
            ),
        ],
    },
    MessageSpec {
        name: "PoseState",
        doc: "Desired and measured pose of P in B (/pose).",
        fields: &[
            f("run", 1, Str, RUN),
            f("time_s", 2, Double, TIME),
            f("desired", 3, Kind::Message("Pose"), "the trajectory's pose"),
            f(
                "measured",
                4,
                Kind::Message("Pose"),
                "forward kinematics of the measured legs",
            ),
        ],
    },
    MessageSpec {
        name: "Legs",
        doc: "Per-leg tracking and forces (/legs).",
        fields: &[
            f("run", 1, Str, RUN),
            f("time_s", 2, Double, TIME),
            r(
                "desired_length_m",
                3,
                Float,
                "6 inverse kinematics of the desired pose, m",
            ),
            r("measured_length_m", 4, Float, "6 measured leg lengths, m"),
            r(
                "error_m",
                5,
                Float,
                "6 tracking errors, desired - measured, m",
            ),
            r("command_force_n", 6, Float, "6 force commands, N"),
            r("measured_force_n", 7, Float, "6 load cells, N"),
        ],
    },
    MessageSpec {
        name: "PidTerms",
        doc: "Leg PID terms (/control/pid).",
        fields: &[
            f("run", 1, Str, RUN),
            f("time_s", 2, Double, TIME),
            r("p_n", 3, Float, "6 proportional terms, N"),
            r("i_n", 4, Float, "6 integral terms, N"),
            r("d_n", 5, Float, "6 derivative-on-measurement terms, N"),
            r("feedforward_n", 6, Float, "6 feed-forward forces, N"),
            r("output_n", 7, Float, "6 saturated PID outputs, N"),
            r("saturated", 8, Bool, "6 flags: output clamped"),
        ],
    },
];

/// The spec of message `name` (short name).
pub fn message(name: &str) -> Option<&'static MessageSpec> {
    MESSAGES.iter().find(|m| m.name == name)
}

fn field_proto(fd: &Field) -> FieldDescriptorProto {
    let (ty, type_name) = match fd.kind {
        Double => (Type::Double, None),
        Float => (Type::Float, None),
        Sint64 => (Type::Sint64, None),
        Kind::Uint64 => (Type::Uint64, None),
        Uint32 => (Type::Uint32, None),
        Bool => (Type::Bool, None),
        Str => (Type::String, None),
        Kind::Message(m) => (Type::Message, Some(format!(".{PACKAGE}.{m}"))),
    };
    FieldDescriptorProto {
        name: Some(fd.name.into()),
        number: Some(fd.number as i32),
        label: Some(if fd.repeated {
            Label::Repeated
        } else {
            Label::Optional
        } as i32),
        r#type: Some(ty as i32),
        type_name,
        json_name: Some(fd.name.into()),
        ..Default::default()
    }
}

/// The descriptor of the package's one file.
pub fn file_descriptor() -> FileDescriptorProto {
    FileDescriptorProto {
        name: Some(FILE_NAME.into()),
        package: Some(PACKAGE.into()),
        syntax: Some("proto3".into()),
        message_type: MESSAGES
            .iter()
            .map(|m| DescriptorProto {
                name: Some(m.name.into()),
                field: m.fields.iter().map(field_proto).collect(),
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    }
}

/// The `FileDescriptorSet` that MCAP's `protobuf` schema encoding carries (every channel's
/// schema record holds the whole set; its name selects the message).
pub fn file_descriptor_set() -> FileDescriptorSet {
    FileDescriptorSet {
        file: vec![file_descriptor()],
    }
}

/// [`file_descriptor_set`], encoded.
pub fn file_descriptor_set_bytes() -> Vec<u8> {
    file_descriptor_set().encode_to_vec()
}

fn type_text(k: Kind) -> &'static str {
    match k {
        Double => "double",
        Float => "float",
        Sint64 => "sint64",
        Kind::Uint64 => "uint64",
        Uint32 => "uint32",
        Bool => "bool",
        Str => "string",
        Kind::Message(m) => m,
    }
}

/// The `.proto` text of [`MESSAGES`], with each message's and field's description as a comment.
pub fn proto_text() -> String {
    let mut s = format!(
        "// The protobuf messages of the stewart run log's 1 kHz channels (docs/log-schema.md).\n\
         // Made from crates/runlog/src/proto/descriptor.rs, which a test compares with this file.\n\
         syntax = \"proto3\";\n\npackage {PACKAGE};\n"
    );
    for m in MESSAGES {
        s.push_str(&format!("\n// {}\nmessage {} {{\n", m.doc, m.name));
        for fd in m.fields {
            let label = if fd.repeated { "repeated " } else { "" };
            s.push_str(&format!(
                "  // {}\n  {label}{} {} = {};\n",
                fd.doc,
                type_text(fd.kind),
                fd.name,
                fd.number
            ));
        }
        s.push_str("}\n");
    }
    s
}
