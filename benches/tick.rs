//! The full control-and-estimation tick on a closed-loop stream of the default scenario, and
//! the parts of it that the per-crate benches do not already cover.
//!
//! The stream: 4096 sensor frames recorded from the simulator 2 s into the default excitation
//! (realistic noise), with the controller and estimator state just before the first frame
//! (`ops::bench::record`, on the production tick `measure::tick::Tick`). Each benchmark replays the ring through a copy of that state
//! and restores the copy (outside the timed window) when the ring wraps, so every timed tick
//! is a real tick of a real run: FK warm-started one sample away, a moving set-point, PIDs
//! tracking, an estimator with thousands of samples behind it.
//!
//! Clocks: every benchmark is timed on the thread's CPU clock (`CLOCK_THREAD_CPUTIME_ID`), so
//! time the scheduler gives to other processes on a busy shared host is not counted; the full
//! tick is also timed on the wall clock (`full_tick/wall`), which includes it. On an idle host
//! the two agree.
//!
//! - `full_tick`: `Tick::step`, the tick `simulate` and `rig` run = `Controller::tick` (sensor
//!   checks, FK, trajectory, IK, Jacobian, six PIDs, supervisor gate) + the frame-to-sample
//!   rule (`measure::feed`) at the controller's pose + `OnlineEstimator::update` (wrench,
//!   conditioning, regressor, weighted U-D RLS, residual scores) on the same frame.
//! - `full_tick/wall`: the same on the wall clock.
//! - `full_tick/controller_part`, `full_tick/estimator_part`: the two halves on the same stream.
//! - `supervisor_check_and_gate`: the supervisor's frame checks and command gate (the only part
//!   of the tick without a bench in its own crate).
//!
//! Already benched in their crates (not repeated here): FK, IK, Jacobian, wrench,
//! conditioning number (crates/kinematics/benches), PID bank, multi-sine sample, controller tick
//! on a synthetic plant (crates/control/benches), wrench, conditioning, regressor, RLS and the
//! whole estimator update (crates/estimator/benches), one simulator sample
//! (crates/sim/benches). `docs/performance.md` collects the medians.

use std::hint::black_box;
use std::time::{Duration, Instant};

use control::io::SensorFrame;
use control::supervisor::{Phase, Supervisor};
use criterion::{criterion_group, criterion_main, Criterion};
use estimator::{OnlineEstimator, Sample};
use ops::bench::{record, Recording};
use sim::scenario::Scenario;

const FRAMES: usize = 4096;

fn recording() -> Recording {
    let loaded = rig_description::load::load(None).expect("embedded default config");
    let scenario = Scenario::new(loaded, None, None).expect("the default world");
    record(&scenario, FRAMES, 2.0).expect("record the default scenario")
}

#[derive(Clone, Copy)]
enum Clock {
    /// CPU time of this thread.
    Cpu,
    /// `Instant`.
    Wall,
}

fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the call's duration.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

impl Clock {
    fn time(self, f: impl FnOnce()) -> Duration {
        match self {
            Clock::Cpu => {
                let t0 = thread_cpu_time();
                f();
                thread_cpu_time() - t0
            }
            Clock::Wall => {
                let t0 = Instant::now();
                f();
                t0.elapsed()
            }
        }
    }
}

/// Times `f` over the ring `items`, `iters` times in all, restoring `start` at every wrap
/// outside the timed window.
fn ring<S: Clone, T>(
    clock: Clock,
    iters: u64,
    start: &S,
    items: &[T],
    mut f: impl FnMut(&mut S, &T),
) -> Duration {
    let mut state = start.clone();
    let mut total = Duration::ZERO;
    let mut done = 0u64;
    while done < iters {
        let n = (iters - done).min(items.len() as u64) as usize;
        total += clock.time(|| {
            for item in &items[..n] {
                f(&mut state, item);
            }
        });
        done += n as u64;
        state.clone_from(start);
    }
    total
}

fn bench(c: &mut Criterion) {
    let rec = recording();

    c.bench_function("full_tick", |b| {
        b.iter_custom(|iters| {
            ring(Clock::Cpu, iters, &rec.start, &rec.frames, |t, f| {
                black_box(t.step(black_box(f)));
            })
        })
    });

    c.bench_function("full_tick/wall", |b| {
        b.iter_custom(|iters| {
            ring(Clock::Wall, iters, &rec.start, &rec.frames, |t, f| {
                black_box(t.step(black_box(f)));
            })
        })
    });

    c.bench_function("full_tick/controller_part", |b| {
        b.iter_custom(|iters| {
            ring(
                Clock::Cpu,
                iters,
                &rec.start.controller,
                &rec.frames,
                |ctl, f| {
                    black_box(ctl.tick(black_box(f)));
                },
            )
        })
    });

    // The estimator's inputs exactly as the full tick builds them (it builds them: the same
    // tick, replayed).
    let mut tick = rec.start.clone();
    let samples: Vec<Sample> = rec
        .frames
        .iter()
        .map(|f| tick.step(f).sample.expect("FK converges on the stream"))
        .collect();
    let estimator: OnlineEstimator = *rec.start.estimator;
    c.bench_function("full_tick/estimator_part", |b| {
        b.iter_custom(|iters| {
            ring(Clock::Cpu, iters, &estimator, &samples, |e, s| {
                let _ = black_box(e.update(black_box(s)));
            })
        })
    });

    let config = rec.start.controller.config().supervisor;
    let stroke = rec.start.controller.geometry().stroke();
    let mut supervisor = Supervisor::new(config, stroke).expect("valid supervisor config");
    supervisor.set_phase(Phase::Excite);
    let first: &SensorFrame = &rec.frames[0];
    supervisor
        .check_sensors(first)
        .expect("the first frame passes the checks");
    let forces = [2500.0, 2600.0, 2400.0, 2550.0, 2450.0, 2500.0];
    c.bench_function("supervisor_check_and_gate", |b| {
        b.iter_custom(|iters| {
            ring(Clock::Cpu, iters, &supervisor, &rec.frames[1..], |s, f| {
                let _ = black_box(s.check_sensors(black_box(f)));
                black_box(s.gate(black_box(&forces), f.sequence));
            })
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
