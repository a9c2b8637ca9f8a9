//! `stewart simulate` end to end, through the library entry point: the default car measured
//! with realistic noise (a shorter excitation than the 60 s acceptance run, so looser
//! figures), the paper's case converging within 50 samples, and the tare: subtracted, saved,
//! reused, and refused for another rig.
//!
//! Every figure is checked against the simulator's truth, which only the report carries.

use crate::support;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use measure::report::{Quantities, Report};
use measure::End;
use sim::NoisePreset;
use support::{simulate_args, Outcome, Scratch, SimulateOptions, IDEAL_LEGS};

/// Runs `simulate` on `scenario` (laid over the default) in a fresh directory.
fn run(
    scenario: &str,
    extra: impl FnOnce(&mut SimulateOptions, &Path),
) -> (tempfile::TempDir, Outcome) {
    let scratch = Scratch::new(scenario);
    let mut args = simulate_args(Some(scratch.config.clone()), scratch.path("run.mcap"));
    extra(&mut args, scratch.dir.path());
    let outcome = support::run_simulate(&args).unwrap_or_else(|e| panic!("{e}"));
    (scratch.dir, outcome)
}

/// `--noise GRADE`: the rig description's datasheet scaled (0 for `none`), for the simulated
/// sensors and the estimator alike.
fn noise(grade: NoisePreset) -> impl FnOnce(&mut SimulateOptions, &Path) {
    move |a, _| a.noise = Some(grade)
}

fn report(outcome: &Outcome) -> &Report {
    outcome
        .report
        .as_ref()
        .expect("a completed run has a report")
}

/// Each checked entry: (name, estimate, sigma, truth).
fn entries(r: &Report) -> Vec<(String, f64, f64, f64)> {
    let t = r.truth.as_ref().expect("simulation reports the truth");
    let get = |q: &Quantities, i: usize| -> f64 {
        match i {
            0 => q.mass,
            1..=3 => q.com[i - 1],
            _ => {
                let (a, b) = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)][i - 4];
                q.inertia_com[a][b]
            }
        }
    };
    let names = [
        "mass", "cx", "cy", "cz", "Jxx", "Jyy", "Jzz", "Jxy", "Jxz", "Jyz",
    ];
    (0..10)
        .map(|i| {
            (
                names[i].to_string(),
                get(&r.estimate, i),
                get(&r.sigma, i),
                get(t, i),
            )
        })
        .collect()
}

/// The acceptance figures, each loosened by `factor`: mass 0.2 %, centre of mass 1 mm,
/// diagonal of J_C 0.5 %, off-diagonal 0.5 % of the smallest principal moment; and the truth
/// within `k` sigma.
fn check_accuracy(r: &Report, factor: f64, k: f64) {
    let smallest = r.principal.moments[0];
    for (name, est, sigma, truth) in entries(r) {
        let err = est - truth;
        let tol = match &name[..] {
            "mass" => 0.002 * truth,
            "cx" | "cy" | "cz" => 1e-3,
            "Jxx" | "Jyy" | "Jzz" => 0.005 * truth,
            _ => 0.005 * smallest,
        } * factor;
        assert!(
            err.abs() <= tol,
            "{name}: estimate {est} truth {truth} error {err:e} beyond {tol:e}"
        );
        assert!(sigma > 0.0 && sigma.is_finite(), "{name}: sigma {sigma}");
        assert!(
            err.abs() <= k * sigma,
            "{name}: error {err:e} is {:.1} sigma (sigma {sigma:e})",
            err / sigma
        );
    }
}

#[test]
fn default_car_with_realistic_noise() {
    // 15 s of excitation instead of 60: sigmas about twice as large, so twice the tolerance.
    let (_dir, outcome) = run(
        "[run]\nduration_s = 15.0\ntare_duration_s = 10.0\n",
        noise(NoisePreset::Realistic),
    );
    let r = report(&outcome);
    check_accuracy(r, 2.0, 4.0);
    assert_eq!(r.consistency.verdict, "consistent");
    assert_eq!(r.tare.source, "measured");
    assert!(r.samples > 14_000, "samples {}", r.samples);
    assert!((r.excitation_s - 15.0).abs() < 0.01, "{}", r.excitation_s);
    assert_eq!(r.rejected_samples, 0);
    // The accelerometer's bias is part of the sigma, and it dominates the mass's.
    assert!(r.systematic.sigma.mass > 0.0 && r.systematic.sigma.mass <= r.sigma.mass);
}

