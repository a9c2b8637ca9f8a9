//! The log's channels: topic, schema name, JSON schema, encoding and message type of each (the
//! 1 kHz channels in compact protobuf blocks, [`crate::compact`], and the 100 Hz ones in
//! protobuf, [`crate::proto`]). The catalogue
//! [`channels`] is the single list that the writer registers, the tests check and
//! `docs/log-schema.md` documents.
//!
//! Every `stewart.*` message carries `run` (`"tare"` or `"loaded"`: which measurement it
//! belongs to) and `time_s` (the backend's sample clock; it restarts at each run only if the
//! backend's clock does). MCAP log times are Unix nanoseconds: the run's start plus the sample
//! clock, kept monotonic across runs.

use serde::Serialize;

use crate::channel::{ChannelSpec, Encoding};
use crate::foxglove;
use crate::proto::{Encode, Encoder};
use crate::schema::{array, boolean, int, nullable, num, numbers, object, string, Schema};

/// Raw sensor frames, every sample.
pub const SENSORS: &str = "/sensors";
/// Force commands sent to the backend, every sample.
pub const COMMANDS: &str = "/commands";
/// Desired and measured pose.
pub const POSE: &str = "/pose";
/// Desired and measured leg lengths, tracking error, forces.
pub const LEGS: &str = "/legs";
/// PID terms per leg.
pub const PID: &str = "/control/pid";
/// Procedure phase and faults.
pub const SUPERVISOR: &str = "/supervisor";
/// The online estimate with sigma and residual.
pub const ESTIMATE: &str = "/estimate";
/// Run metadata (once): config, seed, estimator settings, geometry.
pub const METADATA: &str = "/run/metadata";
/// The estimator's settings for one measurement (once per run).
pub const ESTIMATOR_SETTINGS: &str = "/run/estimator";
/// The tare subtracted (once per run, when known).
pub const TARE: &str = "/run/tare";
/// Ground truth (simulation only; never read by the estimator).
pub const TRUTH: &str = "/run/truth";
/// `foxglove.FrameTransform` base → platform.
pub const TF: &str = "/tf";
/// `foxglove.FrameTransform` platform → payload centre of mass (principal axes), loaded runs
/// with a known tare.
pub const TF_PAYLOAD: &str = "/tf/payload";
/// `foxglove.SceneUpdate`: base, plate, legs, payload inertia ellipsoid.
pub const SCENE: &str = "/scene";

fn six(d: &'static str) -> Schema {
    numbers(6, d)
}

fn three(d: &'static str) -> Schema {
    numbers(3, d)
}

fn run_field() -> (&'static str, Schema) {
    (
        "run",
        string("measurement this belongs to: \"tare\" or \"loaded\""),
    )
}

fn time_field() -> (&'static str, Schema) {
    ("time_s", num("backend sample time, s"))
}

/// The JSON form's schema of `stewart.SensorBlock` on [`SENSORS`] ([`crate::compact`]).
fn sensor_block_schema() -> Schema {
    let counts = |d| array(int(""), None, d);
    object(
        vec![
            run_field(),
            ("sequence", counts("backend sample counters, delta-coded")),
            ("time_ns", counts("sample instants, ns, delta-coded")),
            (
                "leg_lengths_nm",
                counts("6 leg lengths a frame, joint centre to joint centre, nm, delta-coded"),
            ),
            (
                "leg_forces_mn",
                counts("6 axial leg forces a frame at the plate joints, mN, delta-coded"),
            ),
            (
                "gyro_urad_s",
                counts("3 angular rates a frame in the IMU's axes, urad/s, delta-coded"),
            ),
            (
                "accel_um_s2",
                counts("3 specific force components a frame, IMU axes, um/s^2, delta-coded"),
            ),
            ("status", counts("backend status bits, one a frame")),
            (
                "raw_index",
                counts("positions of the values without a count"),
            ),
            (
                "raw_value",
                array(
                    nullable(num("")),
                    None,
                    "those values (NaN and infinities: null)",
                ),
            ),
        ],
        "Consecutive sensor frames of one measurement, as counts",
    )
}

/// The JSON form's schema of `stewart.CommandBlock` on [`COMMANDS`] ([`crate::compact`]).
fn command_block_schema() -> Schema {
    let counts = |d| array(int(""), None, d);
    object(
        vec![
            run_field(),
            (
                "time_ns",
                counts("time of the sensor frame each command answers, ns, delta-coded"),
            ),
            ("sequence", counts("host command counters, delta-coded")),
            (
                "sensor_sequence",
                counts("sensor sequence each command was computed from, delta-coded"),
            ),
            (
                "leg_forces_mn",
                counts("6 axial force commands a frame, mN, delta-coded"),
            ),
            (
                "enable",
                array(
                    boolean(""),
                    None,
                    "actuators follow the forces, one a frame",
                ),
            ),
            (
                "raw_index",
                counts("positions of the values without a count"),
            ),
            (
                "raw_value",
                array(
                    nullable(num("")),
                    None,
                    "those values (NaN and infinities: null)",
                ),
            ),
        ],
        "Consecutive force commands of one measurement, as counts",
    )
}

