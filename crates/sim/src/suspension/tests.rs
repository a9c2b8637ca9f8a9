//! The suspension against physics written out here: a one-degree-of-freedom oscillator's
//! transmissibility, and the energy balance of two free bodies on the units. Both bodies are
//! integrated by rapier ([`PlateWorld`]), the units' forces taken as the simulator takes them
//! (`simulator/sprung.rs`).

use super::*;
use crate::world::{Loads, PlateWorld};
use nalgebra::Rotation3;

const G: Vector3<f64> = GRAVITY_M_S2;

fn car() -> BodyProperties {
    let q = Rotation3::from_euler_angles(0.05, -0.08, 0.3);
    BodyProperties::from_principal(1500.0, [0.15, -0.1, 0.5], [450.0, 2100.0, 2300.0], &q)
}

fn home() -> Pose {
    Pose::new(Vector3::new(0.0, 0.0, 1.3), Rotation3::identity())
}

fn config(damping_ratio: f64) -> SuspensionConfig {
    SuspensionConfig {
        enabled: true,
        damping_ratio,
        ..SuspensionConfig::default()
    }
}

/// A world with the fixture and the unsprung part of `payload` as the plate and the sprung body
/// resting on it at `home()`.
fn world(c: &SuspensionConfig, payload: &BodyProperties, h: f64) -> (PlateWorld, Suspension) {
    let s = Suspension::new(c, payload, &Rotation3::identity()).unwrap();
    let unsprung = Suspension::unsprung(c, payload);
    let mut w = PlateWorld::new(
        &BodyProperties::default(),
        unsprung.as_ref(),
        &home(),
        h,
        false,
    );
    w.set_sprung(Some(s.body()));
    (w, s)
}

fn body_motion(w: &PlateWorld, s: &Suspension) -> Motion {
    let (pose, v_com, omega) = w.sprung_state().unwrap();
    Motion::from_com(pose, &s.body().com(), &v_com, &omega)
}

/// One step of the sprung body with the plate at `plate` (its motion at the step's start),
/// as the simulator takes it: units at the instant, midpoint gyroscopic torque.
fn step_body(
    w: &mut PlateWorld,
    s: &Suspension,
    plate: &Motion,
    plate_torque: Vector3<f64>,
    h: f64,
) {
    let raw = body_motion(w, s);
    let first = s.forces(plate, &raw);
    let body = s.body_instant(&raw, &first, h, true);
    let units = s.forces(plate, &body);
    let on_plate = units.plate_loads();
    let on_body = units.body_loads();
    w.step(
        &Loads {
            forces: &[&on_plate],
            torque: plate_torque,
        },
        &Loads {
            forces: &[&on_body],
            torque: s.gyroscopic_torque(&body),
        },
    );
}

/// `|H(f)| = √(1 + (2ζr)²) / √((1 − r²)² + (2ζr)²)`, `r = f / f_b`: base excitation of a
/// one-degree-of-freedom oscillator.
fn transmissibility(r: f64, zeta: f64) -> f64 {
    let d = 2.0 * zeta * r;
    (1.0 + d * d).sqrt() / ((1.0 - r * r).powi(2) + d * d).sqrt()
}

/// The plate driven vertically, `z = A sin(2π f t)` about `home()`, the sprung body free on
/// its units: after the transient (`settle_s`), the body's heave amplitude over `periods`
/// whole periods (projection on the drive's sine and cosine) over `A`, and the largest
/// deflection `|z_b − z_p|` over `A` then.
fn heave_response(f: f64, settle_s: f64, periods: u32) -> (f64, f64) {
    let h = 1e-3;
    let (mut w, s) = world(&config(0.25), &car(), h);
    let amplitude = 0.02;
    let omega = 2.0 * core::f64::consts::PI * f;
    let z0 = home().position_m.z;
    let settle = (settle_s / h).round() as usize;
    let measure = (f64::from(periods) / f / h).round() as usize;
    let (mut re, mut im, mut worst) = (0.0, 0.0, 0.0f64);
    for n in 0..settle + measure {
        let t = n as f64 * h;
        let z = amplitude * (omega * t).sin();
        let plate = Motion {
            pose: Pose::new(Vector3::new(0.0, 0.0, z0 + z), Rotation3::identity()),
            v_origin: Vector3::new(0.0, 0.0, amplitude * omega * (omega * t).cos()),
            omega: Vector3::zeros(),
        };
        w.set_plate_state(&plate.pose, &plate.v_origin, &plate.omega);
        if n >= settle {
            let zb = w.sprung_state().unwrap().0.position_m.z - z0;
            re += zb * (omega * t).sin();
            im += zb * (omega * t).cos();
            worst = worst.max((zb - z).abs());
        }
        step_body(&mut w, &s, &plate, Vector3::zeros(), h);
    }
    let k = 2.0 / measure as f64;
    ((k * re).hypot(k * im) / amplitude, worst / amplitude)
}

