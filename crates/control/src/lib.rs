//! Control core of the Stewart-platform inertia rig: leg PID, excitation trajectories, safety
//! supervisor, the per-tick controller pipeline, and the sensor/command types with the backend
//! trait that the simulator and the rig implement.
//!
//! `no_std`, no `alloc`: every type is fixed-size, nothing allocates, nothing panics on any input
//! (invalid data gives a [`ControlError`] or a supervisor [`Fault`]). Units are SI throughout.
//!
//! The PID bank, the trajectories, the ramps and the feasibility check are generic over the
//! scalar ([`kinematics::Real`]: `f64` by default, or `f32` for a single-precision FPU); the
//! [`Controller`] and the [`Supervisor`] run in `f64` on the wire's frames (docs/firmware.md).
//!
//! What a user needs is re-exported at the crate root; the modules keep their paths
//! (`control::io::SensorFrame`, `control::controller::Controller`, …) and hold the rest.
//!
//! Data flow of one tick (see [`controller::Controller::tick`]):
//! `sensors -> supervisor watchdog -> FK -> phase (settle / excite / park) -> IK -> PID bank ->
//! supervisor gate -> command`.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod controller;
mod error;
#[cfg(test)]
mod f32_tests;
mod fault;
pub mod inverse_dynamics;
pub mod io;
pub mod pid;
pub mod stability;
pub mod supervisor;
pub mod trajectory;

pub use controller::{Controller, ControllerConfig, TickOutput};
pub use error::{ControlError, ErrorKind};
pub use fault::Fault;
pub use io::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};
pub use pid::{AntiWindup, PidConfig};
pub use supervisor::{Phase, Supervisor, SupervisorConfig};
pub use trajectory::{FeasibilityLimits, MultiSineConfig, Trajectory};
