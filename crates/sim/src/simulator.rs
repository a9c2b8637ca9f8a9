//! The simulated rig as a [`control::io::Backend`]: [`Simulator`], whose docs say what a sample
//! describes and how the physics is integrated.

use control::io::{Backend, CommandFrame, SensorFrame, Status, LEG_COUNT};
use kinematics::{Geometry, Pose};
use nalgebra::{Matrix3, Vector3};
use stewart_types::InertialParameters;

use crate::actuator::Actuators;
use crate::body::BodyProperties;
use crate::cell_loads::CellLoads;
use crate::config::{GyroscopicModel, SimConfig};
use crate::dynamics::{Acceleration, RigidBodyModel};
use crate::error::SimError;
use crate::legs::Legs;
use crate::sensor_model::SensorModel;
use crate::suspension::Suspension;
use crate::world::{Loads, PlateWorld, GRAVITY_M_S2};

use sprung::SprungLoads;

/// Velocity of the plate at the current sample instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlateVelocity {
    /// Velocity of the P origin, in B, m/s.
    pub linear_m_s: Vector3<f64>,
    /// Angular velocity, in B, rad/s.
    pub angular_rad_s: Vector3<f64>,
}

/// Legs at one pose, in B.
#[derive(Clone, Copy, Debug)]
struct LegState {
    lengths_m: [f64; 6],
    units: [Vector3<f64>; 6],
    /// Plate joints relative to the P origin, `R pᵢ`.
    arms_m: [Vector3<f64>; 6],
    /// Extension rates from rapier's stored velocities, m/s.
    rates_m_s: [f64; 6],
}

/// Forces and motion at one instant.
#[derive(Clone, Copy, Debug)]
struct Evaluation {
    /// The actuators' output between cylinder and rod, N.
    forces_n: [f64; 6],
    /// Axial force each leg applies to the plate, `u·F`, N.
    plate_axial_n: [f64; 6],
    /// What the load cells read (at the plate or the base end), N.
    cell_n: [f64; 6],
    /// The force across each load cell.
    cell_loads: CellLoads,
    /// Force each leg applies to the plate at its joint, in B.
    joint_forces_b: [Vector3<f64>; 6],
    /// Torque of the spherical joints' friction on the plate, in B.
    joint_torque_b: Vector3<f64>,
    omega_p: Vector3<f64>,
    acceleration: Acceleration,
    /// The suspension units' forces and the sprung body's torque at the instant.
    sprung: Option<SprungLoads>,
}

/// Everything true about the current sample instant.
#[derive(Clone, Copy, Debug)]
struct Instant {
    pose: Pose,
    lengths_m: [f64; 6],
    /// The actuators' output (what a brake engaging now holds).
    forces_n: [f64; 6],
    /// Axial force each leg applies to the plate.
    plate_axial_n: [f64; 6],
    /// The force across each load cell (the period's mean, as the cells' readings).
    cell_loads: CellLoads,
    /// Force each leg applies to the plate at its joint, in B.
    joint_forces_b: [Vector3<f64>; 6],
    velocity: PlateVelocity,
    acceleration: Acceleration,
    clean: SensorFrame,
}

/// The filtered channels at one physics node, in P.
#[derive(Clone, Copy, Debug, Default)]
struct Node {
    forces_n: [f64; 6],
    transverse_n: [[f64; 2]; 6],
    gyro_rad_s: Vector3<f64>,
    accel_m_s2: Vector3<f64>,
}

impl Node {
    /// The channels of `e`, the accelerometer at `mount_m`:
    /// `f_a = f + ω̇ × r_a + ω × (ω × r_a)`.
    /// `gyro_rad_s`: [`Simulator::gyro_at_instant`].
    fn new(e: &Evaluation, mount_m: &Vector3<f64>, gyro_rad_s: &Vector3<f64>) -> Self {
        let (omega, acc) = (e.omega_p, e.acceleration);
        Self {
            forces_n: e.cell_n,
            transverse_n: e.cell_loads.transverse_n,
            gyro_rad_s: *gyro_rad_s,
            accel_m_s2: acc.specific_force_m_s2
                + acc.angular_rad_s2.cross(mount_m)
                + omega.cross(&omega.cross(mount_m)),
        }
    }
}

/// Trapezoidal sum of the node values of the current sample period.
#[derive(Clone, Copy, Debug, Default)]
struct PeriodSum {
    sum: Node,
    weight: f64,
}

