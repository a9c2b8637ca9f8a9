//! Whole-estimator tests against an independent rigid-body model (`testkit`).

use crate::online::{
    neumann_solve, Correction, EstimatorConfig, OnlineEstimator, Outcome, ParameterSet, Sample,
};
use crate::regressor::rigid_body;
use crate::rls::{NormalEquations, Rls};
use crate::testkit::{
    random_body, synthetic_sample, test_geometry, Motion, PointBody, SensorNoise,
};
use nalgebra::{Cholesky, SMatrix, SVector, Vector3, Vector6};
use rand::{rngs::StdRng, Rng, SeedableRng};
use std::vec::Vec;
use stewart_types::ParameterVector;

/// Scale of each parameter's group (mass; first moment; tensor), so that a tiny product of
/// inertia is judged against the size of the tensor rather than against itself.
fn group_scales(theta: &ParameterVector) -> ParameterVector {
    let h = theta.fixed_rows::<3>(1).norm();
    let j = (theta[4] + theta[5] + theta[6]) / 3.0;
    ParameterVector::from_fn(|i, _| match i {
        0 => theta[0].abs(),
        1..=3 => h.max(theta[i].abs()),
        _ => j.max(theta[i].abs()),
    })
}

fn worst_relative(estimate: &ParameterVector, truth: &ParameterVector) -> f64 {
    let s = group_scales(truth);
    (0..10)
        .map(|i| (estimate[i] - truth[i]).abs() / s[i])
        .fold(0.0, f64::max)
}

fn random_motion(rng: &mut StdRng) -> Motion {
    let mut m = Motion::rich();
    for axis in m.translation.iter_mut().chain(m.rotation.iter_mut()) {
        for term in axis.terms.iter_mut() {
            term.0 *= rng.random_range(0.5..1.5);
            term.1 *= rng.random_range(0.8..1.25);
            term.2 = rng.random_range(0.0..std::f64::consts::TAU);
        }
    }
    m
}

/// Exact recovery: ten parameters of random point-mass bodies along random rich motions,
/// from exact states (ω, ω̇, f) and the wrench of the independent model, through the regressor
/// and the U-D RLS with the online estimator's weak prior; and the batch solver over the same
/// rows. All ten parameters to 1e-9 of their group's scale.
#[test]
fn exact_recovery_of_random_bodies() {
    let mut rng = StdRng::seed_from_u64(2024);
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let body = random_body(&mut rng);
        let truth = body.parameters().to_vector();
        let motion = random_motion(&mut rng);
        let sigma = Vector6::new(1.0, 1.0, 1.0, 0.2, 0.2, 0.2);
        let w = sigma.map(|s| 1.0 / s);
        let mut rls = Rls::<10>::new(SVector::zeros(), SVector::from_element(1e8), 1.0).unwrap();
        let mut batch = NormalEquations::<10>::new(1.0).unwrap();
        for k in 0..600 {
            let s = motion.state(0.01 * k as f64);
            let phi = rigid_body(&s.omega, &s.omega_dot, &s.specific_force);
            let y = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
            let rows = SMatrix::<f64, 6, 10>::from_fn(|r, c| phi[(r, c)] * w[r]);
            let wy = y.component_mul(&w);
            rls.update(&rows, &wy);
            batch.add(&rows, &wy);
        }
        worst = worst.max(worst_relative(rls.theta(), &truth));
        worst = worst.max(worst_relative(&batch.solve().unwrap(), &truth));
    }
    std::eprintln!("exact recovery: worst relative error {worst:.2e}");
    assert!(worst < 1e-9, "worst relative error {worst:e}");
}

fn config(cutoff: Option<f64>, period: f64) -> EstimatorConfig {
    let mut c = EstimatorConfig::new(test_geometry(), period);
    c.lowpass_cutoff_hz = cutoff;
    c
}

/// The estimator for [`SensorNoise`]'s noise at 1/`period` Hz behind a 20 Hz low-pass: its
/// gyro and accelerometer figures, equation sigmas near the residuals', half-blocks of `block`
/// samples.
fn noisy_config(noise: &SensorNoise, period: f64, block: u32) -> EstimatorConfig {
    let mut c = config(Some(20.0), period);
    c.equation_sigma = Vector6::new(26.0, 26.0, 26.0, 10.0, 10.0, 10.0);
    c.gyro_noise_rad_s = noise.gyro_rad_s;
    c.accel_noise_m_s2 = noise.accel_m_s2;
    c.covariance_half_block_samples = block;
    c
}

/// A noiseless [`synthetic_sample`] with the accelerometer at the P origin.
fn exact_sample(
    geometry: &kinematics::Geometry,
    body: &PointBody,
    motion: &Motion,
    t: f64,
    rng: &mut StdRng,
) -> crate::online::Sample {
    synthetic_sample(
        geometry,
        body,
        motion,
        t,
        &Vector3::zeros(),
        &SensorNoise::default(),
        rng,
    )
}

#[allow(clippy::too_many_arguments)]
fn run(
    estimator: &mut OnlineEstimator,
    body: &PointBody,
    motion: &Motion,
    samples: usize,
    period: f64,
    accel_at: &Vector3<f64>,
    noise: &SensorNoise,
    rng: &mut StdRng,
) {
    let g = estimator.config().geometry;
    for k in 0..samples {
        let s = synthetic_sample(&g, body, motion, k as f64 * period, accel_at, noise, rng);
        estimator.update(&s).unwrap();
    }
}

/// The whole pipeline on noiseless data at 1 kHz: leg forces through the kinematics, gyro and
/// an accelerometer off the P origin, derivative and 20 Hz low-pass. What is left is the
/// O((ωΔt)⁴) error of the interpolation stencils.
#[test]
fn pipeline_recovers_a_vehicle_from_leg_forces_and_imu() {
    let body = PointBody::vehicle_like();
    let truth = body.parameters();
    let accel_at = Vector3::new(0.4, -0.3, 0.08);
    let mut c = config(Some(20.0), 1e-3);
    c.accelerometer_position_m = accel_at;
    let mut est = OnlineEstimator::new(c).unwrap();
    let mut rng = StdRng::seed_from_u64(1);
    run(
        &mut est,
        &body,
        &Motion::rich(),
        8000,
        1e-3,
        &accel_at,
        &SensorNoise::default(),
        &mut rng,
    );
    let e = est.estimate();
    let err = worst_relative(&e.parameters.to_vector(), &truth.to_vector());
    std::eprintln!(
        "pipeline: worst relative error {err:.2e}, residual rms {:.2e}",
        e.residual_rms.max()
    );
    assert!(err < 1e-8, "worst relative error {err:e}");
    assert!((e.com_m - truth.com_m().unwrap()).norm() < 1e-5);
    assert!(e.consistency.is_consistent());
    // The stencil's three samples and the 20 Hz low-pass's warm-up (≈ 10 time constants).
    assert_eq!(e.counts.used + e.counts.conditioning, 8000);
    assert!((60..100).contains(&e.counts.conditioning), "{:?}", e.counts);
    // Residual rms is tiny compared with the wrench (≈ 1.2e4 N, ≈ 5e3 N·m).
    assert!(e.residual_rms.max() < 1.0, "{}", e.residual_rms);
}

