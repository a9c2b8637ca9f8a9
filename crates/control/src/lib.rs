//! Control core of the Stewart-platform inertia rig: leg PID, excitation trajectories, safety
//! supervisor, the per-tick controller pipeline, and the sensor/command types with the backend
//! trait that the simulator and the rig implement.
//!
//! `no_std`, no `alloc`: every type is fixed-size, nothing allocates, nothing panics on any input
//! (invalid data gives a [`ControlError`] or a supervisor [`Fault`](supervisor::Fault)). Units are
//! SI throughout.
//!
//! Data flow of one tick (see [`controller::Controller::tick`]):
//! `sensors -> supervisor watchdog -> FK -> phase (settle / excite / park) -> IK -> PID bank ->
//! supervisor gate -> command`.
#![cfg_attr(not(test), no_std)]
#![warn(missing_docs)]

pub mod controller;
mod error;
pub mod io;
pub mod pid;
pub mod supervisor;
pub mod trajectory;

pub use error::{ControlError, ErrorKind};
