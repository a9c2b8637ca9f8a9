//! The simulator with legs of mass and inertia and joint friction, against hand formulas,
//! conservation of energy and work, and finite differences of the legs' motion.

use super::tests::{car, geometry};
use super::*;
use crate::legs::Legs;
use crate::sensors::{NoisePreset, SensorConfig};
use nalgebra::{Rotation3, Vector6};
use rig_description::config::{LegsConfig, LoadCellEnd};

const G: Vector3<f64> = stewart_types::GRAVITY_B_M_S2;

/// The default rig's legs (configs/default.toml) without joint friction.
fn legs_config() -> LegsConfig {
    LegsConfig {
        joint_coulomb_torque_nm: 0.0,
        joint_viscous_nm_s_per_rad: 0.0,
        ..rig_description::load::load(None)
            .expect("the embedded default loads")
            .config
            .legs
    }
}

fn config(legs: LegsConfig) -> SimConfig {
    SimConfig {
        sensors: SensorConfig::preset(NoisePreset::None),
        substeps: 1,
        legs,
        ..Default::default()
    }
}

fn leg_sim(legs: LegsConfig) -> Simulator {
    Simulator::new(
        geometry(),
        BodyProperties::default(),
        Some(car()),
        &config(legs),
        0,
    )
    .unwrap()
}

fn tilted() -> Pose {
    let home = geometry().home_pose();
    Pose::new(
        home.position_m + Vector3::new(0.06, -0.04, 0.05),
        Rotation3::from_euler_angles(0.08, -0.06, 0.1),
    )
}

/// An enabling (or braking) command with the sample's own sequence numbers.
pub(super) fn command(seq: u64, forces: [f64; 6], enable: bool) -> CommandFrame {
    CommandFrame {
        sequence: seq,
        sensor_sequence: seq,
        leg_forces_n: forces,
        enable,
    }
}

/// `hold` plus a 900 N sine on each leg, each at its own frequency and phase.
pub(super) fn wave(hold: &[f64; 6], t: f64) -> [f64; 6] {
    core::array::from_fn(|i| {
        let k = i as f64;
        hold[i] + 900.0 * (2.0 * core::f64::consts::PI * (1.1 + 0.41 * k) * t + k).sin()
    })
}

#[test]
fn massless_legs_through_the_coupled_path_reproduce_the_plain_simulator() {
    let mut plain = leg_sim(LegsConfig::default());
    let mut coupled = leg_sim(LegsConfig::default());
    coupled.legs_model = Some(Legs::forced(LegsConfig::default()));
    let hold = plain.true_leg_forces_n();
    let (mut worst_f, mut worst_a) = (0.0f64, 0.0f64);
    for k in 0..400u64 {
        let cmd = command(k, wave(&hold, plain.time_s()), k > 0);
        plain.write(&cmd).unwrap();
        coupled.write(&cmd).unwrap();
        let (a, b) = (plain.clean_frame(), coupled.clean_frame());
        for ((x, y), h) in a.leg_forces_n.iter().zip(b.leg_forces_n).zip(hold) {
            worst_f = worst_f.max((x - y).abs() / h.abs());
        }
        let acc = (Vector3::from(a.accel_m_s2) - Vector3::from(b.accel_m_s2)).norm();
        worst_a = worst_a.max(acc);
    }
    assert!(
        plain.true_velocity().angular_rad_s.norm() > 1e-3,
        "not moving"
    );
    assert!(worst_f < 1e-9 && worst_a < 1e-9, "{worst_f:e} {worst_a:e}");
}

