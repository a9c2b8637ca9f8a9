//! The leg model against the two bodies' Newton–Euler equations, evaluated by numerical
//! differentiation of their positions and momenta along a prescribed plate-joint motion.

use super::*;

const G: Vector3<f64> = stewart_types::GRAVITY_B_M_S2;

/// Heavy legs with joint friction: the default rig's figures.
pub(crate) fn config() -> LegsConfig {
    LegsConfig {
        load_cell_end: LoadCellEnd::Plate,
        cylinder_mass_kg: 28.0,
        cylinder_com_from_base_m: 0.45,
        cylinder_inertia_kg_m2: 2.8,
        rod_mass_kg: 12.0,
        rod_com_from_plate_m: 0.55,
        rod_inertia_kg_m2: 1.0,
        joint_coulomb_torque_nm: 1.0,
        joint_viscous_nm_s_per_rad: 5.0,
        ..LegsConfig::default()
    }
}

const BASE: Vector3<f64> = Vector3::new(0.3, -0.2, 0.1);

/// A prescribed plate-joint path `s(t)` and its analytic derivatives.
fn joint(t: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let (a, w1) = (Vector3::new(0.2, -0.1, 0.15), 3.1);
    let (b, w2) = (Vector3::new(-0.05, 0.12, 0.08), 5.3);
    let s0 = Vector3::new(0.8, 0.4, 1.7);
    let s = s0 + a * (w1 * t).sin() + b * (w2 * t).cos();
    let v = a * w1 * (w1 * t).cos() - b * w2 * (w2 * t).sin();
    let acc = -a * w1 * w1 * (w1 * t).sin() - b * w2 * w2 * (w2 * t).cos();
    (s, v, acc)
}

/// The two bodies at `t` from their definitions: centres of mass and the angular momentum
/// about the base joint, `Σ m r × ṙ + I (𝟙 − u uᵀ) ω` with `ω = u × u̇` (no spin), the rates
/// by central differences of the positions.
struct Bodies {
    unit: Vector3<f64>,
    cylinder: Vector3<f64>,
    rod: Vector3<f64>,
}

fn bodies(c: &LegsConfig, t: f64) -> Bodies {
    let (s, _, _) = joint(t);
    let u = (s - BASE).normalize();
    Bodies {
        unit: u,
        cylinder: BASE + c.cylinder_com_from_base_m * u,
        rod: s - c.rod_com_from_plate_m * u,
    }
}

fn rate<F: Fn(f64) -> Vector3<f64>>(f: F, t: f64, d: f64) -> Vector3<f64> {
    (f(t - 2.0 * d) - 8.0 * f(t - d) + 8.0 * f(t + d) - f(t + 2.0 * d)) / (12.0 * d)
}

const D: f64 = 1e-3;

fn momentum_about_base(c: &LegsConfig, t: f64) -> Vector3<f64> {
    let b = bodies(c, t);
    let ud = rate(|t| bodies(c, t).unit, t, D);
    let vc = rate(|t| bodies(c, t).cylinder, t, D);
    let vr = rate(|t| bodies(c, t).rod, t, D);
    let w = b.unit.cross(&ud);
    c.cylinder_mass_kg * (b.cylinder - BASE).cross(&vc)
        + c.rod_mass_kg * (b.rod - BASE).cross(&vr)
        + (c.cylinder_inertia_kg_m2 + c.rod_inertia_kg_m2) * w
}

fn motion(t: f64) -> (LegMotion, Vector3<f64>) {
    let (s, v, a) = joint(t);
    (LegMotion::new(&BASE, &s, &v), a)
}

#[test]
fn the_joint_force_satisfies_both_bodies_newton_euler_equations() {
    let c = config();
    let legs = Legs::new(c).unwrap();
    let plate_omega = Vector3::new(0.3, -0.5, 0.2);
    let f_a = 4321.0;
    for t in [0.0, 0.17, 0.42, 0.9] {
        let (m, s_acc) = motion(t);
        let law = legs.law(&m, &plate_omega, &G);
        let f = law.force(f_a, &s_acc);
        let u = m.unit;
        // Moment balance about the base joint, across the leg.
        let hdot = rate(|t| momentum_about_base(&c, t), t, D);
        let b = bodies(&c, t);
        let tau_u = -legs.friction_nm(&m.omega_rad_s);
        let tau_s = -legs.friction_nm(&(m.omega_rad_s - plate_omega));
        let moment = (m.length_m * u).cross(&(-f))
            + c.cylinder_mass_kg * (b.cylinder - BASE).cross(&G)
            + c.rod_mass_kg * (b.rod - BASE).cross(&G)
            + tau_u
            + tau_s;
        let residual = moment - hdot;
        let across = residual - u * u.dot(&residual);
        assert!(
            across.norm() < 1e-6 * hdot.norm().max(moment.norm()),
            "t {t}: moment residual {across:?} of {hdot:?}"
        );
        // The rod along the axis: actuator, joint, weight against its acceleration.
        let a_r = rate(|t| rate(|t| bodies(&c, t).rod, t, D), t, D);
        let axial = f_a - u.dot(&f) + c.rod_mass_kg * u.dot(&G) - c.rod_mass_kg * u.dot(&a_r);
        assert!(axial.abs() < 1e-6 * f_a, "t {t}: axial residual {axial}");
        // The base end carries the plate end plus both bodies' inertia and weight.
        let a_c = rate(|t| rate(|t| bodies(&c, t).cylinder, t, D), t, D);
        let want = f + c.cylinder_mass_kg * (a_c - G) + c.rod_mass_kg * (a_r - G);
        let base = Legs::new(LegsConfig {
            load_cell_end: LoadCellEnd::Base,
            ..c
        })
        .unwrap()
        .cell(&m, &f, &s_acc, &G);
        assert!((base.axial_n - u.dot(&want)).abs() < 1e-6 * f_a);
        assert!((base.transverse_n - (want - u * u.dot(&want))).norm() < 1e-6 * f_a);
        let plate = legs.cell(&m, &f, &s_acc, &G);
        assert!((plate.axial_n - u.dot(&f)).abs() < 1e-12 * f_a);
    }
}