impl PeriodSum {
    fn add(&mut self, node: &Node, weight: f64) {
        let s = &mut self.sum;
        for (sum, f) in s.forces_n.iter_mut().zip(node.forces_n) {
            *sum += weight * f;
        }
        for (sum, f) in s.transverse_n.iter_mut().zip(node.transverse_n) {
            sum[0] += weight * f[0];
            sum[1] += weight * f[1];
        }
        s.gyro_rad_s += weight * node.gyro_rad_s;
        s.accel_m_s2 += weight * node.accel_m_s2;
        self.weight += weight;
    }

    /// The mean, or `None` before any node.
    fn mean(&self) -> Option<Node> {
        if self.weight <= 0.0 {
            return None;
        }
        let k = 1.0 / self.weight;
        let s = &self.sum;
        Some(Node {
            forces_n: s.forces_n.map(|v| v * k),
            transverse_n: s.transverse_n.map(|v| v.map(|x| x * k)),
            gyro_rad_s: s.gyro_rad_s * k,
            accel_m_s2: s.accel_m_s2 * k,
        })
    }
}

/// The simulated Stewart platform: rapier physics, actuators and sensors, as a
/// [`Backend`].
///
/// # What a sample describes
///
/// Sample `k` is read at `t_k = k T` (`T` the sample period, an integer number `N` of physics
/// substeps `h`). As on a real rig:
///
/// - **load cells, gyro, accelerometer** report, when the physics resolves the sample period
///   (`N > 1`), their **mean over the period** `[t_{k−1}, t_k]`, as a sensor behind an
///   anti-alias (integrating) filter does: a sigma-delta load-cell ADC, a MEMS IMU's
///   decimation filter. The mean is the trapezoidal rule over the period's `N + 1` physics nodes
///   `t_n` (half weight at both ends), each node evaluated as below, so these channels are one
///   linear filter of simultaneous values and still satisfy the rigid body's equations
///   together: exactly in the linear terms, to `O((ω̇ T)²)` ≈ 10⁻⁷ in the products of rates.
///   With `N = 1` there is no motion inside a sample to filter (the force is one kick, the
///   interpolant between nodes is what an ideal filter would see) and they report the node
///   at `t_k`, consistent with the encoders and without delay.
/// - **encoders** (leg lengths) are latched at the instant `t_k`: they need no anti-alias
///   filter, and the leg controllers want them without delay (averaged lengths, half a sample
///   late, made the default PIDs oscillate at 500 Hz).
///
/// So with `N > 1` the filtered channels describe the period's middle `t_k − T/2` (their group
/// delay) and the lengths `t_k`. The pose that pairs with a frame's forces is that of the
/// period's middle, e.g. forward kinematics of `(l_{k−1} + l_k)/2` (second order). With the
/// pose of `l_k`, as the estimator takes it now, the wrench's directions are half a sample
/// early: the fitted parameters stay within about 10⁻⁵ of a noise-free truth but the fit
/// residual rises to about 1 N (measured with this simulator), far below the load cells' noise.
///
/// Why the means: with `N > 1` the lagged actuator force bends inside a sample (its slope jumps
/// when a new command arrives at `t_k`). A load cell read at the instant misses that, while the
/// gyro's change over a sample integrates it: such frames disagreed with Newton–Euler by about
/// 4·10⁻⁴ of the wrench (rms) and biased a noise-free estimate's J_xx by 0.07 % with `N = 4`.
/// Means over the period agree to about 10⁻⁶ (test
/// `load_cells_with_substeps_report_the_mean_force_of_the_sample`). Sample 0 and a sample right
/// after [`Simulator::set_state`] or [`Simulator::set_payload`] have no period behind them and
/// report the node values at the instant.
///
/// Each node `t_n` is evaluated *at that instant*:
///
/// - **pose, leg lengths**: rapier's pose after `n` steps (positions live on step boundaries).
/// - **load cells**: the axial force each actuator applies at `t_n`, i.e. the force rapier
///   integrates over the next substep. With legs of mass, inertia or joint friction
///   ([`crate::legs`], `SimConfig::legs`), the axial force through the cell at the plate or the
///   base end, from the legs' motion at `t_n` (see `simulator/coupled.rs`). At `t_k` it depends only on the actuator state (the lag
///   applies its state, then advances), never on the command written after the read, so it is
///   known when the sample is taken.
/// - **gyro**: rapier's stored velocity is that of the half step *before* `t_k` (symplectic
///   Euler read as leapfrog: `v_{n+½} = v_{n−½} + h a(x_n)`). The mean of the velocities on
///   either side, `ω_{k−½} + (h/2) ω̇(t_k)`, is what rapier's trajectory passes through at `t_k`
///   to second order (the dynamics use it), but its differences are the trapezoidal sums of the
///   kicks, `h (ω̇ₙ + ω̇ₙ₋₁)/2`, where a body driven continuously by the node forces gains
///   `∫ω̇ = h (ω̇ₙ + ω̇ₙ₋₁)/2 − (h³/12) ω⃛`: differentiated, that mean is `ω̇ + (h²/12) ω⃛`, and the
///   torque it implies misses the forces by `(h²/12) J ω⃛`: 0.3 % of the torque 20 ms into
///   `configs/paper.toml`'s start, 3 N·m rms over its first 60 samples. So the gyro reports
///   `ω_{k−½} + (h/2) ω̇ₙ − (h/12)(ω̇ₙ − ω̇ₙ₋₁)` (ω̇ₙ₋₁ of the node before; none after a state
///   change), the continuous body's rate to third order, as a real rig's gyro reads it.
/// - **accelerometer**: the specific force `f = a_O − g` and `ω̇` that the wrench of those leg
///   forces produces on the body at `t_k` by Newton–Euler with the true (rapier's own) inertial
///   parameters and `ω(t_k)` — exactly the acceleration of rapier's next kick with the default
///   [`GyroscopicModel::Midpoint`] — moved to the mounting point:
///   `f_a = f + ω̇ × r_a + ω × (ω × r_a)`.
///
/// With legs, the accelerometer's `f`, `ω̇` are those of the plate coupled to the legs (one
/// 6×6 solve with their reflected inertia, twice per substep to take the velocities to the
/// instant), rapier applies the joint forces that solve gives, and its plate moves with exactly
/// that acceleration (test `rapier_moves_the_plate_with_the_coupled_acceleration`, 10⁻¹²). The
/// Newton–Euler property below then holds for the joint forces (the plate's wrench), not for
/// the cells' axial readings, which miss the joints' transverse force.
///
/// So the load cells, the pose, the gyro and the accelerometer of one node satisfy the rigid
/// body's equations at one instant, and their means over a period satisfy them on average. A
/// half-step skew between channels (a force held over a step against a centrally differenced
/// rate) leaves the fitted parameters nearly intact but raises the fit residual by orders of
/// magnitude (measured with this simulator, as below).
///
/// Measured (tests `sample_channels_are_simultaneous`, `leg_wrench_matches_newton_euler_*`,
/// `load_cells_with_substeps_*`; 1 kHz, 1.7 t tumbling at up to 1 rad/s): Newton–Euler on
/// rapier's motion matches the leg wrench to 3·10⁻⁸ per substep (midpoint gyroscopic torque)
/// or 3·10⁻⁴ (rapier's). Newton–Euler on the frames alone (pose by forward kinematics of the
/// mean of two successive frames' leg lengths, `ω̇` from a 4th-order central difference of the
/// gyro), with the default 100 Hz actuator: 2.6·10⁻⁶ rms with one substep (1.5·10⁻⁵ with the
/// half-step mean as the gyro's reading), 6.6·10⁻⁷ with four, against 3.9·10⁻⁴ with four when
/// the load cells were read at the instant.
///
/// # Suspended payload
///
/// With `[world.suspension]` enabled ([`SimConfig::suspension`]), the payload's sprung share is
/// a second rapier body on four spring-damper units (`crate::suspension`); the plate carries the
/// fixture and the unsprung part rigidly. The units' forces at each substep's start instant
/// (both bodies' velocities taken to the instant like the plate's) enter the plate's
/// Newton–Euler or coupled solve, the brake's implicit rates and the hold, so the
/// accelerometer still reports the plate's true acceleration and the load cells the legs' true
/// forces; rapier applies the opposite forces to the sprung body. The truth
/// ([`Simulator::true_payload`], [`Simulator::true_parameters`]) stays the whole payload at rest.
///
/// # Gyroscopic torque
///
/// Rapier 0.36's gyroscopic forces (`RigidBodyBuilder::gyroscopic_forces_enabled`, on by
/// default) are an explicit correction applied *after* the force kick, with the angular
/// momentum's norm capped: first order, 3·10⁻⁴ of the torque at 1 rad/s. By default we switch
/// them off and apply `−ω × (J_C ω)` ourselves as a torque, evaluated at `ω(t_n)`, which makes
/// the kick the Newton–Euler acceleration at the instant (second order).
/// [`GyroscopicModel::Rapier`] restores rapier's.
///
/// Exception: a brake engaging or releasing takes effect from the next substep, so the force of
/// the sample taken just before such a command differs by the brake's damping term.
///
/// # Sensor errors
///
/// `read` returns the clean channels above ([`Simulator::clean_frame`], the IMU's in P at its
/// true position) through the sensor model (`sensor_model`'s docs give each error's equation):
/// noise, biases, drift, gains, crosstalk, the IMU's axes and scale errors, its skew and the
/// frame's jitter (the frame's `time_s` is its jittered sampling instant). A frame the model
/// loses never reaches `read`: `write` runs one more period on the same command. (The frame at
/// construction and after [`Simulator::set_state`] or [`Simulator::set_payload`] is always
/// delivered.)
pub struct Simulator {
    geometry: Geometry,
    config: SimConfig,
    fixture: BodyProperties,
    payload: Option<BodyProperties>,
    /// Everything rigid on the plate: fixture + payload, or fixture + the payload's unsprung
    /// part when it rides on a suspension.
    model: RigidBodyModel,
    /// Fixture + the whole payload at rest: the truth a rigid measurement aims at.
    truth: InertialParameters,
    /// The sprung body and its units (`None`: a rigid payload, or no payload).
    suspension: Option<Suspension>,
    /// The legs' mass, inertia and joint friction (`None`: massless, frictionless legs).
    legs_model: Option<Legs>,
    /// Tensor of fixture + payload about their joint centre of mass, in P.
    inertia_com: Matrix3<f64>,
    world: PlateWorld,
    actuators: Actuators,
    sensors: SensorModel,
    substep_s: f64,
    sample: u64,
    now: Instant,
    /// Node sums of the period since the last sample (empty after a state change).
    period: PeriodSum,
    /// ω̇ (P) of the last substep's start node, for the gyro's reading
    /// ([`Simulator::gyro_at_instant`]); `None` after a state change.
    last_angular_rad_s2: Option<Vector3<f64>>,
    frame: SensorFrame,
}

