//! `stewart bench`'s work: can this computer run the loop fast enough?
//!
//! Measures, on the user's host and for the configured scenario, the full control-and-estimation
//! tick ([`measure::tick::Tick::step`], the tick `simulate` and `rig` run: sensor checks,
//! forward kinematics, set-point, inverse kinematics, six PIDs, supervisor gate, then
//! leg-force wrench, conditioning, regressor and RLS update on the same frame) and the
//! simulator's speed. The platform is driven in closed loop exactly as in a run (brake hold,
//! settle, excitation, park) and every tick is timed on its own, so the p99 includes what the
//! host does to a real loop: other processes, cache pollution by the physics step between
//! ticks, frequency changes.
//!
//! The same [`Tick`] and [`ClosedLoop`] serve the criterion benches (`benches/tick.rs`) and
//! the no-heap test (`tests/no_heap_tick.rs`), so all three measure one definition of "the
//! tick".

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use control::io::{Backend, CommandFrame, SensorFrame};
use control::supervisor::Phase;
use measure::setup::{self, Measurement};
use measure::tick::{Tick, TickStep};
use serde::{Deserialize, Serialize};
use sim::scenario::Scenario;
use sim::NoisePreset;

/// Fraction of the sample period the tick's p99 may use for the loop rate to "fit with
/// margin": the rest is left for I/O, logging and the operating system's jitter.
pub const MARGIN_FRACTION: f64 = 0.5;

/// Options of `stewart bench`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchOptions {
    /// Scenario TOML, laid over the embedded default (configs/default.toml).
    pub config: Option<PathBuf>,
    /// Excitation time of the measured run including the fades, simulated s.
    pub duration_s: f64,
    /// Sensor grade (`None`: the rig description's datasheet).
    pub noise: Option<NoisePreset>,
    /// Random seed of the simulated world (world.seed).
    pub seed: Option<u64>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        Self {
            config: None,
            duration_s: 20.0,
            noise: None,
            seed: None,
        }
    }
}

/// Why `bench` measured nothing.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The configuration was refused before anything ran.
    #[error("{0}")]
    Config(#[from] rig_description::load::ConfigError),
    /// The closed loop failed.
    #[error("{0:#}")]
    Run(anyhow::Error),
}

/// Runs `bench`: loads the scenario of `options` and measures it ([`measure`]).
pub fn run(options: &BenchOptions) -> Result<BenchReport, Error> {
    // `--duration` stands for run.duration_s, and the bench keeps every tick's time: the key's
    // range bounds that record.
    let range = rig_description::range::ranges::RUN_DURATION_S;
    if let Some(problem) = range.problem(options.duration_s) {
        return Err(Error::Config(rig_description::load::ConfigError::single(
            crate::measurement::flag_issue("--duration", problem),
        )));
    }
    let loaded = rig_description::load::load(options.config.as_deref())?;
    let scenario = Scenario::new(loaded, options.seed, options.noise)?;
    measure(&scenario, options.duration_s).map_err(Error::Run)
}

/// The configured scenario on the simulator (payload on), after the brake hold, with the
/// production tick ([`Tick`]) ready for its first controlled frame.
pub struct ClosedLoop {
    /// The simulated rig.
    pub sim: sim::Simulator,
    /// Controller, frame-to-sample rule, estimator: the tick `simulate` and `rig` run.
    pub tick: Tick,
    /// Excitation duration including the fades, s.
    pub excitation_s: f64,
}

