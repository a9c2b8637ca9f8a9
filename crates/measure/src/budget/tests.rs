//! The budget's effects against independent checks on synthetic runs: a second fit of samples
//! with the error actually added (by the synthetic generator, not by [`super::perturb`]), the
//! estimator's own exact sensitivity, a closed form for the legs, and the rigid-body check
//! both ways.

use estimator::{EstimatorConfig, OnlineEstimator, ParameterVector, Sample};
use kinematics::Geometry;
use nalgebra::{Matrix6, Vector3, Vector6};

use super::fit::{Data, Fit, Mode, Model};
use super::legs::{self, LegEffects};
use super::perturb::{Context, Scalar};
use super::testkit::{self, Synth};
use super::*;
use rig_description::config::{LegsConfig, LoadCellEnd};

fn model(g: &Geometry, synth: &Synth) -> Model {
    Model {
        geometry: *g,
        lever_m: synth.lever_m,
        equation_sigma: Vector6::new(5.0, 5.0, 5.0, 2.0, 2.0, 2.0),
        mode: Mode::Full,
    }
}

fn fitted(g: &Geometry, synth: &Synth, samples: &[Sample]) -> ParameterVector {
    let data = Data::new(synth.record(g, samples).entries(), model(g, synth));
    Fit::solve(&data).expect("fit")
}

/// The effect of `scalar` at `sigma` on `synth`'s clean run, with the legs of `legs`.
fn effect(
    g: &Geometry,
    synth: &Synth,
    scalar: Scalar,
    sigma: f64,
    l: &LegsConfig,
) -> ParameterVector {
    let samples = synth.samples(g, |_, _, _| {});
    let data = Data::new(synth.record(g, &samples).entries(), model(g, synth));
    let theta = synth.body.to_vector();
    let fit = Fit::new(&data, &theta).expect("fit");
    let motions = legs::motions(&data, &fit.idx, fit.h);
    let legs: LegEffects = legs::effects(&data, &motions, l);
    let ctx = Context {
        data: &data,
        fit: &fit,
        legs: &legs,
        described: l,
        motions: &motions,
        imu: None,
        load_cells: None,
        rest_gravity_m_s2: None,
        joint_baseline: Default::default(),
        leg_maps: Default::default(),
    };
    fit.effect(&scalar.residual_change(&ctx, sigma))
}

fn assert_close(name: &str, got: &ParameterVector, want: &ParameterVector, rel: f64) {
    // In the reported quantities (m, c, J_C), per group: θ's h and J_O can move together
    // along a weakly determined direction that cancels in J_C.
    let g = estimator::uncertainty::derived_jacobian(&testkit::body().to_vector());
    let (got, want) = (g * got, g * want);
    let mut any = false;
    for (group, range) in [("mass", 0..1), ("com", 1..4), ("J_C", 4..10)] {
        let total = want.amax().max(got.amax());
        let scale = want
            .rows(range.start, range.len())
            .amax()
            .max(got.rows(range.start, range.len()).amax());
        let err = (got - want).rows(range.start, range.len()).amax();
        any |= scale > 0.0;
        // Floors: an entry a thousandth of the largest of the group's own unit is nothing.
        let floor = match group {
            "mass" => 1e-2 * total,
            "com" => 1e-9,
            _ => 1e-4 * total,
        };
        assert!(
            err <= rel * scale + floor,
            "{name} {group}: error {err:.3e} of {scale:.3e}\n got {got:.4e}\nwant {want:.4e}"
        );
    }
    assert!(any, "{name}: no effect at all");
}

/// The fit itself: noise-free samples of a known body give it back.
#[test]
fn the_budgets_fit_recovers_the_body() {
    let g = testkit::geometry();
    let synth = Synth::default();
    let theta = fitted(&g, &synth, &synth.samples(&g, |_, _, _| {}));
    let truth = synth.body.to_vector();
    for i in 0..10 {
        let tol = 1e-5 * truth.amax();
        assert!(
            (theta[i] - truth[i]).abs() < tol,
            "θ[{i}] {} vs {}",
            theta[i],
            truth[i]
        );
    }
}