/// Braked at rest at a tilted pose, each leg's joint force across the leg is the legs'
/// weight moment about the base joint divided by the length, along gravity's transverse part
/// (a lever on its base pivot, held at its tip).
#[test]
fn braked_at_a_tilted_pose_the_joints_carry_the_legs_weight_moment() {
    let c = legs_config();
    let mut s = leg_sim(c);
    let pose = tilted();
    s.set_state(&pose, &Vector3::zeros(), &Vector3::zeros())
        .unwrap();
    for k in 0..300 {
        s.write(&CommandFrame::safe_stop(k, k)).unwrap();
    }
    assert!(s.true_velocity().linear_m_s.norm() < 1e-9);
    assert!((s.true_pose().position_m - pose.position_m).norm() < 1e-9);
    let now = s.true_pose();
    let forces = s.true_joint_forces_n();
    let base = s.geometry().base_joints_m();
    let mut plate_wrench = Vector6::zeros();
    for i in 0..6 {
        let joint = now.position_m + now.rotation * s.geometry().plate_joints_m()[i];
        let l = (joint - base[i]).norm();
        let u = (joint - base[i]) / l;
        let cylinder = base[i] + c.cylinder_com_from_base_m * u;
        let rod = joint - c.rod_com_from_plate_m * u;
        let moment = c.cylinder_mass_kg * (cylinder - base[i]).cross(&G)
            + c.rod_mass_kg * (rod - base[i]).cross(&G);
        let g_across = (G - u * u.dot(&G)).normalize();
        let want = moment.norm() / l * g_across;
        let f = forces[i];
        let across = f - u * u.dot(&f);
        assert!(
            (across - want).norm() < 1e-6 * want.norm(),
            "leg {i}: {across:?} vs {want:?}"
        );
        assert!(want.norm() > 20.0, "leg {i}: {want:?}");
        // The cell at the plate end carries the same force across it.
        let (e1, e2) = crate::cell_loads::transverse_basis(&u);
        let cell = s.true_cell_transverse_n()[i];
        assert!((cell[0] - across.dot(&e1)).abs() < 1e-9 * want.norm());
        assert!((cell[1] - across.dot(&e2)).abs() < 1e-9 * want.norm());
        let arm = joint - now.position_m;
        let t = arm.cross(&f);
        plate_wrench += Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z);
    }
    // The joint forces hold the plate and payload (not the legs) against gravity.
    let p = s.true_parameters();
    let weight = p.mass_kg * G;
    let com = now.rotation * (p.first_moment_kg_m / p.mass_kg);
    let f = plate_wrench.fixed_rows::<3>(0) + weight;
    let t = plate_wrench.fixed_rows::<3>(3) + com.cross(&weight);
    assert!(f.norm() < 1e-6 * weight.norm() && t.norm() < 1e-6 * weight.norm());
    // At rest the accelerometer reads −g.
    let accel = Vector3::from(s.read().unwrap().accel_m_s2);
    assert!((accel + now.rotation.inverse() * G).norm() < 1e-9);
}

/// Plate + payload and both leg bodies' kinetic energy, from the bodies' velocities, and the
/// potential energy of gravity, J.
fn energy(s: &Simulator, c: &LegsConfig) -> f64 {
    let pose = s.true_pose();
    let v = s.true_velocity();
    let (w, v_o) = (v.angular_rad_s, v.linear_m_s);
    let p = s.true_parameters();
    let r = pose.rotation;
    let com = r * (p.first_moment_kg_m / p.mass_kg);
    let j_c = r.matrix() * s.inertia_com * r.matrix().transpose();
    let v_c = v_o + w.cross(&com);
    let mut e = 0.5 * p.mass_kg * v_c.norm_squared() + 0.5 * w.dot(&(j_c * w))
        - p.mass_kg * G.dot(&(pose.position_m + com));
    let base = s.geometry().base_joints_m();
    for (b, p_i) in base.iter().zip(s.geometry().plate_joints_m()) {
        let arm = r * p_i;
        let joint = pose.position_m + arm;
        let joint_v = v_o + w.cross(&arm);
        let l = (joint - b).norm();
        let u = (joint - b) / l;
        let u_dot = (joint_v - u * u.dot(&joint_v)) / l;
        let w_leg = u.cross(&u_dot);
        let v_cyl = c.cylinder_com_from_base_m * u_dot;
        let v_rod = joint_v - c.rod_com_from_plate_m * u_dot;
        e += 0.5 * c.cylinder_mass_kg * v_cyl.norm_squared()
            + 0.5 * c.rod_mass_kg * v_rod.norm_squared()
            + 0.5 * (c.cylinder_inertia_kg_m2 + c.rod_inertia_kg_m2) * w_leg.norm_squared();
        let cyl = b + c.cylinder_com_from_base_m * u;
        let rod = joint - c.rod_com_from_plate_m * u;
        e -= G.dot(&(c.cylinder_mass_kg * cyl + c.rod_mass_kg * rod));
    }
    e
}

