//! The whole procedure against a simple plant, and the pipeline's fault paths.
//!
//! The plant is a test double, not the platform's dynamics: six independent legs, each a mass
//! `m·l̈ = F − W − c·l̇` carrying a constant load W, integrated semi-implicitly at 1 kHz. It
//! exercises the pipeline (FK of consistent lengths, phases, IK, PIDs, gate); the rigid-body
//! simulation lives in the `sim` crate.

use super::*;
use crate::io::Status;
use crate::trajectory::{Axis, SineComponent};
use kinematics::{KinematicsError, Matrix3, StrokeLimits};

const DT: f64 = 1e-3;
const LEG_MASS_KG: f64 = 250.0;
const LEG_DAMPING: f64 = 500.0;
const LOAD_N: f64 = 4000.0;

fn geometry() -> Geometry {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).unwrap()
}

#[derive(Clone)]
struct Legs {
    lengths: [f64; LEG_COUNT],
    rates: [f64; LEG_COUNT],
    forces: [f64; LEG_COUNT],
    sequence: u64,
    time_s: f64,
}

impl Legs {
    fn at(pose: &Pose) -> Self {
        Self {
            lengths: geometry().leg_lengths(pose).into(),
            rates: [0.0; LEG_COUNT],
            forces: [0.0; LEG_COUNT],
            sequence: 0,
            time_s: 0.0,
        }
    }

    fn frame(&self) -> SensorFrame {
        SensorFrame {
            sequence: self.sequence,
            time_s: self.time_s,
            leg_lengths_m: self.lengths,
            leg_forces_n: self.forces,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0; 3],
            status: Status(Status::ENABLED),
        }
    }

    /// Applies the command for one step; brakes (enable false) hold the legs still.
    fn step(&mut self, command: &CommandFrame) {
        for i in 0..LEG_COUNT {
            if command.enable {
                self.forces[i] = command.leg_forces_n[i];
                let accel = (self.forces[i] - LOAD_N - LEG_DAMPING * self.rates[i]) / LEG_MASS_KG;
                self.rates[i] += accel * DT;
                self.lengths[i] += self.rates[i] * DT;
            } else {
                self.forces[i] = LOAD_N;
                self.rates[i] = 0.0;
            }
        }
        self.sequence += 1;
        self.time_s += DT;
    }
}

fn eq8(duration_s: f64) -> Trajectory {
    Trajectory::paper_eq8(
        geometry().home_pose(),
        [0.03, 0.025, 0.02],
        [0.5, 0.7, 0.9],
        duration_s,
        1.0,
    )
    .unwrap()
}

fn config() -> ControllerConfig {
    ControllerConfig {
        feedforward_n: [LOAD_N; LEG_COUNT],
        ..ControllerConfig::default()
    }
}

#[test]
fn full_procedure_runs_through_every_phase_and_tracks() {
    let with_rate = procedure(config());
    let without_rate = procedure(ControllerConfig {
        rate_feedforward: false,
        ..config()
    });
    std::println!("worst excitation tracking error: {with_rate} m with rate feed-forward, {without_rate} m without");
    // A ~10 Hz loop tracking ≤ 0.9 Hz motion with the D term on the measurement only lags by
    // about f/f_c ≈ 10 % of the legs' ~3 cm excursion; the kd·ṙ feed-forward removes most of
    // that lag.
    assert!(without_rate < 5e-3, "tracking error {without_rate} m");
    assert!(
        with_rate < 0.5 * without_rate,
        "rate feed-forward did not help: {with_rate} m"
    );
}