impl ClosedLoop {
    /// Builds the loaded world of `scenario` with an excitation of `excitation_s`, holds the
    /// brakes for `run.brake_hold_s` feeding the estimator's conditioning and takes the mean
    /// leg forces of the last 0.1 s as the PID feed-forward, as a measurement does.
    pub fn new(scenario: &Scenario, excitation_s: f64) -> Result<Self> {
        let loaded = &scenario.loaded;
        let config = &loaded.config;
        let geometry = setup::geometry(loaded).map_err(|e| anyhow!("{e}"))?;
        let trajectory =
            setup::trajectory(loaded, &geometry, excitation_s).map_err(|e| anyhow!("{e}"))?;
        let controller = setup::controller(loaded, &geometry, trajectory, Measurement::Loaded)
            .map_err(|e| anyhow!("{e}"))?;
        let mut sim = scenario
            .simulator(geometry, true)
            .map_err(|e| anyhow!("{e}"))?;
        let mut tick = setup::tick(config, &geometry, Measurement::Loaded, controller)
            .map_err(|e| anyhow!("the estimator refused its settings: {e}"))?;
        let feedforward =
            measure::run::brake_hold(&mut sim, &mut tick, config, |_, _, _, _| Ok(false))?
                .context("the brake hold stopped")?;
        tick.start_control(
            feedforward,
            setup::feedforward_load(config, Measurement::Loaded, None),
        )?;
        Ok(Self {
            sim,
            tick,
            excitation_s,
        })
    }

    /// Reads a frame, ticks, writes the command; returns the frame and the step.
    pub fn step(&mut self) -> Result<(SensorFrame, TickStep)> {
        let frame = self.sim.read()?;
        let step = self.tick.step(&frame);
        self.sim.write(&step.control.command)?;
        Ok((frame, step))
    }

    /// Steps until the controller reaches `phase` (or gives up after `max_samples`).
    pub fn run_until(&mut self, phase: Phase, max_samples: u64) -> Result<()> {
        for _ in 0..max_samples {
            let (_, step) = self.step()?;
            if step.control.phase == phase {
                return Ok(());
            }
            if step.control.phase == Phase::Fault {
                bail!("the supervisor faulted: {:?}", self.tick.controller.fault());
            }
        }
        bail!(
            "phase {} not reached in {max_samples} samples",
            phase.name()
        )
    }
}

/// A closed-loop sensor stream and the pipeline's state just before its first frame: replaying
/// `frames` through a copy of `start` gives exactly the ticks of the recorded run (the
/// commands only feed the simulator, which is not replayed).
#[derive(Clone, Debug)]
pub struct Recording {
    /// Tick state before `frames[0]`.
    pub start: Tick,
    /// The frames, one per sample period.
    pub frames: Vec<SensorFrame>,
    /// The commands the pipeline sent in reply, one per frame.
    pub commands: Vec<CommandFrame>,
}

/// Records `frames` samples of the configured scenario, starting `into_excitation_s` seconds
/// into the excitation (the controller's busiest phase: FK moving, trajectory non-zero).
pub fn record(scenario: &Scenario, frames: usize, into_excitation_s: f64) -> Result<Recording> {
    let config = &scenario.loaded.config;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let excitation_s =
        into_excitation_s + frames as f64 * period_s + 2.0 * config.excitation.fade_s + 1.0;
    let mut run = ClosedLoop::new(scenario, excitation_s)?;
    run.run_until(Phase::Excite, 600_000)?;
    for _ in 0..(into_excitation_s / period_s).round() as u64 {
        run.step()?;
    }
    let start = run.tick.clone();
    let mut out = Vec::with_capacity(frames);
    let mut commands = Vec::with_capacity(frames);
    for _ in 0..frames {
        let (frame, step) = run.step()?;
        if step.control.phase != Phase::Excite {
            bail!(
                "the recording left the excitation (phase {})",
                step.control.phase.name()
            );
        }
        out.push(frame);
        commands.push(step.control.command);
    }
    Ok(Recording {
        start,
        frames: out,
        commands,
    })
}