/// Friction power of all twelve joints, `Σ φ(w)·w` with the law written out here.
fn friction_power(s: &Simulator, c: &LegsConfig) -> f64 {
    let pose = s.true_pose();
    let v = s.true_velocity();
    let phi = |w: Vector3<f64>| {
        let n = w.norm();
        let coulomb = if n > 0.0 {
            c.joint_coulomb_torque_nm * (n / crate::legs::JOINT_FRICTION_SMOOTHING_RAD_S).tanh()
        } else {
            0.0
        };
        c.joint_viscous_nm_s_per_rad * n * n + coulomb * n
    };
    let base = s.geometry().base_joints_m();
    let mut power = 0.0;
    for (b, p_i) in base.iter().zip(s.geometry().plate_joints_m()) {
        let arm = pose.rotation * p_i;
        let joint = pose.position_m + arm;
        let joint_v = v.linear_m_s + v.angular_rad_s.cross(&arm);
        let l = (joint - b).norm();
        let u = (joint - b) / l;
        let w_leg = u.cross(&joint_v) / l;
        power += phi(w_leg) + phi(w_leg - v.angular_rad_s);
    }
    power
}

/// A free motion: brakes off, actuators at zero force (a lag far faster than the step), the
/// plate thrown upwards with angular velocity `spin`. Returns, at every sample after the
/// first, the energy, the legs' part of it and the joints' friction power.
fn free_motion(legs: LegsConfig, spin: Vector3<f64>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut cfg = config(legs);
    cfg.actuator.bandwidth_hz = 1e6;
    let mut s =
        Simulator::new(geometry(), BodyProperties::default(), Some(car()), &cfg, 0).unwrap();
    s.set_state(
        &s.geometry().home_pose(),
        &Vector3::new(0.1, -0.05, 1.2),
        &spin,
    )
    .unwrap();
    // The first step still applies the brake's hold force; from then on the legs are free.
    s.write(&command(0, [0.0; 6], true)).unwrap();
    let (mut e, mut legs_part, mut power) = (Vec::new(), Vec::new(), Vec::new());
    for k in 1..300 {
        let total = energy(&s, &legs);
        e.push(total);
        legs_part.push(total - energy(&s, &LegsConfig::default()));
        power.push(friction_power(&s, &legs));
        s.write(&command(k, [0.0; 6], true)).unwrap();
    }
    (e, legs_part, power)
}

fn spread(x: &[f64]) -> f64 {
    x.iter().cloned().fold(f64::MIN, f64::max) - x.iter().cloned().fold(f64::MAX, f64::min)
}

fn drift(e: &[f64]) -> f64 {
    e.iter().map(|x| (x - e[0]).abs()).fold(0.0, f64::max)
}

/// Total energy (plate, payload and legs kinetic, gravity potential) is conserved on a free
/// motion without friction, 0.3 s with 1 ms steps. Thrown without spin: measured drift
/// 5·10⁻⁵ J while the legs' energy swings by 22 J. Thrown spinning at 0.7 rad/s the plate's
/// own integration (rapier's first-order rotation update) drifts by 0.16 J with massless legs
/// too; the legs add 7·10⁻³ J to it, against their 23 J swing.
#[test]
fn energy_is_conserved_on_a_free_motion_without_friction() {
    let c = legs_config();
    let (e, legs_part, _) = free_motion(c, Vector3::zeros());
    println!(
        "no spin: drift {:.2e} J, legs swing {:.2e} J",
        drift(&e),
        spread(&legs_part)
    );
    assert!(spread(&legs_part) > 10.0);
    assert!(drift(&e) < 5e-4, "energy drifts by {} J", drift(&e));
    let spin = Vector3::new(0.4, -0.3, 0.5);
    let (e, legs_part, _) = free_motion(c, spin);
    let (plain, _, _) = free_motion(LegsConfig::default(), spin);
    let added = (drift(&e) - drift(&plain)).abs();
    println!(
        "spinning: drift {:.2e} J (massless legs {:.2e} J), legs swing {:.2e} J",
        drift(&e),
        drift(&plain),
        spread(&legs_part)
    );
    assert!(spread(&legs_part) > 10.0);
    assert!(added < 2e-2, "the legs add {added} J of drift");
}