/// Runs the whole procedure on the leg plant; returns the worst leg-length tracking error
/// during the excitation.
fn procedure(config: ControllerConfig) -> f64 {
    let g = geometry();
    let trajectory = eq8(6.0);
    let mut controller = Controller::new(g, trajectory, config).unwrap();
    // Start 3 cm below and slightly tilted from home, as if resting on the brakes.
    let start = Pose::from_rpy(
        g.home_pose().position_m - Vector3::new(0.0, 0.0, 0.03),
        0.01,
        0.0,
        0.0,
    );
    let mut legs = Legs::at(&start);
    let mut phases = [Phase::Idle; 8];
    let mut transitions = 0;
    let mut entered = [0.0f64; 8];
    let mut worst_excite_error: f64 = 0.0;
    let mut worst_pose_error: f64 = 0.0;
    let mut first_command = None;
    let mut last = Phase::Idle;
    for _ in 0..20_000 {
        let out = controller.tick(&legs.frame());
        assert_eq!(out.fault, None, "fault at t = {}", legs.time_s);
        if first_command.is_none() {
            first_command = Some(out);
        }
        if out.phase != last {
            phases[transitions] = out.phase;
            entered[transitions] = legs.time_s;
            transitions += 1;
            last = out.phase;
        }
        assert_eq!(out.command.enable, out.phase.is_active());
        assert_eq!(out.command.sensor_sequence, legs.sequence);
        for f in out.command.leg_forces_n {
            assert!(f.abs() <= config.supervisor.max_command_force_n);
        }
        if out.phase == Phase::Excite {
            for i in 0..LEG_COUNT {
                let e = out.desired_leg_lengths_m[i] - out.measured_leg_lengths_m[i];
                worst_excite_error = worst_excite_error.max(e.abs());
            }
            // FK of the measured lengths gives a pose whose IK reproduces them.
            let measured = out.measured_pose.unwrap();
            let back = g.leg_lengths(&measured);
            for i in 0..LEG_COUNT {
                assert!((back[i] - legs.lengths[i]).abs() < 1e-9);
            }
            let (dp, dr) = measured.distance_to(&out.desired.pose);
            worst_pose_error = worst_pose_error.max(dp).max(dr);
        }
        legs.step(&out.command);
        if out.phase == Phase::Done {
            break;
        }
    }
    assert_eq!(
        &phases[..transitions],
        &[Phase::Settle, Phase::Excite, Phase::Park, Phase::Done]
    );
    // Settle: the ramp from 3 cm needs 1.875·0.03/0.2 = 0.28 s < 1 s, so 1 s ramp + 2 s hold.
    assert!(
        (entered[1] - entered[0] - 3.0).abs() < 1.5 * DT,
        "{entered:?}"
    );
    assert!((entered[2] - entered[1] - 6.0).abs() < 1.5 * DT);
    assert!((entered[3] - entered[2] - 2.5).abs() < 1.5 * DT);
    // Bumpless start: the ramp begins at the measured pose, so the first force is the
    // feed-forward alone (no proportional or derivative kick).
    let first = first_command.unwrap();
    assert_eq!(first.phase, Phase::Settle);
    for f in first.command.leg_forces_n {
        assert!((f - LOAD_N).abs() < 1e-3, "first force {f}");
    }
    assert!(worst_pose_error < 5e-3, "pose error {worst_pose_error}");
    // Parked back home.
    let home_lengths = g.leg_lengths(&g.home_pose());
    for i in 0..LEG_COUNT {
        assert!((legs.lengths[i] - home_lengths[i]).abs() < 1e-3);
    }
    // Done commands brakes from now on.
    let after = controller.tick(&legs.frame());
    assert_eq!(after.phase, Phase::Done);
    assert!(!after.command.enable);
    worst_excite_error
}

/// Runs `ticks` good ticks of the procedure; returns the controller and plant.
fn running(ticks: usize) -> (Controller, Legs) {
    let g = geometry();
    let mut controller = Controller::new(g, eq8(6.0), config()).unwrap();
    let mut legs = Legs::at(&g.home_pose());
    for _ in 0..ticks {
        let out = controller.tick(&legs.frame());
        assert_eq!(out.fault, None);
        legs.step(&out.command);
    }
    (controller, legs)
}

#[test]
fn feedforward_set_after_construction_acts_as_if_configured() {
    let g = geometry();
    let mut configured = Controller::new(g, eq8(6.0), config()).unwrap();
    let mut set_later = Controller::new(
        g,
        eq8(6.0),
        ControllerConfig {
            feedforward_n: [0.0; LEG_COUNT],
            ..config()
        },
    )
    .unwrap();
    let mut bad = [LOAD_N; LEG_COUNT];
    bad[2] = f64::NAN;
    assert!(matches!(
        set_later.set_feedforward(bad),
        Err(ControlError::NonFinite { index: 2, .. })
    ));
    assert_eq!(set_later.config().feedforward_n, [0.0; LEG_COUNT]);
    set_later.set_feedforward([LOAD_N; LEG_COUNT]).unwrap();
    let mut legs = Legs::at(&g.home_pose());
    for _ in 0..3000 {
        let frame = legs.frame();
        let a = configured.tick(&frame);
        let b = set_later.tick(&frame);
        assert_eq!(a.command, b.command);
        legs.step(&a.command);
    }
    assert_eq!(configured.phase(), set_later.phase());
}

