//! The I/O boundary between the cores and a backend (simulator or rig).
//!
//! Data flows one way per tick: [`Backend::read`] gives a [`SensorFrame`], the cores compute, and
//! [`Backend::write`] sends a [`CommandFrame`]. Both frames are plain `Copy` data in SI units so
//! that they can be logged, sent over a wire and compared bit for bit.

use crate::LEG_COUNT;

/// Status bits reported by a backend with each sensor frame.
///
/// A bit set means the condition is present. Unknown bits are preserved, never interpreted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Status(pub u32);

impl Status {
    /// All actuators are powered and accept force commands.
    pub const ENABLED: u32 = 1 << 0;
    /// The brakes are engaged (actuators locked or dumped to a safe state).
    pub const BRAKED: u32 = 1 << 1;
    /// The backend itself detected a fault (rig-side safety tripped).
    pub const FAULT: u32 = 1 << 2;
    /// An emergency stop is pressed.
    pub const ESTOP: u32 = 1 << 3;
    /// One or more sensor values in this frame are known to be invalid.
    pub const SENSOR_INVALID: u32 = 1 << 4;

    /// True when every bit of `mask` is set.
    pub const fn has(self, mask: u32) -> bool {
        self.0 & mask == mask
    }
}

/// One synchronous sample of every sensor on the platform.
///
/// Every channel describes the same instant `time_s`: the estimator fits forces, rates and
/// accelerations of one instant to each other, so a time skew between channels shows up as a
/// large fit residual.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorFrame {
    /// Backend sample counter, increasing by one per sample (gaps mean lost samples).
    pub sequence: u64,
    /// Sample instant on the backend's clock, seconds.
    pub time_s: f64,
    /// Measured leg lengths (joint centre to joint centre), metres.
    pub leg_lengths_m: [f64; LEG_COUNT],
    /// Measured axial leg forces at the plate joints, newtons; positive pushes the plate away
    /// from the base.
    pub leg_forces_n: [f64; LEG_COUNT],
    /// Angular rate of the plate, in the IMU's axes (P's when the IMU is aligned; the rig
    /// description's `sensors.imu.orientation_deg` turns them into P), rad/s.
    pub gyro_rad_s: [f64; 3],
    /// Specific force (a − g) at the accelerometer's mounting point, in the IMU's axes, m/s².
    pub accel_m_s2: [f64; 3],
    /// Backend status bits.
    pub status: Status,
}

impl SensorFrame {
    /// True when every numeric channel is finite (no NaN, no infinity).
    pub fn is_finite(&self) -> bool {
        self.time_s.is_finite()
            && self.leg_lengths_m.iter().all(|v| v.is_finite())
            && self.leg_forces_n.iter().all(|v| v.is_finite())
            && self.gyro_rad_s.iter().all(|v| v.is_finite())
            && self.accel_m_s2.iter().all(|v| v.is_finite())
    }
}

/// What the host asks the actuators to do until the next command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CommandFrame {
    /// Host command counter, increasing by one per command.
    pub sequence: u64,
    /// Sequence number of the last sensor frame the host used to compute this command.
    pub sensor_sequence: u64,
    /// Axial force each actuator should produce, newtons (positive extends the leg).
    pub leg_forces_n: [f64; LEG_COUNT],
    /// `true`: actuators follow `leg_forces_n`. `false`: brake, whatever the forces say.
    pub enable: bool,
}

impl CommandFrame {
    /// The safe-stop command: brakes on, zero force.
    pub const fn safe_stop(sequence: u64, sensor_sequence: u64) -> Self {
        Self {
            sequence,
            sensor_sequence,
            leg_forces_n: [0.0; LEG_COUNT],
            enable: false,
        }
    }
}

/// A platform the cores can drive: the simulator or a real rig behind a link.
///
/// The contract: `read` returns the next sensor sample (a rig blocks until it arrives; a
/// simulator returns the state at its current time); `write` applies a command until the next
/// sample (a simulator advances its physics by one control period inside `write`).
pub trait Backend {
    /// What can go wrong talking to this backend.
    type Error;

    /// The next sensor sample.
    fn read(&mut self) -> Result<SensorFrame, Self::Error>;

    /// Apply `command` until the next sample.
    fn write(&mut self, command: &CommandFrame) -> Result<(), Self::Error>;

    /// Nominal time between samples, seconds.
    fn sample_period_s(&self) -> f64;
}
