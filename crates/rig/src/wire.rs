//! The messages of the rig protocol, as they travel on the wire (no_std, no alloc).
//!
//! Every message is one variant of [`Message`]; its body is the postcard encoding of that enum
//! (variant index as a varint, then the fields in declaration order). `docs/protocol.md` gives
//! the byte layout of each field; the declaration order here *is* the wire order, so do not
//! reorder fields without bumping [`PROTOCOL_VERSION`].
//!
//! Floats are IEEE-754 binary64 so that a frame carries the sensor values bit for bit; times
//! are integer nanoseconds so that a firmware can fill them from a hardware counter.

use serde::{Deserialize, Serialize};

/// Version of this protocol. Carried in the header of every frame; a peer that sees another
/// version refuses the frame (and the session) with a clear error.
pub const PROTOCOL_VERSION: u8 = 1;

/// Number of legs the protocol carries (a 6-6 Stewart platform): the shared
/// `stewart_types::LEG_COUNT`, fixed by [`PROTOCOL_VERSION`].
pub use stewart_types::LEG_COUNT;

/// Length of the fixed-size rig identity string, bytes (UTF-8, zero padded).
pub const IDENTITY_LEN: usize = 32;

/// Sent by the host to open (or reopen) a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// Random number chosen by the host; the rig echoes it in [`HelloAck::host_nonce`] so that
    /// the host can tell a fresh answer from a replayed one.
    pub host_nonce: u64,
    /// Fingerprint of the shared key the host will tag frames with (see [`key_id`] in the
    /// codec), `None` when the host uses no key. Lets the rig refuse a key mismatch by name
    /// instead of silently dropping every frame.
    ///
    /// [`key_id`]: crate::codec::key_id
    pub key_id: Option<u32>,
}

/// Which sensors the rig has and where.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorLayout {
    /// Number of legs with a length sensor and a load cell; must be [`LEG_COUNT`].
    pub leg_count: u8,
    /// True when the plate carries an IMU (gyro and accelerometer).
    pub imu_present: bool,
    /// Accelerometer mounting point in the platform frame P, metres.
    pub accel_position_m: [f64; 3],
}

/// The rig's hard limits. The host never commands beyond them; the rig brakes and reports a
/// fault when a command or a measured motion exceeds them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Shortest allowed leg length (joint centre to joint centre), metres.
    pub stroke_min_m: f64,
    /// Longest allowed leg length, metres.
    pub stroke_max_m: f64,
    /// Largest allowed leg speed (magnitude), m/s.
    pub speed_max_m_s: f64,
    /// Most negative (pulling) actuator force allowed, newtons.
    pub force_min_n: f64,
    /// Most positive (pushing) actuator force allowed, newtons.
    pub force_max_n: f64,
}

/// The rig's answer to [`Hello`]: who it is, what it measures, how fast, within which limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HelloAck {
    /// The [`Hello::host_nonce`] this answers.
    pub host_nonce: u64,
    /// Session number chosen by the rig (random, non-zero); with a key it is mixed into every
    /// later tag so frames of an old session cannot be replayed into this one.
    pub session_id: u64,
    /// Rig identity, UTF-8, zero padded (e.g. "emulator" or a serial number).
    pub identity: [u8; IDENTITY_LEN],
    /// The sensors the rig reports.
    pub layout: SensorLayout,
    /// Time between sensor frames, nanoseconds.
    pub sample_period_ns: u32,
    /// The rig brakes when no valid command arrived for this long, nanoseconds.
    pub watchdog_ns: u32,
    /// The rig's hard limits.
    pub limits: Limits,
}

/// One synchronous sample of every sensor, from the rig.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sensor {
    /// Sample counter: 1 for the first frame after a [`HelloAck`], then +1 per sample period,
    /// also for samples the link lost.
    pub sequence: u64,
    /// Sample instant on the rig's clock, nanoseconds.
    pub time_ns: u64,
    /// Leg lengths, metres.
    pub leg_lengths_m: [f64; LEG_COUNT],
    /// Axial leg forces, newtons (positive pushes the plate away from the base).
    pub leg_forces_n: [f64; LEG_COUNT],
    /// Plate angular rate in P axes, rad/s.
    pub gyro_rad_s: [f64; 3],
    /// Specific force at the accelerometer in P axes, m/s².
    pub accel_m_s2: [f64; 3],
    /// Status bits, as `control::io::Status`.
    pub status: u32,
}

/// What the host asks the actuators to do until the next command.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Command {
    /// Command counter: 1 for the first command of a session, then increasing.
    pub sequence: u64,
    /// [`Sensor::sequence`] of the frame this command was computed from.
    pub sensor_sequence: u64,
    /// Actuator forces, newtons.
    pub leg_forces_n: [f64; LEG_COUNT],
    /// `true`: follow the forces; `false`: brake.
    pub enable: bool,
}