fn assert_safe_stop(out: &TickOutput, expected: Fault) {
    assert_eq!(out.phase, Phase::Fault);
    assert_eq!(out.fault, Some(expected));
    assert!(!out.command.enable);
    assert_eq!(out.command.leg_forces_n, [0.0; LEG_COUNT]);
    assert_eq!(out.result(), Err(ControlError::Faulted(expected)));
}

#[test]
fn non_finite_sensor_mid_excitation_stops_safely() {
    let (mut controller, mut legs) = running(4000);
    assert_eq!(controller.phase(), Phase::Excite);
    let mut frame = legs.frame();
    frame.gyro_rad_s[1] = f64::NAN;
    let out = controller.tick(&frame);
    let expected = Fault::SensorNotFinite {
        channel: crate::supervisor::SensorChannel::Gyro,
        index: 1,
    };
    assert_safe_stop(&out, expected);
    // Latched: good frames keep the safe stop.
    for _ in 0..10 {
        legs.step(&out.command);
        assert_safe_stop(&controller.tick(&legs.frame()), expected);
    }
}

#[test]
fn a_repeated_frame_stops_safely() {
    let (mut controller, legs) = running(500);
    let out = controller.tick(&legs.frame());
    assert!(out.command.enable);
    let again = controller.tick(&legs.frame());
    assert_safe_stop(
        &again,
        Fault::SequenceNotAdvancing {
            previous: legs.sequence,
            received: legs.sequence,
        },
    );
}

#[test]
fn forward_kinematics_failure_is_a_fault() {
    let g = geometry();
    let fk = FkOptions {
        max_jump_m: 0.05,
        ..FkOptions::default()
    };
    let cfg = ControllerConfig { fk, ..config() };
    let mut controller = Controller::new(g, eq8(6.0), cfg).unwrap();
    // The platform rests 0.2 m below home, further than FK may jump from its warm start.
    let low = Pose::from_rpy(
        g.home_pose().position_m - Vector3::new(0.0, 0.0, 0.2),
        0.0,
        0.0,
        0.0,
    );
    let out = controller.tick(&Legs::at(&low).frame());
    let Some(Fault::ForwardKinematics(KinematicsError::FkWrongAssembly { jump_m, .. })) = out.fault
    else {
        panic!("FK jump not refused: {:?}", out.fault);
    };
    assert!((jump_m - 0.2).abs() < 1e-9);
    assert_safe_stop(&out, out.fault.unwrap());
    assert_eq!(out.measured_pose, None);

    // With the resting pose as the warm start it converges, and the settle ramp is stretched
    // so that the legs stay slow: 1.875·Δl/(0.5·0.4 m/s).
    let mut controller = Controller::new(g, eq8(6.0), cfg).unwrap();
    controller.set_pose_guess(low);
    let mut legs = Legs::at(&low);
    let first = controller.tick(&legs.frame());
    assert_eq!(first.fault, None);
    assert_eq!(first.phase, Phase::Settle);
    legs.step(&first.command);
    let mut fastest: f64 = 0.0;
    for _ in 0..4000 {
        let out = controller.tick(&legs.frame());
        assert_eq!(out.fault, None);
        for s in out.desired_leg_speeds_m_s {
            fastest = fastest.max(s.abs());
        }
        legs.step(&out.command);
    }
    assert!(
        fastest > 0.1 && fastest < 0.25,
        "settle ramp leg speed {fastest}"
    );
}

