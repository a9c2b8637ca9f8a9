//! Can the rig's own data calibrate its joints? A dev-only analysis: which
//! combinations of the 36 joint coordinates the IMU and the load cells observe, and what
//! knowing them would do to the error budget's `geometry` line of the payload's estimate.
//!
//! `cargo run --release --example joint_observability [-- SEED [REPORT.json [SCENARIO.toml]]]`
//! (SCENARIO.toml laid over the default, as `--config`), REPORT.json
//! the default procedure's report of the same seed (`stewart simulate --duration 20 --seed
//! SEED --report REPORT.json`, its IMU calibrated first): the payload's whole sigma with the
//! joints' line replaced is then that report's.
//!
//! 1. One default measurement on the simulated rig (`--duration 20`: tare run, loaded run); the
//!    budget's joint effects of both runs give the payload's sensitivity to each joint
//!    coordinate, S (10 × 36: d_k = δθ_k(loaded) − δθ_k(tare) per tolerance), and the
//!    `geometry` line, S σ² Sᵀ, as the report builds it (checked against the report's own).
//! 2. The information of each candidate calibration about the joints ([`observe`]), with the
//!    datasheet's noise and the nuisance parameters each shares with them, plus the prior
//!    N(0, σ² I); its posterior covariance P of the joints.
//! 3. The line again with S P Sᵀ, for each candidate and for them all; and the line if every
//!    combination but the frames' own rigid motions were known exactly (the floor of any
//!    calibration from the rig's own data).
//!
//! The simulator's drawn joints are never read.

mod observe;
mod statics;

use std::sync::atomic::AtomicBool;

use anyhow::Context;
use estimator::{Estimate, InertialParameters, ParameterCovariance, ParameterVector};
use measure::observer::{Ignore, Observer};
use measure::report::{sigmas, Quantities};
use measure::sequence::{self, Job, SequencePlan, Station, TarePlan, TareSource};
use measure::Measurement;
use measure::{setup, MeasureOutcome};
use nalgebra::{DMatrix, SMatrix, SymmetricEigen, Vector3};
use observe::{Datasheet, Dynamic, Information, JOINTS};
use rig_description::load::Overrides;
use rig_description::sources::ErrorSource;
use runlog::compact::AtLogResolution;

/// The simulator as the sequence's station, as `stewart simulate` runs it.
struct SimStation {
    sim: sim::Simulator,
    payload: sim::BodyProperties,
}

impl Station for SimStation {
    fn measure<O: Observer>(&mut self, job: Job<'_>, o: &mut O) -> anyhow::Result<MeasureOutcome> {
        job.run(&mut AtLogResolution(&mut self.sim), o)
    }
    fn load_payload<O: Observer>(&mut self, _: &mut O, _: &AtomicBool) -> anyhow::Result<bool> {
        self.sim
            .change_payload_and_settle(Some(self.payload), 2.0)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        Ok(true)
    }
}

/// One line: mass kg, com mm, J_C kg·m².
fn line(name: &str, q: &Quantities) {
    let f = q.flat();
    println!(
        "{name:<44} {:>6.3} | {:>5.3} {:>5.3} {:>5.3} | {:>5.2} {:>5.2} {:>5.2} {:>5.2} {:>5.2} {:>5.2}",
        f[0],
        f[1] * 1e3,
        f[2] * 1e3,
        f[3] * 1e3,
        f[4],
        f[5],
        f[6],
        f[7],
        f[8],
        f[9]
    );
}

type Sensitivity = SMatrix<f64, 10, JOINTS>;

/// The payload's sigma of every quantity for the joints' covariance `p` (m²).
fn geometry_line(theta: &ParameterVector, s: &Sensitivity, p: &DMatrix<f64>) -> Quantities {
    let p = SMatrix::<f64, JOINTS, JOINTS>::from_fn(|i, j| p[(i, j)]);
    let c: ParameterCovariance = s * p * s.transpose();
    sigmas(&Estimate::from_parameters(
        InertialParameters::from_vector(theta),
        c,
    ))
}