/// Each perturbation of the record against a second fit of samples with the error added
/// where it physically acts.
#[test]
fn each_sources_effect_matches_a_second_fit_with_the_error_added() {
    let g = testkit::geometry();
    let synth = Synth::default();
    let clean = fitted(&g, &synth, &synth.samples(&g, |_, _, _| {}));
    let second = |corrupt: &dyn Fn(u64, &testkit::State, &mut Sample)| {
        fitted(&g, &synth, &synth.samples(&g, |k, s, x| corrupt(k, s, x))) - clean
    };
    let none = LegsConfig::default();
    let check = |name: &str, scalar: Scalar, sigma: f64, want: ParameterVector, rel: f64| {
        let got = effect(&g, &synth, scalar, sigma, &none);
        assert_close(name, &got, &want, rel);
    };
    check(
        "gain",
        Scalar::Gain(2),
        1e-3,
        second(&|_, _, x| x.leg_forces_n[2] *= 1.001),
        1e-3,
    );
    check(
        "offset",
        Scalar::Offset(1),
        4.0,
        second(&|_, _, x| x.leg_forces_n[1] += 4.0),
        1e-3,
    );
    check(
        "drift",
        Scalar::Drift(4),
        6.0,
        second(&|_, _, x| x.leg_forces_n[4] += 6.0 * x.time_s / 60.0),
        1e-2,
    );
    check(
        "accel bias",
        Scalar::AccelBias(2),
        0.01,
        second(&|_, _, x| x.accel_m_s2.z += 0.01),
        3e-3,
    );
    check(
        "accel bias x",
        Scalar::AccelBias(0),
        0.002,
        second(&|_, _, x| x.accel_m_s2.x += 0.002),
        1.5e-2,
    );
    check(
        "misalignment",
        Scalar::Misalignment(0),
        1e-3,
        second(&|_, _, x| {
            let r = testkit::turn(0, 1e-3);
            x.gyro_rad_s = r * x.gyro_rad_s;
            x.accel_m_s2 = r * x.accel_m_s2;
        }),
        1e-2,
    );
    check(
        "gyro scale",
        Scalar::GyroScale(1),
        1e-3,
        second(&|_, _, x| x.gyro_rad_s.y *= 1.001),
        1e-2,
    );
    check(
        "accel scale",
        Scalar::AccelScale(2),
        1e-3,
        second(&|_, _, x| x.accel_m_s2.z *= 1.001),
        1e-3,
    );
    // The model's lever arm moved by +δ is the accelerometer at −δ from its described place.
    let d = Vector3::new(0.002, 0.0, 0.0);
    check(
        "lever arm",
        Scalar::LeverArm(0),
        0.002,
        second(&|_, s, x| {
            x.accel_m_s2 -= s.omega_dot.cross(&d) + s.omega.cross(&s.omega.cross(&d))
        }),
        3e-2,
    );
    // Known limit: the skew's residual change s·ẏ is nearly orthogonal to Φ, so its δθ is a
    // small remainder; it agrees with the second fit to 12 % for the mass and 40 % for J_C
    // (first order in s: the same at 0.2 ms and 2 ms), hence the loose bound.
    let skew = 2e-3;
    check(
        "time skew",
        Scalar::TimeSkew,
        skew,
        second(&|k, _, x| {
            let t = k as f64 / synth.rate_hz - skew;
            let s = synth.state(&g, t);
            let r = synth.lever_m;
            x.gyro_rad_s = s.omega;
            x.accel_m_s2 =
                s.specific_force + s.omega_dot.cross(&r) + s.omega.cross(&s.omega.cross(&r));
        }),
        0.5,
    );
}

/// A joint built 1 mm off the drawing: the same leg lengths solved on the described design
/// give the recorded pose, forces and lengths come from the built one.
#[test]
fn a_joint_off_the_drawing_matches_a_second_fit_on_the_built_design() {
    let g = testkit::geometry();
    let synth = Synth::default();
    let clean = fitted(&g, &synth, &synth.samples(&g, |_, _, _| {}));
    let none = LegsConfig::default();
    for (plate, leg, coord) in [(true, 3, 0), (false, 0, 2), (true, 5, 2)] {
        let sigma = 1e-3;
        let mut b = *g.base_joints_m();
        let mut p = *g.plate_joints_m();
        if plate {
            p[leg][coord] += sigma;
        } else {
            b[leg][coord] += sigma;
        }
        let built = Geometry::from_points(b, p, g.stroke()).unwrap();
        let off = Synth {
            built: Some(built),
            ..synth.clone()
        };
        let want = fitted(&g, &synth, &off.samples(&g, |_, _, _| {})) - clean;
        // The record is the described view: the built joints applied to it move θ the
        // other way.
        let got = -effect(&g, &synth, Scalar::Joint(plate, leg, coord), sigma, &none);
        assert_close(&format!("joint {plate} {leg} {coord}"), &got, &want, 3e-2);
    }
}