/// Heave of the sprung body on a vertically oscillating plate against a one-degree-of-freedom
/// oscillator's transmissibility (ζ = 0.25, f_b = 1.3 Hz): measured within 2·10⁻⁴ of |H| at
/// r = 0.1, 0.5, 1 and 2 (tolerance 10⁻³); at r = 0.1 the body moves with the plate (deflection
/// 1 % of the stroke), at resonance it moves 2.24 times the plate's amplitude.
#[test]
fn heave_transmissibility_is_a_one_degree_of_freedom_oscillators() {
    let (fb, zeta) = (1.3, 0.25);
    for (r, periods) in [(0.1, 1), (0.5, 4), (1.0, 6), (2.0, 10)] {
        let (got, deflection) = heave_response(r * fb, 7.0, periods);
        let want = transmissibility(r, zeta);
        println!("r = {r}: |H| = {got:.5}, analytic {want:.5}, deflection {deflection:.4} A");
        assert!((got - want).abs() < 1e-3 * want, "r = {r}: {got} vs {want}");
        if r <= 0.1 {
            assert!(
                deflection < 0.015,
                "the body lags the plate by {deflection} A"
            );
        }
    }
}

/// Both bodies' kinetic and gravitational energy plus the units' stored energy, with the
/// velocities at the instant (mean of the half steps either side), J.
fn energy(s: &Suspension, plate_body: &BodyProperties, plate: &Motion, body: &Motion) -> f64 {
    let rigid = |b: &BodyProperties, m: &Motion| {
        let r = m.pose.rotation.matrix();
        let com = m.pose.position_m + m.pose.rotation * b.com();
        let j = r * b.inertia_com() * r.transpose();
        let v = m.point_velocity(&com);
        0.5 * b.mass_kg * v.norm_squared() + 0.5 * m.omega.dot(&(j * m.omega))
            - b.mass_kg * G.dot(&com)
    };
    rigid(plate_body, plate) + rigid(s.body(), body) + s.potential_energy(&plate.pose, &body.pose)
}

fn average(a: &Motion, b: &Motion) -> Motion {
    Motion {
        pose: a.pose,
        v_origin: 0.5 * (a.v_origin + b.v_origin),
        omega: 0.5 * (a.omega + b.omega),
    }
}

/// The car's mass and tensor with its centre of mass right above the fixture's.
fn centred_car() -> BodyProperties {
    BodyProperties {
        com_m: [0.0, 0.0, 0.5],
        ..car()
    }
}