#[test]
fn commands_are_clamped_to_the_supervisor_limit() {
    let g = geometry();
    let mut cfg = config();
    cfg.pid.output_min_n = -1e7;
    cfg.pid.output_max_n = 1e7;
    cfg.pid.kp = 1e9;
    let mut controller = Controller::new(g, eq8(6.0), cfg).unwrap();
    let mut legs = Legs::at(&g.home_pose());
    let mut clamped = 0;
    for k in 0..200 {
        let mut frame = legs.frame();
        // After the first tick (which starts the settle ramp at the measured pose) leg 2 reads
        // 1 mm long: kp = 1e9 N/m asks for 1 MN.
        if k > 0 {
            frame.leg_lengths_m[2] += 1e-3;
        }
        let out = controller.tick(&frame);
        assert_eq!(out.fault, None);
        if out.clamped {
            clamped += 1;
            assert_eq!(
                out.command.leg_forces_n[2],
                -cfg.supervisor.max_command_force_n
            );
            assert!(out.pid[2].output < -5e5);
        }
        for f in out.command.leg_forces_n {
            assert!(f.abs() <= cfg.supervisor.max_command_force_n);
        }
        // The plant is not stepped: the frame advances only in sequence and time.
        legs.sequence += 1;
        legs.time_s += DT;
    }
    assert_eq!(clamped, 199);
}

#[test]
fn infeasible_trajectories_are_refused_before_motion() {
    let g = geometry();
    let components = [SineComponent {
        axis: Axis::Z,
        amplitude: 0.5,
        frequency_hz: 0.05,
        phase_rad: 0.0,
    }];
    let trajectory = Trajectory::new(g.home_pose(), &components, 20.0, 5.0, 5.0).unwrap();
    let err = Controller::new(g, trajectory, config()).unwrap_err();
    assert!(
        matches!(err, ControlError::StrokeViolation { .. }),
        "{err:?}"
    );
}

#[test]
fn park_request_mid_excitation_ramps_smoothly_home() {
    let (mut controller, mut legs) = running(5000);
    assert_eq!(controller.phase(), Phase::Excite);
    let before = controller.tick(&legs.frame());
    legs.step(&before.command);
    controller.request_park();
    let mut previous = before;
    let mut ticks = 0;
    loop {
        let out = controller.tick(&legs.frame());
        assert_eq!(out.fault, None);
        // The set-point stays continuous in position and velocity across the switch.
        for i in 0..LEG_COUNT {
            let step = out.desired_leg_lengths_m[i] - previous.desired_leg_lengths_m[i];
            assert!(step.abs() < 1e-3, "set-point jump {step}");
            let accel = out.desired_leg_speeds_m_s[i] - previous.desired_leg_speeds_m_s[i];
            assert!(accel.abs() < 5e-3, "set-point speed jump {accel}");
        }
        legs.step(&out.command);
        previous = out;
        ticks += 1;
        if out.phase == Phase::Done || ticks > 5000 {
            break;
        }
    }
    assert_eq!(previous.phase, Phase::Done);
    // A brake of at most the longest brake duration, the 2 s ramp home, the 0.5 s hold.
    let took_s = ticks as f64 * DT;
    let longest_s = BRAKE_DURATIONS_S[BRAKE_DURATIONS_S.len() - 1];
    assert!(
        took_s > 2.5 + BRAKE_DURATIONS_S[0] - 2.0 * DT && took_s < 2.5 + longest_s + 2.0 * DT,
        "park took {ticks} ticks"
    );
}

/// A multi-sine that drives some leg at `fraction` of the feasibility speed limit: one
/// harmonic of 0.3125 Hz per axis (the family `stewart plan` designs), amplitudes scaled from
/// the feasibility check's own peak speed.
fn fast_multisine(fraction: f64) -> Trajectory {
    let g = geometry();
    let axes = [
        Axis::X,
        Axis::Y,
        Axis::Z,
        Axis::Roll,
        Axis::Pitch,
        Axis::Yaw,
    ];
    let build = |scale: f64| {
        let components = core::array::from_fn::<_, 6, _>(|k| SineComponent {
            axis: axes[k],
            amplitude: scale * if k < 3 { 0.01 } else { 0.02 },
            frequency_hz: 0.3125 * (k + 1) as f64,
            phase_rad: 0.0,
        });
        Trajectory::new(g.home_pose(), &components, 12.8, 2.0, 2.0).unwrap()
    };
    let limits = FeasibilityLimits {
        max_leg_speed_m_s: 100.0,
        ..FeasibilityLimits::default()
    };
    let unit = build(1.0).check_feasibility(&g, &limits).unwrap();
    let peak = unit.max_speed_m_s.iter().copied().fold(0.0, f64::max);
    build(fraction * FeasibilityLimits::<f64>::default().max_leg_speed_m_s / peak)
}