/// A closed form for the legs: with the cell at the base end, a massless cylinder and the
/// rod's mass m₂ all at the plate joint, the plate carries six point masses the estimator
/// does not see, so the fit's effect is minus their parameters.
#[test]
fn point_mass_legs_at_the_plate_joints_are_missed_whole() {
    let g = testkit::geometry();
    let synth = Synth::default();
    let m2 = 12.0;
    let l = LegsConfig {
        load_cell_end: LoadCellEnd::Base,
        cylinder_mass_kg: 0.0,
        cylinder_com_from_base_m: 0.5,
        cylinder_inertia_kg_m2: 0.0,
        rod_mass_kg: m2,
        rod_com_from_plate_m: 0.0,
        rod_inertia_kg_m2: 0.0,
        ..LegsConfig::default()
    };
    let got = effect(&g, &synth, Scalar::LegDynamics, 1.0, &l);
    let masses = g
        .plate_joints_m()
        .iter()
        .map(|p| estimator::InertialParameters::point_mass(m2, *p))
        .fold(estimator::InertialParameters::zero(), |a, b| a + b);
    assert_close("point-mass legs", &got, &(-masses.to_vector()), 2e-3);
    // Linear in the figure: twice the mass, twice the effect (a second run of the model).
    let twice = LegsConfig {
        rod_mass_kg: 2.0 * m2,
        ..l
    };
    let got2 = effect(&g, &synth, Scalar::LegDynamics, 1.0, &twice);
    assert_close("linearity", &got2, &(got * 2.0), 1e-9);
    // Compensated with the described legs, a rod mass off by δ leaves six point masses of δ.
    let delta = 0.24;
    let off = effect(&g, &synth, Scalar::LegFigure(3), delta, &l);
    assert_close(
        "rod mass off",
        &off,
        &(-masses.to_vector() * (delta / m2)),
        2e-3,
    );
    // Massless, frictionless legs: nothing, and no crosstalk either.
    let none = LegsConfig::default();
    for s in [
        Scalar::LegDynamics,
        Scalar::JointFriction,
        Scalar::Crosstalk(2, 1),
    ] {
        assert_eq!(effect(&g, &synth, s, 1.0, &none), ParameterVector::zeros());
    }
}

/// The accelerometer bias's effect from the budget's fit against the estimator's own exact
/// sensitivity (another conditioning, another weighting of the same equations).
#[test]
fn the_fits_bias_effect_matches_the_estimators_sensitivity() {
    let g = testkit::geometry();
    let synth = Synth {
        duration_s: 30.0,
        ..Synth::default()
    };
    let samples = synth.samples(&g, |_, _, _| {});
    let mut c = EstimatorConfig::new(g, 1e-3);
    c.accelerometer_position_m = synth.lever_m;
    c.lowpass_cutoff_hz = Some(5.0);
    c.equation_sigma = Vector6::new(5.0, 5.0, 5.0, 2.0, 2.0, 2.0);
    let mut est = OnlineEstimator::new(c).unwrap();
    // The budget's record holds the samples the estimator used, as online.
    let mut used = synth.record(&g, &[]);
    for s in &samples {
        if let Ok(estimator::Outcome::Used) = est.update(s) {
            used.push(s);
        }
    }
    let exact = est.accel_bias_sensitivity() * 0.01;
    let data = Data::new(used.entries(), model(&g, &synth));
    let fit = Fit::new(&data, &synth.body.to_vector()).expect("fit");
    let motions = legs::motions(&data, &fit.idx, fit.h);
    let described = LegsConfig::default();
    let legs = legs::effects(&data, &motions, &described);
    let ctx = Context {
        data: &data,
        fit: &fit,
        legs: &legs,
        described: &described,
        motions: &motions,
        imu: None,
        load_cells: None,
        rest_gravity_m_s2: None,
        joint_baseline: Default::default(),
        leg_maps: Default::default(),
    };
    for axis in 0..3 {
        let got = fit.effect(&Scalar::AccelBias(axis).residual_change(&ctx, 0.01));
        let want = ParameterVector::from_fn(|i, _| exact[(i, axis)]);
        // In the reported quantities (m, c, J_C): within 5 % for the vertical bias (the mass's
        // m·b/g, the largest effect); the horizontal ones reach J_C through weakly determined
        // combinations that the two fits' different filtering and warm-up weigh differently
        // (30 % apart here, measured), so only 40 % is asked. (In θ itself): θ's h and J_O move together along a
        // weakly determined direction that the two fits' different filtering resolves
        // differently, and that cancels in J_C.
        let g = estimator::uncertainty::derived_jacobian(&synth.body.to_vector());
        let (got, want) = (g * got, g * want);
        // Floors: what is negligible beside the z bias's 1.9 kg, 0.3 mm and 0.5 kg·m².
        for (name, range, floor) in [
            ("mass", 0..1, 0.02),
            ("com", 1..4, 3e-6),
            ("J_C", 4..10, 5e-3),
        ] {
            let scale = want.rows(range.start, range.len()).amax().max(floor);
            let err = (got - want).rows(range.start, range.len()).amax();
            assert!(
                err <= if axis == 2 { 0.05 } else { 0.4 } * scale,
                "bias {axis} {name}: {err:.3e} of {scale:.3e}\n{got:.4e}\n{want:.4e}"
            );
        }
    }
}

