//! Lost and late frames cost little: the default car measured for 20 s (tare and loaded
//! runs, the datasheet's noise), then the same recorded frames re-estimated with 1 % and 10 %
//! of them dropped at random and with 10 µs of timestamp jitter. The payload (loaded − tare)
//! is checked against the simulator's truth.
//!
//! Figures (`cargo test --release --test lost_frames -- --nocapture` prints them): before the
//! conditioning bridged gaps on its grid, 1 % lost multiplied σ(J_C) by 3–5 and 10 % by 13–18,
//! and 10 µs of jitter by 1.4–2.2; with it, at most 1.04, 1.18 and 1.0 (docs/accuracy.md).

use crate::support;

use control::io::SensorFrame;
use estimator::{Estimate, EstimatorConfig};
use kinematics::FkOptions;
use measure::observer::{EstimatorStarted, Observer, TickEvent};
use measure::replay::{replay, BiasSigmas};
use measure::Measurement;
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rig_description::LoadedConfig;
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

/// One measurement's frames and the estimator settings it ran with.
struct Recorded {
    frames: Vec<SensorFrame>,
    config: EstimatorConfig,
    fk: FkOptions,
}

/// The tare and the loaded measurement of one scenario, and the payload's truth.
struct Runs {
    loaded: LoadedConfig,
    tare: Recorded,
    payload_on: Recorded,
    truth: InertialParameters,
}

fn measure_one(scenario: &Scenario, measurement: Measurement) -> Recorded {
    let mut rec = Recorder::default();
    support::measure_run(scenario, measurement, &mut rec);
    let (config, fk) = rec.config.expect("the excitation started");
    Recorded {
        frames: rec.frames,
        config,
        fk,
    }
}

fn runs(scenario_text: &str) -> Runs {
    let loaded = support::config_str(scenario_text, "lost_frames.toml");
    let scenario = Scenario::new(loaded, None, None).expect("the scenario's world");
    let p = scenario.world.payload;
    Runs {
        loaded: scenario.loaded.clone(),
        tare: measure_one(&scenario, Measurement::Tare),
        payload_on: measure_one(&scenario, Measurement::Loaded),
        truth: InertialParameters::from_com(
            p.mass_kg,
            Vector3::from(p.com_m),
            Matrix3::from_fn(|r, c| p.inertia_com_kg_m2[r][c]),
        ),
    }
}

fn replayed(runs: &Runs, run: &Recorded, frames: &[SensorFrame]) -> Estimate {
    replay(
        frames,
        run.config,
        run.fk,
        &runs.loaded.config.sensors.imu,
        BiasSigmas::default(),
        1000,
    )
    .expect("replay")
    .estimate
}

/// The payload alone: loaded − tare, covariances added (the runs are independent).
fn payload(runs: &Runs, tare: &[SensorFrame], loaded: &[SensorFrame]) -> (Estimate, Estimate) {
    let t = replayed(runs, &runs.tare, tare);
    let l = replayed(runs, &runs.payload_on, loaded);
    let theta = l.parameters.to_vector() - t.parameters.to_vector();
    let p = Estimate::from_parameters(
        InertialParameters::from_vector(&theta),
        l.covariance + t.covariance,
    );
    (p, l)
}