#[test]
fn a_park_from_any_moment_of_a_fast_excitation_stays_under_the_leg_speed_limit() {
    // A single quintic from the set-point's state straight home carries the start's
    // acceleration through the whole ramp: cut short at full speed, a fast excitation's park
    // along it overshoots the leg speed limit and faults.
    let g = geometry();
    let limit_m_s = FeasibilityLimits::<f64>::default().max_leg_speed_m_s;
    let mut controller = Controller::new(g, fast_multisine(0.98), config()).unwrap();
    let mut legs = Legs::at(&g.home_pose());
    let mut parks = 0;
    let mut worst_m_s: f64 = 0.0;
    for tick in 0..16_000 {
        let out = controller.tick(&legs.frame());
        assert_eq!(out.fault, None, "excitation fault at t = {}", legs.time_s);
        legs.step(&out.command);
        // Every 0.137 s of the excitation, park a copy from there.
        if out.phase != Phase::Excite || tick % 137 != 0 {
            continue;
        }
        let (mut parked, mut parked_legs) = (controller, legs.clone());
        parked.request_park();
        let mut previous = out;
        let mut done = false;
        for _ in 0..8_000 {
            let step = parked.tick(&parked_legs.frame());
            assert_eq!(step.fault, None, "park from t = {} faulted", legs.time_s);
            for i in 0..LEG_COUNT {
                worst_m_s = worst_m_s.max(step.desired_leg_speeds_m_s[i].abs());
                let jump = step.desired_leg_speeds_m_s[i] - previous.desired_leg_speeds_m_s[i];
                assert!(jump.abs() < 0.02, "set-point speed jumps by {jump} m/s");
            }
            parked_legs.step(&step.command);
            previous = step;
            if step.phase == Phase::Done {
                done = true;
                break;
            }
        }
        assert!(done, "the park from t = {} did not finish", legs.time_s);
        parks += 1;
    }
    assert!(parks > 50, "{parks} parks");
    assert!(
        worst_m_s <= limit_m_s,
        "a park's set-point reached {worst_m_s} m/s (limit {limit_m_s})"
    );
}

#[test]
fn clear_fault_restarts_from_idle() {
    let (mut controller, mut legs) = running(100);
    let mut frame = legs.frame();
    frame.status = Status(Status::ESTOP);
    assert_safe_stop(&controller.tick(&frame), Fault::EmergencyStop);
    controller.clear_fault();
    assert_eq!(controller.phase(), Phase::Idle);
    legs.step(&CommandFrame::safe_stop(0, 0));
    let out = controller.tick(&legs.frame());
    assert_eq!(out.phase, Phase::Settle);
    assert!(out.command.enable);
}

#[test]
fn gravity_feedforward_balances_the_weight() {
    let g = geometry();
    let pose = Pose::from_rpy(
        g.home_pose().position_m + Vector3::new(0.02, 0.0, 0.0),
        0.05,
        -0.03,
        0.1,
    );
    let com = Vector3::new(0.3, -0.2, 0.8);
    let mass = 1500.0;
    let f = gravity_feedforward(&g, &pose, mass, &com).unwrap();
    let w = g.wrench_in_base(&pose, &Vector6::from(f));
    let weight = Vector3::new(0.0, 0.0, -mass * GRAVITY_M_S2);
    // Legs plus gravity: zero net force and zero net torque about the P origin.
    assert!((w.force_n + weight).norm() < 1e-8);
    let gravity_torque = (pose.rotation * com).cross(&weight);
    assert!((w.torque_nm + gravity_torque).norm() < 1e-8);
    // Centred load at home: equal legs, each carrying a sixth of the weight along its axis.
    let centred = gravity_feedforward(&g, &g.home_pose(), mass, &Vector3::zeros()).unwrap();
    let uz = g.legs(&g.home_pose()).units[0].z;
    for fi in centred {
        assert!((fi - mass * GRAVITY_M_S2 / 6.0 / uz).abs() < 1e-6);
    }
    assert!(gravity_feedforward(&g, &pose, f64::NAN, &com).is_err());
}

