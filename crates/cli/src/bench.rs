//! `stewart bench`: can this computer run the loop fast enough?
//!
//! Measures, on the user's host and for the configured scenario, the full control-and-estimation
//! tick ([`TickPipeline::tick`]: sensor checks, forward kinematics, set-point, inverse
//! kinematics, six PIDs, supervisor gate, then leg-force wrench, conditioning, regressor and
//! RLS update on the same frame) and the simulator's speed. The platform is driven in closed
//! loop exactly as in a run (brake hold, settle, excitation, park) and every tick is timed on
//! its own, so the p99 includes what the host does to a real loop: other processes, cache
//! pollution by the physics step between ticks, frequency changes.
//!
//! The same [`TickPipeline`] and [`Scenario`] serve the criterion benches (`benches/tick.rs`)
//! and the no-heap test (`tests/no_heap_tick.rs`), so all three measure one definition of
//! "the tick".

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use clap::Args;
use control::controller::Controller;
use control::io::{Backend, CommandFrame, SensorFrame};
use control::supervisor::Phase;
use estimator::{EstimatorError, OnlineEstimator, Outcome, Sample};
use kinematics::{Vector3, Vector6};
use serde::Serialize;

use crate::config::NoisePreset;
use crate::config_load::LoadedConfig;
use crate::preflight::{self, Measurement};

/// Fraction of the sample period the tick's p99 may use for the loop rate to "fit with
/// margin": the rest is left for I/O, logging and the operating system's jitter.
pub const MARGIN_FRACTION: f64 = 0.5;

/// Flags of `stewart bench`.
#[derive(Clone, Debug, Default, Args)]
pub struct BenchArgs {
    /// Scenario TOML, laid over the embedded default (configs/default.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<std::path::PathBuf>,
    /// Excitation time of the measured run including the fades, simulated s.
    #[arg(long, value_name = "SECONDS", default_value_t = 20.0)]
    pub duration: f64,
    /// Sensor noise preset (sensors.noise).
    #[arg(long, value_enum)]
    pub noise: Option<NoisePreset>,
    /// Random seed of the simulation (run.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Print the result as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// What one [`TickPipeline::tick`] produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickStep {
    /// The command to write to the backend.
    pub command: CommandFrame,
    /// The controller's phase after the tick.
    pub phase: Phase,
    /// The estimator's verdict on this frame; `None` when forward kinematics gave no pose.
    pub estimator: Option<Result<Outcome, EstimatorError>>,
}

/// One full control-and-estimation tick's state: the controller and an estimator fed on the
/// same frame with the controller's forward-kinematics pose. Plain `Copy` data, so a snapshot
/// restores it exactly.
#[derive(Clone, Copy, Debug)]
pub struct TickPipeline {
    /// FK, set-point, IK, PIDs, supervisor.
    pub controller: Controller,
    /// Wrench, conditioning, regressor, RLS.
    pub estimator: OnlineEstimator,
}

impl TickPipeline {
    /// One tick: [`Controller::tick`], then [`OnlineEstimator::update`] with the frame's leg
    /// forces, gyro and accelerometer at the pose FK just found. Allocation-free.
    #[inline]
    pub fn tick(&mut self, frame: &SensorFrame) -> TickStep {
        let out = self.controller.tick(frame);
        let estimator = out.measured_pose.map(|pose| {
            self.estimator.update(&Sample {
                time_s: frame.time_s,
                pose,
                leg_forces_n: Vector6::from(frame.leg_forces_n),
                gyro_rad_s: Vector3::from(frame.gyro_rad_s),
                accel_m_s2: Vector3::from(frame.accel_m_s2),
            })
        });
        TickStep {
            command: out.command,
            phase: out.phase,
            estimator,
        }
    }
}

/// The configured scenario on the simulator (payload on), after the brake hold, with the
/// pipeline ready for its first tick.
pub struct Scenario {
    /// The simulated rig.
    pub sim: sim::Simulator,
    /// Controller and estimator.
    pub pipeline: TickPipeline,
    /// Excitation duration including the fades, s.
    pub excitation_s: f64,
}