/// The paper's case: noiseless, centre of mass at the P origin, the three sines of Eq. 8, the
/// six-parameter form. Every entry must stay within 1 % from fewer than 100 samples on.
#[test]
fn paper_case_converges_within_100_samples() {
    let pairs = [
        (40.0, Vector3::new(0.9, 0.35, 0.25)),
        (30.0, Vector3::new(-0.4, 0.6, 0.15)),
        (25.0, Vector3::new(0.2, -0.3, 0.5)),
        (20.0, Vector3::new(0.6, 0.1, -0.3)),
    ];
    let mut body = PointBody {
        masses_kg: Vec::new(),
        positions_m: Vec::new(),
    };
    for (m, r) in pairs {
        body.masses_kg.extend([m, m]);
        body.positions_m.extend([r, -r]);
    }
    let truth = body.parameters();
    assert!(truth.first_moment_kg_m.norm() < 1e-12);
    let jc = truth.inertia_com_kg_m2().unwrap();
    let truth6 = [
        jc[(0, 0)],
        jc[(1, 1)],
        jc[(2, 2)],
        jc[(0, 1)],
        jc[(0, 2)],
        jc[(1, 2)],
    ];
    let scale = (truth6[0] + truth6[1] + truth6[2]) / 3.0;

    let period = 0.01;
    let mut c = config(None, period);
    c.parameters = ParameterSet::InertiaAboutKnownCom {
        mass_kg: truth.mass_kg,
        com_m: Vector3::zeros(),
    };
    let mut est = OnlineEstimator::new(c).unwrap();
    let motion = Motion::paper(test_geometry().home_pose().position_m);
    let mut rng = StdRng::seed_from_u64(0);
    let g = test_geometry();
    let mut last_outside = 0;
    for k in 0..400 {
        let s = exact_sample(&g, &body, &motion, k as f64 * period, &mut rng);
        est.update(&s).unwrap();
        let e = est.estimate();
        let j = e.inertia_com_kg_m2;
        let got = [
            j[(0, 0)],
            j[(1, 1)],
            j[(2, 2)],
            j[(0, 1)],
            j[(0, 2)],
            j[(1, 2)],
        ];
        // "Within 1 %" of each entry, products of inertia judged against the tensor's scale.
        let ok =
            (0..6).all(|i| (got[i] - truth6[i]).abs() <= 0.01 * truth6[i].abs().max(0.1 * scale));
        if !ok {
            last_outside = k + 1;
        }
    }
    std::eprintln!("paper case: every entry within 1 % from sample {last_outside}");
    assert!(
        last_outside < 100,
        "entries within 1 % only from sample {last_outside}"
    );
    assert_eq!(est.estimate().mass_sigma_kg, 0.0);
}

/// Tare: the fixture (a sixth of the payload's mass, centre of mass elsewhere) measured alone,
/// then fixture plus payload; loaded − tare recovers the payload, while ignoring the tare would
/// be far off.
#[test]
fn tare_subtraction_recovers_the_payload() {
    let payload = PointBody::vehicle_like();
    let fixture = PointBody {
        masses_kg: std::vec![90.0, 60.0, 45.0, 35.0],
        positions_m: std::vec![
            Vector3::new(-0.6, 0.5, 0.05),
            Vector3::new(0.7, 0.4, 0.1),
            Vector3::new(0.1, -0.8, 0.02),
            Vector3::new(-0.3, -0.2, 0.3),
        ],
    };
    let truth = payload.parameters();
    let tare_truth = fixture.parameters();
    assert!(tare_truth.mass_kg >= truth.mass_kg / 6.0);
    let mut loaded = fixture.clone();
    loaded.masses_kg.extend(payload.masses_kg.iter().copied());
    loaded
        .positions_m
        .extend(payload.positions_m.iter().copied());

    let mut rng = StdRng::seed_from_u64(4);
    let noise = SensorNoise::default();
    let mut tare_est = OnlineEstimator::new(config(Some(20.0), 1e-3)).unwrap();
    run(
        &mut tare_est,
        &fixture,
        &Motion::rich(),
        6000,
        1e-3,
        &Vector3::zeros(),
        &noise,
        &mut rng,
    );
    let mut loaded_est = OnlineEstimator::new(config(Some(20.0), 1e-3)).unwrap();
    run(
        &mut loaded_est,
        &loaded,
        &Motion::rich(),
        6000,
        1e-3,
        &Vector3::zeros(),
        &noise,
        &mut rng,
    );
    let tare = tare_est.estimate();
    let e = loaded_est
        .estimate()
        .without_tare(&tare.parameters, &tare.covariance);

    let err = worst_relative(&e.parameters.to_vector(), &truth.to_vector());
    std::eprintln!("tare: payload worst relative error {err:.2e}");
    assert!(err < 1e-8, "payload worst relative error {err:e}");
    assert!((e.com_m - truth.com_m().unwrap()).norm() < 1e-4);
    let jc = truth.inertia_com_kg_m2().unwrap();
    assert!((e.inertia_com_kg_m2 - jc).norm() < 1e-4 * jc.norm());
    // Without the tare the centre of mass is off by centimetres and the mass by 18 %.
    let raw = loaded_est.estimate();
    assert!((raw.com_m - truth.com_m().unwrap()).norm() > 0.01);
    assert!((raw.mass_kg() - truth.mass_kg).abs() > 0.1 * truth.mass_kg);
}