/// Plate (fixture + unsprung part of `payload`) and sprung body thrown upwards, free (no legs),
/// for 2 s with steps `h`. `tumble`: the body off its rest place, turned and moving against
/// the plate, both turning; otherwise the body only raised by 4 cm (with [`centred_car`], a
/// pure heave). Returns the energy and the dampers' dissipated energy (trapezoidal sum of
/// their power) at every step.
fn free_flight(
    damping_ratio: f64,
    h: f64,
    payload: &BodyProperties,
    tumble: bool,
) -> (Vec<f64>, Vec<f64>) {
    let c = config(damping_ratio);
    let (mut w, s) = world(&c, payload, h);
    let plate_body = {
        let p = crate::InertialParameters::from_body(&BodyProperties::default())
            + crate::InertialParameters::from_body(&Suspension::unsprung(&c, payload).unwrap());
        BodyProperties::from_parameters(&p).unwrap()
    };
    let k = if tumble { 1.0 } else { 0.0 };
    let up = Vector3::new(0.1, -0.2, 9.0);
    w.set_state(&home(), &up, &(k * Vector3::new(0.02, -0.03, 0.05)));
    let turned = Pose::new(
        home().position_m + Vector3::new(k * 0.02, k * -0.01, 0.04),
        Rotation3::from_euler_angles(k * 0.02, k * -0.015, k * 0.03),
    );
    w.set_sprung_state(
        &turned,
        &(up + k * Vector3::new(-0.1, 0.05, 0.2)),
        &(k * Vector3::new(-0.05, 0.08, -0.04)),
    );
    let plate_motion = |w: &PlateWorld| {
        let (v, om) = w.raw_velocities();
        Motion::from_com(w.pose(), &plate_body.com(), &v, &om)
    };
    let (mut energies, mut dissipated) = (Vec::new(), Vec::new());
    let (mut work, mut last_power) = (0.0, None);
    for _ in 0..(2.0 / h).round() as usize {
        let plate_raw = plate_motion(&w);
        let body_raw = body_motion(&w, &s);
        // The plate's instant rate and velocity from its own Newton–Euler equations.
        let first = s.forces(&plate_raw, &body_raw);
        let com = plate_raw.pose.position_m + plate_raw.pose.rotation * plate_body.com();
        let wrench = first.on_plate(&com);
        let r = plate_raw.pose.rotation.matrix();
        let j = r * plate_body.inertia_com() * r.transpose();
        let wr = plate_raw.omega;
        let torque = Vector3::new(wrench[3], wrench[4], wrench[5]) - wr.cross(&(j * wr));
        let omega = wr + 0.5 * h * j.try_inverse().unwrap() * torque;
        let a = Vector3::new(wrench[0], wrench[1], wrench[2]) / plate_body.mass_kg + G;
        let v_com = plate_raw.point_velocity(&com) + 0.5 * h * a;
        let plate = Motion::from_com(plate_raw.pose, &plate_body.com(), &v_com, &omega);
        step_body(&mut w, &s, &plate, -omega.cross(&(j * omega)), h);
        let plate_mid = average(&plate_raw, &plate_motion(&w));
        let body_mid = average(&body_raw, &body_motion(&w, &s));
        let power = s.damper_power(&plate_mid, &body_mid);
        if let Some(p) = last_power {
            work += 0.5 * h * (p + power);
        }
        last_power = Some(power);
        energies.push(energy(&s, &plate_body, &plate_mid, &body_mid));
        dissipated.push(work);
    }
    (energies, dissipated)
}

fn drift(e: &[f64]) -> f64 {
    e.iter().map(|x| (x - e[0]).abs()).fold(0.0, f64::max)
}

/// Largest gap between the energy lost and the dampers' work so far, and their total work.
fn balance(e: &[f64], work: &[f64]) -> (f64, f64) {
    let gap = e
        .iter()
        .zip(work)
        .map(|(x, w)| (e[0] - x - w).abs())
        .fold(0.0, f64::max);
    (gap, work[work.len() - 1])
}

/// Without damping the units store what the bodies lose. A pure heave (nothing turns): the
/// energy stays within 8·10⁻³ J of a 70 J oscillation, a quarter of it with half the step:
/// leapfrog's bounded `O((ω h)²)` energy error, not a drift. Tumbling, the light
/// plate spun up to 1 rad/s by the units' moments: the energy drifts by 0.2 J with 0.5 ms steps
/// and half that with half the steps — rapier's first-order rotation update (as for the plate
/// alone, see the legs' energy test), not the units, whose error would not vanish with the
/// step.
#[test]
fn the_units_conserve_energy_without_damping() {
    let coarse = drift(&free_flight(0.0, 5e-4, &centred_car(), false).0);
    let fine = drift(&free_flight(0.0, 2.5e-4, &centred_car(), false).0);
    println!("heave: energy drift {coarse:.2e} J, {fine:.2e} J with half the step");
    assert!(coarse < 2e-2);
    assert!((fine / coarse - 0.25).abs() < 0.03);
    let coarse = drift(&free_flight(0.0, 5e-4, &car(), true).0);
    let fine = drift(&free_flight(0.0, 2.5e-4, &car(), true).0);
    println!("tumbling: energy drift {coarse:.3e} J, {fine:.3e} J with half the step");
    assert!(coarse < 1.0);
    assert!((fine / coarse - 0.5).abs() < 0.05);
}