pub(super) fn figures() -> Figures {
    Figures::of(&rig_description::load::load(None).unwrap().config)
}

fn noisy(f: &Figures) -> Synth {
    let s = &f.sensors;
    Synth {
        duration_s: 30.0,
        noise: Some((
            [
                s.gyro_noise_rad_s(),
                s.accel_noise_m_s2(),
                s.load_cell.noise_n,
            ],
            7,
        )),
        frequencies: [0.3, 0.7, 1.1, 0.5, 0.9, 1.7],
        ..Synth::default()
    }
}

pub(super) fn run_budget(
    g: &Geometry,
    synth: &Synth,
    samples: &[Sample],
    f: &Figures,
) -> RunBudget {
    run_budget_with(g, synth, samples, f, |_| {})
}

/// [`run_budget`] with the estimator's settings changed by `settings`.
pub(super) fn run_budget_with(
    g: &Geometry,
    synth: &Synth,
    samples: &[Sample],
    f: &Figures,
    settings: impl FnOnce(&mut EstimatorConfig),
) -> RunBudget {
    let mut c = EstimatorConfig::new(*g, 1.0 / synth.rate_hz);
    c.accelerometer_position_m = synth.lever_m;
    c.equation_sigma = Vector6::new(5.0, 5.0, 5.0, 2.0, 2.0, 2.0);
    settings(&mut c);
    let mut e = estimator::Estimate::from_parameters(
        synth.body,
        estimator::ParameterCovariance::identity(),
    );
    e.counts.used = samples.len() as u64;
    analyse(
        &synth.record(g, samples),
        &c,
        f,
        &e,
        &EstimatorEffects::default(),
    )
}

/// A rigid body with the datasheet's noise passes; the same with a 1.3 Hz bounce of the body's
/// force (a car on its suspension) fails, and the check names the frequency.
#[test]
fn the_rigid_body_check_passes_a_rigid_body_and_flags_a_resonance() {
    let g = testkit::geometry();
    // The synthetic world's legs are massless and frictionless: so is its description.
    let f = Figures {
        legs: LegsConfig::default(),
        ..figures()
    };
    let synth = noisy(&f);
    let rigid = run_budget(&g, &synth, &synth.samples(&g, |_, _, _| {}), &f);
    let r = rigid.rigid_body.expect("checked");
    assert!(r.ok, "{r:?}");
    assert!(r.residual_ratio > 0.5 && r.residual_ratio < 2.0, "{r:?}");
    // 300 N vertical at 1.3 Hz, shared by the legs (about 2 % of the body's weight).
    let bounce = synth.samples(&g, |k, s, x| {
        let t = k as f64 / synth.rate_hz;
        let fz = 300.0 * (2.0 * core::f64::consts::PI * 1.3 * t).sin();
        let j = g.jacobian(&s.pose).transpose();
        let df = j
            .lu()
            .solve(&Vector6::new(0.0, 0.0, fz, 0.0, 0.0, 0.0))
            .unwrap();
        x.leg_forces_n += df;
    });
    let b = run_budget(&g, &synth, &bounce, &f)
        .rigid_body
        .expect("checked");
    assert!(!b.ok, "{b:?}");
    assert!((b.peak_hz - 1.3).abs() < 0.05, "{b:?}");
}