/// Noise: Gaussian noise on the six leg forces, the gyro and the accelerometer; over many seeds
/// (40 s each) the errors must match the reported sigmas: mean z² in [0.5, 2] for every
/// parameter (θ and the derived c and J_C).
#[test]
fn reported_sigmas_match_the_spread_over_seeds() {
    let body = PointBody::vehicle_like();
    let truth = body.parameters();
    let t = truth.to_vector();
    let c_true = truth.com_m().unwrap();
    let jc_true = truth.inertia_com_kg_m2().unwrap();
    let noise = SensorNoise {
        leg_force_n: 5.0,
        gyro_rad_s: 2e-3,
        accel_m_s2: 0.02,
    };
    let seeds = 48;
    let period = 1e-3;
    let mut z2 = ParameterVector::zeros();
    let mut z2_derived = ParameterVector::zeros();
    let mut rel = ParameterVector::zeros();
    for seed in 0..seeds {
        // Half-blocks of 0.4 s, the default (100 per run). The gyro's derivative noise, J ω̇,
        // reaches the scores of h (whose regressor column, gravity, is nearly constant): its
        // slopes' share and the fit's J error are taken out of them (`crate::score`). Without
        // the latter c_z's mean z² is 0.50 here.
        let mut est = OnlineEstimator::new(noisy_config(&noise, period, 400)).unwrap();
        let mut rng = StdRng::seed_from_u64(1000 + seed);
        run(
            &mut est,
            &body,
            &Motion::rich(),
            40_000,
            period,
            &Vector3::zeros(),
            &noise,
            &mut rng,
        );
        let e = est.estimate();
        let theta = e.parameters.to_vector();
        for i in 0..10 {
            let z = (theta[i] - t[i]) / e.parameter_sigma[i];
            z2[i] += z * z / seeds as f64;
            rel[i] = rel[i].max(e.parameter_sigma[i] / group_scales(&t)[i]);
        }
        let mut d = ParameterVector::zeros();
        let mut ds = ParameterVector::zeros();
        d[0] = e.mass_kg() - truth.mass_kg;
        ds[0] = e.mass_sigma_kg;
        for k in 0..3 {
            d[1 + k] = e.com_m[k] - c_true[k];
            ds[1 + k] = e.com_sigma_m[k];
        }
        for (k, r, col) in stewart_types::TENSOR_ENTRIES {
            d[k] = e.inertia_com_kg_m2[(r, col)] - jc_true[(r, col)];
            ds[k] = e.inertia_com_sigma_kg_m2[(r, col)];
        }
        for i in 0..10 {
            z2_derived[i] += (d[i] / ds[i]).powi(2) / seeds as f64;
        }
    }
    std::eprintln!("noise: mean z² of θ {:.2?}", z2.as_slice());
    std::eprintln!("noise: mean z² of m, c, J_C {:.2?}", z2_derived.as_slice());
    std::eprintln!("noise: largest sigma / scale {:.1e}", rel.max());
    for i in 0..10 {
        assert!((0.5..=2.0).contains(&z2[i]), "θ[{i}]: mean z² {}", z2[i]);
        assert!(
            (0.5..=2.0).contains(&z2_derived[i]),
            "derived[{i}]: mean z² {}",
            z2_derived[i]
        );
    }
}

/// A table of exact weighted samples of a body along a rich motion, for the long runs.
fn exact_table(body: &PointBody, count: usize) -> Vec<(SMatrix<f64, 6, 10>, SVector<f64, 6>)> {
    let motion = Motion::rich();
    let w = Vector6::new(1.0, 1.0, 1.0, 5.0, 5.0, 5.0);
    (0..count)
        .map(|k| {
            let s = motion.state(0.0137 * k as f64);
            let phi = rigid_body(&s.omega, &s.omega_dot, &s.specific_force);
            let y = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
            (
                SMatrix::from_fn(|r, c| phi[(r, c)] * w[r]),
                y.component_mul(&w),
            )
        })
        .collect()
}

/// Long run: 10⁷ sample updates (six scalar updates each) on exact data, λ = 1 and λ = 0.999.
/// P must stay symmetric positive definite and equal to the inverse of the information matrix
/// of the same rows (computed in closed form for the periodic sequence), and θ must not move
/// from the truth by more than 1e-9 of its scale.
fn long_run(lambda: f64) {
    let body = PointBody::vehicle_like();
    let truth = body.parameters().to_vector();
    let cycle = 1000;
    let table = exact_table(&body, cycle);
    let mut rls = Rls::<10>::new(SVector::zeros(), SVector::from_element(1e8), lambda).unwrap();
    let total: usize = 10_000_000;
    for k in 0..total {
        let (rows, y) = &table[k % cycle];
        rls.update(rows, y);
        if k == 10 * cycle {
            let err = worst_relative(rls.theta(), &truth);
            assert!(err < 1e-9, "after {k}: {err:e}");
        }
    }
    let err = worst_relative(rls.theta(), &truth);
    std::eprintln!("long run λ = {lambda}: worst relative error {err:.2e}");
    assert!(err < 1e-9, "λ = {lambda}: worst relative error {err:e}");

    let (_, d) = rls.factors();
    assert!(d.iter().all(|v| *v > 0.0 && v.is_finite()));
    let p = rls.covariance();
    assert_eq!(p, p.transpose());
    assert!(Cholesky::new(p).is_some());
    // Information after `total` samples of a periodic sequence (prior long forgotten or
    // negligible): A = Σ_cycle λ^(age) φφᵀ · Σ_j λ^(j·cycle), i.e. one cycle's discounted
    // information times the number (λ = 1) or geometric sum (λ < 1) of cycles.
    let mut one = NormalEquations::<10>::new(lambda).unwrap();
    for (rows, y) in &table {
        one.add(rows, y);
    }
    let cycles = (total / cycle) as f64;
    let repeat = if lambda < 1.0 {
        (1.0 - lambda.powf(cycle as f64 * cycles)) / (1.0 - lambda.powf(cycle as f64))
    } else {
        cycles
    };
    let expect = Cholesky::new(one.information() * repeat).unwrap().inverse();
    for i in 0..10 {
        for j in 0..10 {
            let scale = (expect[(i, i)] * expect[(j, j)]).sqrt();
            assert!(
                (p[(i, j)] - expect[(i, j)]).abs() < 1e-6 * scale,
                "λ = {lambda}: P[{i},{j}] = {} vs {}",
                p[(i, j)],
                expect[(i, j)]
            );
        }
    }
}

#[test]
fn long_run_without_forgetting() {
    long_run(1.0);
}

#[test]
fn long_run_with_forgetting() {
    long_run(0.999);
}

/// The per-sample history's θ (a Neumann series on the last block's verdict) is the checked θ to
/// rounding at every sample of a run whose regressor-noise correction applies, and it does
/// take the correction (it differs from the plain least-squares θ).
#[test]
fn quick_theta_is_the_corrected_theta_along_a_noisy_run() {
    let body = PointBody::vehicle_like();
    let mut c = config(Some(20.0), 1e-3);
    c.gyro_noise_rad_s = 2e-2;
    let mut e = OnlineEstimator::new(c).unwrap();
    let g = test_geometry();
    let noise = SensorNoise {
        leg_force_n: 3.0,
        gyro_rad_s: 2e-2,
        accel_m_s2: 0.01,
    };
    let mut rng = StdRng::seed_from_u64(5);
    let (mut compared, mut worst, mut correction) = (0, 0.0f64, 0.0f64);
    for k in 0..3000 {
        let s = synthetic_sample(
            &g,
            &body,
            &Motion::rich(),
            k as f64 * 1e-3,
            &Vector3::zeros(),
            &noise,
            &mut rng,
        );
        if e.update(&s) != Ok(Outcome::Used) || k < 1500 {
            continue;
        }
        let (full, quick) = (e.theta(), e.theta_quick());
        let scale = group_scales(&full);
        for i in 0..10 {
            worst = worst.max((quick[i] - full[i]).abs() / scale[i]);
        }
        let plain = e.assemble(Correction::None);
        correction = correction.max(((full - plain).component_div(&scale)).amax());
        compared += 1;
    }
    assert!(compared > 1000, "{compared} samples compared");
    assert!(
        correction > 1e-6,
        "the correction did not apply: {correction:e}"
    );
    assert!(
        worst < 1e-10,
        "quick θ off the checked one by {worst:e} of scale"
    );
}