impl core::fmt::Debug for Simulator {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Simulator")
            .field("time_s", &self.time_s())
            .field("payload", &self.payload.is_some())
            .finish_non_exhaustive()
    }
}

/// The payload's part rigid on the plate and its suspension, per `config`, with P level at
/// `rest` when the sprung body rests on its preload.
fn split_payload(
    config: &SimConfig,
    payload: Option<&BodyProperties>,
    rest: &nalgebra::Rotation3<f64>,
) -> (Option<BodyProperties>, Option<Suspension>) {
    match payload.and_then(|p| Suspension::new(&config.suspension, p, rest).map(|s| (p, s))) {
        Some((p, s)) => (Suspension::unsprung(&config.suspension, p), Some(s)),
        None => (payload.copied(), None),
    }
}

fn total_model(
    fixture: &BodyProperties,
    payload: Option<&BodyProperties>,
) -> Result<RigidBodyModel, SimError> {
    let mut p = InertialParameters::from_body(fixture);
    if let Some(b) = payload {
        p = p + InertialParameters::from_body(b);
    }
    RigidBodyModel::new(p).ok_or(SimError::InvalidBody {
        body: "plate + payload",
        reason: "spatial inertia is not positive definite",
    })
}

impl Simulator {
    /// A rig of `geometry` carrying `fixture` and, unless this is a tare world, `payload`,
    /// at the geometry's home pose, at rest, with the brakes holding the static load.
    ///
    /// Refuses invalid configs and bodies, an unreachable home pose, a singular geometry, and a
    /// brake or actuator friction too stiff for the physics substep (see [`Self::set_payload`]).
    pub fn new(
        geometry: Geometry,
        fixture: BodyProperties,
        payload: Option<BodyProperties>,
        config: &SimConfig,
        seed: u64,
    ) -> Result<Self, SimError> {
        config.validate()?;
        fixture.validate("fixture")?;
        if let Some(p) = &payload {
            p.validate("payload")?;
        }
        let pose = geometry.home_pose();
        let (rigid, suspension) = split_payload(config, payload.as_ref(), &pose.rotation);
        let model = total_model(&fixture, rigid.as_ref())?;
        let truth = *total_model(&fixture, payload.as_ref())?.params();
        let substep_s = config.substep_s();
        let mut world = PlateWorld::new(
            &fixture,
            rigid.as_ref(),
            &pose,
            substep_s,
            config.gyroscopic == GyroscopicModel::Rapier,
        );
        world.set_sprung(suspension.as_ref().map(Suspension::body));
        let placeholder = Actuators::new_braked(config.actuator, substep_s, &[0.0; 6], &[0.0; 6]);
        let mut sim = Self {
            geometry,
            config: *config,
            fixture,
            payload,
            inertia_com: model.inertia_com(),
            model,
            truth,
            suspension,
            legs_model: Legs::new(config.legs),
            world,
            actuators: placeholder,
            sensors: SensorModel::new(config.sensors, config.sample_rate_hz, seed),
            substep_s,
            sample: 0,
            now: Instant {
                pose,
                lengths_m: [0.0; 6],
                forces_n: [0.0; 6],
                plate_axial_n: [0.0; 6],
                cell_loads: CellLoads::default(),
                joint_forces_b: [Vector3::zeros(); 6],
                velocity: PlateVelocity {
                    linear_m_s: Vector3::zeros(),
                    angular_rad_s: Vector3::zeros(),
                },
                acceleration: Acceleration {
                    specific_force_m_s2: Vector3::zeros(),
                    angular_rad_s2: Vector3::zeros(),
                },
                clean: SensorFrame::default(),
            },
            period: PeriodSum::default(),
            last_angular_rad_s2: None,
            frame: SensorFrame::default(),
        };
        sim.check_stability()?;
        sim.set_state(&pose, &Vector3::zeros(), &Vector3::zeros())?;
        Ok(sim)
    }