#[test]
fn the_reflected_inertia_holds_the_legs_kinetic_energy() {
    let c = config();
    let legs = Legs::new(c).unwrap();
    for t in [0.05, 0.3, 0.77] {
        let (m, _) = motion(t);
        let (s, v, _) = joint(t);
        let law = legs.law(&m, &Vector3::zeros(), &G);
        // From the bodies' velocities: ½ m |v|² + ½ I |ω|² each.
        let b = bodies(&c, t);
        let w = b.unit.cross(&rate(|t| bodies(&c, t).unit, t, D));
        let vc = rate(|t| bodies(&c, t).cylinder, t, D);
        let vr = rate(|t| bodies(&c, t).rod, t, D);
        let want = 0.5 * c.cylinder_mass_kg * vc.norm_squared()
            + 0.5 * c.rod_mass_kg * vr.norm_squared()
            + 0.5 * (c.cylinder_inertia_kg_m2 + c.rod_inertia_kg_m2) * w.norm_squared();
        let reflected = 0.5 * v.dot(&(law.inertia_kg * v));
        assert!(
            (reflected - want).abs() < 1e-9 * want,
            "{reflected} vs {want}"
        );
        assert!((legs.kinetic_energy(&m) - want).abs() < 1e-9 * want);
        assert!((m.length_m - (s - BASE).norm()).abs() < 1e-15);
    }
}

#[test]
fn the_plate_sees_the_legs_wrench_through_the_reflected_inertia() {
    let legs = Legs::new(config()).unwrap();
    let omega = Vector3::new(0.4, 0.1, -0.6);
    let v_o = Vector3::new(0.1, -0.2, 0.05);
    let arms: [Vector3<f64>; 6] = core::array::from_fn(|i| {
        let a = i as f64;
        Vector3::new(1.1 * (a + 0.3).cos(), 1.1 * (a + 0.3).sin(), 0.02 * a)
    });
    let origin = Vector3::new(0.02, 0.01, 1.8);
    let laws: [JointLaw; 6] = core::array::from_fn(|i| {
        let base = Vector3::new(1.5 * (i as f64).cos(), 1.5 * (i as f64).sin(), 0.0);
        let s = origin + arms[i];
        legs.law(
            &LegMotion::new(&base, &s, &(v_o + omega.cross(&arms[i]))),
            &omega,
            &G,
        )
    });
    let f_a = [5000.0, 5200.0, 4800.0, 5100.0, 4900.0, 5050.0];
    let (m, q) = reflect(&laws, &arms, &omega, Some(&f_a));
    let x = Vector6::new(0.3, -1.2, 0.5, 0.7, -0.4, 0.9);
    let (a, wd) = (x.fixed_rows::<3>(0), x.fixed_rows::<3>(3));
    let mut want = Vector6::zeros();
    for i in 0..6 {
        let r = &arms[i];
        let acc = a + wd.cross(r) + omega.cross(&omega.cross(r));
        let f = laws[i].force(f_a[i], &acc);
        let t = r.cross(&f) - laws[i].spherical_torque_nm;
        want += Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z);
    }
    let got = q - m * x;
    assert!((got - want).norm() < 1e-9 * want.norm(), "{got} vs {want}");
    assert!((m - m.transpose()).amax() < 1e-9 * m.amax());
}

#[test]
fn massless_frictionless_legs_are_no_model() {
    assert!(Legs::new(LegsConfig::default()).is_none());
    let only_friction = LegsConfig {
        joint_viscous_nm_s_per_rad: 1.0,
        ..LegsConfig::default()
    };
    assert!(Legs::new(only_friction).is_some());
}