/// The same stream gives bit-identical estimates (what `stewart estimate` relies on to
/// reproduce an online run), and the window and gap rules behave as documented.
#[test]
fn deterministic_and_windowed() {
    let body = PointBody::vehicle_like();
    let mut c = config(Some(20.0), 1e-3);
    c.window_start_s = 0.5;
    c.window_end_s = 1.5;
    c.gyro_noise_rad_s = 1e-3;
    let mut a = OnlineEstimator::new(c).unwrap();
    let mut b = OnlineEstimator::new(c).unwrap();
    let g = test_geometry();
    let noise = SensorNoise {
        leg_force_n: 3.0,
        gyro_rad_s: 1e-3,
        accel_m_s2: 0.01,
    };
    let mut rng = StdRng::seed_from_u64(77);
    let mut samples = Vec::new();
    for k in 0..2000 {
        // A 50 ms gap at 1 s restarts the conditioning.
        let t = k as f64 * 1e-3 + if k >= 1000 { 0.05 } else { 0.0 };
        samples.push(synthetic_sample(
            &g,
            &body,
            &Motion::rich(),
            t,
            &Vector3::zeros(),
            &noise,
            &mut rng,
        ));
    }
    for s in &samples {
        a.update(s).unwrap();
    }
    for s in &samples {
        b.update(s).unwrap();
    }
    let (ea, eb) = (a.estimate(), b.estimate());
    assert_eq!(ea.parameters.to_vector(), eb.parameters.to_vector());
    assert_eq!(ea.covariance, eb.covariance);
    let counts = ea.counts;
    assert_eq!(counts.restarts, 1);
    assert_eq!(counts.after_window, 2000 - 1451);
    // Before 0.5 s, and after the restart three (the stencil) plus the low-pass's warm-up,
    // feed only the conditioning.
    let warmup = crate::conditioning::Conditioner::new(crate::conditioning::ConditioningConfig {
        sample_period_s: 1e-3,
        lowpass_cutoff_hz: Some(20.0),
        accelerometer_position_m: Vector3::zeros(),
        max_gap_s: 0.01,
        max_rate_error: 1e-4,
        gyro_noise_rad_s: 0.0,
    })
    .unwrap()
    .warmup_samples() as u64;
    assert!((60..100).contains(&warmup), "{warmup}");
    assert_eq!(counts.conditioning, 500 + 3 + warmup);
    assert_eq!(counts.used, 1451 - 503 - warmup);
    assert_eq!(counts.rejected, 0);
}

/// `EstimatorConfig::conditioning` carries each of the configuration's conditioning settings,
/// and the estimator conditions with exactly those: the samples it withholds at the start are
/// the stencil's three and the warm-up of a conditioner built from them, for cut-offs whose
/// warm-ups differ.
#[test]
fn the_estimator_conditions_as_its_configuration_says() {
    let mut c = config(Some(7.5), 2e-3);
    c.accelerometer_position_m = Vector3::new(0.1, -0.2, 0.3);
    c.max_gap_s = 0.05;
    c.max_rate_error = 3e-4;
    c.gyro_noise_rad_s = 2e-3;
    assert_eq!(
        c.conditioning(),
        crate::conditioning::ConditioningConfig {
            sample_period_s: 2e-3,
            lowpass_cutoff_hz: Some(7.5),
            accelerometer_position_m: Vector3::new(0.1, -0.2, 0.3),
            max_gap_s: 0.05,
            max_rate_error: 3e-4,
            gyro_noise_rad_s: 2e-3,
        }
    );
    let body = PointBody::vehicle_like();
    let g = test_geometry();
    let mut rng = StdRng::seed_from_u64(5);
    let mut warmups = Vec::new();
    for cutoff in [Some(5.0), Some(40.0)] {
        let c = config(cutoff, 1e-3);
        let warmup = crate::conditioning::Conditioner::new(c.conditioning())
            .unwrap()
            .warmup_samples() as u64;
        let mut e = OnlineEstimator::new(c).unwrap();
        for k in 0..1000 {
            let s = synthetic_sample(
                &g,
                &body,
                &Motion::rich(),
                k as f64 * 1e-3,
                &Vector3::zeros(),
                &SensorNoise::default(),
                &mut rng,
            );
            e.update(&s).unwrap();
        }
        let counts = e.counts();
        assert_eq!(counts.conditioning, 3 + warmup, "cut-off {cutoff:?}");
        assert_eq!(counts.used, 1000 - 3 - warmup, "cut-off {cutoff:?}");
        warmups.push(warmup);
    }
    assert!(warmups[0] > warmups[1], "{warmups:?}");
}

mod robustness {
    use super::*;
    use crate::error::ErrorKind;
    use proptest::prelude::*;