    /// Moves the plate to `pose` with the given velocity of the P origin and angular velocity
    /// (both in B), and engages the brakes holding the static load at that pose (so at zero
    /// velocity the plate stays at rest). The sample counter and the noise stream continue.
    pub fn set_state(
        &mut self,
        pose: &Pose,
        linear_m_s: &Vector3<f64>,
        angular_rad_s: &Vector3<f64>,
    ) -> Result<(), SimError> {
        let finite = pose.position_m.iter().all(|v| v.is_finite())
            && pose.rotation.matrix().iter().all(|v| v.is_finite())
            && linear_m_s.iter().all(|v| v.is_finite())
            && angular_rad_s.iter().all(|v| v.is_finite());
        if !finite {
            return Err(SimError::InvalidConfig {
                field: "initial state",
                value: f64::NAN,
                reason: "pose and velocities must be finite",
            });
        }
        self.geometry
            .check_reachable(pose)
            .map_err(SimError::Unreachable)?;
        let legs = self.legs(pose);
        let hold = self.static_forces(pose, &legs)?;
        self.world.set_state(pose, linear_m_s, angular_rad_s);
        self.actuators =
            Actuators::new_braked(self.config.actuator, self.substep_s, &legs.lengths_m, &hold);
        self.period = PeriodSum::default();
        self.last_angular_rad_s2 = None;
        self.refresh()
    }

