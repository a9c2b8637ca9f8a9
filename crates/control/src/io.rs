//! The I/O boundary between the cores and a backend (simulator or rig).
//!
//! Data flows one way per tick: [`Backend::read`] gives a [`SensorFrame`], the cores compute, and
//! [`Backend::write`] sends a [`CommandFrame`]. Both frames are plain `Copy` data in SI units so
//! that they can be logged, sent over a wire and compared bit for bit.
//!
//! The types are defined once in `stewart-types` (shared with the simulator, the rig and the
//! front ends) and re-exported here and at the crate root.

pub use stewart_types::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};
