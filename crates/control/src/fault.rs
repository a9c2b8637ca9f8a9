//! Why the safety supervisor stopped the platform: [`Fault`], shared by the supervisor (which
//! latches it) and [`ControlError::Faulted`](crate::ControlError::Faulted) (which reports it).
//! Re-exported as `control::supervisor::{Fault, SensorChannel}` and at the crate root.

use core::fmt;

use kinematics::KinematicsError;

use crate::io::Status;

/// A sensor channel of [`SensorFrame`](crate::io::SensorFrame), to name non-finite data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SensorChannel {
    /// `time_s`.
    Time,
    /// `leg_lengths_m`.
    LegLength,
    /// `leg_forces_n`.
    LegForce,
    /// `gyro_rad_s`.
    Gyro,
    /// `accel_m_s2`.
    Accel,
}

/// Why the supervisor stopped the platform: the limit, the leg (0-based) and the value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// The backend reported an emergency stop.
    EmergencyStop,
    /// The backend reported its own fault or invalid sensors (`Status::FAULT`,
    /// `Status::SENSOR_INVALID`).
    BackendStatus {
        /// The status word as received.
        status: Status,
    },
    /// A sensor value is NaN or infinite.
    SensorNotFinite {
        /// The channel.
        channel: SensorChannel,
        /// Index within the channel (leg or axis; 0 for time).
        index: usize,
    },
    /// The sensor sequence number did not advance: the same (stale) frame again, or reordered.
    SequenceNotAdvancing {
        /// Sequence of the previous accepted frame.
        previous: u64,
        /// Sequence received.
        received: u64,
    },
    /// The sensor time did not advance.
    TimeNotAdvancing {
        /// Time of the previous accepted frame, s.
        previous_s: f64,
        /// Time received, s.
        received_s: f64,
    },
    /// Too long since the previous frame in sensor time (lost samples or a stalled link).
    SampleGap {
        /// Time since the previous frame, s.
        gap_s: f64,
        /// The configured limit, s.
        limit_s: f64,
    },
    /// The newest frame is older than allowed on the host clock.
    SensorTooOld {
        /// Age of the frame, s.
        age_s: f64,
        /// The configured limit, s.
        limit_s: f64,
    },
    /// A measured leg is shorter than the stroke minimum less the margin.
    LegTooShort {
        /// Leg index.
        leg: usize,
        /// Measured length, m.
        length_m: f64,
        /// The limit, m.
        limit_m: f64,
    },
    /// A measured leg is longer than the stroke maximum plus the margin.
    LegTooLong {
        /// Leg index.
        leg: usize,
        /// Measured length, m.
        length_m: f64,
        /// The limit, m.
        limit_m: f64,
    },
    /// A leg moves faster than allowed (filtered finite difference of measured lengths).
    LegSpeed {
        /// Leg index.
        leg: usize,
        /// Speed estimate, m/s (signed: positive extends).
        speed_m_s: f64,
        /// The limit, m/s.
        limit_m_s: f64,
    },
    /// A measured leg force exceeds the limit in magnitude.
    MeasuredForce {
        /// Leg index.
        leg: usize,
        /// Measured force, N.
        force_n: f64,
        /// The limit, N.
        limit_n: f64,
    },
    /// The controller computed a non-finite force command.
    CommandNotFinite {
        /// Leg index.
        leg: usize,
    },
    /// A desired leg length lies outside the stroke (the trajectory or the park ramp left it).
    DesiredOutOfStroke {
        /// Leg index.
        leg: usize,
        /// Desired length, m.
        length_m: f64,
    },
    /// Forward kinematics found no pose for the measured leg lengths.
    ForwardKinematics(KinematicsError),
}

impl Fault {
    /// Whether this fault is a stall (samples stopped arriving in time: the host or the link
    /// paused) rather than a fault of the platform or its sensors: a run it ended may be
    /// repeated once the rig braked.
    pub fn is_stall(&self) -> bool {
        matches!(self, Fault::SampleGap { .. } | Fault::SensorTooOld { .. })
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::EmergencyStop => write!(f, "emergency stop"),
            Self::BackendStatus { status } => {
                write!(f, "backend reported a fault (status {:#x})", status.0)
            }
            Self::SensorNotFinite { channel, index } => {
                write!(f, "sensor {channel:?}[{index}] is not finite")
            }
            Self::SequenceNotAdvancing { previous, received } => {
                write!(f, "stale sensor data: sequence {received} after {previous}")
            }
            Self::TimeNotAdvancing {
                previous_s,
                received_s,
            } => write!(
                f,
                "stale sensor data: time {received_s} s after {previous_s} s"
            ),
            Self::SampleGap { gap_s, limit_s } => write!(
                f,
                "sensor gap {gap_s:.4} s exceeds the watchdog limit {limit_s:.4} s"
            ),
            Self::SensorTooOld { age_s, limit_s } => write!(
                f,
                "sensor data {age_s:.4} s old exceeds the watchdog limit {limit_s:.4} s"
            ),
            Self::LegTooShort {
                leg,
                length_m,
                limit_m,
            } => write!(
                f,
                "leg {leg} length {length_m:.5} m below limit {limit_m:.5} m"
            ),
            Self::LegTooLong {
                leg,
                length_m,
                limit_m,
            } => write!(
                f,
                "leg {leg} length {length_m:.5} m above limit {limit_m:.5} m"
            ),
            Self::LegSpeed {
                leg,
                speed_m_s,
                limit_m_s,
            } => write!(
                f,
                "leg {leg} speed {speed_m_s:.4} m/s exceeds limit {limit_m_s:.4} m/s"
            ),
            Self::MeasuredForce {
                leg,
                force_n,
                limit_n,
            } => write!(
                f,
                "leg {leg} measured force {force_n:.1} N exceeds limit {limit_n:.1} N"
            ),
            Self::CommandNotFinite { leg } => write!(f, "leg {leg} force command is not finite"),
            Self::DesiredOutOfStroke { leg, length_m } => write!(
                f,
                "leg {leg} desired length {length_m:.5} m is outside the stroke"
            ),
            Self::ForwardKinematics(e) => write!(f, "forward kinematics failed: {e}"),
        }
    }
}