    /// What an operator does between a rig's runs: puts `payload` on the braked plate (or takes
    /// it off) and waits `settle_s` with the brakes on (safe stops) before the next run, which
    /// then starts from a plate at rest rather than one still sagging onto its brakes (the
    /// next brake hold weighs it, and measures the accelerometer's offset as its mean).
    pub fn change_payload_and_settle(
        &mut self,
        payload: Option<BodyProperties>,
        settle_s: f64,
    ) -> Result<(), SimError> {
        self.set_payload(payload)?;
        let frames = (settle_s / self.sample_period_s()).ceil();
        let frames = if frames.is_finite() && frames > 0.0 {
            frames as u64
        } else {
            0
        };
        for i in 0..frames {
            let sequence = self.frame.sequence;
            self.write(&CommandFrame::safe_stop(i, sequence))?;
        }
        Ok(())
    }

    /// Puts a payload on the plate or takes it off (`None`: the tare world), keeping the
    /// current motion and actuator state (a sprung body is put on resting, moving with the
    /// plate). Also re-checks brake and friction stability, which is worst for the lightest
    /// body.
    pub fn set_payload(&mut self, payload: Option<BodyProperties>) -> Result<(), SimError> {
        if let Some(p) = &payload {
            p.validate("payload")?;
        }
        let rest = self.geometry.home_pose().rotation;
        let (rigid, suspension) = split_payload(&self.config, payload.as_ref(), &rest);
        let model = total_model(&self.fixture, rigid.as_ref())?;
        let truth = *total_model(&self.fixture, payload.as_ref())?.params();
        let old = core::mem::replace(&mut self.model, model);
        let old_suspension = core::mem::replace(&mut self.suspension, suspension);
        if let Err(e) = self.check_stability() {
            self.model = old;
            self.suspension = old_suspension;
            return Err(e);
        }
        self.inertia_com = self.model.inertia_com();
        self.truth = truth;
        self.payload = payload;
        self.world.set_payload(rigid.as_ref());
        self.world
            .set_sprung(self.suspension.as_ref().map(Suspension::body));
        self.period = PeriodSum::default();
        self.last_angular_rad_s2 = None;
        self.refresh()
    }

