//! Every fault path trips, commands the safe stop and names its cause.

use super::*;
use kinematics::KinematicsError;

const STROKE: StrokeLimits = StrokeLimits {
    min_length_m: 1.0,
    max_length_m: 1.5,
};
const DT: f64 = 1e-3;

fn frame(k: u64) -> SensorFrame {
    SensorFrame {
        sequence: 100 + k,
        time_s: 10.0 + k as f64 * DT,
        leg_lengths_m: [1.25; LEG_COUNT],
        leg_forces_n: [2000.0; LEG_COUNT],
        gyro_rad_s: [0.01, -0.02, 0.03],
        accel_m_s2: [0.0, 0.0, 9.81],
        status: Status(Status::ENABLED),
    }
}

/// A supervisor in Excite that has accepted frames 0..=9.
fn running() -> Supervisor {
    let mut s = Supervisor::new(SupervisorConfig::default(), STROKE).unwrap();
    assert_eq!(s.set_phase(Phase::Excite), Phase::Excite);
    for k in 0..10 {
        s.check_sensors(&frame(k)).unwrap();
    }
    s
}

/// Feeds `bad` (after a good history) and checks the whole fault contract.
fn assert_trips(bad: SensorFrame, expected: Fault) {
    let mut s = running();
    assert_eq!(s.check_sensors(&bad), Err(expected));
    assert_fault_contract(&mut s, expected);
}

fn assert_fault_contract(s: &mut Supervisor, expected: Fault) {
    assert_eq!(s.phase(), Phase::Fault);
    assert_eq!(s.fault(), Some(expected));
    let gated = s.gate(&[1000.0; LEG_COUNT], 7);
    assert!(!gated.command.enable);
    assert_eq!(gated.command.leg_forces_n, [0.0; LEG_COUNT]);
    assert_eq!(gated.command.sensor_sequence, 7);
    // Latched: good data, phase requests and later faults change nothing.
    assert_eq!(s.check_sensors(&frame(50)), Err(expected));
    assert_eq!(s.set_phase(Phase::Excite), Phase::Fault);
    s.trip(Fault::EmergencyStop);
    assert_eq!(s.fault(), Some(expected));
    assert!(!s.gate(&[0.0; LEG_COUNT], 8).command.enable);
}

#[test]
fn emergency_stop_trips() {
    let mut bad = frame(10);
    bad.status = Status(Status::ENABLED | Status::ESTOP);
    assert_trips(bad, Fault::EmergencyStop);
}

#[test]
fn backend_fault_and_invalid_sensor_bits_trip() {
    for bits in [Status::FAULT, Status::SENSOR_INVALID] {
        let mut bad = frame(10);
        bad.status = Status(Status::ENABLED | bits);
        assert_trips(bad, Fault::BackendStatus { status: bad.status });
    }
}

#[test]
fn each_non_finite_channel_trips_and_is_named() {
    type Spoil = fn(&mut SensorFrame, usize);
    let cases: [(SensorChannel, usize, Spoil); 5] = [
        (SensorChannel::Time, 0, |f, _| f.time_s = f64::NAN),
        (SensorChannel::LegLength, 3, |f, i| {
            f.leg_lengths_m[i] = f64::NAN
        }),
        (SensorChannel::LegForce, 5, |f, i| {
            f.leg_forces_n[i] = f64::INFINITY
        }),
        (SensorChannel::Gyro, 2, |f, i| f.gyro_rad_s[i] = f64::NAN),
        (SensorChannel::Accel, 1, |f, i| {
            f.accel_m_s2[i] = f64::NEG_INFINITY
        }),
    ];
    for (channel, index, spoil) in cases {
        let mut bad = frame(10);
        spoil(&mut bad, index);
        assert_trips(bad, Fault::SensorNotFinite { channel, index });
    }
}

#[test]
fn repeated_sequence_trips_as_stale() {
    let mut bad = frame(10);
    bad.sequence = frame(9).sequence;
    assert_trips(
        bad,
        Fault::SequenceNotAdvancing {
            previous: 109,
            received: 109,
        },
    );
}

#[test]
fn frozen_clock_trips_as_stale() {
    let mut bad = frame(10);
    bad.time_s = frame(9).time_s;
    assert_trips(
        bad,
        Fault::TimeNotAdvancing {
            previous_s: bad.time_s,
            received_s: bad.time_s,
        },
    );
}

#[test]
fn a_gap_longer_than_the_timeout_trips() {
    let mut bad = frame(10);
    bad.time_s = frame(9).time_s + 0.05;
    let Err(Fault::SampleGap { gap_s, limit_s }) = running().check_sensors(&bad) else {
        panic!("gap not detected");
    };
    assert!((gap_s - 0.05).abs() < 1e-9);
    assert_eq!(limit_s, SupervisorConfig::default().max_sample_gap_s);
    // Up to the limit is fine (lost samples are tolerated).
    let mut ok = frame(10);
    ok.time_s = frame(9).time_s + 0.019;
    assert!(running().check_sensors(&ok).is_ok());
}

#[test]
fn old_data_on_the_host_clock_trips() {
    let mut s = running();
    assert!(s.check_age(0.005).is_ok());
    let expected = Fault::SensorTooOld {
        age_s: 0.5,
        limit_s: 0.02,
    };
    assert_eq!(s.check_age(0.5), Err(expected));
    assert_fault_contract(&mut s, expected);
    assert!(running().check_age(f64::NAN).is_err());
}

