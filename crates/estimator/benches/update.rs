//! Cost of the estimator's per-sample work: one full update (leg forces → wrench, conditioning,
//! regressor, weighted U-D RLS and residual scores), its parts, and a full estimate.
use criterion::{criterion_group, criterion_main, Criterion};
use estimator::conditioning::{Conditioner, ConditioningConfig};
use estimator::regressor::{from_signals, RegressorSignals};
use estimator::rls::Rls;
use estimator::{EstimatorConfig, OnlineEstimator, ParameterSet, Sample};
use kinematics::{Geometry, Pose, StrokeLimits, Vector3, Vector6, Wrench};
use nalgebra::{SMatrix, SVector};
use std::hint::black_box;

const PERIOD_S: f64 = 1e-3;

fn geometry() -> Geometry {
    let stroke = StrokeLimits {
        min_length_m: 1.3,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.0, 0.4, 0.4, stroke).expect("valid geometry")
}

/// A plausible sample at step k: gentle multi-axis sines, forces round 2 kN.
fn sample(g: &Geometry, k: u64) -> Sample {
    let t = k as f64 * PERIOD_S;
    let w = |f: f64, p: f64| (2.0 * std::f64::consts::PI * f * t + p).sin();
    let pose = Pose::from_rpy(
        g.home_pose().position_m
            + Vector3::new(0.02 * w(0.4, 0.0), 0.02 * w(0.5, 1.0), 0.01 * w(0.6, 2.0)),
        0.1 * w(0.41, 0.0),
        0.1 * w(0.47, 1.0),
        0.1 * w(0.29, 2.0),
    );
    Sample {
        time_s: t,
        sequence: None,
        pose,
        leg_forces_n: Vector6::from_fn(|i, _| 2000.0 + 100.0 * w(0.3 + 0.1 * i as f64, i as f64)),
        gyro_rad_s: Vector3::new(0.3 * w(0.41, 1.5), 0.3 * w(0.47, 2.5), 0.2 * w(0.29, 3.5)),
        accel_m_s2: Vector3::new(
            0.9 * w(0.47, 0.3),
            -0.9 * w(0.41, 0.2),
            9.8 + 0.2 * w(0.6, 0.1),
        ),
    }
}

fn bench(c: &mut Criterion) {
    let g = geometry();
    let ring: Vec<Sample> = (0..4096).map(|k| sample(&g, k)).collect();

    let run = |name: &str, config: EstimatorConfig, c: &mut Criterion| {
        let mut est = OnlineEstimator::new(config).expect("valid config");
        let mut k: u64 = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                let mut s = ring[(k % 4096) as usize];
                s.time_s = k as f64 * PERIOD_S;
                k += 1;
                black_box(est.update(black_box(&s)))
            })
        });
        est
    };

    let mut full = EstimatorConfig::new(g, PERIOD_S);
    full.gyro_noise_rad_s = 1e-3;
    let est = run("update_full_10_parameters", full, c);
    c.bench_function("estimate_full", |b| b.iter(|| black_box(&est).estimate()));
    c.bench_function("theta_corrected", |b| b.iter(|| black_box(&est).theta()));
    let mut with_legs = full;
    with_legs.leg_force_offsets = true;
    run("update_full_10_parameters_leg_offsets", with_legs, c);

    let mut six = EstimatorConfig::new(g, PERIOD_S);
    six.parameters = ParameterSet::InertiaAboutKnownCom {
        mass_kg: 1000.0,
        com_m: Vector3::zeros(),
    };
    run("update_paper_6_parameters", six, c);

    // Parts.
    let mut cond = Conditioner::new(ConditioningConfig {
        sample_period_s: PERIOD_S,
        lowpass_cutoff_hz: Some(20.0),
        accelerometer_position_m: Vector3::new(0.1, 0.0, 0.05),
        max_gap_s: 0.01,
        max_rate_error: 1e-4,
        gyro_noise_rad_s: 0.0,
    })
    .expect("valid conditioning");
    let mut k: u64 = 0;
    c.bench_function("part_conditioning", |b| {
        b.iter(|| {
            let s = &ring[(k % 4096) as usize];
            k += 1;
            let w = Wrench {
                force_n: Vector3::new(10.0, 20.0, 9000.0),
                torque_nm: Vector3::new(1.0, 2.0, 3.0),
            };
            black_box(cond.push(k as f64 * PERIOD_S, &s.gyro_rad_s, &s.accel_m_s2, &w))
        })
    });
    let s = RegressorSignals::new(
        &Vector3::new(0.1, -0.2, 0.3),
        &Vector3::new(1.0, 2.0, -1.0),
        &Vector3::new(0.5, -0.3, 9.8),
    );
    c.bench_function("part_regressor", |b| b.iter(|| from_signals(black_box(&s))));
    let s = ring[0];
    c.bench_function("part_wrench", |b| {
        b.iter(|| estimator::wrench::measured(&g, black_box(&s.pose), black_box(&s.leg_forces_n)))
    });
    let mut rls =
        Rls::<10>::new(SVector::zeros(), SVector::from_element(1e8), 1.0).expect("valid rls");
    let rows = SMatrix::<f64, 6, 10>::from_fn(|r, c| ((r * 10 + c) as f64 * 0.37).sin());
    let y = SVector::<f64, 6>::from_fn(|r, _| r as f64);
    c.bench_function("part_rls_6_rows", |b| {
        b.iter(|| rls.update(black_box(&rows), black_box(&y)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