#[test]
fn invalid_configs_are_refused() {
    let g = geometry();
    let mut cfg = config();
    cfg.park_s = 0.0;
    assert!(Controller::new(g, eq8(6.0), cfg).is_err());
    let mut cfg = config();
    cfg.feedforward_n[3] = f64::INFINITY;
    assert_eq!(
        Controller::new(g, eq8(6.0), cfg).unwrap_err(),
        ControlError::NonFinite {
            what: "controller.feedforward_n",
            index: 3
        }
    );
}

/// `set_load`: each tick's feed-forward is the static load, the rate term and the load's
/// inverse dynamics at the set-point less its weight's share at the warm-start pose (so at
/// rest there, nothing changes); a load that is not a body is refused and changes nothing.
#[test]
fn the_loads_feedforward_adds_its_dynamics_less_its_weight_at_the_hold_pose() {
    use crate::inverse_dynamics::load_leg_forces;
    let g = geometry();
    let mut controller = Controller::new(g, eq8(6.0), config()).unwrap();
    let before = controller;
    let mut not_a_body = InertialParameters::point_mass(1900.0, Vector3::new(0.0, 0.0, 0.4));
    not_a_body.mass_kg = 0.0;
    assert!(controller.set_load(not_a_body).is_err());
    not_a_body.mass_kg = f64::NAN;
    assert!(controller.set_load(not_a_body).is_err());
    assert_eq!(controller, before);

    let load = InertialParameters::from_com(
        1900.0,
        Vector3::new(0.1, -0.05, 0.4),
        Matrix3::from_diagonal(&Vector3::new(800.0, 2500.0, 2900.0)),
    );
    let home = g.home_pose();
    controller.set_pose_guess(home);
    controller.set_load(load).unwrap();
    let at_hold = load_leg_forces(&g, &load, &rest_at(&home)).unwrap();
    let mut legs = Legs::at(&home);
    let (mut at_rest, mut moving) = (0, 0);
    for _ in 0..5000 {
        let out = controller.tick(&legs.frame());
        if out.phase.is_active() {
            let dynamic = load_leg_forces(&g, &load, &out.desired).unwrap();
            for leg in 0..LEG_COUNT {
                let rate = controller.config().pid.kd * out.desired_leg_speeds_m_s[leg];
                let expected = LOAD_N + rate + dynamic[leg] - at_hold[leg];
                assert!((out.pid[leg].feedforward - expected).abs() < 1e-6);
            }
            if out.desired.twist().norm() == 0.0 && out.desired.pose == home {
                at_rest += 1;
                for leg in 0..LEG_COUNT {
                    assert!((out.pid[leg].feedforward - LOAD_N).abs() < 1e-6);
                }
            }
            if (dynamic[0] - at_hold[0]).abs() > 100.0 {
                moving += 1;
            }
        }
        legs.step(&out.command);
    }
    assert!(
        at_rest > 100 && moving > 100,
        "at rest {at_rest}, moving {moving}"
    );
}

/// A load whose inverse dynamics along the excitation exceed the command limit is refused
/// before anything moves, naming the leg, the time and the force; the controller is unchanged.
#[test]
fn a_load_the_legs_cannot_drive_along_the_excitation_is_refused() {
    let g = geometry();
    let mut controller = Controller::new(g, eq8(6.0), config()).unwrap();
    controller.set_pose_guess(g.home_pose());
    let before = controller;
    let heavy = InertialParameters::from_com(
        1900.0,
        Vector3::new(0.0, 0.0, 0.4),
        Matrix3::from_diagonal(&Vector3::new(2.0e5, 2.0e5, 2.0e5)),
    );
    let Err(ControlError::ForceViolation {
        force_n, limit_n, ..
    }) = controller.check_load_forces(&heavy)
    else {
        panic!("not refused");
    };
    assert!(force_n.abs() > limit_n);
    assert_eq!(limit_n, controller.config().supervisor.max_command_force_n);
    assert_eq!(controller, before);
    let car = InertialParameters::from_com(
        1900.0,
        Vector3::new(0.0, 0.0, 0.4),
        Matrix3::from_diagonal(&Vector3::new(800.0, 2500.0, 2900.0)),
    );
    controller.check_load_forces(&car).unwrap();
}