#[test]
fn leg_outside_the_stroke_trips_naming_the_leg() {
    let mut short = frame(10);
    short.leg_lengths_m[4] = 0.998;
    assert_trips(
        short,
        Fault::LegTooShort {
            leg: 4,
            length_m: 0.998,
            limit_m: 0.999,
        },
    );
    let mut long = frame(10);
    long.leg_lengths_m[1] = 1.502;
    assert_trips(
        long,
        Fault::LegTooLong {
            leg: 1,
            length_m: 1.502,
            limit_m: 1.501,
        },
    );
    // Within the margin is not a fault (first frame: no speed estimate yet).
    let mut edge = frame(10);
    edge.leg_lengths_m[1] = 1.5005;
    let mut fresh = Supervisor::new(SupervisorConfig::default(), STROKE).unwrap();
    assert!(fresh.check_sensors(&edge).is_ok());
}

#[test]
fn measured_force_over_the_limit_trips() {
    let mut bad = frame(10);
    bad.leg_forces_n[2] = -31_000.0;
    assert_trips(
        bad,
        Fault::MeasuredForce {
            leg: 2,
            force_n: -31_000.0,
            limit_n: 30_000.0,
        },
    );
}

/// Leg 3 moves at `speed` m/s from frame 0 on; returns the first fault, if any, in 0.2 s.
fn ramp_leg(speed: f64) -> (Supervisor, Option<Fault>) {
    let mut s = Supervisor::new(SupervisorConfig::default(), STROKE).unwrap();
    s.set_phase(Phase::Excite);
    for k in 0..200 {
        let mut f = frame(k);
        f.leg_lengths_m[3] += speed * k as f64 * DT;
        if let Err(fault) = s.check_sensors(&f) {
            return (s, Some(fault));
        }
    }
    (s, None)
}

#[test]
fn leg_speed_is_estimated_and_limited() {
    let (s, fault) = ramp_leg(0.4);
    assert_eq!(fault, None);
    // The filter converges to the true speed (5 ms time constant, 200 ms run).
    assert!((s.leg_speeds_m_s()[3] - 0.4).abs() < 1e-6);
    assert!(s.leg_speeds_m_s()[0].abs() < 1e-12);

    let (mut s, fault) = ramp_leg(-0.8);
    let Some(Fault::LegSpeed {
        leg,
        speed_m_s,
        limit_m_s,
    }) = fault
    else {
        panic!("speed not detected: {fault:?}");
    };
    assert_eq!(leg, 3);
    assert!(speed_m_s < -0.5 && speed_m_s > -0.8);
    assert_eq!(limit_m_s, 0.5);
    assert_fault_contract(&mut s, fault.unwrap());
}

#[test]
fn non_finite_command_trips() {
    let mut s = running();
    let mut forces = [100.0; LEG_COUNT];
    forces[5] = f64::NAN;
    let gated = s.gate(&forces, 9);
    assert!(!gated.command.enable);
    assert_eq!(gated.command.leg_forces_n, [0.0; LEG_COUNT]);
    assert_fault_contract(&mut s, Fault::CommandNotFinite { leg: 5 });
}

#[test]
fn external_trip_latches_its_cause() {
    let mut s = running();
    let cause = Fault::ForwardKinematics(KinematicsError::FkDidNotConverge {
        iterations: 30,
        residual_m: 1e-3,
    });
    s.trip(cause);
    assert_fault_contract(&mut s, cause);
}

#[test]
fn commands_are_clamped_to_the_force_limit() {
    let mut s = running();
    let forces = [1e9, -1e9, 24_999.0, -25_001.0, 0.0, f64::MAX];
    let gated = s.gate(&forces, 3);
    assert!(gated.command.enable);
    assert!(gated.clamped);
    assert_eq!(
        gated.command.leg_forces_n,
        [25_000.0, -25_000.0, 24_999.0, -25_000.0, 0.0, 25_000.0]
    );
    let within = s.gate(&[100.0; LEG_COUNT], 4);
    assert!(!within.clamped);
    assert_eq!(within.command.leg_forces_n, [100.0; LEG_COUNT]);
    assert_eq!(within.command.sequence, gated.command.sequence + 1);
    assert_eq!(s.phase(), Phase::Excite);
}

#[test]
fn idle_and_done_command_the_safe_stop() {
    let mut s = Supervisor::new(SupervisorConfig::default(), STROKE).unwrap();
    assert!(!s.gate(&[100.0; LEG_COUNT], 0).command.enable);
    s.set_phase(Phase::Done);
    assert!(!s.gate(&[100.0; LEG_COUNT], 0).command.enable);
    assert_eq!(s.fault(), None);
}

#[test]
fn clear_fault_returns_to_idle_with_a_fresh_watchdog() {
    let mut s = running();
    s.trip(Fault::EmergencyStop);
    s.clear_fault();
    assert_eq!(s.phase(), Phase::Idle);
    assert_eq!(s.fault(), None);
    // An earlier sequence is accepted after the reset: the history was cleared.
    assert!(s.check_sensors(&frame(0)).is_ok());
}

#[test]
fn fault_messages_name_limit_leg_and_value() {
    let text = std::format!(
        "{}",
        Fault::LegSpeed {
            leg: 2,
            speed_m_s: 0.71,
            limit_m_s: 0.5
        }
    );
    assert!(text.contains("leg 2") && text.contains("0.71") && text.contains("0.5"));
}

#[test]
fn invalid_configs_are_refused() {
    let c = SupervisorConfig {
        max_leg_speed_m_s: 0.0,
        ..SupervisorConfig::default()
    };
    assert!(Supervisor::new(c, STROKE).is_err());
    let c = SupervisorConfig {
        leg_length_margin_m: f64::NAN,
        ..SupervisorConfig::default()
    };
    assert!(Supervisor::new(c, STROKE).is_err());
    let reversed = StrokeLimits {
        min_length_m: 2.0,
        max_length_m: 1.0,
    };
    assert!(Supervisor::new(SupervisorConfig::default(), reversed).is_err());
}