/// A pose in B: position, roll-pitch-yaw (R = Rx·Ry·Rz) and quaternion.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct PoseValue {
    /// P origin in B, m.
    pub position_m: [f64; 3],
    /// Roll, pitch, yaw, rad.
    pub rpy_rad: [f64; 3],
}

impl PoseValue {
    /// From a kinematics pose.
    pub fn new(p: &kinematics::Pose) -> Self {
        let (r, pi, y) = p.rpy();
        Self {
            position_m: [p.position_m.x, p.position_m.y, p.position_m.z],
            rpy_rad: [r, pi, y],
        }
    }

    fn schema(d: &'static str) -> Schema {
        object(
            vec![
                ("position_m", three("P origin in B, m")),
                ("rpy_rad", three("roll, pitch, yaw with R = Rx·Ry·Rz, rad")),
            ],
            d,
        )
    }
}

/// `stewart.PoseState` on [`POSE`].
#[derive(Clone, Debug, Serialize)]
pub struct PoseMsg {
    /// Measurement.
    pub run: &'static str,
    /// Sample time, s.
    pub time_s: f64,
    /// Where the trajectory wants the plate.
    pub desired: PoseValue,
    /// Forward kinematics of the measured leg lengths.
    pub measured: PoseValue,
}

impl PoseMsg {
    fn schema() -> Schema {
        object(
            vec![
                run_field(),
                time_field(),
                ("desired", PoseValue::schema("trajectory's pose of P in B")),
                (
                    "measured",
                    PoseValue::schema("forward kinematics of the measured legs"),
                ),
            ],
            "Desired and measured pose of the platform frame P in the base frame B",
        )
    }
}

/// `stewart.Legs` on [`LEGS`].
#[derive(Clone, Debug, Serialize)]
pub struct LegsMsg {
    /// Measurement.
    pub run: &'static str,
    /// Sample time, s.
    pub time_s: f64,
    /// Inverse kinematics of the desired pose, m.
    pub desired_length_m: [f64; 6],
    /// Measured, m.
    pub measured_length_m: [f64; 6],
    /// Desired − measured, m.
    pub error_m: [f64; 6],
    /// Commanded force, N.
    pub command_force_n: [f64; 6],
    /// Measured force, N.
    pub measured_force_n: [f64; 6],
}

impl LegsMsg {
    fn schema() -> Schema {
        object(
            vec![
                run_field(),
                time_field(),
                (
                    "desired_length_m",
                    six("inverse kinematics of the desired pose, m"),
                ),
                ("measured_length_m", six("measured leg lengths, m")),
                ("error_m", six("tracking error, desired - measured, m")),
                ("command_force_n", six("force commands, N")),
                ("measured_force_n", six("load cells, N")),
            ],
            "Per-leg tracking and forces",
        )
    }
}

/// `stewart.PidTerms` on [`PID`].
#[derive(Clone, Debug, Serialize)]
pub struct PidMsg {
    /// Measurement.
    pub run: &'static str,
    /// Sample time, s.
    pub time_s: f64,
    /// Proportional terms, N.
    pub p_n: [f64; 6],
    /// Integral terms, N.
    pub i_n: [f64; 6],
    /// Derivative terms, N.
    pub d_n: [f64; 6],
    /// Feed-forward, N.
    pub feedforward_n: [f64; 6],
    /// Saturated outputs, N.
    pub output_n: [f64; 6],
    /// Output clamped.
    pub saturated: [bool; 6],
}

impl PidMsg {
    /// From the six PID outputs.
    pub fn new(run: &'static str, time_s: f64, o: &[control::pid::PidOutput; 6]) -> Self {
        Self {
            run,
            time_s,
            p_n: o.map(|x| x.p),
            i_n: o.map(|x| x.i),
            d_n: o.map(|x| x.d),
            feedforward_n: o.map(|x| x.feedforward),
            output_n: o.map(|x| x.output),
            saturated: o.map(|x| x.saturated),
        }
    }

    fn schema() -> Schema {
        object(
            vec![
                run_field(),
                time_field(),
                ("p_n", six("proportional terms, N")),
                ("i_n", six("integral terms, N")),
                ("d_n", six("derivative-on-measurement terms, N")),
                ("feedforward_n", six("feed-forward forces, N")),
                ("output_n", six("saturated PID outputs, N")),
                ("saturated", array(boolean(""), Some(6), "output clamped")),
            ],
            "Leg PID terms",
        )
    }
}

