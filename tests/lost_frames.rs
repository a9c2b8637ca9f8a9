//! Experiment: lost frames and timestamp jitter against the estimate.

mod support;

use std::sync::atomic::AtomicBool;

use control::io::SensorFrame;
use estimator::{Estimate, EstimatorConfig};
use kinematics::FkOptions;
use measure::observer::{EstimatorStarted, Observer, TickEvent};
use measure::replay::{replay, BiasSigmas};
use measure::{End, LoadedConfig, MeasureSetup, Measurement};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use sim::scenario::Scenario;
use stewart_types::{parallel_axis, InertialParameters};

#[derive(Default)]
struct Recorder {
    frames: Vec<SensorFrame>,
    config: Option<(EstimatorConfig, FkOptions)>,
}

impl Observer for Recorder {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        self.frames.push(*e.frame);
        Ok(())
    }
    fn estimator_started(&mut self, e: &EstimatorStarted<'_>) -> anyhow::Result<()> {
        self.config = Some((*e.config, *e.fk));
        Ok(())
    }
}

struct Run {
    loaded: LoadedConfig,
    frames: Vec<SensorFrame>,
    config: EstimatorConfig,
    fk: FkOptions,
    truth_mass: f64,
    truth_jc: Matrix3<f64>,
}

fn loaded_run(scenario_text: &str, excitation_s: f64) -> Run {
    let loaded = support::config_str(scenario_text, "lost_frames.toml");
    let scenario = Scenario::new(loaded, None, None).expect("the scenario's world");
    let loaded = scenario.loaded.clone();
    let geometry = measure::setup::geometry(&loaded).expect("geometry");
    let trajectory =
        measure::setup::trajectory(&loaded, &geometry, excitation_s).expect("trajectory");
    let controller =
        measure::setup::controller(&loaded, &geometry, trajectory).expect("controller");
    let mut backend = scenario.simulator(geometry, true).expect("simulator");
    let setup = MeasureSetup {
        config: &loaded.config,
        geometry,
        measurement: Measurement::Loaded,
        tare: None,
    };
    let mut rec = Recorder::default();
    let outcome = measure::measure(
        &mut backend,
        &setup,
        controller,
        &mut rec,
        &AtomicBool::new(false),
    )
    .expect("the measurement runs");
    assert_eq!(outcome.end, End::Completed);
    let (config, fk) = rec.config.expect("the excitation started");
    let body = |b: sim::scenario::BodyConfig| {
        InertialParameters::from_com(
            b.mass_kg,
            Vector3::from(b.com_m),
            Matrix3::from_fn(|r, c| b.inertia_com_kg_m2[r][c]),
        )
        .to_vector()
    };
    let total =
        InertialParameters::from_vector(&(body(scenario.world.fixture) + body(scenario.world.payload)));
    let c = total.first_moment_kg_m / total.mass_kg;
    let jc = total.inertia_origin_kg_m2 - parallel_axis(&c) * total.mass_kg;
    Run {
        loaded,
        frames: rec.frames,
        config,
        fk,
        truth_mass: total.mass_kg,
        truth_jc: jc,
    }
}

fn estimate(run: &Run, frames: &[SensorFrame]) -> Estimate {
    replay(
        frames,
        run.config,
        run.fk,
        &run.loaded.config.sensors.imu,
        BiasSigmas::default(),
        1000,
    )
    .expect("replay")
    .estimate
}

fn summary(name: &str, run: &Run, e: &Estimate) {
    let s = e.inertia_com_sigma_kg_m2;
    let err = e.inertia_com_kg_m2 - run.truth_jc;
    let z = err.component_div(&s);
    println!(
        "{name:>12}: m {:.3}±{:.3} (z {:+.2}) σJ diag [{:.4} {:.4} {:.4}] off [{:.4} {:.4} {:.4}] z diag [{:+.2} {:+.2} {:+.2}] off [{:+.2} {:+.2} {:+.2}] used {} restarts {} resid {:?}",
        e.parameters.mass_kg,
        e.mass_sigma_kg,
        (e.parameters.mass_kg - run.truth_mass) / e.mass_sigma_kg,
        s[(0, 0)], s[(1, 1)], s[(2, 2)], s[(0, 1)], s[(0, 2)], s[(1, 2)],
        z[(0, 0)], z[(1, 1)], z[(2, 2)], z[(0, 1)], z[(0, 2)], z[(1, 2)],
        e.counts.used, e.counts.restarts,
        e.residual_rms.as_slice()
    );
}

fn drop_frames(frames: &[SensorFrame], share: f64, seed: u64) -> Vec<SensorFrame> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    frames
        .iter()
        .filter(|_| rng.random::<f64>() >= share)
        .copied()
        .collect()
}

fn jitter(frames: &[SensorFrame], sigma_s: f64, seed: u64) -> Vec<SensorFrame> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    frames
        .iter()
        .map(|f| {
            let mut f = *f;
            f.time_s += sigma_s * (2.0 * rng.random::<f64>() - 1.0) * 3f64.sqrt();
            f
        })
        .collect()
}

#[test]
#[ignore]
fn experiment() {
    let run = loaded_run("[run]\nduration_s = 20.0\n", 20.0);
    summary("all", &run, &estimate(&run, &run.frames));
    for seed in 1..4 {
        summary("1%", &run, &estimate(&run, &drop_frames(&run.frames, 0.01, seed)));
    }
    summary("10%", &run, &estimate(&run, &drop_frames(&run.frames, 0.10, 1)));
    summary("jitter10us", &run, &estimate(&run, &jitter(&run.frames, 10e-6, 1)));
}