    /// Leg lengths, unit vectors, arms and extension rates at `pose` with rapier's velocities.
    fn legs(&self, pose: &Pose) -> LegState {
        let (v_com, omega) = self.world.raw_velocities();
        let com_b =
            pose.rotation * (self.model.params().first_moment_kg_m / self.model.params().mass_kg);
        let v_origin = v_com - omega.cross(&com_b);
        let base = self.geometry.base_joints_m();
        let plate = self.geometry.plate_joints_m();
        let mut s = LegState {
            lengths_m: [0.0; 6],
            units: [Vector3::zeros(); 6],
            arms_m: [Vector3::zeros(); 6],
            rates_m_s: [0.0; 6],
        };
        for i in 0..LEG_COUNT {
            let arm = pose.rotation * plate[i];
            let l = pose.position_m + arm - base[i];
            let len = l.norm();
            let u = if len > 0.0 { l / len } else { Vector3::z() };
            s.lengths_m[i] = len;
            s.units[i] = u;
            s.arms_m[i] = arm;
            s.rates_m_s[i] = u.dot(&(v_origin + omega.cross(&arm)));
        }
        s
    }

    /// The state of the instant at the start of the next substep: the leg forces the actuators
    /// apply, their wrench about the P origin in P, the angular velocity at the instant
    /// (`ω_{n−½} + (h/2) ω̇`, see the module docs) and the Newton–Euler acceleration there.
    fn evaluate(&self, pose: &Pose, legs: &LegState) -> Evaluation {
        let forces = if self.actuators.braked() {
            let rates = self.implicit_brake_rates(pose, legs);
            self.actuators.output(&legs.lengths_m, &rates)
        } else {
            self.actuators.output(&legs.lengths_m, &legs.rates_m_s)
        };
        if let Some(model) = &self.legs_model {
            return self.evaluate_coupled(model, pose, legs, &forces);
        }
        let rt = pose.rotation.inverse();
        let mut force_p = Vector3::zeros();
        let mut torque_p = Vector3::zeros();
        let joints = self.geometry.plate_joints_m().iter();
        for ((force, unit), joint) in forces.iter().zip(&legs.units).zip(joints) {
            let f = rt * (unit * *force);
            force_p += f;
            torque_p += joint.cross(&f);
        }
        let (_, omega_b) = self.world.raw_velocities();
        let omega_raw = rt * omega_b;
        let plate_raw = self
            .suspension
            .as_ref()
            .map(|_| self.plate_raw_motion(pose));
        let start = plate_raw.as_ref().and_then(|m| self.sprung_start(m));
        let (mut f1, mut t1) = (force_p, torque_p);
        if let Some(st) = &start {
            let (f, t) = sprung::plate_wrench_p(&st.forces, pose);
            f1 += f;
            t1 += t;
        }
        let first = self.model.acceleration(&f1, &t1, &omega_raw);
        let omega = omega_raw + 0.5 * self.substep_s * first.angular_rad_s2;
        let mut sprung = None;
        if let (Some(st), Some(raw)) = (&start, &plate_raw) {
            let a_origin = pose.rotation * first.specific_force_m_s2 + GRAVITY_M_S2;
            let plate = sprung::Motion {
                pose: *pose,
                v_origin: raw.v_origin + 0.5 * self.substep_s * a_origin,
                omega: pose.rotation * omega,
            };
            let loads = self.sprung_at(st, &plate);
            let (f, t) = sprung::plate_wrench_p(&loads.forces, pose);
            force_p += f;
            torque_p += t;
            sprung = Some(loads);
        }
        let acceleration = self.model.acceleration(&force_p, &torque_p, &omega);
        Evaluation {
            forces_n: forces,
            plate_axial_n: forces,
            cell_n: forces,
            cell_loads: CellLoads::default(),
            joint_forces_b: core::array::from_fn(|i| legs.units[i] * forces[i]),
            joint_torque_b: Vector3::zeros(),
            omega_p: omega,
            acceleration,
            sprung,
        }
    }

    /// One physics substep: forces along the current leg lines at the plate joints, plus the
    /// gyroscopic torque at the instant when we integrate it ([`GyroscopicModel::Midpoint`]).
    /// Returns the channels at the substep's start node, with the forces it applied.
    fn substep(&mut self) -> Node {
        let pose = self.world.pose();
        let legs = self.legs(&pose);
        let e = self.evaluate(&pose, &legs);
        let node = Node::new(&e, &self.mount_m(), &self.gyro_at_instant(&e));
        self.last_angular_rad_s2 = Some(e.acceleration.angular_rad_s2);
        let applied: [(Vector3<f64>, Vector3<f64>); 6] =
            core::array::from_fn(|i| (e.joint_forces_b[i], pose.position_m + legs.arms_m[i]));
        let gyroscopic = match self.config.gyroscopic {
            GyroscopicModel::Midpoint => {
                let w = &e.omega_p;
                pose.rotation * -w.cross(&(self.inertia_com * w))
            }
            GyroscopicModel::Rapier => Vector3::zeros(),
        };
        let torque = if self.legs_model.is_some() {
            gyroscopic + e.joint_torque_b
        } else {
            gyroscopic
        };
        let (units_on_plate, units_on_body, body_torque) = match &e.sprung {
            Some(s) => (s.forces.plate_loads(), s.forces.body_loads(), s.torque_b),
            None => Default::default(),
        };
        let plate_groups: [&[(Vector3<f64>, Vector3<f64>)]; 2] = [&applied, &units_on_plate];
        let groups = if e.sprung.is_some() { 2 } else { 1 };
        self.world.step(
            &Loads {
                forces: &plate_groups[..groups],
                torque,
            },
            &Loads {
                forces: &[&units_on_body],
                torque: body_torque,
            },
        );
        self.actuators.advance(&e.forces_n);
        node
    }

