//! Per-tick costs: the six-leg PID bank, one multi-sine sample, and one full `Controller::tick`
//! (watchdog, FK warm-started, trajectory, IK, Jacobian, PIDs, gate) in the Excite phase.

use std::hint::black_box;

use control::controller::{Controller, ControllerConfig};
use control::io::{SensorFrame, Status, LEG_COUNT};
use control::pid::{PidBank, PidConfig};
use control::supervisor::Phase;
use control::trajectory::{MultiSineConfig, Trajectory};
use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use kinematics::{Geometry, StrokeLimits};

fn geometry() -> Geometry {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).expect("valid bench geometry")
}

fn pid_bank(c: &mut Criterion) {
    let mut bank = PidBank::uniform(PidConfig::default()).expect("default PID config");
    let setpoints = [1.9; LEG_COUNT];
    let feedforward = [4000.0; LEG_COUNT];
    let mut k = 0u32;
    c.bench_function("pid_bank_update", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            let wobble = 1e-4 * f64::from(k % 7);
            let measured = [1.9 + wobble; LEG_COUNT];
            black_box(bank.update(
                black_box(&setpoints),
                black_box(&measured),
                &feedforward,
                1e-3,
            ))
        })
    });
}

fn trajectory_sample(c: &mut Criterion) {
    let g = geometry();
    let traj = Trajectory::multisine(g.home_pose(), &MultiSineConfig::default())
        .expect("default multisine");
    let mut t = 0.0;
    c.bench_function("multisine_sample_18_components", |b| {
        b.iter(|| {
            t = (t + 1e-3) % 40.0;
            black_box(traj.sample(black_box(t)))
        })
    });
}

fn controller_tick(c: &mut Criterion) {
    let g = geometry();
    let traj = Trajectory::multisine(g.home_pose(), &MultiSineConfig::default())
        .expect("default multisine");
    let config = ControllerConfig {
        feedforward_n: [4000.0; LEG_COUNT],
        ..ControllerConfig::default()
    };
    let mut controller = Controller::new(g, traj, config).expect("feasible bench trajectory");
    // A perfectly tracking plant: each frame measures the previous tick's desired lengths.
    let mut frame = SensorFrame {
        leg_lengths_m: g.leg_lengths(&g.home_pose()).into(),
        leg_forces_n: [4000.0; LEG_COUNT],
        accel_m_s2: [0.0, 0.0, stewart_types::STANDARD_GRAVITY_M_S2],
        status: Status(Status::ENABLED),
        ..SensorFrame::default()
    };
    // Into the excitation: 1 s settle ramp + 2 s hold, then 10 s of multi-sine.
    for _ in 0..13_000 {
        let out = controller.tick(&frame);
        frame.sequence += 1;
        frame.time_s += 1e-3;
        frame.leg_lengths_m = out.desired_leg_lengths_m;
    }
    assert_eq!(controller.phase(), Phase::Excite);
    c.bench_function("controller_tick_excite", |b| {
        b.iter_batched(
            || (controller, frame),
            |(mut snapshot, f)| black_box(snapshot.tick(black_box(&f))),
            BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, pid_bank, trajectory_sample, controller_tick);
criterion_main!(benches);
