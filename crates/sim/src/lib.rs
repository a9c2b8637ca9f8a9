//! A simulated 6-6 Stewart platform on `rapier3d-f64`, as a [`control::io::Backend`].
//!
//! - The world: a fixed base and one dynamic body (plate + payload) built from two colliders
//!   with explicit mass properties; the tare world is the same without the payload collider.
//!   Gyroscopic forces on, gravity [`GRAVITY_M_S2`] = (0, 0, −9.80665) m/s² in B (z up),
//!   substeps of at most [`MAX_SUBSTEP_S`].
//! - Legs ([`SimConfig::legs`], the rig description's `[legs]`): massless by default, axial
//!   force elements: every substep the forces are reset and each actuator's force is applied
//!   along the current leg line at its plate joint. With mass, inertia or joint friction
//!   (`legs`), each leg is a cylinder on its universal joint and a rod on its spherical joint,
//!   slaved to the plate's motion; the plate's acceleration is solved with the legs' reflected
//!   inertia and rapier gets the joint forces; the load cells read the axial force at the
//!   plate or the base end. (Rapier's joint reaction impulses do not serve as load cells.)
//! - Suspension ([`SuspensionConfig`], off by default): a share of the payload rides on four
//!   spring-damper units as a second rapier body, the rest stays rigid on the plate; the
//!   plate's equations carry the units' forces (module `suspension`).
//! - Actuators ([`ActuatorConfig`]): first-order lag, saturation, viscous and Coulomb friction,
//!   and a brake.
//! - Sensors ([`SensorConfig`]): encoders, load cells, gyro and accelerometer with seeded noise,
//!   biases and quantization, the load cells' drift, gain and transverse sensitivity, the IMU's
//!   misalignment, scale errors and position, the IMU's time skew, sampling jitter and lost
//!   frames (the model and its equations: `sensor_model`); presets `none`, `realistic`,
//!   `harsh` ([`NoisePreset`]). Each error source draws from its own stream of the seed.
//! - [`Simulator`]: the backend; load cells, gyro and accelerometer report their mean over the
//!   sample period, as behind an anti-alias filter, and the encoders the instant (see the
//!   [`Simulator`] docs). Ground truth is exposed through `true_*` methods, for reports and
//!   tests only.
//! - [`RigidBodyModel`]: Newton–Euler about the P origin, the simulator's accelerometer model.
//!
//! Body inertia: a [`BodyProperties`] (mass, centre of mass, tensor about the centre of mass, in
//! P) becomes the shared [`InertialParameters`] about the P origin by
//! [`InertialParameters::from_body`] (parallel-axis theorem J_O = J_C + m(‖c‖²𝟙 − c cᵀ)).
//!
//! Configuration structs ([`SimConfig`], [`ActuatorConfig`], [`SensorConfig`],
//! [`BodyProperties`]) derive serde with `deny_unknown_fields`, so a front end can embed them
//! as TOML sections.

#![warn(missing_docs)]

mod actuator;
mod body;
mod cell_loads;
mod config;
mod dynamics;
mod error;
mod imperfections;
mod legs;
mod sensor_model;
mod sensors;
mod simulator;
mod streams;
mod suspension;
mod world;

pub use actuator::ActuatorConfig;
pub use body::BodyProperties;
pub use config::{GyroscopicModel, SimConfig, MAX_SUBSTEP_S};
pub use dynamics::{Acceleration, RigidBodyModel};
pub use error::{SimError, SimErrorKind};
pub use imperfections::{Imperfections, SuspensionConfig};
pub mod scenario;

pub use sensor_model::ImuAsBuilt;
pub use sensors::{
    AccelerometerConfig, GyroConfig, ImuAxesConfig, LegLengthSensorConfig, LoadCellConfig,
    NoisePreset, SensorConfig, TimingConfig, UnknownPreset,
};
pub use simulator::{PlateVelocity, Simulator};
/// The ten inertial parameters about the P origin, defined once in `stewart-types`.
pub use stewart_types::InertialParameters;
pub use world::GRAVITY_M_S2;
