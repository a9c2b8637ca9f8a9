use super::*;
use control::trajectory::{MultiSineConfig, Spectrum};
use estimator::{OnlineEstimator, Sample};
use nalgebra::Vector6;
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};
use rig_description::config::ExcitationKind;

fn default_planner() -> (crate::LoadedConfig, Planner) {
    let loaded = rig_description::load::load(None).expect("default loads");
    let planner = Planner::new(&loaded).expect("planner");
    (loaded, planner)
}

/// A short, brisk multi-sine on all six axes: enough to determine the ten parameters in a few
/// seconds.
fn brisk(planner: &Planner, duration_s: f64) -> Trajectory {
    Trajectory::multisine(
        planner.geometry.home_pose(),
        &MultiSineConfig {
            base_frequency_hz: 0.25,
            harmonics_per_axis: 1,
            peak_amplitudes: [0.01, 0.01, 0.01, 0.03, 0.03, 0.03],
            duration_s,
            fade_in_s: 1.0,
            fade_out_s: 1.0,
            spectrum: Spectrum::FlatVelocity,
        },
    )
    .expect("trajectory")
}

/// The accelerometer's vertical offset alone: a constant error δ in the specific force, which
/// the equations F = m f + … read as a mass error m δ/g near rest (f ≈ g), and the datasheet
/// planner's figure of it: the noise over √(the samples at rest before the excitation).
#[test]
fn the_accelerometer_offset_moves_the_mass_by_m_delta_over_g() {
    let (loaded, planner) = default_planner();
    let trajectory = brisk(&planner, 6.0);
    let theta = planner.payload + planner.fixture;
    let offset = 2e-4;
    let noise = ChannelNoise {
        load_cell_n: 0.0,
        gyro_rad_s: 0.0,
        accel_m_s2: 0.0,
        accel_offset_m_s2: offset,
    };
    let points = motion::sample(&trajectory, planner.conditioning.period_s);
    let cov = predict::covariance(
        &points,
        &theta,
        &planner.geometry,
        &planner.conditioning,
        &noise,
    )
    .expect("determined");
    let expected = theta[0] * offset / stewart_types::STANDARD_GRAVITY_M_S2;
    let mass_sigma = cov[(0, 0)].sqrt();
    assert!(
        (mass_sigma / expected - 1.0).abs() < 0.02,
        "{mass_sigma} kg against m δ/g = {expected} kg"
    );
    let c = &loaded.config;
    let samples =
        (c.run.brake_hold_s + c.control.settle_ramp_s + c.run.settle_s) * c.sensors.sample_rate_hz;
    let per_sample = planner.noise.accel_m_s2;
    assert!((planner.noise.accel_offset_m_s2 - per_sample / samples.sqrt()).abs() < 1e-15);
    assert!(planner.noise.accel_offset_m_s2 > 0.0);
}

/// The predicted covariance against the estimator itself, written apart from the prediction:
/// the spread of its estimates over noise drawn at random must match the predicted sigma of
/// every parameter (within the sampling spread of 40 draws, about ±11 % one sigma, and the
/// warm-up the estimator drops).
#[test]
fn the_predicted_covariance_matches_the_estimators_spread_over_random_noise() {
    let (_, planner) = default_planner();
    // Ten times the datasheet's noise keeps the estimator's own rounding far below it.
    let noise = ChannelNoise {
        load_cell_n: 10.0 * planner.noise.load_cell_n,
        gyro_rad_s: 10.0 * planner.noise.gyro_rad_s,
        accel_m_s2: 10.0 * planner.noise.accel_m_s2,
        accel_offset_m_s2: 0.0,
    };
    for drift in [true, false] {
        let ratios = spread_over_predicted(6.0, &noise, false, drift);
        eprintln!("TEMP drift {drift}: {ratios:.3?}");
        assert!(
            ratios.iter().all(|r| (0.7..1.35).contains(r)),
            "load cells' drift fitted: {drift}; spread over predicted sigma, per parameter: \
             {ratios:.3?}"
        );
    }
}

/// Fitting the load cells' zero drift costs a short run information: the rates are six more
/// unknowns that a few seconds' ramp barely tells from the load, and the prediction says so
/// (every parameter's predicted sigma at least that of the fit without the drift, the mass's
/// by more than a tenth on 6 s; the test above checks both against the estimator).
#[test]
fn the_drift_fit_costs_a_short_run_what_its_rates_take() {
    let (_, planner) = default_planner();
    let trajectory = brisk(&planner, 6.0);
    let theta = planner.payload + planner.fixture;
    let points = motion::sample(&trajectory, planner.conditioning.period_s);
    let sigma = |drift: bool| {
        let conditioning = Conditioning {
            load_cell_drift: drift,
            ..planner.conditioning
        };
        let cov = predict::covariance(
            &points,
            &theta,
            &planner.geometry,
            &conditioning,
            &planner.noise,
        )
        .expect("determined");
        cov.diagonal().map(f64::sqrt)
    };
    let (with, without) = (sigma(true), sigma(false));
    assert!(
        with.iter()
            .zip(without.iter())
            .all(|(w, o)| *w >= *o * (1.0 - 1e-9)),
        "{with:.3e} against {without:.3e}"
    );
    assert!(
        with[0] > 1.1 * without[0],
        "{} against {}",
        with[0],
        without[0]
    );
}

