//! The rig link's end-to-end tests (`stewart emulate` and `stewart rig`, keyed sessions,
//! signals, stalls, lossy links, calibrations on the rig), one test binary: each file a
//! module, `cargo test --test rig MODULE::` runs one. Real-time tests take the support
//! module's process-wide lock, so they never compete with each other for the two cores.

mod support;

mod rig_calibration;
mod rig_interrupt;
mod rig_key;
mod rig_live_view;
mod rig_lossy_link;
mod rig_measurement;
mod rig_refusals;
mod rig_replay;
mod rig_silence;
mod rig_stall;
mod rig_systematic;