/// `stewart.Supervisor` on [`SUPERVISOR`]: on every change and at 10 Hz.
#[derive(Clone, Debug, Serialize)]
pub struct SupervisorMsg {
    /// Measurement.
    pub run: &'static str,
    /// Sample time, s.
    pub time_s: f64,
    /// Procedure phase (idle, settle, excite, park, done, fault).
    pub phase: String,
    /// The latched fault, if any.
    pub fault: Option<String>,
    /// Commands clamped by the supervisor's force limit this sample.
    pub clamped: bool,
    /// Operator interrupt (Ctrl-C) seen.
    pub interrupted: bool,
}

impl SupervisorMsg {
    fn schema() -> Schema {
        object(
            vec![
                run_field(),
                time_field(),
                ("phase", string("idle, settle, excite, park, done or fault")),
                ("fault", nullable(string("the latched fault, in words"))),
                (
                    "clamped",
                    boolean("a command was clamped to the force limit"),
                ),
                ("interrupted", boolean("operator interrupt (Ctrl-C) seen")),
            ],
            "Procedure phase and faults",
        )
    }
}

/// Mass, centre of mass and J_C with one sigma each.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct BodyEstimate {
    /// kg.
    pub mass_kg: f64,
    /// kg.
    pub mass_sigma_kg: f64,
    /// In P, m.
    pub com_m: [f64; 3],
    /// m.
    pub com_sigma_m: [f64; 3],
    /// J_C in P axes, kg·m², row-major.
    pub inertia_com_kg_m2: [[f64; 3]; 3],
    /// kg·m².
    pub inertia_com_sigma_kg_m2: [[f64; 3]; 3],
}

impl BodyEstimate {
    /// From an estimator estimate (NaN where the mass is not positive; JSON writes those as
    /// `null`).
    pub fn new(e: &estimator::Estimate) -> Self {
        let m3 = |m: &nalgebra::Matrix3<f64>| {
            core::array::from_fn(|r| core::array::from_fn(|c| m[(r, c)]))
        };
        Self {
            mass_kg: e.parameters.mass_kg,
            mass_sigma_kg: e.mass_sigma_kg,
            com_m: e.com_m.into(),
            com_sigma_m: e.com_sigma_m.into(),
            inertia_com_kg_m2: m3(&e.inertia_com_kg_m2),
            inertia_com_sigma_kg_m2: m3(&e.inertia_com_sigma_kg_m2),
        }
    }

    fn schema(d: &'static str) -> Schema {
        let n3 = || array(nullable(num("")), Some(3), "");
        object(
            vec![
                ("mass_kg", nullable(num("kg"))),
                ("mass_sigma_kg", nullable(num("one sigma, kg"))),
                ("com_m", n3()),
                ("com_sigma_m", n3()),
                (
                    "inertia_com_kg_m2",
                    array(n3(), Some(3), "J_C in P axes, kg·m²"),
                ),
                (
                    "inertia_com_sigma_kg_m2",
                    array(n3(), Some(3), "one sigma, kg·m²"),
                ),
            ],
            d,
        )
    }
}

/// `stewart.Estimate` on [`ESTIMATE`] (decimated; see the docs for the rate).
#[derive(Clone, Debug, Serialize)]
pub struct EstimateMsg {
    /// Measurement.
    pub run: &'static str,
    /// Sample time, s.
    pub time_s: f64,
    /// Samples used by the least squares so far.
    pub samples: u64,
    /// Samples rejected so far.
    pub rejected: u64,
    /// θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] of everything on the plate (this run),
    /// about the P origin in P axes.
    pub theta: [f64; 10],
    /// One sigma of each entry of θ.
    pub theta_sigma: [f64; 10],
    /// RMS residual of [Fx, Fy, Fz] (N) and [τx, τy, τz] (N·m).
    pub residual_rms: [f64; 6],
    /// Everything on the plate, centre-of-mass form.
    pub body: BodyEstimate,
    /// The payload alone (tare subtracted), in the loaded run when a tare is known.
    pub payload: Option<BodyEstimate>,
}

impl EstimateMsg {
    fn schema() -> Schema {
        let n10 = |d| array(nullable(num("")), Some(10), d);
        object(
            vec![
                run_field(),
                time_field(),
                ("samples", int("samples used by the least squares")),
                ("rejected", int("samples rejected by the input checks")),
                (
                    "theta",
                    n10("[m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] about the P origin, P axes; kg, kg·m, kg·m²"),
                ),
                ("theta_sigma", n10("one sigma of each entry of theta")),
                (
                    "residual_rms",
                    array(nullable(num("")), Some(6), "RMS residual of Fx, Fy, Fz (N), τx, τy, τz (N·m)"),
                ),
                ("body", BodyEstimate::schema("everything on the plate")),
                (
                    "payload",
                    nullable(BodyEstimate::schema("the payload alone (tare subtracted)")),
                ),
            ],
            "The online estimate with its uncertainty",
        )
    }
}

