//! One sample period of the simulator (`write` + `read`) at the default 1 kHz with two 0.5 ms
//! physics substeps, realistic sensors, a 1.5 t car on a 200 kg fixture, legs driven by the
//! static hold plus sines. Target: ≥ 100 simulated seconds per wall second, i.e. ≤ 10 µs here.

use std::hint::black_box;

use control::io::{Backend, CommandFrame};
use criterion::{criterion_group, criterion_main, Criterion};
use kinematics::{Geometry, StrokeLimits};
use nalgebra::Rotation3;
use sim::{BodyProperties, SimConfig, Simulator};

fn simulator(config: &SimConfig) -> Simulator {
    let geometry = Geometry::from_radii(
        1.2,
        0.9,
        20f64.to_radians(),
        20f64.to_radians(),
        StrokeLimits {
            min_length_m: 1.0,
            max_length_m: 1.6,
        },
    )
    .expect("bench geometry");
    let car = BodyProperties::from_principal(
        1500.0,
        [0.15, -0.1, 0.5],
        [450.0, 2100.0, 2300.0],
        &Rotation3::from_euler_angles(0.05, -0.08, 0.3),
    );
    Simulator::new(geometry, BodyProperties::default(), Some(car), config, 1).expect("bench sim")
}

fn bench_step(c: &mut Criterion) {
    for (name, substeps) in [("sample_1khz_2substeps", 2), ("sample_1khz_1substep", 1)] {
        let config = SimConfig {
            substeps,
            ..SimConfig::default()
        };
        let mut sim = simulator(&config);
        let hold = sim.read().expect("read").leg_forces_n;
        let mut k = 0u64;
        c.bench_function(name, |b| {
            b.iter(|| {
                // Stay near home: re-centre every few seconds of simulated time.
                if k % 4000 == 0 {
                    sim = simulator(&config);
                }
                let t = k as f64 * 1e-3;
                let forces = core::array::from_fn(|i| {
                    hold[i]
                        + 300.0 * (2.0 * core::f64::consts::PI * (0.5 + 0.1 * i as f64) * t).sin()
                });
                let cmd = CommandFrame {
                    sequence: k,
                    sensor_sequence: k,
                    leg_forces_n: forces,
                    enable: true,
                };
                sim.write(black_box(&cmd)).expect("write");
                k += 1;
                black_box(sim.read().expect("read"))
            })
        });
    }
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
