//! Between the wire messages and `control::io` frames.
//!
//! Values pass bit for bit; times become integer nanoseconds on the wire (rounded to the
//! nearest; negative or non-finite times become 0).

use stewart_types::{CommandFrame, SensorFrame, Status};

use crate::wire::{Command, Sensor};

/// Seconds to wire nanoseconds (nearest, saturating; NaN and negatives give 0).
pub fn seconds_to_ns(seconds: f64) -> u64 {
    // `as` saturates and maps NaN to 0, which is what a timestamp field can hold. libm's
    // `round` (half away from zero) is `f64::round` without std.
    libm::round(seconds * 1e9) as u64
}

/// Wire nanoseconds to seconds.
pub fn ns_to_seconds(ns: u64) -> f64 {
    // Division by an exact 1e9 rounds once, so whole milliseconds come back exactly.
    ns as f64 / 1e9
}

impl From<&Sensor> for SensorFrame {
    fn from(s: &Sensor) -> Self {
        SensorFrame {
            sequence: s.sequence,
            time_s: ns_to_seconds(s.time_ns),
            leg_lengths_m: s.leg_lengths_m,
            leg_forces_n: s.leg_forces_n,
            gyro_rad_s: s.gyro_rad_s,
            accel_m_s2: s.accel_m_s2,
            status: Status(s.status),
        }
    }
}

impl From<&SensorFrame> for Sensor {
    fn from(f: &SensorFrame) -> Self {
        Sensor {
            sequence: f.sequence,
            time_ns: seconds_to_ns(f.time_s),
            leg_lengths_m: f.leg_lengths_m,
            leg_forces_n: f.leg_forces_n,
            gyro_rad_s: f.gyro_rad_s,
            accel_m_s2: f.accel_m_s2,
            status: f.status.0,
        }
    }
}

impl From<&Command> for CommandFrame {
    fn from(c: &Command) -> Self {
        CommandFrame {
            sequence: c.sequence,
            sensor_sequence: c.sensor_sequence,
            leg_forces_n: c.leg_forces_n,
            enable: c.enable,
        }
    }
}

impl From<&CommandFrame> for Command {
    fn from(c: &CommandFrame) -> Self {
        Command {
            sequence: c.sequence,
            sensor_sequence: c.sensor_sequence,
            leg_forces_n: c.leg_forces_n,
            enable: c.enable,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_map_both_ways() {
        let frame = SensorFrame {
            sequence: 17,
            time_s: 12.345,
            leg_lengths_m: [0.5, 0.51, 0.52, 0.53, 0.54, 0.55],
            leg_forces_n: [1.0, -2.0, 3.5, f64::MAX, f64::MIN_POSITIVE, -0.0],
            gyro_rad_s: [0.1, -0.2, 0.3],
            accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
            status: Status(Status::ENABLED | 1 << 31),
        };
        let back = SensorFrame::from(&Sensor::from(&frame));
        assert_eq!(back, frame);
        let command = CommandFrame {
            sequence: 3,
            sensor_sequence: 17,
            leg_forces_n: [1.0, 2.0, 3.0, 4.0, 5.0, -6.0],
            enable: true,
        };
        assert_eq!(CommandFrame::from(&Command::from(&command)), command);
    }

    #[test]
    fn times_round_to_the_nanosecond_and_bad_ones_become_zero() {
        for k in [0u64, 1, 999, 123_456_789] {
            let t = k as f64 / 1e3;
            assert_eq!(ns_to_seconds(seconds_to_ns(t)), t, "{t}");
        }
        assert_eq!(seconds_to_ns(f64::NAN), 0);
        assert_eq!(seconds_to_ns(-1.0), 0);
        assert_eq!(seconds_to_ns(1.5e-9), 2);
    }
}
