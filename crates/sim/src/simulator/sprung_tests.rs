//! The simulator with a suspended payload: rest, the plate's acceleration with the units'
//! forces, the truth, and the disabled suspension leaving the simulator as it is.

use super::leg_tests::{command, wave};
use super::tests::{car, geometry};
use super::*;
use crate::imperfections::SuspensionConfig;
use crate::sensors::{NoisePreset, SensorConfig};
use nalgebra::Vector6;
use rig_description::config::LegsConfig;
use stewart_types::STANDARD_GRAVITY_M_S2;

const G: Vector3<f64> = stewart_types::GRAVITY_B_M_S2;

fn suspension() -> SuspensionConfig {
    SuspensionConfig {
        enabled: true,
        ..SuspensionConfig::default()
    }
}

fn config(suspension: SuspensionConfig, legs: LegsConfig) -> SimConfig {
    SimConfig {
        sensors: SensorConfig::preset(NoisePreset::None),
        suspension,
        legs,
        ..Default::default()
    }
}

fn sim(cfg: &SimConfig) -> Simulator {
    Simulator::new(geometry(), BodyProperties::default(), Some(car()), cfg, 0).unwrap()
}

/// Braked at home, the sprung body stays where it rests (preloads right) to 10⁻⁹ m and
/// 10⁻⁹ rad, the plate too, the accelerometer reads 1 g up and the legs weigh the whole
/// payload: the hold includes the sprung body's weight.
#[test]
fn at_rest_at_home_the_body_stays_put_and_the_legs_carry_it() {
    for legs in [LegsConfig::default(), crate::legs::tests::config()] {
        let mut s = sim(&config(suspension(), legs));
        let home = s.geometry().home_pose();
        for k in 0..1000 {
            s.write(&CommandFrame::safe_stop(k, k)).unwrap();
        }
        let body = s.true_sprung_pose().unwrap();
        assert!((body.position_m - home.position_m).norm() < 1e-9);
        assert!((body.rotation.matrix() - home.rotation.matrix()).amax() < 1e-9);
        assert!((s.true_pose().position_m - home.position_m).norm() < 1e-9);
        let f = s.read().unwrap();
        assert!((Vector3::from(f.accel_m_s2) + G).norm() < 1e-9);
        if legs == LegsConfig::default() {
            let w = s
                .geometry()
                .wrench_in_platform(&s.true_pose(), &Vector6::from(f.leg_forces_n));
            let mass = w.force_n.z / STANDARD_GRAVITY_M_S2;
            assert!((mass - 1700.0).abs() < 1e-6, "weighed {mass} kg");
            // The moment of the whole payload's weight about the P origin: the sprung body's
            // weight acts at its centre of mass.
            let c = s.true_parameters().first_moment_kg_m;
            let want = c.cross(&(-G));
            assert!((w.torque_nm - want).norm() < 1e-6, "{:?}", w.torque_nm);
        }
    }
}

/// Rapier's plate, pushed by the legs and the units, moves with exactly the acceleration the
/// accelerometer model reports, with massless legs and with legs of mass and friction, while
/// the body swings on its units (measured 5·10⁻¹³ relative, 2 cm swing).
#[test]
fn rapier_moves_the_plate_with_the_acceleration_the_accelerometer_reports() {
    for legs in [LegsConfig::default(), crate::legs::tests::config()] {
        let mut s = sim(&SimConfig {
            substeps: 1,
            ..config(suspension(), legs)
        });
        let hold = s.true_leg_forces_n();
        let p = *s.model.params();
        let h = s.substep_s;
        let (mut worst_lin, mut worst_ang, mut swing) = (0.0f64, 0.0f64, 0.0f64);
        for k in 0..600u64 {
            let cmd = command(k, wave(&hold, s.time_s()), true);
            s.actuators
                .command(&cmd.leg_forces_n, true, &s.now.lengths_m, &s.now.forces_n);
            let pose = s.world.pose();
            let legs = s.legs(&pose);
            let e = s.evaluate(&pose, &legs);
            assert!(e.sprung.is_some());
            let (v0, w0) = s.world.raw_velocities();
            s.substep();
            let (v1, w1) = s.world.raw_velocities();
            let r = pose.rotation;
            let c = r * (p.first_moment_kg_m / p.mass_kg);
            let omega = r * e.omega_p;
            let w_dot = r * e.acceleration.angular_rad_s2;
            let a_origin = r * e.acceleration.specific_force_m_s2 + G;
            let a_com = a_origin + w_dot.cross(&c) + omega.cross(&omega.cross(&c));
            // Relative, with a floor: the first substep starts from rest.
            worst_lin = worst_lin.max(((v1 - v0) / h - a_com).norm() / a_com.norm().max(0.1));
            worst_ang = worst_ang.max(((w1 - w0) / h - w_dot).norm() / w_dot.norm().max(0.1));
            s.sample += 1;
            s.refresh().unwrap();
            let body = s.true_sprung_pose().unwrap();
            swing = swing.max((body.position_m - s.true_pose().position_m).norm());
        }
        println!(
            "rapier vs reported: linear {worst_lin:.2e}, angular {worst_ang:.2e}, body off the \
             plate by up to {swing:.3} m"
        );
        assert!(swing > 1e-3, "the body does not move on its units");
        assert!(worst_lin < 1e-9 && worst_ang < 1e-9);
    }
}