/// Figures of `stewart bench`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// Configuration source.
    pub config: String,
    /// Loop (sample) rate, Hz.
    pub sample_rate_hz: f64,
    /// Physics substeps per sample.
    pub physics_substeps: u32,
    /// Noise preset of the simulated sensors.
    pub noise: String,
    /// Logical CPUs the host offers this process.
    pub host_cpus: usize,
    /// False when this binary was built without optimisations (figures then mean little).
    pub release_build: bool,
    /// Ticks timed (every tick from the first settle frame to the end of the park).
    pub ticks: u64,
    /// Median time of one full tick, µs.
    pub tick_median_us: f64,
    /// 99th percentile, µs.
    pub tick_p99_us: f64,
    /// Longest tick, µs.
    pub tick_max_us: f64,
    /// Sample period, µs.
    pub period_us: f64,
    /// p99 as a fraction of the sample period.
    pub p99_fraction_of_period: f64,
    /// `p99 < MARGIN_FRACTION × period`.
    pub fits_with_margin: bool,
    /// One-line verdict.
    pub verdict: String,
    /// Samples the simulator advanced while timed.
    pub sim_samples: u64,
    /// Simulated seconds per wall second of the simulator alone (`write` + `read`).
    pub sim_speed: f64,
    /// Median of one simulator sample period (`write` + `read`), µs.
    pub sim_step_median_us: f64,
    /// Simulated seconds per wall second of the whole closed loop (simulator + tick + timing).
    pub closed_loop_speed: f64,
    /// Whether the run ended normally (a fault would make the figures unrepresentative).
    pub completed: bool,
}

/// Microseconds, to the nanosecond.
fn micros(d: Duration) -> f64 {
    d.as_nanos() as f64 / 1e3
}