/// With the default damping the energy drops by the dampers' work alone (their ∑ c |ḋ|² dt):
/// on a pure heave to 10⁻⁴ of it (measured 2·10⁻⁵: 0.01 J of 487 J); tumbling, the gap
/// (0.03 J of 640 J) is first order in the step like the undamped drift.
#[test]
fn the_dampers_alone_dissipate_energy() {
    let (e, work) = free_flight(0.25, 5e-4, &centred_car(), false);
    let (gap, dissipated) = balance(&e, &work);
    println!("heave: dampers' work {dissipated:.3} J, worst gap {gap:.2e} J");
    assert!(
        dissipated > 50.0,
        "too little damping to test: {dissipated} J"
    );
    assert!(gap < 1e-4 * dissipated);
    let (e, work) = free_flight(0.25, 5e-4, &car(), true);
    let (coarse, dissipated) = balance(&e, &work);
    let (e, work) = free_flight(0.25, 2.5e-4, &car(), true);
    let (fine, _) = balance(&e, &work);
    println!("tumbling: dampers' work {dissipated:.3} J, gap {coarse:.2e} J, {fine:.2e} J with half the step");
    assert!(dissipated > 10.0);
    assert!((fine / coarse - 0.5).abs() < 0.1);
}

/// At rest on a level plate the preloads carry the body's weight and its centre of mass
/// (forces and moments balance), and the units' stiffness and damping follow the heave mode.
#[test]
fn preload_carries_the_weight_and_the_units_give_the_bounce_frequency() {
    let c = config(0.25);
    let s = Suspension::new(&c, &car(), &Rotation3::identity()).unwrap();
    let m = 0.85 * 1500.0;
    let rest = s.rest_forces(&home());
    let w = rest.on_body(&s.com_b(&home()));
    assert!((Vector3::new(w[0], w[1], w[2]) + m * G).norm() < 1e-9);
    assert!(Vector3::new(w[3], w[4], w[5]).norm() < 1e-9);
    let (k, d) = s.unit_constants();
    let f = (4.0 * k / m).sqrt() / (2.0 * core::f64::consts::PI);
    assert!((f - 1.3).abs() < 1e-12);
    assert!((4.0 * d / (2.0 * (4.0 * k * m).sqrt()) - 0.25).abs() < 1e-12);
    assert!(
        Suspension::new(&SuspensionConfig::default(), &car(), &Rotation3::identity()).is_none()
    );
    let unsprung = Suspension::unsprung(&c, &car()).unwrap();
    assert!((unsprung.mass_kg + s.body().mass_kg - 1500.0).abs() < 1e-9);
    assert!((unsprung.inertia_com() + s.body().inertia_com() - car().inertia_com()).amax() < 1e-9);
}

#[test]
fn out_of_range_tables_are_refused() {
    for (field, bad) in [
        (
            "suspension.sprung_share",
            SuspensionConfig {
                sprung_share: 1.2,
                ..config(0.25)
            },
        ),
        (
            "suspension.sprung_share",
            SuspensionConfig {
                sprung_share: 0.0,
                ..config(0.25)
            },
        ),
        (
            "suspension.bounce_hz",
            SuspensionConfig {
                bounce_hz: -1.0,
                ..config(0.25)
            },
        ),
        ("suspension.damping_ratio", config(-0.1)),
        (
            "suspension.track_m",
            SuspensionConfig {
                track_m: f64::NAN,
                ..config(0.25)
            },
        ),
    ] {
        match validate(&bad) {
            Err(SimError::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
        assert!(validate(&SuspensionConfig {
            enabled: false,
            ..bad
        })
        .is_ok());
    }
    // A bounce far too stiff for the step is refused.
    let stiff = SuspensionConfig {
        bounce_hz: 400.0,
        ..config(0.25)
    };
    let s = Suspension::new(&stiff, &car(), &Rotation3::identity()).unwrap();
    assert!(s.check_stability(1e-3).is_err());
    let s = Suspension::new(&config(0.25), &car(), &Rotation3::identity()).unwrap();
    assert!(s.check_stability(1e-3).is_ok());
}
