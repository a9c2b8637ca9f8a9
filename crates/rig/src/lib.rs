//! Hardware I/O for the Stewart rig: the wire protocol, its transports, the host backend and a
//! rig emulator.
//!
//! * [`wire`] and [`codec`] are the protocol (documented byte by byte in `docs/protocol.md`),
//!   and [`firmware::RigCore`] is the rig's side of it (session, key, watchdog, limits, brakes,
//!   faults, sensor frames; docs/firmware.md). They build without `std` and without an
//!   allocator (`default-features = false`) so that a rig's firmware runs them as they are.
//! * With the default `std` feature: [`transport`] (UDP, serial), [`host::RigBackend`] (a
//!   `control::io::Backend` talking to a rig), [`emulator`] (any backend, e.g. the
//!   simulator, served behind the protocol in real time by [`firmware::RigCore`]), [`link`] (the
//!   backend as a measurement holds it: brake heartbeat, first failure, loop timing), [`key`]
//!   (the shared key and its file) and [`realtime`] (real-time priority where allowed).
//!
//! Entry points for the command line: [`host::RigBackend::connect`] for `stewart rig` and
//! [`emulator::serve`] (or [`emulator::Emulator::bind`] + [`emulator::Emulator::run`]) for
//! `stewart emulate`.
#![cfg_attr(all(not(feature = "std"), not(test)), no_std)]
#![warn(missing_docs)]

pub mod codec;
mod convert;
pub mod firmware;
pub mod wire;

#[cfg(feature = "std")]
pub mod emulator;
#[cfg(feature = "std")]
mod error;
#[cfg(feature = "std")]
pub mod host;
#[cfg(feature = "std")]
pub mod key;
#[cfg(feature = "std")]
pub mod monitored;
#[cfg(feature = "std")]
pub mod realtime;
#[cfg(feature = "std")]
mod stats;
#[cfg(feature = "std")]
pub mod transport;

#[cfg(feature = "std")]
pub use error::{ErrorKind, RigError};
#[cfg(feature = "std")]
pub use host::{RigBackend, RigOptions};
#[cfg(feature = "std")]
pub use key::Key;
#[cfg(feature = "std")]
pub use stats::LinkStats;

#[cfg(all(test, feature = "std"))]
mod loopback_tests;
#[cfg(all(test, feature = "std"))]
mod scripted_tests;