/// With joint friction the energy falls by the work of the friction torques,
/// `∫ Σ φ(w)·w dt` over the twelve joints (trapezoidal rule over the samples): measured
/// 4.4521 J lost against 4.4521 J of work, 4·10⁻⁵ J apart at worst over 0.3 s.
#[test]
fn joint_friction_dissipates_the_work_of_its_torques() {
    let c = LegsConfig {
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..legs_config()
    };
    let (e, _, power) = free_motion(c, Vector3::zeros());
    let t = 1e-3;
    let mut work = 0.0;
    let mut worst = 0.0f64;
    for k in 1..e.len() {
        work += 0.5 * t * (power[k - 1] + power[k]);
        worst = worst.max((e[0] - e[k] - work).abs());
        assert!(e[k] <= e[k - 1] + 1e-6, "energy rose at sample {k}");
    }
    let lost = e[0] - e[e.len() - 1];
    println!("lost {lost:.4} J, friction work {work:.4} J, worst gap {worst:.2e} J");
    assert!(work > 1.0, "too little friction to check: {work} J");
    assert!(
        worst < 1e-3 * work,
        "energy and friction work disagree by {worst} J"
    );
}

/// With the cells at the base end they read the plate-end force plus the legs' weight and
/// inertia along the axis, `u·Σ m (a − g)` over cylinder and rod, their centres of mass'
/// accelerations by second differences of their positions over three samples: measured
/// 5·10⁻⁵ N apart while that term ranges over 283 to 338 N.
#[test]
fn base_end_cells_read_the_plate_end_force_plus_the_legs_axial_weight_and_inertia() {
    let c = LegsConfig {
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..legs_config()
    };
    let mut plate = leg_sim(c);
    let mut base = leg_sim(LegsConfig {
        load_cell_end: LoadCellEnd::Base,
        ..c
    });
    let hold = plate.true_leg_forces_n();
    let t = plate.sample_period_s();
    let mut poses = Vec::new();
    let mut diffs = Vec::new();
    for k in 0..400u64 {
        poses.push(plate.true_pose());
        let (a, b) = (plate.clean_frame(), base.clean_frame());
        diffs.push(core::array::from_fn::<f64, 6, _>(|i| {
            b.leg_forces_n[i] - a.leg_forces_n[i]
        }));
        let cmd = command(k, wave(&hold, plate.time_s()), k > 0);
        plate.write(&cmd).unwrap();
        base.write(&cmd).unwrap();
    }
    let geometry = plate.geometry();
    let bodies = |pose: &Pose, i: usize| {
        let b = geometry.base_joints_m()[i];
        let joint = pose.position_m + pose.rotation * geometry.plate_joints_m()[i];
        let u = (joint - b).normalize();
        (
            u,
            b + c.cylinder_com_from_base_m * u,
            joint - c.rod_com_from_plate_m * u,
        )
    };
    let (mut worst, mut lo, mut hi) = (0.0f64, f64::MAX, f64::MIN);
    for k in 20..poses.len() - 1 {
        for (i, diff) in diffs[k].iter().enumerate() {
            let (u, cyl, rod) = bodies(&poses[k], i);
            let (_, cyl_a, rod_a) = bodies(&poses[k - 1], i);
            let (_, cyl_b, rod_b) = bodies(&poses[k + 1], i);
            let a_c = (cyl_b - 2.0 * cyl + cyl_a) / (t * t);
            let a_r = (rod_b - 2.0 * rod + rod_a) / (t * t);
            let want = u.dot(&(c.cylinder_mass_kg * (a_c - G) + c.rod_mass_kg * (a_r - G)));
            worst = worst.max((diff - want).abs());
            lo = lo.min(want);
            hi = hi.max(want);
        }
    }
    println!("base − plate: {lo:.1} to {hi:.1} N, worst disagreement {worst:.2e} N");
    assert!(
        hi - lo > 20.0,
        "the legs' inertia hardly moves: {lo} to {hi} N"
    );
    assert!(worst < 0.05, "base-end cells off by {worst} N");
}