/// The gyro's noise alone on a 3 s run: the estimator takes the gyro's error at the run's two
/// ends out of its estimate (`estimator::gyro_error::ends`), which is most of the first moment's error
/// in a short run. Against the same draws fed without the pose (nothing to measure the gyro's
/// error against), the spread of hₓ and h_y falls about fivefold (measured 0.21 and 0.29 of the
/// blind spread); the tensor's, which the ends barely reach, stays.
#[test]
fn the_gyros_ends_taken_out_shrink_the_first_moments_spread_on_a_planned_motion() {
    let (_, planner) = default_planner();
    let noise = ChannelNoise {
        load_cell_n: 0.0,
        gyro_rad_s: 10.0 * planner.noise.gyro_rad_s,
        accel_m_s2: 0.0,
        accel_offset_m_s2: 0.0,
    };
    // Without the pose there are no drift rows either: both without the drift fit, so that
    // the ends alone differ.
    let measured = spread_over_predicted(3.0, &noise, false, false);
    let blind = spread_over_predicted(3.0, &noise, true, false);
    let shrink: Vec<f64> = measured.iter().zip(&blind).map(|(m, b)| m / b).collect();
    assert!(shrink[1] < 0.35 && shrink[2] < 0.45, "h: {shrink:.3?}");
    assert!(
        shrink[4..].iter().all(|r| (0.9..1.1).contains(r)),
        "J: {shrink:.3?}"
    );
}

/// The spread of 40 estimates over noise drawn at random, divided by the predicted sigma, per
/// parameter, on the brisk motion of `duration` s; `blind`: the wrench handed to the estimator
/// directly, without the pose the gyro's error is measured against; `drift`: the load cells'
/// zero drift fitted (by the estimator, and paid for in the prediction).
fn spread_over_predicted(
    duration: f64,
    noise: &ChannelNoise,
    blind: bool,
    drift: bool,
) -> Vec<f64> {
    let (loaded, mut planner) = default_planner();
    planner.conditioning.load_cell_drift = drift;
    let trajectory = brisk(&planner, duration);
    let theta = planner.payload + planner.fixture;
    let period = planner.conditioning.period_s;
    let points = motion::sample(&trajectory, period);
    let predicted = predict::covariance(
        &points,
        &theta,
        &planner.geometry,
        &planner.conditioning,
        noise,
    )
    .expect("determined");
    // Per sample: the pose, the clean leg forces, ω and the specific force.
    type Clean = (kinematics::Pose, Vector6<f64>, Vector3<f64>, Vector3<f64>);
    let clean: Vec<Clean> = points
        .iter()
        .map(|p| {
            let f = motion::leg_forces(&planner.geometry, None, &theta, p).expect("regular");
            (
                p.plate.pose,
                f,
                p.plate.angular_velocity_rad_s,
                p.signals.specific_force_m_s2,
            )
        })
        .collect();
    let mut config = measure::setup::estimator_config(
        &loaded.config,
        &planner.geometry,
        measure::setup::Measurement::Loaded,
        f64::NEG_INFINITY,
        f64::INFINITY,
    );
    config.legs = None;
    config.gyro_noise_rad_s = noise.gyro_rad_s;
    config.accel_noise_m_s2 = noise.accel_m_s2;
    config.leg_force_offsets = false;
    config.load_cell_drift = drift;
    let mut rng = StdRng::seed_from_u64(7);
    let unit = Normal::new(0.0, 1.0).expect("normal");
    let draws = 40;
    let mut estimates = Vec::with_capacity(draws);
    for _ in 0..draws {
        let mut est = OnlineEstimator::new(config).expect("estimator");
        for (k, (pose, f, w, a)) in clean.iter().enumerate() {
            let mut draw = |s: f64| s * unit.sample(&mut rng);
            let sample = Sample {
                time_s: k as f64 * period,
                sequence: Some(k as u64),
                pose: *pose,
                leg_forces_n: f.map(|x| x + draw(noise.load_cell_n)),
                gyro_rad_s: w.map(|x| x + draw(noise.gyro_rad_s)),
                accel_m_s2: a.map(|x| x + draw(noise.accel_m_s2)),
            };
            if blind {
                let w = estimator::wrench::measured(
                    &planner.geometry,
                    &sample.pose,
                    &sample.leg_forces_n,
                );
                est.update_with_wrench(sample.time_s, &w, &sample.gyro_rad_s, &sample.accel_m_s2)
                    .expect("accepted");
            } else {
                est.update(&sample).expect("accepted");
            }
        }
        estimates.push(est.theta());
    }
    let n = draws as f64;
    let mean = estimates.iter().sum::<ParameterVector>() / n;
    let ratios: Vec<f64> = (0..10)
        .map(|p| {
            let spread = (estimates
                .iter()
                .map(|e| (e[p] - mean[p]).powi(2))
                .sum::<f64>()
                / (n - 1.0))
                .sqrt();
            spread / predicted[(p, p)].sqrt()
        })
        .collect();
    ratios
}

