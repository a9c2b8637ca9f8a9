//! No heap in the measurement loop: a counting global allocator around the production
//! measurement (`measure::measure` on the simulator: brake hold, settle, excitation, park) sees
//! zero allocations, reallocations and frees from the first backend `read` until the
//! controller reaches `Phase::Done`. What the loop calls out to is not counted: the backend's
//! `read` and `write` (the simulator steps its physics there) and the observer's callbacks
//! (a log or a GUI may allocate) are disarmed by the test's own backend and observer. Start-up
//! (configuration, simulator, controller, estimator, the θ history's reservation) happens
//! before the first read and is not counted either.
//!
//! A second check counts [`measure::tick::Tick::step`] alone on the bench scenario, as the
//! criterion bench (`benches/tick.rs`) times it. Counting is per thread: the harness runs the
//! tests side by side, and one test's allocations must not land in another's window.

mod support;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::AtomicBool;

use control::io::{Backend, CommandFrame, SensorFrame};
use control::supervisor::Phase;
use estimator::Outcome;
use measure::observer::{EstimatorStarted, MeasurementEnded, Observer, TickEvent};
use measure::{End, MeasureSetup, Measurement};
use rig_description::LoadedConfig;
use sim::scenario::Scenario;

struct Counting;

/// Where this thread is in the counted window.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Window {
    /// Before the first backend read.
    NotStarted,
    /// From the first backend read until the controller reached Done.
    Open,
    /// After Done.
    Closed,
}