/// Rapier's plate, pushed by the joint forces and the spherical joints' friction torque, moves
/// with exactly the coupled acceleration the accelerometer model reports (measured 1·10⁻¹²).
#[test]
fn rapier_moves_the_plate_with_the_coupled_acceleration() {
    let mut s = leg_sim(LegsConfig {
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..legs_config()
    });
    let home = s.geometry().home_pose();
    s.set_state(&home, &Vector3::zeros(), &Vector3::new(-0.5, 0.7, 0.6))
        .unwrap();
    let hold = s.true_leg_forces_n();
    let p = s.true_parameters();
    let h = s.substep_s;
    let (mut worst_lin, mut worst_ang) = (0.0f64, 0.0f64);
    for k in 0..300u64 {
        let cmd = command(k, wave(&hold, s.time_s()), true);
        s.actuators
            .command(&cmd.leg_forces_n, true, &s.now.lengths_m, &s.now.forces_n);
        let pose = s.world.pose();
        let legs = s.legs(&pose);
        let e = s.evaluate(&pose, &legs);
        let (v0, w0) = s.world.raw_velocities();
        s.substep();
        let (v1, w1) = s.world.raw_velocities();
        let r = pose.rotation;
        let c = r * (p.first_moment_kg_m / p.mass_kg);
        let omega = r * e.omega_p;
        let w_dot = r * e.acceleration.angular_rad_s2;
        let a_origin = r * e.acceleration.specific_force_m_s2 + G;
        let a_com = a_origin + w_dot.cross(&c) + omega.cross(&omega.cross(&c));
        worst_lin = worst_lin.max(((v1 - v0) / h - a_com).norm() / a_com.norm());
        worst_ang = worst_ang.max(((w1 - w0) / h - w_dot).norm() / w_dot.norm());
        s.sample += 1;
        s.refresh().unwrap();
    }
    println!("rapier vs coupled: linear {worst_lin:.2e}, angular {worst_ang:.2e}");
    assert!(worst_lin < 1e-9 && worst_ang < 1e-9);
}

/// The scenario builds the simulated legs from the rig description's `[legs]` through the
/// world's switches: `leg_dynamics` on draws the masses, centres and inertias within their
/// tolerances, `joint_friction` on the friction figures, each from its own stream of the seed;
/// a source off leaves its figures as described.
#[test]
fn the_worlds_switches_draw_the_built_legs_within_their_tolerances() {
    use rig_description::load::{load, load_str};
    let scenario = crate::scenario::Scenario::new(load(None).unwrap(), None, None).unwrap();
    let described = scenario.loaded.config.legs;
    assert!(described.cylinder_mass_kg > 0.0 && described.joint_coulomb_torque_nm > 0.0);
    let built = scenario.sim_config().legs;
    let within = |got: f64, want: f64, sigma: f64| got != want && (got - want).abs() < 5.0 * sigma;
    assert!(within(
        built.cylinder_mass_kg,
        described.cylinder_mass_kg,
        described.cylinder_mass_kg * described.mass_tolerance
    ));
    assert!(within(
        built.rod_com_from_plate_m,
        described.rod_com_from_plate_m,
        described.com_tolerance_m
    ));
    assert!(within(
        built.joint_coulomb_torque_nm,
        described.joint_coulomb_torque_nm,
        described.joint_coulomb_torque_nm * described.friction_tolerance
    ));
    // The same seed builds the same legs; another seed other legs.
    assert_eq!(scenario.built_legs(), built);
    let other = crate::scenario::Scenario::new(load(None).unwrap(), Some(2), None).unwrap();
    assert_ne!(other.built_legs().rod_mass_kg, built.rod_mass_kg);
    let text = "[world.imperfections]\nleg_dynamics = false\n";
    let scenario =
        crate::scenario::Scenario::new(load_str(text, "s.toml").unwrap(), None, None).unwrap();
    let legs = scenario.sim_config().legs;
    assert_eq!(legs.cylinder_mass_kg, described.cylinder_mass_kg);
    assert_eq!(legs.rod_inertia_kg_m2, described.rod_inertia_kg_m2);
    assert_eq!(legs.joint_coulomb_torque_nm, built.joint_coulomb_torque_nm);
    let text = "[world.imperfections]\njoint_friction = false\n";
    let scenario =
        crate::scenario::Scenario::new(load_str(text, "s.toml").unwrap(), None, None).unwrap();
    let legs = scenario.sim_config().legs;
    assert_eq!(
        legs.joint_viscous_nm_s_per_rad,
        described.joint_viscous_nm_s_per_rad
    );
    assert_eq!(legs.rod_mass_kg, built.rod_mass_kg);
}