    /// The gyro's reading at a node: `ω(tₙ) − (h/12)(ω̇ₙ − ω̇ₙ₋₁)`, the rate that a continuous
    /// body driven by the node forces has (module docs, "What a sample describes").
    fn gyro_at_instant(&self, e: &Evaluation) -> Vector3<f64> {
        let a = e.acceleration.angular_rad_s2;
        match self.last_angular_rad_s2 {
            Some(prev) => e.omega_p - self.substep_s / 12.0 * (a - prev),
            None => e.omega_p,
        }
    }

    /// The accelerometer's true position in P (the described one plus its tolerance's draw).
    fn mount_m(&self) -> Vector3<f64> {
        self.sensors.mount_m()
    }

    /// Evaluates every channel at the current instant (see the module docs), closes the
    /// period's mean with it (or takes the instant when no period lies behind), and samples the
    /// sensors.
    fn refresh(&mut self) -> Result<(), SimError> {
        let pose = self.world.pose();
        let legs = self.legs(&pose);
        let e = self.evaluate(&pose, &legs);
        let node = Node::new(&e, &self.mount_m(), &self.gyro_at_instant(&e));
        self.period.add(&node, 0.5);
        // A period lies behind this instant: the motion ran on from the previous sample.
        let continuous = self.period.weight > 0.5;
        let sensed = if self.config.substeps > 1 && self.period.weight > 0.5 {
            self.period.mean().unwrap_or(node)
        } else {
            node
        };
        self.period = PeriodSum::default();
        let (omega, acc) = (e.omega_p, e.acceleration);
        // Velocity of the P origin: rapier's is the centre of mass's, half a step old.
        let (v_com, omega_b) = self.world.raw_velocities();
        let p = self.model.params();
        let com_b = pose.rotation * (p.first_moment_kg_m / p.mass_kg);
        let v_origin_raw = v_com - omega_b.cross(&com_b);
        let a_origin_b = pose.rotation * acc.specific_force_m_s2 + GRAVITY_M_S2;
        let velocity = PlateVelocity {
            linear_m_s: v_origin_raw + 0.5 * self.substep_s * a_origin_b,
            angular_rad_s: pose.rotation * omega,
        };
        let status = if self.actuators.braked() {
            Status::BRAKED
        } else {
            Status::ENABLED
        };
        let clean = SensorFrame {
            sequence: self.sample,
            time_s: self.time_s(),
            leg_lengths_m: legs.lengths_m,
            leg_forces_n: sensed.forces_n,
            gyro_rad_s: sensed.gyro_rad_s.into(),
            accel_m_s2: sensed.accel_m_s2.into(),
            status: Status(status),
        };
        if !clean.is_finite() {
            return Err(SimError::Diverged {
                time_s: self.time_s(),
            });
        }
        self.now = Instant {
            pose,
            lengths_m: legs.lengths_m,
            forces_n: e.forces_n,
            plate_axial_n: e.plate_axial_n,
            cell_loads: CellLoads {
                transverse_n: sensed.transverse_n,
            },
            joint_forces_b: e.joint_forces_b,
            velocity,
            acceleration: acc,
            clean,
        };
        self.frame = self
            .sensors
            .measure(&clean, &self.now.cell_loads, continuous);
        Ok(())
    }

    /// Simulated time of the current sample, s.
    pub fn time_s(&self) -> f64 {
        self.sample as f64 * self.config.sample_period_s()
    }

    /// The rig's geometry.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The configuration the simulator was built with.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Ground truth (reports and tests only): pose of P in B at the current sample.
    pub fn true_pose(&self) -> Pose {
        self.now.pose
    }

    /// Ground truth: velocity of the plate at the current sample.
    pub fn true_velocity(&self) -> PlateVelocity {
        self.now.velocity
    }

    /// Ground truth: specific force of the P origin and angular acceleration, in P.
    pub fn true_acceleration(&self) -> Acceleration {
        self.now.acceleration
    }

    /// Ground truth: the axial force each leg applies to the plate at the current sample, N
    /// (the actuator's force when the legs are massless; with the cells at the plate end, what
    /// they read at the instant).
    pub fn true_leg_forces_n(&self) -> [f64; 6] {
        self.now.plate_axial_n
    }