#[test]
fn default_car_without_noise_is_exact() {
    let (_dir, outcome) = run(
        &format!("{IDEAL_LEGS}[run]\nduration_s = 10.0\ntare_duration_s = 6.0\n"),
        noise(NoisePreset::None),
    );
    let r = report(&outcome);
    // The acceptance for ideal sensors: every entry within 0.05 %; off-diagonal entries
    // (tens of kg·m²) against 0.05 % of the smallest principal moment.
    let smallest = r.principal.moments[0];
    for (name, est, _, truth) in entries(r) {
        let tol = match &name[..] {
            "cx" | "cy" | "cz" => 0.0005 * 0.5,
            "Jxy" | "Jxz" | "Jyz" => 0.0005 * smallest,
            _ => 0.0005 * truth.abs(),
        };
        assert!((est - truth).abs() <= tol, "{name}: {est} vs {truth}");
    }
    // Ideal sensors: every sensor's systematic line of the error budget is zero (the `noise`
    // line is the estimator's covariance, which sees the integration's model error), and so is
    // the geometry's (`--noise none` scales the joints' tolerance too: an exactly built rig).
    let line = |id: &str| *r.budget_line(id).unwrap();
    for id in [
        "accel_bias",
        "load_cell_offset",
        "load_cell_scale",
        "timestamp_jitter",
    ] {
        assert_eq!(line(id).mass, 0.0, "{id}");
    }
    // The IMU's lines are the calibration pass's uncertainty (`calibration.measure_imu`): on
    // ideal sensors only the integration's model error on this short run, at least an order
    // below the realistic rig's calibrated lines (1e-3 kg, 1e-4 m, 0.3 kg·m²).
    for id in ["imu_misalignment", "imu_lever_arm", "time_skew"] {
        let l = line(id);
        assert!(l.mass < 1e-4, "{id}: {l:?}");
        assert!(l.com.iter().all(|c| *c < 1e-5), "{id}: {l:?}");
        assert!(
            l.inertia_com.iter().flatten().all(|j| *j < 3e-2),
            "{id}: {l:?}"
        );
    }
    assert_eq!(line("geometry").inertia_com[0][0], 0.0);
    // Massless, frictionless legs: nothing for the cells to miss.
    assert_eq!(line("leg_dynamics").inertia_com[0][0], 0.0);
    assert_eq!(line("joint_friction").inertia_com[0][0], 0.0);
    // Ideal sensors leave only the integration's model error in the residual.
    assert!(
        r.residual_rms.torque_nm.iter().all(|v| *v < 0.1),
        "{:?}",
        r.residual_rms
    );
}

/// Issue 14: the paper's case (its legs as described, 40 kg and joint friction) within 1 % in
/// at most 50 samples. Measured 47 with this 4 s run; with the file's 20 s 45, and 58 with the
/// half-step mean as the simulator's gyro reading, 62 with a 20 Hz cut-off.
#[test]
fn paper_case_converges_within_50_samples() {
    let paper = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/configs/paper.toml"))
        .unwrap();
    // Shorter than the file's 20 s: convergence is decided in the first tenth of a second.
    let (_dir, outcome) = run(
        &format!("{paper}\n[run]\nduration_s = 4.0\ntare_duration_s = 4.0\n")
            .replace("[run]\nduration_s = 20.0\ntare_duration_s = 20.0\n", ""),
        |_, _| {},
    );
    let r = report(&outcome);
    assert_eq!(r.run.params, 6);
    let n = r.convergence.samples_to_1pct.expect("converges");
    assert!(n <= 50, "samples_to_1pct = {n}");
    // The six-parameter model takes the mass and centre of mass as given.
    let t = r.truth.as_ref().unwrap();
    assert_eq!(r.estimate.mass, t.mass);
    assert_eq!(r.sigma.mass, 0.0);
    for (a, b) in [(0, 0), (1, 1), (2, 2)] {
        let (e, t) = (r.estimate.inertia_com[a][b], t.inertia_com[a][b]);
        assert!((e - t).abs() < 1e-3 * t, "J[{a}][{b}] {e} vs {t}");
    }
}

fn tare_path(dir: &Path) -> PathBuf {
    dir.join("tare.json")
}

/// Regression: `simulate --save-tare` wrote a tare file without the tare run's bias
/// sensitivities, so a run reusing it counted the tare's share of the systematic part as zero
/// and reported the mass's systematic sigma several times too large.
#[test]
fn a_saved_tare_carries_its_share_of_the_systematic_sigma() {
    let scenario = "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n";
    let (dir, first) = run(scenario, |a, d| a.measure.save_tare = Some(tare_path(d)));
    let saved = tare_path(dir.path());
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    for key in ["accel_bias_sensitivity", "load_cell_offset_sensitivity"] {
        assert!(file[key].is_array(), "{key} missing from the saved tare");
    }
    assert!(
        file["budget"]["effects"].is_array(),
        "the budget's effects missing from the saved tare"
    );
    let (_dir2, second) = run(scenario, |a, _| a.measure.tare = Some(saved.clone()));
    let same_run = report(&first).systematic.sigma.mass;
    let from_file = report(&second).systematic.sigma.mass;
    // The loaded runs differ (the second has no tare run before it), so not bit for bit; a
    // zero tare share would make it about six times larger.
    assert!(
        (from_file / same_run - 1.0).abs() < 0.2,
        "systematic mass sigma {from_file} from the file vs {same_run} in the same run"
    );
}