/// `x` to `digits` significant figures (so the JSON shows what was measured, not float noise).
fn significant(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// The `q`-quantile (0..=1) of sorted durations, by the nearest-rank rule.
pub fn quantile(sorted: &[Duration], q: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Runs the configured scenario once in closed loop, timing every tick and every simulator
/// step, and judges whether the loop rate fits.
pub fn measure(scenario: &Scenario, excitation_s: f64) -> Result<BenchReport> {
    let loaded = &scenario.loaded;
    let config = &loaded.config;
    let mut run = ClosedLoop::new(scenario, excitation_s)?;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let c = &config.control;
    let r = &config.run;
    let expected_s = c.settle_ramp_s + r.settle_s + excitation_s + r.park_s + c.park_hold_s;
    let budget = (expected_s / period_s).ceil() as usize + (120.0 / period_s) as usize;
    let mut ticks = Vec::with_capacity(budget);
    let mut steps = Vec::with_capacity(budget);
    let mut completed = false;
    let start = Instant::now();
    let mut sim_frame = run.sim.read()?;
    for _ in 0..budget {
        let t0 = Instant::now();
        let step = run.tick.step(&sim_frame);
        let t1 = Instant::now();
        run.sim.write(&step.control.command)?;
        sim_frame = run.sim.read()?;
        let t2 = Instant::now();
        ticks.push(t1 - t0);
        steps.push(t2 - t1);
        match step.control.phase {
            Phase::Done => {
                completed = true;
                break;
            }
            Phase::Fault => break,
            _ => {}
        }
    }
    let wall = start.elapsed();
    let sim_wall: Duration = steps.iter().sum();
    let simulated_s = steps.len() as f64 * period_s;
    ticks.sort_unstable();
    steps.sort_unstable();
    let median = micros(quantile(&ticks, 0.5));
    let p99 = micros(quantile(&ticks, 0.99));
    let period_us = period_s * 1e6;
    let fraction = p99 / period_us;
    let fits = fraction < MARGIN_FRACTION;
    let verdict = if fits {
        format!(
            "fits with margin: p99 {p99:.1} µs is {:.1} % of the {period_us:.0} µs period (limit {:.0} %)",
            100.0 * fraction,
            100.0 * MARGIN_FRACTION
        )
    } else if fraction < 1.0 {
        format!(
            "fits without margin: p99 {p99:.1} µs is {:.1} % of the {period_us:.0} µs period (want < {:.0} %); lower sensors.sample_rate_hz or use a faster host",
            100.0 * fraction,
            100.0 * MARGIN_FRACTION
        )
    } else {
        format!(
            "does not fit: p99 {p99:.1} µs exceeds the {period_us:.0} µs period; lower sensors.sample_rate_hz or use a faster host"
        )
    };
    Ok(BenchReport {
        config: loaded.source.clone(),
        sample_rate_hz: config.sensors.sample_rate_hz,
        physics_substeps: scenario.world.physics_substeps,
        noise: scenario.noise.name().into(),
        host_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
        release_build: !cfg!(debug_assertions),
        ticks: ticks.len() as u64,
        tick_median_us: median,
        tick_p99_us: p99,
        tick_max_us: micros(ticks.last().copied().unwrap_or_default()),
        period_us,
        p99_fraction_of_period: significant(fraction, 3),
        fits_with_margin: fits,
        verdict,
        sim_samples: steps.len() as u64,
        sim_speed: significant(simulated_s / sim_wall.as_secs_f64(), 3),
        sim_step_median_us: micros(quantile(&steps, 0.5)),
        closed_loop_speed: significant(simulated_s / wall.as_secs_f64(), 3),
        completed,
    })
}

/// The report as a short table.
pub fn render(b: &BenchReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "loop: {:.0} Hz ({:.0} µs period), {} physics substeps, noise {}, {} CPUs{}",
        b.sample_rate_hz,
        b.period_us,
        b.physics_substeps,
        b.noise,
        b.host_cpus,
        if b.release_build {
            ""
        } else {
            " — DEBUG BUILD: use `cargo run --release` for real figures"
        }
    );
    let _ = writeln!(
        out,
        "full tick (control + estimation), {} ticks: median {:.2} µs, p99 {:.2} µs, max {:.1} µs",
        b.ticks, b.tick_median_us, b.tick_p99_us, b.tick_max_us
    );
    let _ = writeln!(
        out,
        "simulator: {:.0} simulated s per wall s ({:.1} µs per sample); closed loop {:.0}×",
        b.sim_speed, b.sim_step_median_us, b.closed_loop_speed
    );
    if !b.completed {
        let _ = writeln!(
            out,
            "warning: the run did not finish normally; figures may be unrepresentative"
        );
    }
    let _ = writeln!(out, "{}", b.verdict);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::Outcome;

    #[test]
    fn nearest_rank_quantiles() {
        let d: Vec<Duration> = (1..=100).map(Duration::from_micros).collect();
        assert_eq!(quantile(&d, 0.5), Duration::from_micros(50));
        assert_eq!(quantile(&d, 0.99), Duration::from_micros(99));
        assert_eq!(quantile(&d, 1.0), Duration::from_micros(100));
        assert_eq!(quantile(&[], 0.5), Duration::ZERO);
    }

    #[test]
    fn significant_figures() {
        assert_eq!(significant(0.0038160000000000004, 3), 0.00382);
        assert_eq!(significant(289.1760214832255, 3), 289.0);
        assert_eq!(significant(-12.345, 2), -12.0);
        assert_eq!(significant(0.0, 3), 0.0);
    }

    #[test]
    fn replaying_a_recording_reproduces_the_run_bit_for_bit() {
        let scenario =
            Scenario::new(rig_description::load::load(None).unwrap(), None, None).unwrap();
        let rec = record(&scenario, 200, 0.5).unwrap();
        let mut replay = rec.start;
        let steps: Vec<TickStep> = rec.frames.iter().map(|f| replay.step(f)).collect();
        let commands: Vec<CommandFrame> = steps.iter().map(|s| s.control.command).collect();
        assert_eq!(commands, rec.commands);
        assert!(steps
            .iter()
            .all(|s| s.control.phase == Phase::Excite && s.control.command.enable));
        assert!(steps.iter().all(|s| s.estimator == Some(Ok(Outcome::Used))));
        // The legs really move: the commands are not a constant hold.
        let spread = rec
            .commands
            .iter()
            .map(|c| c.leg_forces_n[0])
            .fold((f64::MAX, f64::MIN), |(lo, hi), f| (lo.min(f), hi.max(f)));
        assert!(spread.1 - spread.0 > 1.0, "{spread:?}");
    }
}