thread_local! {
    /// Allocation events are counted while set.
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static EVENTS: Cell<u64> = const { Cell::new(0) };
    static WINDOW: Cell<Window> = const { Cell::new(Window::NotStarted) };
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

/// Runs `f` (something the loop calls out to) uncounted, then re-arms if the window is open.
fn outside<T>(f: impl FnOnce() -> T) -> T {
    ARMED.with(|a| a.set(false));
    let out = f();
    ARMED.with(|a| a.set(WINDOW.with(Cell::get) == Window::Open));
    out
}

#[test]
fn the_counter_sees_a_heap_allocation() {
    let (b, n) = counted(|| std::hint::black_box(Box::new([1u8; 64])));
    drop(b);
    assert!(n >= 1, "the counting allocator is not installed");
}

/// The simulator as the measurement's backend: the first `read` opens the counted window;
/// the simulator's own work is not counted.
struct Uncounted {
    sim: sim::Simulator,
}

impl Backend for Uncounted {
    type Error = sim::SimError;

    fn read(&mut self) -> Result<SensorFrame, Self::Error> {
        if WINDOW.with(Cell::get) == Window::NotStarted {
            WINDOW.with(|w| w.set(Window::Open));
        }
        outside(|| self.sim.read())
    }

    fn write(&mut self, command: &CommandFrame) -> Result<(), Self::Error> {
        outside(|| self.sim.write(command))
    }

    fn sample_period_s(&self) -> f64 {
        self.sim.sample_period_s()
    }
}

/// Records the phases and the estimator's used samples; closes the counted window at Done.
/// Its own work (the records grow) is not counted.
#[derive(Default)]
struct Recorder {
    phases: Vec<Phase>,
    ticks: u64,
    excite_ticks: u64,
    used: u64,
    estimator_started: bool,
}

impl Observer for Recorder {
    fn measurement_started(&mut self, _: Measurement) -> anyhow::Result<()> {
        outside(|| Ok(()))
    }

    fn tick(&mut self, event: &TickEvent<'_>) -> anyhow::Result<()> {
        outside(|| {
            self.ticks += 1;
            if self.phases.last() != Some(&event.phase) {
                self.phases.push(event.phase);
            }
            if event.phase == Phase::Excite {
                self.excite_ticks += 1;
            }
            if let Some(e) = event.estimator {
                self.used = e.counts().used;
            }
            if matches!(event.phase, Phase::Done | Phase::Fault) {
                WINDOW.with(|w| w.set(Window::Closed));
            }
            Ok(())
        })
    }

    fn estimator_started(&mut self, _: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        outside(|| {
            self.estimator_started = true;
            Ok(())
        })
    }

    fn measurement_ended(&mut self, _: &MeasurementEnded<'_>) -> anyhow::Result<()> {
        outside(|| Ok(()))
    }
}

/// Excitation of the counted runs (including the fades), s.
const EXCITATION_S: f64 = 6.0;

/// One loaded measurement of `loaded`'s world (payload on) through `measure::measure`.
fn production_run(loaded: LoadedConfig) {
    let scenario = Scenario::new(loaded, None, None).expect("the scenario's world");
    let loaded = &scenario.loaded;
    let geometry = measure::setup::geometry(loaded).expect("geometry");
    let trajectory =
        measure::setup::trajectory(loaded, &geometry, EXCITATION_S).expect("trajectory");
    let controller = measure::setup::controller(loaded, &geometry, trajectory, Measurement::Loaded)
        .expect("controller");
    let mut backend = Uncounted {
        sim: scenario.simulator(geometry, true).expect("simulator"),
    };
    let setup = MeasureSetup {
        config: &loaded.config,
        geometry,
        measurement: Measurement::Loaded,
        tare: None,
    };
    let mut observer = Recorder::default();
    let stop = AtomicBool::new(false);

    WINDOW.with(|w| w.set(Window::NotStarted));
    let before = EVENTS.with(Cell::get);
    let outcome = measure::measure(&mut backend, &setup, controller, &mut observer, &stop);
    ARMED.with(|a| a.set(false));
    let events = EVENTS.with(Cell::get) - before;
    let window = WINDOW.with(Cell::get);
    let outcome = outcome.expect("the measurement runs");

    assert_eq!(outcome.end, End::Completed);
    assert!(
        window == Window::Closed,
        "the controller never reached Done"
    );
    assert_eq!(
        observer.phases,
        [
            Phase::Idle,
            Phase::Settle,
            Phase::Excite,
            Phase::Park,
            Phase::Done
        ],
        "the run must pass through every phase"
    );
    assert!(observer.estimator_started);
    check_used(observer.used, observer.excite_ticks, loaded);
    assert!(observer.ticks > 9_000, "only {} ticks", observer.ticks);
    assert_eq!(
        events, 0,
        "{events} heap events in the {} ticks of the measurement",
        observer.ticks
    );
}

/// The estimator fits (nearly) every sample of the excitation: its window opens on the first
/// excitation frame, and the conditioning has warmed up long before (from the brake hold on).
/// The simulated rig loses a share of its frames (`sensors.timing.frame_loss`): a tick per
/// frame that arrives, within 5 sigma of the binomial count.
fn check_used(used: u64, excite_ticks: u64, loaded: &LoadedConfig) {
    let rate_hz = loaded.config.sensors.sample_rate_hz;
    let frames = (EXCITATION_S * rate_hz).floor();
    let loss = loaded.config.sensors.timing.frame_loss;
    let fewest = frames * (1.0 - loss) - 5.0 * (frames * loss * (1.0 - loss)).sqrt() - 1.0;
    assert!(
        excite_ticks as f64 >= fewest,
        "only {excite_ticks} excitation ticks"
    );
    assert!(
        used + 10 >= excite_ticks && used <= excite_ticks + 10,
        "estimator used {used} samples over {excite_ticks} excitation ticks"
    );
}

#[test]
fn ten_parameter_measurement_never_touches_the_heap() {
    production_run(support::default_config());
}

#[test]
fn six_parameter_measurement_never_touches_the_heap() {
    production_run(support::config_str("[estimator]\nparams = 6\n", "six.toml"));
}

/// `Tick::step` alone, on the bench scenario the criterion bench uses: every step of a whole
/// closed-loop run after the brake hold (settle, excitation, park) counted, the simulator's
/// read and write between them not.
#[test]
fn the_tick_alone_never_touches_the_heap() {
    let scenario = support::default_world();
    let mut closed_loop =
        ops::bench::ClosedLoop::new(&scenario, EXCITATION_S).expect("bench closed loop");
    let (mut ticks, mut excite_ticks, mut events, mut used) = (0u64, 0u64, 0u64, 0u64);
    let mut phases = Vec::new();
    for _ in 0..100_000 {
        let frame = closed_loop.sim.read().expect("read");
        let (step, n) = counted(|| closed_loop.tick.step(&frame));
        closed_loop.sim.write(&step.control.command).expect("write");
        ticks += 1;
        events += n;
        if step.estimator == Some(Ok(Outcome::Used)) {
            used += 1;
        }
        if step.control.phase == Phase::Excite {
            excite_ticks += 1;
        }
        if phases.last() != Some(&step.control.phase) {
            phases.push(step.control.phase);
        }
        if matches!(step.control.phase, Phase::Done | Phase::Fault) {
            break;
        }
    }
    assert_eq!(
        phases,
        [Phase::Settle, Phase::Excite, Phase::Park, Phase::Done],
        "the run must pass through every active phase"
    );
    assert!(ticks > 9_000, "only {ticks} ticks");
    check_used(used, excite_ticks, &scenario.loaded);
    assert_eq!(events, 0, "{events} heap events in {ticks} ticks");
}