#[test]
fn tare_is_subtracted_saved_and_reused() {
    let scenario = &format!("{IDEAL_LEGS}[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n");
    let (dir, first) = run(scenario, |a, d| {
        a.noise = Some(NoisePreset::None);
        a.measure.save_tare = Some(tare_path(d));
    });
    let r1 = report(&first).clone();
    // The tare is the empty fixture (400 kg, centre of mass 5 cm above the P origin), and the
    // payload is the loaded estimate minus it.
    let fixture = &r1.tare.estimate;
    assert!((fixture.mass - 400.0).abs() < 0.01, "{}", fixture.mass);
    assert!((fixture.com[2] - 0.05).abs() < 1e-4, "{:?}", fixture.com);
    let t = r1.truth.as_ref().unwrap();
    assert!((r1.estimate.mass - t.mass).abs() < 0.01);
    assert!((r1.estimate.com[2] - t.com[2]).abs() < 1e-4);

    // A second run that reuses the saved tare skips the tare run and agrees.
    let saved = tare_path(dir.path());
    let (_dir2, second) = run(scenario, |a, _| {
        a.noise = Some(NoisePreset::None);
        a.measure.tare = Some(saved.clone());
    });
    let r2 = report(&second);
    assert_eq!(r2.tare.source, "file");
    assert_eq!(r2.tare.theta, r1.tare.theta);
    assert!((r2.estimate.mass - r1.estimate.mass).abs() < 0.01);
    for i in 0..3 {
        assert!((r2.estimate.inertia_com[i][i] - r1.estimate.inertia_com[i][i]).abs() < 0.05);
    }

    // The same tare on a rig with other joints is refused before anything moves.
    // (The 0.1 Hz multi-sine: the planned default runs at the leg-speed limit of this rig's
    // joints, not of another's.)
    let other = "[platform]\nbase_radius_m = 1.6\n[run]\nduration_s = 6.0\n[excitation]\nkind = \"multisine\"\n";
    let cfg = dir.path().join("other.toml");
    std::fs::write(&cfg, other).unwrap();
    let mut args = simulate_args(Some(cfg), dir.path().join("never.mcap"));
    args.measure.tare = Some(saved);
    let err = support::run_simulate(&args).expect_err("another rig's tare");
    assert!(
        matches!(err, ops::measurement::Error::Input(_)),
        "refused as an input (exit 2): {err}"
    );
    assert!(err.to_string().contains("tare.json"), "{err}");
    assert!(err.to_string().contains("joint"), "{err}");
    assert!(
        !dir.path().join("never.mcap").exists(),
        "a refused run writes no log"
    );
}

#[test]
fn interrupt_parks_and_finishes_the_log() {
    let dir = support::scratch_dir();
    let log = dir.path().join("run.mcap");
    let mut args = simulate_args(None, log.clone());
    args.measure.duration_s = Some(30.0);
    let stop = AtomicBool::new(false);
    let outcome = std::thread::scope(|s| {
        s.spawn(|| {
            // Interrupt once the log has grown: the run is under way.
            for _ in 0..600 {
                std::thread::sleep(std::time::Duration::from_millis(50));
                if std::fs::metadata(&log)
                    .map(|m| m.len() > 200_000)
                    .unwrap_or(false)
                {
                    break;
                }
            }
            stop.store(true, std::sync::atomic::Ordering::SeqCst);
        });
        ops::simulate::run(&args, &mut support::Silent, &stop).unwrap()
    });
    assert_eq!(outcome.end, End::Interrupted);
    assert!(outcome.report.is_none());
    // The log is complete (summary and footer, every record readable: the reader checks) and
    // says the platform parked.
    let messages = support::read_log(&log);
    assert!(!messages.is_empty());
    let phases: Vec<(String, bool)> = support::on(&messages, "/supervisor")
        .iter()
        .map(|v| {
            (
                v["phase"].as_str().unwrap().to_string(),
                v["interrupted"].as_bool().unwrap(),
            )
        })
        .collect();
    let (last, interrupted) = phases.last().unwrap();
    assert!(*interrupted);
    assert!(last == "done" || last == "idle", "ended in {last}");
    assert!(
        phases.iter().any(|(p, i)| p == "park" && *i),
        "parked after the interrupt"
    );
}

#[test]
fn an_accelerometer_offset_measured_at_rest_does_not_reach_the_mass() {
    // A world whose only imperfection is the accelerometer's bias (the datasheet's 1e-3 m/s²,
    // drawn by the seed): its vertical share moves the payload's mass by about m·b/g when it
    // stays in the readings, and by the offset's residual (noise-free here) when the offset
    // is measured at rest before each run's excitation against the site's gravity.
    let error = |local_gravity: &str| {
        let scenario = format!(
            "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n\
             [estimator]\nlocal_gravity_m_s2 = {local_gravity}\n"
        );
        let (_dir, outcome) = run(&scenario, |a, _| {
            a.only = Some(rig_description::sources::ErrorSource::AccelBias)
        });
        let r = report(&outcome);
        let truth = r.truth.as_ref().expect("truth");
        (r.estimate.mass - truth.mass).abs()
    };
    let kept = error("0.0");
    let measured = error("9.80665");
    assert!(kept > 0.02, "the bias moved the mass by only {kept} kg");
    assert!(
        measured < 0.1 * kept,
        "with the offset measured at rest the mass is off by {measured} kg, without {kept} kg"
    );
}
