//! Costs of the per-tick kinematics: inverse kinematics, Jacobian, wrench, conditioning and a
//! warm-started forward kinematics as at a 1 kHz loop.
use criterion::{criterion_group, criterion_main, Criterion};
use kinematics::{FkOptions, Geometry, Pose, StrokeLimits, Vector3, Vector6};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    let g = Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).expect("valid geometry");
    let pose = Pose::from_rpy(
        g.home_pose().position_m + Vector3::new(0.03, -0.02, 0.05),
        0.05,
        -0.04,
        0.08,
    );
    // One millisecond of motion earlier: the warm start of a 1 kHz loop.
    let previous = Pose::from_rpy(
        pose.position_m - Vector3::new(1e-4, 0.0, 1e-4),
        0.0499,
        -0.0401,
        0.0802,
    );
    let lengths = g.leg_lengths(&pose);
    let forces = Vector6::new(3000.0, 3100.0, 2900.0, 3050.0, 2950.0, 3000.0);
    c.bench_function("ik_leg_lengths", |b| {
        b.iter(|| g.leg_lengths(black_box(&pose)))
    });
    c.bench_function("jacobian", |b| b.iter(|| g.jacobian(black_box(&pose))));
    c.bench_function("wrench_in_platform", |b| {
        b.iter(|| g.wrench_in_platform(black_box(&pose), black_box(&forces)))
    });
    c.bench_function("inverse_condition_number", |b| {
        b.iter(|| g.inverse_condition_number(black_box(&pose)))
    });
    let options = FkOptions::default();
    c.bench_function("fk_warm_start_1khz", |b| {
        b.iter(|| g.forward_kinematics(black_box(&lengths), black_box(&previous), &options))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