    fn corrupt(s: &mut Sample, what: u8, value: f64) {
        match what % 9 {
            0 => s.gyro_rad_s[(value.to_bits() % 3) as usize] = value,
            1 => s.accel_m_s2[(value.to_bits() % 3) as usize] = value,
            2 => s.leg_forces_n[(value.to_bits() % 6) as usize] = value,
            3 => s.pose.position_m.x = value,
            4 => s.time_s = value,
            5 => s.time_s -= 0.5,
            6 => s.gyro_rad_s *= value,
            7 => s.leg_forces_n *= value,
            _ => {}
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// No input makes the estimator panic; every bad sample is rejected, counted and
        /// leaves a finite estimate behind.
        #[test]
        fn never_panics_and_counts_every_sample(
            edits in prop::collection::vec((any::<u8>(), any::<f64>(), 0usize..300), 0..40)
        ) {
            let body = PointBody::vehicle_like();
            let mut c = config(Some(20.0), 1e-3);
            c.gyro_noise_rad_s = 1e-3;
            let mut est = OnlineEstimator::new(c).unwrap();
            let g = test_geometry();
            let mut rng = StdRng::seed_from_u64(3);
            let mut calls = 0u64;
            for k in 0..300 {
                let mut s = synthetic_sample(&g, &body, &Motion::rich(), k as f64 * 1e-3,
                    &Vector3::zeros(), &SensorNoise::default(), &mut rng);
                for (what, value, at) in &edits {
                    if *at == k {
                        corrupt(&mut s, *what, *value);
                    }
                }
                calls += 1;
                match est.update(&s) {
                    Ok(_) => {}
                    Err(e) => prop_assert_eq!(e.kind(), ErrorKind::RejectedSample),
                }
            }
            let e = est.estimate();
            let n = e.counts;
            prop_assert_eq!(n.used + n.conditioning + n.rejected + n.after_window, calls);
            prop_assert!(e.parameters.to_vector().iter().all(|v| v.is_finite()));
            prop_assert!(e.covariance.iter().all(|v| v.is_finite()));
        }
    }
}

/// Two estimators fed the vehicle along the rich motion through the six-axis path, with
/// Gaussian noise of `noise_n` on every wrench entry, the second one's wrench shifted by `w0`.
fn twin_wrench_run(
    config: EstimatorConfig,
    noise_n: f64,
    samples: usize,
    seed: u64,
    w0: Vector6<f64>,
) -> (OnlineEstimator, OnlineEstimator) {
    use rand_distr::{Distribution, Normal};
    let body = PointBody::vehicle_like();
    let motion = Motion::rich();
    let mut plain = OnlineEstimator::new(config).unwrap();
    let mut shifted = plain.clone();
    let mut rng = StdRng::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise_n).unwrap();
    let wrench = |w: &Vector6<f64>| kinematics::Wrench {
        force_n: w.fixed_rows::<3>(0).into_owned(),
        torque_nm: w.fixed_rows::<3>(3).into_owned(),
    };
    for k in 0..samples {
        let t = k as f64 * config.sample_period_s;
        let s = motion.state(t);
        let mut w = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
        for v in w.iter_mut() {
            *v += normal.sample(&mut rng);
        }
        plain
            .update_with_wrench(t, &wrench(&w), &s.omega, &s.specific_force)
            .unwrap();
        shifted
            .update_with_wrench(t, &wrench(&(w + w0)), &s.omega, &s.specific_force)
            .unwrap();
    }
    (plain, shifted)
}

/// A constant wrench offset (a load cell's zero offset, m·b and h × b of an accelerometer
/// bias) is a constant error, not noise: it must not inflate the reported sigmas. The bug this
/// guards against: the block scores counted each block's share of a constant offset as noise,
/// and the default scenario's realistic load-cell offsets (4 N per cell) tripled σ(J_zz) while
/// moving J_zz by a fifth of that. Here an offset of a few times the noise: the sigmas must
/// stay those of the offset-free twin (same noise draws).
#[test]
fn constant_wrench_offset_does_not_inflate_the_sigmas() {
    let mut c = config(Some(20.0), 1e-3);
    c.equation_sigma = Vector6::new(5.0, 5.0, 5.0, 5.0, 5.0, 5.0);
    let w0 = Vector6::new(30.0, -20.0, 25.0, 15.0, -25.0, 20.0);
    let (plain, shifted) = twin_wrench_run(c, 5.0, 12_000, 7, w0);
    let (a, b) = (plain.estimate(), shifted.estimate());
    for i in 0..10 {
        let ratio = b.parameter_sigma[i] / a.parameter_sigma[i];
        assert!(
            (0.9..1.1).contains(&ratio),
            "θ[{i}]: sigma {} with the offset, {} without",
            b.parameter_sigma[i],
            a.parameter_sigma[i]
        );
    }
}

/// The first-order sensitivities against a second fit fed the perturbed samples: a constant
/// wrench offset moves θ exactly linearly; an accelerometer bias (a regressor perturbation)
/// to first order.
#[test]
fn offset_and_bias_sensitivities_match_a_second_fit() {
    let mut c = config(Some(20.0), 1e-3);
    c.equation_sigma = Vector6::new(26.0, 26.0, 26.0, 10.0, 10.0, 10.0);
    c.gyro_noise_rad_s = 2e-3;
    c.accel_noise_m_s2 = 0.02;
    let noise = SensorNoise {
        leg_force_n: 5.0,
        gyro_rad_s: 2e-3,
        accel_m_s2: 0.02,
    };
    let body = PointBody::vehicle_like();
    let motion = Motion::rich();
    let g = c.geometry;
    // Accelerometer bias of 1e-3 m/s² along each axis in turn.
    for axis in 0..3 {
        let mut plain = OnlineEstimator::new(c).unwrap();
        let mut biased = plain.clone();
        let mut rng = StdRng::seed_from_u64(3);
        for k in 0..6000 {
            let t = k as f64 * 1e-3;
            let s = synthetic_sample(&g, &body, &motion, t, &Vector3::zeros(), &noise, &mut rng);
            let mut p = s;
            p.accel_m_s2[axis] += 1e-3;
            plain.update(&s).unwrap();
            biased.update(&p).unwrap();
        }
        let effect = biased.theta() - plain.theta();
        let predicted = plain.accel_bias_sensitivity().column(axis) * 1e-3;
        let worst = (predicted - effect).abs().max();
        std::eprintln!(
            "accel bias axis {axis}: largest effect {:.3e}, largest first-order miss {worst:.3e}",
            effect.abs().max()
        );
        assert!(
            worst <= 1e-3 * effect.abs().max(),
            "axis {axis}: predicted {predicted} vs {effect}"
        );
    }
    // Constant leg-force offsets (load-cell zero offsets): they reach the wrench through the
    // pose-dependent leg directions, which the rich motion turns by up to 0.25 rad.
    let offsets = Vector6::new(4.0, -3.0, 5.0, -4.0, 2.0, 6.0);
    for parameters in both_parameter_sets() {
        let mut cc = c;
        cc.parameters = parameters;
        cc.leg_force_offsets = true;
        let mut plain = OnlineEstimator::new(cc).unwrap();
        let mut shifted = plain.clone();
        let mut rng = StdRng::seed_from_u64(4);
        for k in 0..6000 {
            let t = k as f64 * 1e-3;
            let s = synthetic_sample(&g, &body, &motion, t, &Vector3::zeros(), &noise, &mut rng);
            let mut p = s;
            p.leg_forces_n += offsets;
            plain.update(&s).unwrap();
            shifted.update(&p).unwrap();
        }
        let effect = shifted.theta() - plain.theta();
        let predicted = plain.leg_force_offset_sensitivity() * offsets;
        // The home-pose (constant-offset) approximation misses the pose dependence.
        let home = plain.wrench_offset_sensitivity()
            * crate::wrench::to_vector(&crate::wrench::measured(&g, &g.home_pose(), &offsets));
        std::eprintln!(
            "leg offsets {parameters:?}: miss {:.1e}, home-pose miss {:.1e} of {:.1e}",
            (predicted - effect).norm(),
            (home - effect).norm(),
            effect.norm()
        );
        assert!(
            (predicted - effect).norm() <= 1e-6 * effect.norm(),
            "{parameters:?}: predicted {predicted} vs {effect}"
        );
    }
    // A constant wrench offset, through the six-axis path (no pose dependence).
    let w0 = Vector6::new(12.0, -7.0, 20.0, 3.0, -5.0, 4.0);
    for parameters in both_parameter_sets() {
        let mut cc = c;
        cc.parameters = parameters;
        let (plain, shifted) = twin_wrench_run(cc, 5.0, 6000, 5, w0);
        let effect = shifted.theta() - plain.theta();
        let predicted = plain.wrench_offset_sensitivity() * w0;
        assert!(
            (predicted - effect).norm() <= 1e-6 * effect.norm(),
            "{parameters:?}: predicted {predicted} vs {effect}"
        );
    }
}