/// How many whitened posterior directions fell below a quarter and a hundredth of the prior's
/// variance (sigma halved, sigma a tenth), and the mean variance ratio along the base's and
/// the plate's rigid motions.
/// The mean posterior/prior variance along the base's six rigid motions and the plate's.
fn rigid_ratios(p: &DMatrix<f64>, sigma: f64, gauge: &DMatrix<f64>) -> (f64, f64) {
    let g = gauge.transpose() * (p / (sigma * sigma)) * gauge;
    let mean = |from: usize| (from..from + 6).map(|i| g[(i, i)]).sum::<f64>() / 6.0;
    (mean(0), mean(6))
}

fn directions(p: &DMatrix<f64>, sigma: f64, gauge: &DMatrix<f64>) -> String {
    let w = p / (sigma * sigma);
    let e = SymmetricEigen::new(w.clone()).eigenvalues;
    let halved = e.iter().filter(|v| **v < 0.25).count();
    let tenth = e.iter().filter(|v| **v < 0.01).count();
    let (base, plate) = rigid_ratios(p, sigma, gauge);
    format!(
        "{halved:>2} of 36 directions below σ/2, {tenth:>2} below σ/10; rigid-motion variance \
         ratio base {base:.2}, plate {plate:.2}"
    )
}

fn main() -> anyhow::Result<()> {
    let seed: u64 = match std::env::args().nth(1) {
        Some(s) => s.parse().context("the seed is a whole number")?,
        None => 1,
    };
    // The default procedure's report of the same seed (its IMU calibrated before the runs,
    // which this measurement leaves out): its whole sigma is what the joints' line is part of.
    let default_report: Option<measure::Report> = match std::env::args().nth(2) {
        Some(path) => Some(serde_json::from_str(&std::fs::read_to_string(&path)?)?),
        None => None,
    };
    // A scenario laid over the default (another tare excitation, other sensors).
    let scenario = std::env::args().nth(3).map(std::path::PathBuf::from);
    let rig = rig_description::load::load(scenario.as_deref())?.with_overrides(&Overrides {
        duration_s: Some(20.0),
        params: None,
    })?;
    let g = setup::geometry(&rig)?;
    let world = sim::scenario::Scenario::new(rig.clone(), Some(seed), None)?;
    let tare = setup::controller(
        &rig,
        &g,
        setup::tare_trajectory(&rig, &g)?,
        Measurement::Tare,
    )?;
    let loaded = setup::controller(
        &rig,
        &g,
        setup::trajectory(&rig, &g, rig.config.run.duration_s)?,
        Measurement::Loaded,
    )?;
    let plan = SequencePlan {
        config: &rig,
        geometry: g,
        tare: TarePlan::Measure(Box::new(tare)),
        loaded: Some(loaded),
        save_tare: None,
        backend: "sim",
    };
    let mut station = SimStation {
        sim: world.simulator(g, false)?,
        payload: world.world.payload.to_sim(),
    };
    eprintln!("seed {seed}: tare and loaded runs on the simulated rig …");
    let outcome = sequence::run(plan, &mut station, &mut Ignore, &AtomicBool::new(false))?;
    let report = outcome
        .report(&rig.config, Default::default(), None)
        .with_context(|| format!("no report: the sequence ended {:?}", outcome.end))?;
    let loaded = outcome.loaded.as_ref().context("no loaded run")?;
    let Some(TareSource::Measured(tare_file, effects)) = &outcome.tare else {
        anyhow::bail!("no measured tare");
    };
    let lb = loaded
        .budget
        .as_ref()
        .context("the loaded run has no budget")?;
    let tb = effects
        .budget
        .as_ref()
        .context("the tare run has no budget")?;
    let record = effects
        .record
        .as_ref()
        .context("the tare run has no record")?;
    let estimate = loaded.estimate.as_ref().context("no loaded estimate")?;
    let theta = estimate.parameters.to_vector() - tare_file.parameters().to_vector();

    let sigma = rig.config.platform.joint_position_tolerance_m;
    let (lk, tk) = (
        lb.effects_of(ErrorSource::Geometry),
        tb.effects_of(ErrorSource::Geometry),
    );
    anyhow::ensure!(
        lk.len() == JOINTS && tk.len() == JOINTS,
        "36 joint effects per run"
    );
    let s = Sensitivity::from_fn(|i, k| (lk[k][i] - tk[k][i]) / sigma);

    println!("sigma of the payload's estimate from the joints (the budget's `geometry` line)");
    println!(
        "{:<44} {:>6} | {:>17} | {:>35}",
        "", "mass kg", "com x y z mm", "J_C xx yy zz xy xz yz kg·m²"
    );
    let prior = DMatrix::identity(JOINTS, JOINTS) * sigma * sigma;
    let prior_line = geometry_line(&theta, &s, &prior);
    if let Some(q) = report.budget_line("geometry") {
        line("report's geometry line", q);
        let (a, b) = (q.flat(), prior_line.flat());
        anyhow::ensure!(
            (0..10).all(|i| (a[i] - b[i]).abs() <= 1e-9 * a[i].abs().max(1e-12)),
            "S σ² Sᵀ is not the report's geometry line"
        );
    }
    line("prior: σ = tolerance per coordinate", &prior_line);

    let sensors = &rig.config.sensors;
    let tare_q = measure::report::quantities(&Estimate::from_parameters(
        tare_file.parameters(),
        ParameterCovariance::zeros(),
    ));
    let d = Datasheet {
        joint_m: sigma,
        rate_hz: sensors.sample_rate_hz,
        gyro_density: sensors.gyro_density_rad_s_sqrt_hz(),
        accel_density: sensors.accel_density_m_s2_sqrt_hz(),
        accel_scale: sensors.accelerometer.scale_error,
        gain: sensors.load_cell.gain_error,
        cell_noise_n: sensors.load_cell.noise_n,
        cell_offset_n: sensors.load_cell.zero_offset_n,
        drift_n_per_min: sensors.load_cell.zero_drift_n_per_min,
        cell_floor_n: 0.1,
        reference_kg: rig.config.calibration.reference_mass_kg.unwrap_or(1000.0),
        reference_tolerance_kg: rig.config.calibration.reference_mass_tolerance_kg,
        fixture_kg: tare_q.mass,
        misalignment_rad: sensors.imu.misalignment_deg.to_radians(),
        gyro_scale: sensors.gyro.scale_error,
        gyro_bias: sensors.gyro.bias_rad_s,
        accel_bias: sensors.accelerometer.bias_m_s2,
        imu_position_m: sensors.imu.position_tolerance_m,
        imu_skew_s: sensors.timing.imu_skew_s,
        free: 10.0,
    };
    let built = observe::built_all(&g);
    let entries = record.entries();
    let poses = statics::static_poses(&g, 0.05, 5.0);
    let (hold_s, move_s) = (10.0, 5.0);
    let gauge = observe::gauge(&g);
    let linear = observe::linearisation_error(&g, &built, &poses, sigma);
    println!(
        "first-order pose step against full forward kinematics, joints moved by σ: largest \
         relative difference {linear:.1e}"
    );
    anyhow::ensure!(linear < 1e-2, "the first-order step is off the kinematics");
    let com = Vector3::from(tare_q.com);

    let cases: [(&str, bool, bool, bool, bool); 7] = [
        ("tare motion: gyro", true, false, false, false),
        ("tare motion: accelerometer", false, true, false, false),
        (
            "tare motion: gyro + accelerometer",
            true,
            true,
            false,
            false,
        ),
        ("static tilts: accelerometer", false, false, true, false),
        ("tare motion + static tilts", true, true, true, false),
        (
            "static cells, fixture and reference",
            false,
            false,
            false,
            true,
        ),
        ("all of the above", true, true, true, true),
    ];
    let mut notes = Vec::new();
    let mut rigid_checks = Vec::new();
    let mut run =
        |name: &str, d: &Datasheet, poses: &[kinematics::Pose], hold_s: f64, which: [bool; 4]| {
            let [gyro, accel, tilts, cells] = which;
            let mut info = Information::new(observe::priors(d));
            if gyro || accel {
                observe::add_motion(&mut info, &g, &built, &entries, d, Dynamic { gyro, accel });
            }
            if tilts {
                statics::add_tilts(&mut info, &g, &built, poses, hold_s, d);
            }
            if cells {
                statics::add_static_wrench(&mut info, &g, &built, poses, hold_s, move_s, com, d);
            }
            let p = info.joint_covariance();
            let q = geometry_line(&theta, &s, &p);
            line(name, &q);
            notes.push(format!("{name:<44} {}", directions(&p, sigma, &gauge)));
            rigid_checks.push((name.to_string(), rigid_ratios(&p, sigma, &gauge).1));
            q
        };
    let mut short = Quantities::default();
    for (name, gyro, accel, tilts, cells) in cases {
        short = run(name, &d, &poses, hold_s, [gyro, accel, tilts, cells]);
    }
    let tight = Datasheet { free: 1.0, ..d };
    run(
        "  the same, fitted parameters at datasheet",
        &tight,
        &poses,
        hold_s,
        [true; 4],
    );
    // A longer procedure over the whole stroke, and the structural limit.
    let wide = statics::static_poses(&g, 0.15, 12.0);
    let name = format!("all, {} poses ±150 mm ±12°, 60 s holds", wide.len());
    let long = run(&name, &d, &wide, 60.0, [true; 4]);
    run(
        "  the same: static tilts alone",
        &d,
        &wide,
        60.0,
        [false, false, true, false],
    );
    run(
        "  the same: static cells alone",
        &d,
        &wide,
        60.0,
        [false, false, false, true],
    );
    let tight = Datasheet { free: 1.0, ..d };
    run(
        "  the same, fitted parameters at datasheet",
        &tight,
        &wide,
        60.0,
        [true; 4],
    );
    let rough = Datasheet {
        cell_floor_n: 0.3,
        ..d
    };
    run(
        "  the same, cells' floor 0.3 N",
        &rough,
        &wide,
        60.0,
        [true; 4],
    );
    let tenth = d.quieter(10.0);
    run(
        "all, every sensor's noise / 10",
        &tenth,
        &poses,
        hold_s,
        [true; 4],
    );
    let quiet = d.quieter(100.0);
    run(
        "all, every sensor's noise / 100",
        &quiet,
        &poses,
        hold_s,
        [true; 4],
    );
    for (i, n) in ["gyro", "accelerometer", "static tilts", "static cells"]
        .iter()
        .enumerate()
    {
        let mut w = [false; 4];
        w[i] = true;
        run(
            &format!("  noise / 100: {n} alone"),
            &quiet,
            &poses,
            hold_s,
            w,
        );
    }
    run(
        "all, noise / 100, wide poses",
        &quiet,
        &wide,
        60.0,
        [true; 4],
    );
    // The plate's rigid motions are the plate frame moved against the plate: no data of the
    // rig's own can see them, which the rows must reproduce whatever the noise.
    for (name, plate) in &rigid_checks {
        anyhow::ensure!(
            *plate > 0.98,
            "{name}: the plate's rigid motions seen ({plate:.3})"
        );
    }
    // The floor: every combination but the frames' rigid motions known exactly.
    let floor = &gauge * gauge.transpose() * sigma * sigma;
    line(
        "floor: only the frames' rigid motions left",
        &geometry_line(&theta, &s, &floor),
    );
    let rest = DMatrix::identity(JOINTS, JOINTS) * sigma * sigma - &floor;
    line(
        "the rest: all but the frames' rigid motions",
        &geometry_line(&theta, &s, &rest),
    );
    // The payload's whole sigma with the geometry line replaced (sources add in quadrature).
    println!();
    println!("the payload's whole sigma (every source)");
    let prior_q = geometry_line(&theta, &s, &prior).flat();
    let whole_report = default_report.as_ref().unwrap_or(&report);
    if let Some(q) = default_report
        .as_ref()
        .and_then(|r| r.budget_line("geometry"))
    {
        line("the given report's geometry line", q);
    }
    let whole = whole_report.sigma.flat();
    line("report", &whole_report.sigma);
    for (name, q) in [
        ("with the short procedure's geometry line", short),
        ("with the long procedure's", long),
    ] {
        let q = q.flat();
        let v: [f64; 10] = core::array::from_fn(|i| {
            (whole[i].powi(2) - prior_q[i].powi(2) + q[i].powi(2))
                .max(0.0)
                .sqrt()
        });
        line(name, &Quantities::from_flat(&v));
    }
    println!();
    println!(
        "{} static poses ({} s each, {} s between), {} record entries of the tare motion",
        poses.len(),
        hold_s,
        move_s,
        entries.len()
    );
    for n in notes {
        println!("{n}");
    }
    Ok(())
}