/// The bug: over a long run the cells' zero drift, which the estimator fits and takes out,
/// stayed in the record the budget's fit and the rigid-body check read, so a rigid payload
/// was flagged as moving. Here 30 s of cells drifting by up to 15 N/s (450 N at the end, the
/// check's ratio 5 when left in: 2.3 at a quarter of it, 8.4 at 1.6 times): left in the
/// record the check fails; with the estimator's drift taken out of it the check passes as
/// the drift-free run does, and the ratio is that run's to 1 %.
#[test]
fn the_fitted_drift_is_taken_out_of_the_record_before_the_rigid_body_check() {
    let g = testkit::geometry();
    let f = Figures {
        legs: LegsConfig::default(),
        ..figures()
    };
    let synth = noisy(&f);
    let rates = Vector6::new(15.0, -10.0, 8.0, -15.0, 5.0, 12.0);
    let clean = synth.samples(&g, |_, _, _| {});
    let start_s = clean.first().map_or(0.0, |s| s.time_s);
    let drifting = synth.samples(&g, |_, _, x| x.leg_forces_n += rates * (x.time_s - start_s));
    let mut c = EstimatorConfig::new(g, 1.0 / synth.rate_hz);
    c.accelerometer_position_m = synth.lever_m;
    c.equation_sigma = Vector6::new(5.0, 5.0, 5.0, 2.0, 2.0, 2.0);
    c.load_cell_drift = true;
    let mut e = estimator::Estimate::from_parameters(
        synth.body,
        estimator::ParameterCovariance::identity(),
    );
    e.counts.used = clean.len() as u64;
    let check = |samples: &[Sample], drift: Option<estimator::LoadCellDrift>| {
        let exact = EstimatorEffects {
            load_cell_drift: drift,
            ..EstimatorEffects::default()
        };
        analyse(&synth.record(&g, samples), &c, &f, &e, &exact)
            .rigid_body
            .expect("checked")
    };
    let reference = check(&clean, None);
    let left = check(&drifting, None);
    let taken = check(
        &drifting,
        Some(estimator::LoadCellDrift {
            rate_n_s: rates,
            covariance: Matrix6::zeros(),
            start_s,
        }),
    );
    std::eprintln!("drift-free {reference:?}\nleft in {left:?}\ntaken out {taken:?}");
    assert!(reference.ok && taken.ok, "{reference:?} {taken:?}");
    assert!(!left.ok, "{left:?}");
    assert!(
        (taken.residual_ratio / reference.residual_ratio - 1.0).abs() < 0.01,
        "{taken:?} against {reference:?}"
    );
}

/// Regression, configs/paper.toml: a rig described as ideal predicts no residual, so the
/// check has nothing to judge by and is not made (against the numerical floor alone a rigid
/// payload reads 187 times it), while the same data with the datasheet's figures are checked
/// and pass.
#[test]
fn an_ideal_rig_description_makes_no_rigid_body_check() {
    let g = testkit::geometry();
    let datasheet = Figures {
        legs: LegsConfig::default(),
        ..figures()
    };
    let ideal = Figures {
        sensors: datasheet.sensors.scaled(0.0),
        joint_tolerance_m: 0.0,
        ..datasheet.clone()
    };
    let synth = Synth {
        duration_s: 30.0,
        frequencies: [0.3, 0.7, 1.1, 0.5, 0.9, 1.7],
        ..Synth::default()
    };
    let samples = synth.samples(&g, |_, _, _| {});
    assert_eq!(run_budget(&g, &synth, &samples, &ideal).rigid_body, None);
    let checked = run_budget(&g, &synth, &samples, &datasheet)
        .rigid_body
        .expect("checked with the datasheet's figures");
    assert!(checked.ok, "{checked:?}");
}

/// Every systematic source gets its fixed number of effects, and the default figures give
/// every one a non-zero effect except the legs' crosstalk, dynamics and friction, which need
/// the legs' own transverse force: here present (default legs have mass).
#[test]
fn every_systematic_source_has_an_effect() {
    let g = testkit::geometry();
    let f = figures();
    let synth = Synth::default();
    let b = run_budget(&g, &synth, &synth.samples(&g, |_, _, _| {}), &f);
    for source in rig_description::sources::ErrorSource::ALL {
        let n = perturb::scalars(source, &f).len();
        let e = b.effects_of(source);
        assert_eq!(e.len(), n, "{source}");
        if n > 0 {
            assert!(
                e.iter().flatten().any(|v| *v != 0.0),
                "{source} has no effect"
            );
        }
    }
    assert!(
        b.jitter_share > 0.0 && b.jitter_share < 0.1,
        "{}",
        b.jitter_share
    );
}