/// The simulator settings of `config` (the same mapping `stewart simulate` uses).
pub fn sim_config(config: &crate::config::Config) -> sim::SimConfig {
    let mut sensors = sim::SensorConfig::preset(config.sensors.noise.to_sim());
    sensors.accelerometer.mount_m = config.sensors.imu_position_m;
    sim::SimConfig {
        sample_rate_hz: config.sensors.sample_rate_hz,
        substeps: config.sensors.physics_substeps,
        actuator: config.actuator,
        sensors,
        ..sim::SimConfig::default()
    }
}

impl Scenario {
    /// Builds the loaded world of `loaded` with an excitation of `excitation_s`, holds the
    /// brakes for `run.brake_hold_s` and takes the mean leg forces of the last 0.1 s as the
    /// PID feed-forward (as a measurement run does), then builds the controller and an
    /// estimator whose window is unbounded (it is fed on every tick).
    pub fn new(loaded: &LoadedConfig, excitation_s: f64) -> Result<Self> {
        let config = &loaded.config;
        let geometry = preflight::geometry(loaded).map_err(|e| anyhow!("{e}"))?;
        let trajectory =
            preflight::trajectory(loaded, &geometry, excitation_s).map_err(|e| anyhow!("{e}"))?;
        let mut sim = sim::Simulator::new(
            geometry,
            config.fixture.to_sim(),
            Some(config.payload.to_sim()),
            &sim_config(config),
            config.run.seed,
        )
        .map_err(|e| anyhow!("the simulator refused the scenario: {e}"))?;
        let rate_hz = config.sensors.sample_rate_hz;
        let hold = ((config.run.brake_hold_s * rate_hz).round() as u64).max(1);
        let average = ((0.1 * rate_hz).round() as u64).clamp(1, hold);
        let mut sum = [0.0; 6];
        for i in 0..hold {
            let frame = sim.read()?;
            if i >= hold - average {
                for (s, f) in sum.iter_mut().zip(frame.leg_forces_n) {
                    *s += f;
                }
            }
            sim.write(&CommandFrame::safe_stop(i, frame.sequence))?;
        }
        let mut controller_config = preflight::controller_config(config);
        controller_config.feedforward_n = sum.map(|s| s / average as f64);
        let controller = Controller::new(geometry, trajectory, controller_config)
            .map_err(|e| anyhow!("the controller refused the scenario: {e}"))?;
        let estimator_config = preflight::estimator_config(
            config,
            &geometry,
            Measurement::Loaded,
            f64::NEG_INFINITY,
            f64::INFINITY,
        );
        let estimator = OnlineEstimator::new(estimator_config)
            .map_err(|e| anyhow!("the estimator refused its settings: {e}"))?;
        Ok(Self {
            sim,
            pipeline: TickPipeline {
                controller,
                estimator,
            },
            excitation_s,
        })
    }

    /// Reads a frame, ticks, writes the command; returns the frame and the step.
    pub fn step(&mut self) -> Result<(SensorFrame, TickStep)> {
        let frame = self.sim.read()?;
        let step = self.pipeline.tick(&frame);
        self.sim.write(&step.command)?;
        Ok((frame, step))
    }