/// The bug: the low-pass started from the first raw ω̇, which carries one sample's derivative
/// noise (≈ 1000× the filtered level at 1 kHz), and the RLS took the filter's start transient
/// as data, biasing J (the CLI once worked around it by warming the estimator on frames from
/// before the excitation). Here noiseless samples but for one gyro excursion of 2 mrad/s in
/// the first sample, fed from the first sample on, with a gap-restart later: the estimate must
/// stay exact, because no sample reaches the fit until the transient has died away.
#[test]
fn low_pass_start_transient_does_not_reach_the_fit() {
    let body = PointBody::vehicle_like();
    let truth = body.parameters().to_vector();
    let motion = Motion::rich();
    let mut est = OnlineEstimator::new(config(Some(5.0), 1e-3)).unwrap();
    let g = est.config().geometry;
    let mut rng = StdRng::seed_from_u64(2);
    for k in 0..8000 {
        // A gap of 50 ms at 4 s restarts the conditioning.
        let t = k as f64 * 1e-3 + if k >= 4000 { 0.05 } else { 0.0 };
        let mut s = exact_sample(&g, &body, &motion, t, &mut rng);
        if k == 0 || k == 4000 {
            s.gyro_rad_s.z += 2e-3;
        }
        est.update(&s).unwrap();
    }
    let e = est.estimate();
    assert_eq!(e.counts.restarts, 1);
    let err = worst_relative(&e.parameters.to_vector(), &truth);
    std::eprintln!("start transient: worst relative error {err:.2e}");
    // 3e-4 when the transient reached the fit.
    assert!(err < 1e-6, "worst relative error {err:e}");
}

/// The leg map the sensitivity uses, times the forces, is the measured wrench (the estimator
/// computes the wrench that way when it keeps the map): against the sum over the legs.
#[test]
fn leg_map_times_forces_is_the_measured_wrench() {
    use kinematics::Pose;
    let g = test_geometry();
    let mut rng = StdRng::seed_from_u64(11);
    for _ in 0..200 {
        let pose = Pose::from_rpy(
            g.home_pose().position_m
                + Vector3::new(
                    rng.random_range(-0.05..0.05),
                    rng.random_range(-0.05..0.05),
                    rng.random_range(-0.05..0.05),
                ),
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.3..0.3),
        );
        let f = Vector6::from_fn(|_, _| rng.random_range(-5000.0..5000.0));
        let by_map = crate::online::leg_map(&g, &pose) * f;
        let w = crate::wrench::to_vector(&crate::wrench::measured(&g, &pose, &f));
        assert!((by_map - w).norm() <= 1e-9 * w.norm(), "{by_map} vs {w}");
    }
}

/// The ten-parameter model and the paper's six-parameter one (about a known centre of mass).
fn both_parameter_sets() -> [ParameterSet; 2] {
    [
        ParameterSet::Full,
        ParameterSet::InertiaAboutKnownCom {
            mass_kg: 1274.0,
            com_m: Vector3::new(0.1, -0.05, 0.4),
        },
    ]
}

/// The Neumann series solves (𝟙 − M) x = b as an LU solve does when M is small, and refuses
/// (for the LU fallback) when it would converge slowly or diverge.
#[test]
fn neumann_series_matches_an_lu_solve_and_refuses_slow_series() {
    let mut rng = StdRng::seed_from_u64(11);
    for _ in 0..50 {
        let scale: f64 = rng.random_range(1e-6..0.04);
        let m = SMatrix::<f64, 10, 10>::from_fn(|_, _| rng.random_range(-scale..scale));
        let b = SVector::<f64, 10>::from_fn(|_, _| rng.random_range(-1e3..1e3));
        let x = neumann_solve(|v| m * v, &b).expect("a small M converges");
        let lu = (SMatrix::<f64, 10, 10>::identity() - m)
            .lu()
            .solve(&b)
            .expect("regular");
        assert!(
            (x - lu).amax() <= 1e-13 * lu.amax(),
            "scale {scale:e}: {:e}",
            (x - lu).amax()
        );
    }
    let b = SVector::<f64, 10>::repeat(1.0);
    let slow = SMatrix::<f64, 10, 10>::identity() * 0.9;
    assert_eq!(neumann_solve(|v| slow * v, &b), None);
    let divergent = SMatrix::<f64, 10, 10>::identity() * 2.0;
    assert_eq!(neumann_solve(|v| divergent * v, &b), None);
    let nan = SMatrix::<f64, 10, 10>::from_element(f64::NAN);
    assert_eq!(neumann_solve(|v| nan * v, &b), None);
}

/// Each reported quantity's degrees of freedom: `None` until enough residual windows count,
/// then finite and at most the count of windows G ((Σa)² ≤ G Σa², and the windows' overlap
/// only lowers it), and the payload keeps the loaded run's, not the tare's (here a short run
/// whose degrees are all `None`).
#[test]
fn each_quantity_reports_its_degrees_of_freedom() {
    let body = PointBody::vehicle_like();
    let noise = SensorNoise {
        leg_force_n: 5.0,
        gyro_rad_s: 2e-4,
        accel_m_s2: 0.002,
    };
    let mut c = config(Some(20.0), 1e-3);
    c.gyro_noise_rad_s = noise.gyro_rad_s;
    c.accel_noise_m_s2 = noise.accel_m_s2;
    c.covariance_half_block_samples = 500;
    let accel_at = Vector3::zeros();
    let mut short = OnlineEstimator::new(c).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    run(
        &mut short,
        &body,
        &Motion::rich(),
        2000,
        1e-3,
        &accel_at,
        &noise,
        &mut rng,
    );
    let tare = short.estimate();
    assert!(tare.degrees_of_freedom.iter().all(Option::is_none));
    let mut est = OnlineEstimator::new(c).unwrap();
    run(
        &mut est,
        &body,
        &Motion::rich(),
        10_000,
        1e-3,
        &accel_at,
        &noise,
        &mut rng,
    );
    let e = est.estimate();
    let g = e.counts.covariance_windows as f64;
    assert!(g >= 15.0, "{:?}", e.counts);
    let most = g;
    for (i, nu) in e.degrees_of_freedom.iter().enumerate() {
        let nu = nu.unwrap_or(f64::NAN);
        assert!(nu > 1.0 && nu <= most + 1e-9, "quantity {i}: ν {nu}");
    }
    let loaded: [f64; 10] = core::array::from_fn(|i| e.degrees_of_freedom[i].unwrap_or(f64::NAN));
    let payload = e.without_tare(&tare.parameters, &tare.covariance);
    for (i, (nu, expected)) in payload.degrees_of_freedom.iter().zip(loaded).enumerate() {
        assert_eq!(*nu, Some(expected), "quantity {i}");
    }
    // The payload is the difference of the two runs, its covariance their sum.
    let difference = e.parameters.to_vector() - tare.parameters.to_vector();
    assert_eq!(payload.parameters.to_vector(), difference);
    assert_eq!(payload.covariance, e.covariance + tare.covariance);
}