/// Why the rig braked or refused something. A `u16` so that a host can print codes it does
/// not know yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaultCode(pub u16);

impl FaultCode {
    /// No valid command within the watchdog time.
    pub const WATCHDOG: Self = Self(1);
    /// A command force outside the limits (or not finite). `leg` names the leg.
    pub const FORCE_LIMIT: Self = Self(2);
    /// A leg left its stroke. `leg` names the leg, `value` is the length in metres.
    pub const STROKE_LIMIT: Self = Self(3);
    /// A leg moved faster than allowed. `value` is the speed in m/s.
    pub const SPEED_LIMIT: Self = Self(4);
    /// The rig does not speak the host's protocol version. `value` is the rig's version.
    pub const VERSION_MISMATCH: Self = Self(5);
    /// The rig requires a key and the host offered none.
    pub const KEY_REQUIRED: Self = Self(6);
    /// The host's key fingerprint differs from the rig's (or its tag did not verify).
    pub const KEY_MISMATCH: Self = Self(7);
    /// The rig is busy with another host's session.
    pub const BUSY: Self = Self(8);
    /// A sensor failed or the actuators' own controller tripped.
    pub const INTERNAL: Self = Self(9);
    /// An emergency stop was pressed.
    pub const ESTOP: Self = Self(10);

    /// A short human name for the code.
    pub const fn name(self) -> &'static str {
        match self.0 {
            0 => "fault latched (shown by the FAULT status bit; its report was lost)",
            1 => "command watchdog expired",
            2 => "command force beyond limit",
            3 => "leg stroke limit",
            4 => "leg speed limit",
            5 => "protocol version mismatch",
            6 => "key required",
            7 => "key mismatch",
            8 => "rig busy with another session",
            9 => "rig internal fault",
            10 => "emergency stop",
            _ => "unknown fault",
        }
    }
}

/// A latched fault is reported again after this many sensor frames.
pub const FAULT_REPEAT_FRAMES: u64 = 20;

/// Leg index meaning "no particular leg" in [`Fault::leg`].
pub const NO_LEG: u8 = 0xFF;

/// A fault report from the rig. Sent when the fault trips and repeated every
/// [`FAULT_REPEAT_FRAMES`] sensor frames while it is latched (a datagram may be lost); the rig
/// stays braked until the host opens a new session.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fault {
    /// What happened.
    pub code: FaultCode,
    /// Leg concerned (0-based), or [`NO_LEG`].
    pub leg: u8,
    /// The offending value in SI units (see each [`FaultCode`]), 0 when none.
    pub value: f64,
    /// Sequence of the last command the rig accepted (0: none).
    pub command_sequence: u64,
}

/// Every message of the protocol. The variant index is the first byte of a frame's body.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message {
    /// Host → rig, index 0.
    Hello(Hello),
    /// Rig → host, index 1.
    HelloAck(HelloAck),
    /// Rig → host, index 2.
    Sensor(Sensor),
    /// Host → rig, index 3.
    Command(Command),
    /// Rig → host, index 4.
    Fault(Fault),
}

impl Message {
    /// A short name of the message's kind, for error messages.
    pub const fn kind_name(&self) -> &'static str {
        match self {
            Message::Hello(_) => "Hello",
            Message::HelloAck(_) => "HelloAck",
            Message::Sensor(_) => "Sensor",
            Message::Command(_) => "Command",
            Message::Fault(_) => "Fault",
        }
    }
}

/// Builds a zero-padded identity from a string, cut at [`IDENTITY_LEN`] bytes (on a character
/// boundary, so the result stays valid UTF-8).
pub fn identity_from_str(name: &str) -> [u8; IDENTITY_LEN] {
    let mut out = [0u8; IDENTITY_LEN];
    let mut end = name.len().min(IDENTITY_LEN);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    out[..end].copy_from_slice(&name.as_bytes()[..end]);
    out
}

/// The identity as text: up to the first zero byte, lossy on invalid UTF-8 (the valid prefix).
pub fn identity_str(identity: &[u8; IDENTITY_LEN]) -> &str {
    let end = identity
        .iter()
        .position(|&b| b == 0)
        .unwrap_or(IDENTITY_LEN);
    let bytes = &identity[..end];
    match core::str::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => core::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or(""),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_round_trip_and_truncation() {
        assert_eq!(identity_str(&identity_from_str("emulator")), "emulator");
        let long = "é".repeat(20); // 40 bytes, 2 per char
        let id = identity_from_str(&long);
        assert_eq!(identity_str(&id), "é".repeat(16));
        let mut bad = identity_from_str("ab");
        bad[2] = 0xFF;
        assert_eq!(identity_str(&bad), "ab");
    }
}