fn summary(name: &str, runs: &Runs, (e, l): &(Estimate, Estimate)) {
    let truth_c = runs.truth.com_m().unwrap();
    let truth_j = runs.truth.inertia_origin_kg_m2 - parallel_axis(&truth_c) * runs.truth.mass_kg;
    let s = e.inertia_com_sigma_kg_m2;
    let z = (e.inertia_com_kg_m2 - truth_j).component_div(&s);
    println!(
        "{name:>12}: m {:.3}±{:.3} (z {:+.2}) σJ diag [{:.4} {:.4} {:.4}] off [{:.4} {:.4} {:.4}] z diag [{:+.2} {:+.2} {:+.2}] off [{:+.2} {:+.2} {:+.2}] used {} lost {} bridged {} restarts {} jitter {:.2e} resid {:?}",
        e.parameters.mass_kg,
        e.mass_sigma_kg,
        (e.parameters.mass_kg - runs.truth.mass_kg) / e.mass_sigma_kg,
        s[(0, 0)], s[(1, 1)], s[(2, 2)], s[(0, 1)], s[(0, 2)], s[(1, 2)],
        z[(0, 0)], z[(1, 1)], z[(2, 2)], z[(0, 1)], z[(0, 2)], z[(1, 2)],
        l.counts.used, l.counts.lost, l.counts.bridged, l.counts.restarts, l.timing.jitter_rms_s,
        l.residual_rms.as_slice()
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

/// σ(J_C) and the errors' z of `e` against the full run `full` and the truth.
fn check(name: &str, runs: &Runs, full: &Estimate, e: &(Estimate, Estimate), max_ratio: f64) {
    summary(name, runs, e);
    let truth_c = runs.truth.com_m().expect("the payload has a mass");
    let truth_j = runs.truth.inertia_origin_kg_m2 - parallel_axis(&truth_c) * runs.truth.mass_kg;
    let e = &e.0;
    let mut z2 = 0.0;
    for (r, c) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
        let sigma = e.inertia_com_sigma_kg_m2[(r, c)];
        let ratio = sigma / full.inertia_com_sigma_kg_m2[(r, c)];
        assert!(
            ratio <= max_ratio,
            "{name}: σ(J_C {r}{c}) grew {ratio:.2}-fold, more than {max_ratio}"
        );
        let z = (e.inertia_com_kg_m2[(r, c)] - truth_j[(r, c)]) / sigma;
        assert!(z.abs() < 3.0, "{name}: J_C {r}{c} off by {z:.2} sigma");
        z2 += z * z / 6.0;
    }
    assert!(z2 < 3.0, "{name}: mean z² of J_C {z2:.2}");
}

#[test]
fn lost_and_late_frames_cost_little() {
    // The recording's own world has the datasheet's noise, biases and zero offsets only: the
    // lost and late frames are what this test adds to it, by dropping and moving frames.
    let runs = runs(
        "[run]\nduration_s = 20.0\ntare_duration_s = 20.0\n\
         [world.imperfections]\nload_cell_scale = false\nload_cell_crosstalk = false\n\
         imu_misalignment = false\nimu_lever_arm = false\ntime_skew = false\n\
         timestamp_jitter = false\nframe_loss = false\nleg_dynamics = false\n\
         joint_friction = false\ngeometry = false\n",
    );
    let (t, l) = (&runs.tare.frames, &runs.payload_on.frames);
    let full = payload(&runs, t, l);
    summary("all frames", &runs, &full);
    assert_eq!(full.1.counts.lost, 0);
    assert!(full.1.timing.from_sequence);

    for seed in 1..3 {
        let e = payload(
            &runs,
            &drop_frames(t, 0.01, seed),
            &drop_frames(l, 0.01, seed + 10),
        );
        // Every lost frame of the loaded run's fed stretch was bridged; none restarted.
        let counts = e.1.counts;
        assert!(counts.lost > 100, "{counts:?}");
        assert_eq!((counts.bridged, counts.restarts), (counts.lost, 0));
        check("1 % lost", &runs, &full.0, &e, 1.2);
    }
    let e = payload(&runs, &drop_frames(t, 0.1, 1), &drop_frames(l, 0.1, 11));
    check("10 % lost", &runs, &full.0, &e, 2.0);

    // Jitter: measured, and the estimate moves by far less than its sigma.
    let e = payload(&runs, &jitter(t, 10e-6, 1), &jitter(l, 10e-6, 2));
    check("10 µs jitter", &runs, &full.0, &e, 1.05);
    let timing = e.1.timing;
    assert!(
        (timing.jitter_rms_s / 10e-6 - 1.0).abs() < 0.05 && !timing.rate_exceeded,
        "{timing:?}"
    );
    for (r, c) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
        let moved = (e.0.inertia_com_kg_m2[(r, c)] - full.0.inertia_com_kg_m2[(r, c)]).abs();
        let sigma = full.0.inertia_com_sigma_kg_m2[(r, c)];
        assert!(
            moved < 0.1 * sigma,
            "jitter moved J_C {r}{c} by {moved} ({sigma} one sigma)"
        );
    }
}