impl PoseValue {
    fn encode(&self, e: &mut Encoder<'_>) {
        e.floats(1, &self.position_m);
        e.floats(2, &self.rpy_rad);
    }
}

impl Encode for PoseMsg {
    const NAME: &'static str = "stewart.PoseState";
    fn encode(&self, e: &mut Encoder<'_>) {
        e.string(1, self.run);
        e.double(2, self.time_s);
        e.message(3, |e| self.desired.encode(e));
        e.message(4, |e| self.measured.encode(e));
    }
}

impl Encode for LegsMsg {
    const NAME: &'static str = "stewart.Legs";
    fn encode(&self, e: &mut Encoder<'_>) {
        e.string(1, self.run);
        e.double(2, self.time_s);
        e.floats(3, &self.desired_length_m);
        e.floats(4, &self.measured_length_m);
        e.floats(5, &self.error_m);
        e.floats(6, &self.command_force_n);
        e.floats(7, &self.measured_force_n);
    }
}

impl Encode for PidMsg {
    const NAME: &'static str = "stewart.PidTerms";
    fn encode(&self, e: &mut Encoder<'_>) {
        e.string(1, self.run);
        e.double(2, self.time_s);
        e.floats(3, &self.p_n);
        e.floats(4, &self.i_n);
        e.floats(5, &self.d_n);
        e.floats(6, &self.feedforward_n);
        e.floats(7, &self.output_n);
        e.bools(8, &self.saturated);
    }
}

/// The whole catalogue, in the order the log registers it.
pub fn channels() -> Vec<ChannelSpec> {
    vec![
        ChannelSpec {
            topic: METADATA,
            encoding: Encoding::Json,
            schema_name: "stewart.RunMetadata",
            schema: crate::metadata::RunMetadata::schema(),
        },
        ChannelSpec {
            topic: ESTIMATOR_SETTINGS,
            encoding: Encoding::Json,
            schema_name: "stewart.EstimatorSettings",
            schema: crate::metadata::EstimatorSettings::schema(),
        },
        ChannelSpec {
            topic: TARE,
            encoding: Encoding::Json,
            schema_name: "stewart.Tare",
            schema: crate::schema::tare::tare_file(),
        },
        ChannelSpec {
            topic: TRUTH,
            encoding: Encoding::Json,
            schema_name: "stewart.Truth",
            schema: crate::metadata::TruthMsg::schema(),
        },
        ChannelSpec {
            topic: SENSORS,
            encoding: Encoding::Protobuf,
            schema_name: "stewart.SensorBlock",
            schema: sensor_block_schema(),
        },
        ChannelSpec {
            topic: COMMANDS,
            encoding: Encoding::Protobuf,
            schema_name: "stewart.CommandBlock",
            schema: command_block_schema(),
        },
        ChannelSpec {
            topic: POSE,
            encoding: Encoding::Protobuf,
            schema_name: "stewart.PoseState",
            schema: PoseMsg::schema(),
        },
        ChannelSpec {
            topic: LEGS,
            encoding: Encoding::Protobuf,
            schema_name: "stewart.Legs",
            schema: LegsMsg::schema(),
        },
        ChannelSpec {
            topic: PID,
            encoding: Encoding::Protobuf,
            schema_name: "stewart.PidTerms",
            schema: PidMsg::schema(),
        },
        ChannelSpec {
            topic: SUPERVISOR,
            encoding: Encoding::Json,
            schema_name: "stewart.Supervisor",
            schema: SupervisorMsg::schema(),
        },
        ChannelSpec {
            topic: ESTIMATE,
            encoding: Encoding::Json,
            schema_name: "stewart.Estimate",
            schema: EstimateMsg::schema(),
        },
        ChannelSpec {
            topic: TF,
            encoding: Encoding::Foxglove,
            schema_name: "foxglove.FrameTransform",
            schema: foxglove::frame_transform_schema(),
        },
        ChannelSpec {
            topic: TF_PAYLOAD,
            encoding: Encoding::Foxglove,
            schema_name: "foxglove.FrameTransform",
            schema: foxglove::frame_transform_schema(),
        },
        ChannelSpec {
            topic: SCENE,
            encoding: Encoding::Foxglove,
            schema_name: "foxglove.SceneUpdate",
            schema: foxglove::scene_update_schema(),
        },
        ChannelSpec {
            topic: crate::rig_record::LINK,
            encoding: Encoding::Json,
            schema_name: crate::rig_record::LINK_SCHEMA_NAME,
            schema: crate::rig_record::LinkMsg::schema(),
        },
    ]
}