/// The gyro's error at the ends of the run ([`crate::gyro_error::ends`]): through ω̇'s derivative an
/// error n of the gyro reaches the fit as [φ ψ(n)θ]/Δt at the run's ends (plus a sum over the
/// run of φ̇ ψ(n)θ), which for the first moment h, whose regressor column is gravity, is most of
/// it. Noiseless samples along the paper's tilts, but for a gyro error that rises to 3e-4 rad/s
/// over the run's last 20 ms: with the pose the estimate measures it and takes it out, and h
/// moves by a small fraction of what the same error does to an estimator that has no pose to
/// measure it against (the wrench given directly). Measured: 4.9e-4 against 9.4e-3 kg·m.
#[test]
fn a_gyro_error_at_the_runs_end_is_taken_out_of_the_first_moment() {
    let body = PointBody::vehicle_like();
    let motion = Motion::paper(Vector3::new(0.0, 0.0, 1.0));
    let mut c = config(Some(5.0), 1e-3);
    // A gyro described as noisy (the correction's condition); the samples carry no noise.
    c.gyro_noise_rad_s = 1e-4;
    let g = c.geometry;
    let samples = 4000;
    let error = Vector3::new(3e-4, -2e-4, 1e-4);
    let run = |with_error: bool, with_pose: bool| {
        let mut e = OnlineEstimator::new(c).unwrap();
        let mut rng = StdRng::seed_from_u64(1);
        for k in 0..samples {
            let t = k as f64 * 1e-3;
            let mut s = exact_sample(&g, &body, &motion, t, &mut rng);
            if with_error && k + 20 >= samples {
                s.gyro_rad_s += error * ((k + 20 - samples) as f64 / 20.0);
            }
            if with_pose {
                e.update(&s).unwrap();
            } else {
                let w = crate::wrench::measured(&g, &s.pose, &s.leg_forces_n);
                e.update_with_wrench(t, &w, &s.gyro_rad_s, &s.accel_m_s2)
                    .unwrap();
            }
        }
        e.theta().fixed_rows::<3>(1).into_owned()
    };
    let measured = (run(true, true) - run(false, true)).norm();
    let blind = (run(true, false) - run(false, false)).norm();
    std::eprintln!("h moved by {measured:.2e} kg·m with the pose, {blind:.2e} without");
    assert!(
        blind > 1e-3,
        "the error must matter without the pose: {blind:e}"
    );
    assert!(measured < 0.1 * blind, "{measured:e} vs {blind:e}");
}

/// The bug: `estimate --window 5:8` on a noise-only log reported the mass 6 σ off (12 logs:
/// mean z² 75, rms error 0.55 kg). The accelerometer's offset was averaged over every sample
/// before the window, the motion between the excitation's start and the window's included,
/// whose mean is not gravity's. With `hold_end_s` at the excitation's start only the rest
/// counts. Here 1 s at rest, then the motion, the window from 2 s, and an accelerometer offset
/// of 0.02 m/s² along gravity: the mass is exact when the hold ends with the rest, and off
/// when the motion is averaged in.
#[test]
fn the_accelerometer_offset_comes_from_the_rest_not_from_the_motion_before_a_late_window() {
    let body = PointBody::vehicle_like();
    let truth = body.parameters().mass_kg;
    let motion = Motion::paper(Vector3::new(0.0, 0.0, 1.0));
    let offset = Vector3::new(0.0, 0.0, 0.02);
    let mass_error = |hold_end_s: Option<f64>| {
        let mut c = config(Some(5.0), 1e-3);
        c.local_gravity_m_s2 = stewart_types::STANDARD_GRAVITY_M_S2;
        c.window_start_s = 2.0;
        c.hold_end_s = hold_end_s;
        let g = c.geometry;
        let mut e = OnlineEstimator::new(c).unwrap();
        let mut rng = StdRng::seed_from_u64(1);
        for k in 0..6000 {
            let t = k as f64 * 1e-3 - 1.0;
            let mut s = exact_sample(&g, &body, &motion, t.max(0.0), &mut rng);
            s.time_s = t;
            if t < 0.0 {
                // At rest at the motion's start pose: gravity's specific force only.
                s.gyro_rad_s = Vector3::zeros();
                s.accel_m_s2 = s.pose.rotation.inverse() * -stewart_types::GRAVITY_B_M_S2;
                let w = body.wrench(&Vector3::zeros(), &Vector3::zeros(), &s.accel_m_s2);
                let wb = s.pose.rotation * Vector3::new(w[0], w[1], w[2]);
                let tb = s.pose.rotation * Vector3::new(w[3], w[4], w[5]);
                let jt = g.jacobian(&s.pose).transpose();
                let wrench = Vector6::new(wb.x, wb.y, wb.z, tb.x, tb.y, tb.z);
                s.leg_forces_n = jt.lu().solve(&wrench).unwrap();
            }
            s.accel_m_s2 += offset;
            e.update(&s).unwrap();
        }
        (e.theta()[0] - truth).abs()
    };
    let rest = mass_error(Some(0.0));
    let mixed = mass_error(None);
    std::eprintln!("mass error: {rest:.2e} kg from the rest, {mixed:.2e} kg with the motion");
    assert!(rest < 1e-3, "{rest:e}");
    assert!(mixed > 20.0 * rest, "{mixed:e} against {rest:e}");
}

/// The mean z² of the centre of mass's entries (mass, c_x, c_y, c_z) over `seeds` short runs
/// of `samples` at 1 kHz with half-blocks of `block` samples, in a world whose error the
/// gyro's derivative noise dominates.
fn short_gyro_run_com_z2(seeds: u64, samples: usize, block: u32) -> [f64; 4] {
    let body = PointBody::vehicle_like();
    let truth = body.parameters();
    let c_true = truth.com_m().unwrap();
    let noise = SensorNoise {
        leg_force_n: 1.0,
        gyro_rad_s: 2e-3,
        accel_m_s2: 2e-3,
    };
    let period = 1e-3;
    let mut z2 = [0.0; 4];
    for seed in 0..seeds {
        let mut est = OnlineEstimator::new(noisy_config(&noise, period, block)).unwrap();
        let mut rng = StdRng::seed_from_u64(5000 + seed);
        run(
            &mut est,
            &body,
            &Motion::rich(),
            samples,
            period,
            &Vector3::zeros(),
            &noise,
            &mut rng,
        );
        let e = est.estimate();
        let errors = [
            (e.mass_kg() - truth.mass_kg, e.mass_sigma_kg),
            (e.com_m[0] - c_true[0], e.com_sigma_m[0]),
            (e.com_m[1] - c_true[1], e.com_sigma_m[1]),
            (e.com_m[2] - c_true[2], e.com_sigma_m[2]),
        ];
        for (z, (error, sigma)) in z2.iter_mut().zip(errors) {
            *z += (error / sigma).powi(2) / seeds as f64;
        }
    }
    z2
}