    /// Ground truth: the force each leg applies to the plate at its joint, in B, N.
    pub fn true_joint_forces_n(&self) -> [Vector3<f64>; 6] {
        self.now.joint_forces_b
    }

    /// Ground truth: the force across each load cell, along `e₁` and `e₂` of the leg's
    /// transverse basis (`e₁ = normalize(u × z_B)`, `e₂ = u × e₁`), as the force the leg's
    /// base side transmits towards the plate, N; the mean over the sample period like the
    /// cells' readings. Zero for massless, frictionless legs.
    pub fn true_cell_transverse_n(&self) -> [[f64; 2]; 6] {
        self.now.cell_loads.transverse_n
    }

    /// Ground truth: every channel of the current sample without the sensor model's errors
    /// (like the sensed frame: leg lengths at the instant, the rest means over the sample
    /// period; see the module docs), at the grid instant `t_k`, the IMU's in P axes at the
    /// accelerometer's true position.
    pub fn clean_frame(&self) -> SensorFrame {
        self.now.clean
    }

    /// Ground truth: the payload's properties (`None` in the tare world); with a suspension,
    /// the whole payload (sprung and unsprung) at rest.
    pub fn true_payload(&self) -> Option<BodyProperties> {
        self.payload
    }

    /// Ground truth: the pose of the sprung body's frame in B (it coincides with P when the
    /// body rests on its units), or `None` without a suspension.
    pub fn true_sprung_pose(&self) -> Option<Pose> {
        self.world.sprung_state().map(|(pose, _, _)| pose)
    }

    /// Ground truth: the IMU as built (its axes, scales, position and delay), for tests of the
    /// IMU calibration.
    pub fn imu_as_built(&self) -> crate::sensor_model::ImuAsBuilt {
        self.sensors.imu_as_built()
    }

    /// Ground truth: each load cell's gain error g_i, as drawn (tests of the load-cell
    /// calibration; never read by the estimator).
    pub fn true_load_cell_gains(&self) -> [f64; 6] {
        self.sensors.load_cell_gains()
    }

    /// Ground truth: the fixture plate's properties.
    pub fn true_fixture(&self) -> BodyProperties {
        self.fixture
    }

    /// Ground truth: parameters of everything on the legs (fixture + payload) about the P
    /// origin; with a suspension, of the whole payload at rest.
    pub fn true_parameters(&self) -> InertialParameters {
        self.truth
    }

    /// Rapier's own view of the plate body (mass, centre of mass in P, tensor about the centre
    /// of mass in P axes), to check that it matches [`Self::true_parameters`] (with a
    /// suspension: fixture + the unsprung part).
    pub fn rapier_body(&self) -> BodyProperties {
        let (m, c, j) = self.world.body_mass_properties();
        BodyProperties {
            mass_kg: m,
            com_m: [c.x, c.y, c.z],
            inertia_com_kg_m2: crate::body::matrix_to_rows(&j),
        }
    }
}

impl Simulator {
    /// One sample period of physics under the current command, then the next sample.
    fn advance(&mut self) -> Result<(), SimError> {
        self.period = PeriodSum::default();
        for j in 0..self.config.substeps {
            let node = self.substep();
            self.period.add(&node, if j == 0 { 0.5 } else { 1.0 });
        }
        self.sample += 1;
        self.refresh()
    }
}

impl Backend for Simulator {
    type Error = SimError;

    /// The sample at the current instant (the same frame until the next `write`).
    fn read(&mut self) -> Result<SensorFrame, SimError> {
        Ok(self.frame)
    }

    /// Applies `command` and advances the physics by one sample period, or more while the
    /// sampled frames are lost on their way to the host (each lost frame: one more period on
    /// the same command), so the next `read` may skip sequence numbers.
    fn write(&mut self, command: &CommandFrame) -> Result<(), SimError> {
        if let Some(leg) = command.leg_forces_n.iter().position(|f| !f.is_finite()) {
            return Err(SimError::InvalidCommand { leg });
        }
        self.actuators.command(
            &command.leg_forces_n,
            command.enable,
            &self.now.lengths_m,
            &self.now.forces_n,
        );
        self.advance()?;
        while self.sensors.frame_lost() {
            self.advance()?;
        }
        Ok(())
    }

    fn sample_period_s(&self) -> f64 {
        self.config.sample_period_s()
    }
}

mod coupled;
mod hold;
#[cfg(test)]
mod imperfection_tests;
#[cfg(test)]
mod leg_tests;
mod sprung;
#[cfg(test)]
mod sprung_tests;
#[cfg(test)]
mod tests;
