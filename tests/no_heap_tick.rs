//! No heap in the tick: a counting global allocator around every full control-and-estimation
//! tick (`stewart_cli::bench::TickPipeline::tick` = `Controller::tick` + `OnlineEstimator::update`
//! on the same frame) of a whole closed-loop run on the simulator — settle, excitation, park —
//! must see zero allocations, reallocations and frees. Start-up (config, simulator, controller,
//! estimator) and the simulator's own step may allocate: only the tick calls are counted, on
//! this thread (the test harness runs other tests on other threads).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use control::io::Backend;
use control::supervisor::Phase;
use estimator::Outcome;
use stewart_cli::bench::Scenario;
use stewart_cli::config_load::{load, load_str, LoadedConfig};

struct Counting;

// Per thread: the harness runs the tests side by side, and one test's allocations must not
// land in another's window.
thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static EVENTS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    // `try_with`: the allocator may run while this thread's locals are being torn down.
    if ARMED.try_with(Cell::get).unwrap_or(false) {
        let _ = EVENTS.try_with(|e| e.set(e.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note();
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` with this thread's allocations counted; returns its result and the count.
fn counted<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let before = EVENTS.with(Cell::get);
    ARMED.with(|a| a.set(true));
    let out = f();
    ARMED.with(|a| a.set(false));
    (out, EVENTS.with(Cell::get) - before)
}

#[test]
fn the_counter_sees_a_heap_allocation() {
    let (b, n) = counted(|| std::hint::black_box(Box::new([1u8; 64])));
    drop(b);
    assert!(n >= 1, "the counting allocator is not installed");
}

/// Ticks a whole run; returns (ticks, allocation events inside ticks, samples the estimator
/// used, phases seen).
fn whole_run(loaded: &LoadedConfig, excitation_s: f64) -> (u64, u64, u64, Vec<Phase>) {
    let mut scenario = Scenario::new(loaded, excitation_s).expect("default scenario");
    let (mut ticks, mut events, mut used) = (0u64, 0u64, 0u64);
    let mut phases = Vec::new();
    for _ in 0..100_000 {
        let frame = scenario.sim.read().expect("read");
        let (step, n) = counted(|| scenario.pipeline.tick(&frame));
        scenario.sim.write(&step.command).expect("write");
        ticks += 1;
        events += n;
        if step.estimator == Some(Ok(Outcome::Used)) {
            used += 1;
        }
        if phases.last() != Some(&step.phase) {
            phases.push(step.phase);
        }
        if matches!(step.phase, Phase::Done | Phase::Fault) {
            break;
        }
    }
    (ticks, events, used, phases)
}

fn check(loaded: &LoadedConfig) {
    let (ticks, events, used, phases) = whole_run(loaded, 6.0);
    assert_eq!(
        phases,
        [Phase::Settle, Phase::Excite, Phase::Park, Phase::Done],
        "the run must pass through every active phase"
    );
    assert!(ticks > 9_000, "only {ticks} ticks");
    // Every tick reaches the estimator; all but the stencil's first samples and the low-pass's
    // warm-up after the start (≈ 10 time constants) reach its fit.
    let warmup =
        estimator::conditioning::Conditioner::new(estimator::conditioning::ConditioningConfig {
            sample_period_s: 1.0 / loaded.config.sensors.sample_rate_hz,
            lowpass_cutoff_hz: Some(loaded.config.estimator.cutoff_hz),
            accelerometer_position_m: nalgebra::Vector3::zeros(),
            max_gap_s: 1.0,
            gyro_noise_rad_s: 0.0,
        })
        .expect("conditioning")
        .warmup_samples() as u64;
    assert!(
        used + 10 + warmup > ticks,
        "estimator used {used} of {ticks} samples (warm-up {warmup})"
    );
    assert_eq!(events, 0, "{events} heap events in {ticks} ticks");
}

#[test]
fn ten_parameter_ticks_never_touch_the_heap() {
    check(&load(None).expect("embedded default"));
}

#[test]
fn six_parameter_ticks_never_touch_the_heap() {
    check(&load_str("[estimator]\nparams = 6\n", "six.toml").expect("six-parameter config"));
}