/// The truth is the whole payload at rest; rapier's plate carries the fixture and the
/// unsprung part; the tare world has no sprung body, and putting the payload back puts it on.
#[test]
fn the_truth_is_the_whole_payload_and_the_plate_carries_the_unsprung_part() {
    let mut s = sim(&config(suspension(), LegsConfig::default()));
    assert_eq!(s.true_payload(), Some(car()));
    let truth = InertialParameters::from_body(&BodyProperties::default())
        + InertialParameters::from_body(&car());
    for (a, b) in s.true_parameters().theta().iter().zip(truth.theta()) {
        assert!((a - b).abs() < 1e-9);
    }
    let plate = s.rapier_body();
    assert!((plate.mass_kg - (200.0 + 0.15 * 1500.0)).abs() < 1e-9);
    s.set_payload(None).unwrap();
    assert!(s.true_sprung_pose().is_none());
    assert!((s.rapier_body().mass_kg - 200.0).abs() < 1e-9);
    s.set_payload(Some(car())).unwrap();
    assert!(s.true_sprung_pose().is_some());
    for k in 0..200 {
        s.write(&CommandFrame::safe_stop(k, k)).unwrap();
    }
    let frame = s.read().unwrap();
    let w = s
        .geometry()
        .wrench_in_platform(&s.true_pose(), &Vector6::from(frame.leg_forces_n));
    let mass = w.force_n.norm() / STANDARD_GRAVITY_M_S2;
    assert!((mass - 1700.0).abs() < 1e-3, "weighed {mass} kg");
}

/// Every clean channel of 0.5 s of excitation, as bits.
fn run_bits(cfg: &SimConfig) -> Vec<u64> {
    let mut s = sim(cfg);
    let hold = s.true_leg_forces_n();
    let mut bits = Vec::new();
    for k in 0..500u64 {
        s.write(&command(k, wave(&hold, s.time_s()), true)).unwrap();
        let f = s.clean_frame();
        let pose = s.true_pose();
        bits.extend(
            f.leg_lengths_m
                .iter()
                .chain(&f.leg_forces_n)
                .chain(&f.gyro_rad_s)
                .chain(&f.accel_m_s2)
                .chain(pose.position_m.iter())
                .map(|v| v.to_bits()),
        );
    }
    bits
}

/// A disabled `[world.suspension]` is not read: whatever its other values, the run is the
/// rigid payload's bit for bit (with and without legs), and differs once enabled.
#[test]
fn a_disabled_suspension_leaves_the_simulator_bit_identical() {
    let odd = SuspensionConfig {
        enabled: false,
        sprung_share: 0.5,
        bounce_hz: 3.0,
        damping_ratio: 0.9,
        track_m: 1.0,
        wheelbase_m: 2.0,
    };
    for legs in [LegsConfig::default(), crate::legs::tests::config()] {
        let rigid = run_bits(&config(SuspensionConfig::default(), legs));
        assert!(rigid == run_bits(&config(odd, legs)));
        assert!(rigid != run_bits(&config(suspension(), legs)));
    }
}