/// The fit's error in J, mostly the gyro's derivative noise and one draw that every
/// residual window shares, reaches the centre of mass's window scores through each window's
/// cross-information of gravity with ω̇; counted as noise of h, it makes a short run's σ(c)
/// several times its spread. The windows are scored at the estimate without the gyro's
/// measured error, its share kept apart (`crate::score`). 3 s, half-blocks of 0.2 s, 96
/// seeds: mean z² of c_x, c_y, c_z 0.35, 0.68, 0.53 with the windows scored at the fit, 0.63,
/// 1.14, 0.81 as they are. (The mass, 0.12, is over-covered either way: docs/accuracy.md.)
#[test]
fn the_gyros_error_in_j_does_not_inflate_the_centre_of_mass_sigma() {
    let z2 = short_gyro_run_com_z2(96, 3000, 200);
    std::eprintln!("gyro-dominated 3 s: mean z² of m, c {z2:.2?}");
    for (k, z) in z2.iter().enumerate().skip(1) {
        assert!((0.5..=2.0).contains(z), "com [{}]: mean z² {z:.2}", k - 1);
    }
}

/// Runs `samples` synthetic samples of the vehicle-like body along the rich motion, each
/// cell's zero drifting at `rates` N/s from the first sample, with and without the drift
/// fitted; returns (drift fitted, drift left in).
fn drifting_run(
    rates: &Vector6<f64>,
    samples: usize,
    seed: u64,
) -> (OnlineEstimator, OnlineEstimator) {
    let mut c = config(Some(20.0), 1e-3);
    c.equation_sigma = Vector6::new(26.0, 26.0, 26.0, 10.0, 10.0, 10.0);
    c.leg_force_offsets = true;
    let noise = SensorNoise {
        leg_force_n: 5.0,
        ..SensorNoise::default()
    };
    let body = PointBody::vehicle_like();
    let motion = Motion::rich();
    let g = c.geometry;
    let mut left = OnlineEstimator::new(c).unwrap();
    c.load_cell_drift = true;
    let mut fitted = OnlineEstimator::new(c).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    for k in 0..samples {
        let t = k as f64 * 1e-3;
        let mut s = synthetic_sample(&g, &body, &motion, t, &Vector3::zeros(), &noise, &mut rng);
        s.leg_forces_n += rates * t;
        fitted.update(&s).unwrap();
        left.update(&s).unwrap();
    }
    (fitted, left)
}

/// The bug: the load cells' zero drift was not part of the model, so over a long run the
/// drift's mean, rate × T/2, moved the mass and the first moment by many sigmas (and the
/// residual windows counted the ramp as noise). Here 20 s with each cell drifting by up to
/// 0.3 N/s (6 N at the end, beside 5 N of noise): fitted, the rates come back within a few of
/// their sigmas and every parameter within 4 sigmas; left in, the mass is off by more than
/// 5 of its (drift-inflated) sigmas.
#[test]
fn a_load_cells_zero_drift_does_not_bias_a_long_run() {
    let rates = Vector6::new(0.3, -0.2, 0.25, -0.3, 0.1, 0.2);
    let truth = PointBody::vehicle_like().parameters().to_vector();
    let (fitted, left) = drifting_run(&rates, 20_000, 7);
    let drift = fitted.load_cell_drift().expect("the drift is fitted");
    let (rate, rate_cov) = (drift.rate_n_s, drift.covariance);
    assert!(drift.start_s.abs() < 0.1, "t₀ {}", drift.start_s);
    for i in 0..6 {
        let z = (rate[i] - rates[i]) / rate_cov[(i, i)].sqrt();
        std::eprintln!(
            "cell {i}: rate {:.4} N/s (put in {:.4}), z {z:.2}",
            rate[i],
            rates[i]
        );
        assert!(z.abs() < 4.0, "cell {i}: {}", rate[i]);
    }
    let z = |e: &OnlineEstimator| {
        let cov = e.covariance();
        ParameterVector::from_fn(|i, _| (e.theta()[i] - truth[i]) / cov[(i, i)].sqrt())
    };
    let (zf, zl) = (z(&fitted), z(&left));
    std::eprintln!("z fitted {:.2}", zf.transpose());
    std::eprintln!("z left in {:.2}", zl.transpose());
    assert!(zf.amax() < 4.0, "fitted: {}", zf.transpose());
    assert!(zl[0].abs() > 5.0, "left in: {}", zl.transpose());
    assert!(left.load_cell_drift().is_none());
}

/// Fitting the drift where there is none: the tensor's sigmas stay within a tenth, θ moves
/// by less than 3.5 of its sigmas (over seeds 1–6 the mass and the first moment moved by up
/// to 2.8 sigmas of the variance the fit adds, seed 8's h_y by 4.3; the tensor's sigmas do
/// not grow, and it moves by a small share of them). The mass and the first moment pay the drift's price: the offset
/// the drift adds by the run's mean time, r̂ T/2, is known only as well as the rate, which
/// for white errors triples the variance of a mean (T²/4 against the ramp's T²/12) and adds
/// it to the noise of the load's own mean; with the sensors' noise alone (this test) that
/// is up to 2× the sigma, against a rig's sigma made mostly of its gains and geometry.
#[test]
fn fitting_a_zero_drift_that_is_not_there_costs_little() {
    let (fitted, left) = drifting_run(&Vector6::zeros(), 20_000, 8);
    let (cf, cl) = (fitted.covariance(), left.covariance());
    let (tf, tl) = (fitted.theta(), left.theta());
    for i in 0..10 {
        let ratio = (cf[(i, i)] / cl[(i, i)]).sqrt();
        let moved = (tf[i] - tl[i]).abs() / cf[(i, i)].sqrt();
        std::eprintln!("θ[{i}]: sigma ratio {ratio:.3}, moved {moved:.3} σ");
        let most = if i < 4 { 2.0 } else { 1.1 };
        assert!(ratio < most && ratio > 0.9, "θ[{i}]: sigma ratio {ratio}");
        assert!(moved < 3.5, "θ[{i}] moved by {moved} σ");
    }
}