/// A bigger motion of the same shape measures better: the sigma of every parameter falls
/// roughly as the motion grows (twice the motion, at least 1.5 times less sigma for J).
#[test]
fn twice_the_motion_predicts_a_smaller_sigma() {
    let (_, planner) = default_planner();
    let small = brisk(&planner, 8.0);
    let big = search_scaled(&small, 2.0);
    let p_small = planner.predict(&small, &small).expect("small determined");
    let p_big = planner.predict(&big, &big).expect("big determined");
    for i in 4..10 {
        assert!(
            p_small.sigma.flat()[i] > 1.5 * p_big.sigma.flat()[i],
            "{}: {} against {}",
            Quantities::NAMES[i],
            p_small.sigma.flat()[i],
            p_big.sigma.flat()[i]
        );
    }
}

fn search_scaled(t: &Trajectory, factor: f64) -> Trajectory {
    let components: Vec<_> = t
        .components()
        .iter()
        .map(|c| control::trajectory::SineComponent {
            amplitude: c.amplitude * factor,
            ..*c
        })
        .collect();
    let (fi, fo) = t.fades_s();
    Trajectory::new(*t.offset(), &components, t.duration_s(), fi, fo).expect("scaled")
}

/// The limits bind: a force limit below the static load refuses any motion, naming the force;
/// a tiny acceleration limit names the acceleration.
#[test]
fn each_limit_refuses_a_motion_that_breaks_it() {
    let (_, mut planner) = default_planner();
    let t = search_scaled(&brisk(&planner, 6.0), 0.5);
    let theta = planner.payload + planner.fixture;
    let com = planner.payload_com_m();
    let usage = planner
        .check(&t, &theta, &com, 5e-3)
        .expect("default limits hold");
    assert!(usage.force > 0.0 && usage.force < 1.0, "{usage:?}");
    let mut low = planner.clone();
    low.max_force_n = 1000.0;
    assert!(matches!(
        low.check(&t, &theta, &com, 5e-3),
        Err(Binding::Force { .. })
    ));
    planner.max_acceleration_m_s2 = 0.01;
    assert!(matches!(
        planner.check(&t, &theta, &com, 5e-3),
        Err(Binding::Acceleration { .. })
    ));
}

/// The excitation file round-trips through the loader: laid over the rig description, it
/// gives the same trajectory.
#[test]
fn an_excitation_file_lays_the_planned_sines_over_the_rig_description() {
    let (loaded, planner) = default_planner();
    let t = brisk(&planner, 20.0);
    let excitation = search::excitation_of(&loaded.config.excitation, &t);
    let text = search::excitation_file(&excitation, "test plan");
    assert!(text.starts_with("# test plan"));
    let laid = loaded
        .clone()
        .with_excitation_text(&text, "plan.toml")
        .expect("the file loads");
    assert_eq!(laid.config.excitation.kind, ExcitationKind::Sines);
    let back = measure::setup::trajectory(&laid, &planner.geometry, 20.0).expect("trajectory");
    for (a, b) in back.components().iter().zip(t.components()) {
        assert_eq!(a.axis, b.axis);
        assert!((a.amplitude - b.amplitude).abs() < 1e-12 * b.amplitude.abs().max(1e-9));
        assert!((a.frequency_hz - b.frequency_hz).abs() < 1e-12);
        assert!((a.phase_rad - b.phase_rad).abs() < 1e-9);
    }
    assert_eq!(back.components().len(), t.components().len());
    // Anything but an [excitation] table is refused, naming the key.
    let err = loaded
        .with_excitation_text("[run]\nduration_s = 5.0\n", "plan.toml")
        .expect_err("refused");
    assert!(err.to_string().contains("run"), "{err}");
}