    /// Steps until the controller reaches `phase` (or gives up after `max_samples`).
    pub fn run_until(&mut self, phase: Phase, max_samples: u64) -> Result<()> {
        for _ in 0..max_samples {
            let (_, step) = self.step()?;
            if step.phase == phase {
                return Ok(());
            }
            if step.phase == Phase::Fault {
                bail!(
                    "the supervisor faulted: {:?}",
                    self.pipeline.controller.fault()
                );
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
    /// Pipeline state before `frames[0]`.
    pub start: TickPipeline,
    /// The frames, one per sample period.
    pub frames: Vec<SensorFrame>,
    /// The commands the pipeline sent in reply, one per frame.
    pub commands: Vec<CommandFrame>,
}

/// Records `frames` samples of the configured scenario, starting `into_excitation_s` seconds
/// into the excitation (the controller's busiest phase: FK moving, trajectory non-zero).
pub fn record(loaded: &LoadedConfig, frames: usize, into_excitation_s: f64) -> Result<Recording> {
    let period_s = 1.0 / loaded.config.sensors.sample_rate_hz;
    let excitation_s =
        into_excitation_s + frames as f64 * period_s + 2.0 * loaded.config.excitation.fade_s + 1.0;
    let mut scenario = Scenario::new(loaded, excitation_s)?;
    scenario.run_until(Phase::Excite, 600_000)?;
    for _ in 0..(into_excitation_s / period_s).round() as u64 {
        scenario.step()?;
    }
    let start = scenario.pipeline;
    let mut out = Vec::with_capacity(frames);
    let mut commands = Vec::with_capacity(frames);
    for _ in 0..frames {
        let (frame, step) = scenario.step()?;
        if step.phase != Phase::Excite {
            bail!(
                "the recording left the excitation (phase {})",
                step.phase.name()
            );
        }
        out.push(frame);
        commands.push(step.command);
    }
    Ok(Recording {
        start,
        frames: out,
        commands,
    })
}

/// Figures of `stewart bench`.
#[derive(Clone, Debug, PartialEq, Serialize)]
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
pub fn measure(loaded: &LoadedConfig, excitation_s: f64) -> Result<BenchReport> {
    let config = &loaded.config;
    let mut scenario = Scenario::new(loaded, excitation_s)?;
    let period_s = 1.0 / config.sensors.sample_rate_hz;
    let c = &config.control;
    let r = &config.run;
    let expected_s = c.settle_ramp_s + r.settle_s + excitation_s + r.park_s + c.park_hold_s;
    let budget = (expected_s / period_s).ceil() as usize + (120.0 / period_s) as usize;
    let mut ticks = Vec::with_capacity(budget);
    let mut steps = Vec::with_capacity(budget);
    let mut completed = false;
    let start = Instant::now();
    let mut sim_frame = scenario.sim.read()?;
    for _ in 0..budget {
        let t0 = Instant::now();
        let step = scenario.pipeline.tick(&sim_frame);
        let t1 = Instant::now();
        scenario.sim.write(&step.command)?;
        sim_frame = scenario.sim.read()?;
        let t2 = Instant::now();
        ticks.push(t1 - t0);
        steps.push(t2 - t1);
        match step.phase {
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
        physics_substeps: config.sensors.physics_substeps,
        noise: config.sensors.noise.name().into(),
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

/// `stewart bench`: loads the configuration, measures, prints. Returns the exit code: 0 when
/// the loop fits with margin, 1 when it does not, 2 when the input was refused.
pub fn main(args: &BenchArgs) -> u8 {
    let run_args = crate::args::RunArgs {
        config: args.config.clone(),
        seed: args.seed,
        noise: args.noise,
        ..Default::default()
    };
    let loaded = match crate::simulate::load_config(&run_args) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return 2;
        }
    };
    match measure(&loaded, args.duration) {
        Ok(report) => {
            if args.json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&report).unwrap_or_default()
                );
            } else {
                print!("{}", render(&report));
            }
            u8::from(!report.fits_with_margin)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            1
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config_load::load;

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
        let loaded = load(None).unwrap();
        let rec = record(&loaded, 200, 0.5).unwrap();
        let mut replay = rec.start;
        let steps: Vec<TickStep> = rec.frames.iter().map(|f| replay.tick(f)).collect();
        let commands: Vec<CommandFrame> = steps.iter().map(|s| s.command).collect();
        assert_eq!(commands, rec.commands);
        assert!(steps
            .iter()
            .all(|s| s.phase == Phase::Excite && s.command.enable));
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