/// The estimator's model of what the cells miss ([`estimator::legs`], written apart from this
/// simulator's coupled legs) closes the plate's Newton–Euler equations: with heavy legs and
/// joint friction, the cells' clean wrench plus the model's unseen wrench at the true motion
/// equals the regressor of the true motion times the true parameters, at either cell end.
/// Without it the equations miss the unseen wrench whole.
#[test]
fn the_estimators_leg_model_closes_the_plates_newton_euler_equations() {
    use estimator::legs::{unseen, PlateMotion};
    use estimator::regressor::{from_signals, RegressorSignals};
    for end in [LoadCellEnd::Plate, LoadCellEnd::Base] {
        let c = LegsConfig {
            load_cell_end: end,
            joint_coulomb_torque_nm: 1.0,
            joint_viscous_nm_s_per_rad: 5.0,
            ..legs_config()
        };
        let mut s = leg_sim(c);
        let hold = s.true_leg_forces_n();
        let theta = s.true_parameters().to_vector();
        let (mut worst, mut unseen_peak) = (0.0f64, 0.0f64);
        for k in 0..600u64 {
            if k > 50 {
                let pose = s.true_pose();
                let v = s.true_velocity();
                let a = s.true_acceleration();
                let omega_p = pose.rotation.inverse() * v.angular_rad_s;
                let motion = PlateMotion {
                    pose,
                    velocity_m_s: v.linear_m_s,
                    acceleration_m_s2: pose.rotation * a.specific_force_m_s2 + G,
                    angular_velocity_rad_s: omega_p,
                    angular_acceleration_rad_s2: a.angular_rad_s2,
                };
                let forces = Vector6::from(s.clean_frame().leg_forces_n);
                let cells = s.geometry().wrench_in_platform(&pose, &forces);
                let u = unseen(s.geometry(), &c.model(), &motion, &G).total();
                let signals =
                    RegressorSignals::new(&omega_p, &a.angular_rad_s2, &a.specific_force_m_s2);
                let want = from_signals(&signals) * theta;
                let got = Vector6::new(
                    cells.force_n.x + u.force_n.x,
                    cells.force_n.y + u.force_n.y,
                    cells.force_n.z + u.force_n.z,
                    cells.torque_nm.x + u.torque_nm.x,
                    cells.torque_nm.y + u.torque_nm.y,
                    cells.torque_nm.z + u.torque_nm.z,
                );
                worst = worst.max((got - want).amax());
                unseen_peak = unseen_peak.max(u.force_n.amax()).max(u.torque_nm.amax());
            }
            let cmd = command(k, wave(&hold, s.time_s()), k > 0);
            s.write(&cmd).unwrap();
        }
        println!("{end:?}: unseen up to {unseen_peak:.1}, equations closed within {worst:.2e}");
        assert!(
            unseen_peak > 50.0,
            "{end:?}: the legs hardly matter: {unseen_peak}"
        );
        assert!(
            worst < 1e-3 * unseen_peak,
            "{end:?}: off by {worst} (unseen {unseen_peak})"
        );
    }
}

/// A joint friction too steep for explicit integration with the physics step is refused,
/// naming its key; the rig description's figures pass.
#[test]
fn too_steep_joint_friction_is_refused() {
    let steep = LegsConfig {
        joint_coulomb_torque_nm: 1e4,
        ..legs_config()
    };
    let err = Simulator::new(
        geometry(),
        BodyProperties::default(),
        None,
        &config(steep),
        0,
    )
    .unwrap_err();
    assert!(matches!(
        err,
        SimError::InvalidConfig {
            field: "legs.joint_coulomb_torque_nm",
            ..
        }
    ));
    let fine = LegsConfig {
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..legs_config()
    };
    assert!(Simulator::new(
        geometry(),
        BodyProperties::default(),
        None,
        &config(fine),
        0
    )
    .is_ok());
}
