//! A simulated 6-6 Stewart platform on `rapier3d-f64`, as a [`control::io::Backend`].
//!
//! - [`world`]: a fixed base and one dynamic body (plate + payload) built from two colliders
//!   with explicit mass properties; the tare world is the same without the payload collider.
//!   Gyroscopic forces on, gravity `(0, 0, −9.80665)`, substeps of at most 1 ms.
//! - Legs are massless axial force elements: every substep the forces are reset and each
//!   actuator's force is applied along the current leg line at its plate joint. (Rapier's joint
//!   reaction impulses do not serve as load cells, DESIGN.md.)
//! - [`actuator`]: first-order lag, saturation, viscous and Coulomb friction, and a brake.
//! - [`sensors`]: encoders, load cells, gyro and accelerometer with seeded noise, bias and
//!   quantization; presets `none`, `realistic`, `harsh`.
//! - [`Simulator`]: the backend; load cells, gyro and accelerometer report their mean over the
//!   sample period, as behind an anti-alias filter, and the encoders the instant (see the
//!   [`simulator`] module docs). Ground truth is exposed through `true_*` methods, for
//!   reports and tests only.
//!
//! Configuration structs ([`SimConfig`], [`ActuatorConfig`], [`SensorConfig`],
//! [`BodyProperties`]) derive serde with `deny_unknown_fields`, so a front end can embed them
//! as TOML sections.

#![warn(missing_docs)]

pub mod actuator;
pub mod body;
pub mod config;
pub mod dynamics;
pub mod error;
pub mod sensors;
pub mod simulator;
pub mod world;

pub use actuator::ActuatorConfig;
pub use body::{BodyProperties, InertialParameters};
pub use config::{GyroscopicModel, SimConfig};
pub use dynamics::{Acceleration, RigidBodyModel};
pub use error::{SimError, SimErrorKind};
pub use sensors::{
    AccelerometerConfig, GyroConfig, LegLengthSensorConfig, LoadCellConfig, NoisePreset,
    SensorConfig,
};
pub use simulator::{PlateVelocity, Simulator};
pub use world::GRAVITY_M_S2;