/// A prior that is not a body, or a target that is not positive, is refused before anything is
/// planned, naming the key.
#[test]
fn a_prior_that_is_not_a_body_is_refused_naming_the_key() {
    let bad = "[plan.payload]\nmass_kg = 1500.0\ncom_m = [0.0, 0.0, 0.5]\n\
               inertia_com_kg_m2 = [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 900.0]]\n";
    let err =
        rig_description::load::load_str(bad, "prior.toml").expect_err("triangle inequality broken");
    assert!(
        err.to_string().contains("plan.payload.inertia_com_kg_m2"),
        "{err}"
    );
    let err = rig_description::load::load_str("[plan]\ntarget_com_m = 0.0\n", "t.toml")
        .expect_err("zero");
    assert!(err.to_string().contains("plan.target_com_m"), "{err}");
}

/// A short plan's fades take at most an eighth of its excitation each, and the file carries
/// them; the default 20 s excitation keeps the rig description's 2 s, and a fade already
/// short (the paper's 0.03 s fade-in) stays as it is.
#[test]
fn a_short_plan_shortens_the_fades_to_an_eighth_of_its_excitation() {
    let (loaded, _) = default_planner();
    let base = &loaded.config.excitation;
    assert_eq!(base.fade_s, 2.0, "the default's fades");
    let long = search::with_short_fades(base, 20.0);
    assert_eq!((long.fade_s, long.fade_out()), (2.0, 2.0));
    for (duration, fade) in [(5.0, 0.625), (2.0, 0.25)] {
        let short = search::with_short_fades(base, duration);
        assert_eq!(
            (short.fade_s, short.fade_out()),
            (fade, fade),
            "{duration} s"
        );
    }
    let mut paper = base.clone();
    paper.fade_s = 0.03;
    paper.fade_out_s = Some(1.0);
    let short = search::with_short_fades(&paper, 4.0);
    assert_eq!((short.fade_s, short.fade_out()), (0.03, 0.5));
}

/// The course over the excitation: at the full length it is `predict` itself (the same code,
/// to the bit), and it falls as the loaded run's information accumulates; before the motion
/// has determined θ it is `None`, not a figure.
#[test]
fn the_predicted_sigma_falls_with_excitation_time_to_the_whole_runs() {
    let (_, planner) = default_planner();
    let duration = 12.0;
    let loaded = brisk(&planner, duration);
    let tare = brisk(&planner, 6.0);
    let whole = planner.predict(&loaded, &tare).expect("determined");
    let course = planner.predicted_course(&loaded, &tare, &[0.002, 3.0, 6.0, 9.0, duration]);
    assert!(course[0].1.is_none(), "two samples determine nothing");
    let last = course[4].1.as_ref().expect("determined");
    assert_eq!(last.sigma, whole.sigma);
    for pair in course[1..].windows(2) {
        let (a, b) = (
            pair[0].1.as_ref().expect("determined").sigma.flat(),
            pair[1].1.as_ref().expect("determined").sigma.flat(),
        );
        for k in 0..10 {
            assert!(
                b[k] < a[k],
                "{} at {} s: {} ≥ {} at {} s",
                Quantities::NAMES[k],
                pair[1].0,
                b[k],
                a[k],
                pair[0].0
            );
        }
    }
}

/// The degrees of freedom the plan predicts for each sigma: on a long brisk multi-sine the
/// windows carry nearly the same information, so every quantity gets close to the count of G
/// equal windows that share half-blocks, G²/(G + 2(G − 1)/π²); on the same motion cut to
/// 2.4 s (its 1 s fades kept; 7 counted windows on half-blocks of 0.24 s) the fades carry
/// little and the fewest falls well below the count of its windows.
#[test]
fn predicted_degrees_of_freedom_follow_the_windows_information() {
    let equal = |g: f64| g * g / (g + 2.0 * (g - 1.0) / (std::f64::consts::PI.powi(2)));
    let (_, planner) = default_planner();
    let long = brisk(&planner, 24.0);
    let nu = planner
        .predicted_degrees_of_freedom(&long)
        .expect("determined");
    // 27 half-blocks of 0.888 s (a long run's, `quality::LONG_RUN_WINDOWS`): windows 1 to 25
    // count.
    assert_eq!(
        measure::quality::half_block_samples_for(400, 24.0, 1e-3),
        888
    );
    let most = equal(25.0);
    for (name, n) in Quantities::NAMES.iter().zip(nu) {
        assert!(
            n <= most + 1e-6 && n > 0.8 * most,
            "{name}: ν {n} against {most}"
        );
    }
    let short = brisk(&planner, 2.4);
    let nu = planner
        .predicted_degrees_of_freedom(&short)
        .expect("determined");
    let block = measure::quality::half_block_samples_for(400, 2.4, 1e-3);
    let g = measure::quality::excitation_windows(2.4, 1e-3, block) as f64;
    assert_eq!((block, g), (240, 7.0));
    let fewest = nu.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        fewest < 0.75 * equal(g),
        "fewest ν {fewest} against {} for equal windows",
        equal(g)
    );
}
