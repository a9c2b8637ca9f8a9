//! The whole measurement on the simulator — tare run with the empty fixture (or a saved tare),
//! the payload put on, the loaded run, park — then the report; or, instead of a payload, a
//! calibration of the simulated rig's IMU or load cells.
//!
//! Every check that can refuse the run (rig description, world, design, both trajectories, the
//! tare file, the simulator's own checks) runs before the first sample. The simulator's truth
//! goes only into the report's `truth` and `/run/truth`; the estimator sees sensor frames only,
//! and assumes what the rig description's datasheet says.
//!
//! A rig description that asks for a calibration each run (`[calibration] measure_imu`,
//! `measure_load_cells`) gets it first: a [`Pass`] of its own on the same simulated world, its
//! log and file beside the measurement's log ([`pass_paths`]), applied to the measurement.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use anyhow::anyhow;
use measure::observer::Observer;
use measure::sequence::{Job, TarePlan};
use measure::{setup, End, MeasureOutcome};
use rig_description::calibration::CalibrationFile;
use rig_description::sources::ErrorSource;
use runlog::compact::AtLogResolution;
use runlog::mcap_log::Delivery;
use runlog::metadata::{BodyTruth, TruthMsg};
use serde::{Deserialize, Serialize};
use sim::scenario::Scenario;
use sim::NoisePreset;

use crate::measurement::{
    self, Calibrate, Error, MeasureOptions, Message, Operator, Outcome, Pass, Spec,
};

/// What to simulate.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SimulateOptions {
    /// The measurement's options.
    pub measure: MeasureOptions,
    /// The simulated world's seed instead of `world.seed`.
    pub seed: Option<u64>,
    /// The simulated sensors' grade instead of the datasheet's (`realistic`).
    pub noise: Option<NoisePreset>,
    /// Simulate a rig with only this one of a real rig's error sources (every other switch of
    /// `[world.imperfections]` off); the rig description, which the estimator reads, stays as
    /// written.
    #[serde(with = "source_id")]
    pub only: Option<ErrorSource>,
    /// Calibrate the IMU instead of measuring a payload: the empty fixture's run, the alignment
    /// fitted and written here. Any IMU calibration the description applies is left out.
    pub calibrate_imu: Option<PathBuf>,
    /// Calibrate the load cells instead of measuring a payload: a tare run, then the world's
    /// reference body in the payload's place, the gains fitted and written here. Any load-cell
    /// calibration the description applies is left out.
    pub calibrate_load_cells: Option<PathBuf>,
    /// An IMU calibration to apply in place of the description's (the file's path and
    /// contents): the load-cell pass takes the IMU pass's.
    #[serde(skip)]
    pub apply_imu: Option<(PathBuf, Box<CalibrationFile>)>,
}

/// An error source as its id in the error budget (`"geometry"`, …).
mod source_id {
    use rig_description::sources::ErrorSource;
    use serde::{de::Error as _, Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<ErrorSource>, s: S) -> Result<S::Ok, S::Error> {
        v.map(ErrorSource::id).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<ErrorSource>, D::Error> {
        Option::<String>::deserialize(d)?
            .map(|id| {
                id.parse()
                    .map_err(|_| D::Error::custom(format!("no error source {id}")))
            })
            .transpose()
    }
}

impl SimulateOptions {
    /// The rig description and the world of the options, checked; with
    /// [`only`](Self::only), the world's switches are that source alone.
    pub fn scenario(&self) -> Result<Scenario, Error> {
        let mut scenario = Scenario::new(self.measure.load_config()?, self.seed, self.noise)?;
        if let Some(source) = self.only {
            scenario.world.imperfections = sim::Imperfections::only(source);
        }
        Ok(scenario)
    }
}

/// Time the braked plate is left to settle after the payload is put on, s.
pub const PAYLOAD_SETTLE_S: f64 = 2.0;

/// The simulator as a measurement's station: the payload change puts the world's payload on.
struct SimStation {
    sim: sim::Simulator,
    payload: sim::BodyProperties,
}

impl measure::sequence::Station for SimStation {
    fn measure<O: Observer>(
        &mut self,
        job: Job<'_>,
        observer: &mut O,
    ) -> anyhow::Result<MeasureOutcome> {
        // Read at the log's resolution: the estimator uses the numbers the log holds.
        job.run(&mut AtLogResolution(&mut self.sim), observer)
    }

    /// Puts the payload on the braked plate and lets it settle for [`PAYLOAD_SETTLE_S`], as a
    /// rig waits for the operator: the loaded run's brake hold then weighs a plate at rest
    /// ([`measure::weigh`]), not one still sagging onto its brakes.
    fn load_payload<O: Observer>(&mut self, _: &mut O, _: &AtomicBool) -> anyhow::Result<bool> {
        self.sim
            .change_payload_and_settle(Some(self.payload), PAYLOAD_SETTLE_S)
            .map_err(|e| anyhow!("the simulator failed while the payload was put on: {e}"))?;
        Ok(true)
    }
}

impl measurement::Station for SimStation {}

fn body_truth(b: &sim::scenario::BodyConfig) -> BodyTruth {
    BodyTruth {
        mass_kg: b.mass_kg,
        com_m: b.com_m,
        inertia_com_kg_m2: b.inertia_com_kg_m2,
        theta: sim::InertialParameters::from_body(&b.to_sim()).theta(),
    }
}

/// The log and calibration file of `pass` beside the measurement's log `log`:
/// `NAME.imu.mcap` and `NAME.imu.toml`, or `NAME.cells.mcap` and `NAME.cells.toml`.
pub fn pass_paths(pass: Pass, log: &Path) -> (PathBuf, PathBuf) {
    let name = match pass {
        Pass::Imu => "imu",
        Pass::LoadCells => "cells",
    };
    (
        log.with_extension(format!("{name}.mcap")),
        log.with_extension(format!("{name}.toml")),
    )
}

/// Runs `pass` before the measurement of `options` (whose log is `log`), on the same simulated
/// world, and applies the file it writes to `scenario`'s rig description. `Ok(Some(outcome))`:
/// the pass was interrupted or faulted and the command ends with its outcome. A pass whose fit
/// fails is a warning: the measurement goes on with the sensors as the description describes
/// them.
fn calibration_pass(
    options: &SimulateOptions,
    pass: Pass,
    log: &Path,
    scenario: &mut Scenario,
    operator: &mut dyn Operator,
    interrupt: &AtomicBool,
) -> Result<Option<Outcome>, Error> {
    let (pass_log, file) = pass_paths(pass, log);
    let c = &scenario.loaded.config.calibration;
    let pass_options = SimulateOptions {
        calibrate_imu: (pass == Pass::Imu).then(|| file.clone()),
        calibrate_load_cells: (pass == Pass::LoadCells).then(|| file.clone()),
        // The load-cell pass applies the IMU calibration the measurement applies.
        apply_imu: match pass {
            Pass::Imu => options.apply_imu.clone(),
            Pass::LoadCells => c
                .imu
                .clone()
                .zip(c.imu_file.clone())
                .map(|(p, f)| (PathBuf::from(p), Box::new(f))),
        },
        measure: MeasureOptions {
            log: Some(pass_log),
            live: None,
            tare: None,
            save_tare: None,
            ..options.measure.clone()
        },
        ..options.clone()
    };
    operator.tell(Message::PassStarted(pass));
    let outcome = match run(
        &pass_options,
        &mut measurement::Quietly(operator),
        interrupt,
    ) {
        Ok(outcome) => outcome,
        Err(Error::Run(e)) => {
            operator.tell(Message::Warning(&match pass {
                Pass::Imu => format!(
                    "the IMU calibration pass failed ({e:#}); measuring with the IMU as \
                     [sensors.imu] describes it"
                ),
                Pass::LoadCells => format!(
                    "the load-cell calibration pass failed ({e:#}); measuring with the \
                     cells as [sensors.load_cell] describes them"
                ),
            }));
            return Ok(None);
        }
        Err(e) => return Err(e),
    };
    if outcome.end != End::Completed {
        return Ok(Some(outcome));
    }
    let c = &mut scenario.loaded.config.calibration;
    let path = Some(file.display().to_string());
    match (outcome.calibration, outcome.load_cell_calibration) {
        (Some(imu), _) if pass == Pass::Imu => {
            operator.tell(Message::ImuCalibrated(&imu, &file));
            c.imu = path;
            c.imu_file = Some(imu);
        }
        (_, Some(cells)) if pass == Pass::LoadCells => {
            operator.tell(Message::LoadCellsCalibrated(&cells, &file));
            c.load_cells = path;
            c.load_cells_file = Some(cells);
        }
        _ => {}
    }
    Ok(None)
}

/// Runs the simulation of `options`, telling `operator`. `interrupt` is the stop flag: when it
/// is set the platform parks, the log is finished and the outcome says [`End::Interrupted`].
pub fn run(
    options: &SimulateOptions,
    operator: &mut dyn Operator,
    interrupt: &AtomicBool,
) -> Result<Outcome, Error> {
    // Everything that can refuse the run, before the first sample.
    options.measure.check_log_free()?;
    let mut scenario = options.scenario()?;
    if let Some((path, file)) = &options.apply_imu {
        let c = &mut scenario.loaded.config.calibration;
        c.imu = Some(path.display().to_string());
        c.imu_file = Some((**file).clone());
    }
    if options.calibrate_imu.is_some() {
        // The calibration fits the raw readings: nothing of an older calibration applied.
        scenario.loaded.config.calibration.imu = None;
        scenario.loaded.config.calibration.imu_file = None;
    }
    let calibrating_cells = options.calibrate_load_cells.is_some();
    if calibrating_cells {
        // The gains are fitted on the raw readings, against a rigid reference body.
        crate::calibration::prepare_reference_runs(&mut scenario.loaded)?;
        scenario.world.suspension.enabled = false;
    }
    // The body put on for the loaded run: the payload, or the reference.
    let body = if calibrating_cells {
        scenario.world.reference
    } else {
        scenario.world.payload
    };
    // A saved tare is checked before a calibration pass moves anything.
    if options.measure.tare.is_some() {
        let geometry = setup::geometry(&scenario.loaded)?;
        options.measure.tare_plan(&scenario.loaded, &geometry)?;
    }
    // The calibration passes' logs and files are named after the measurement's log.
    let mut log_path = None;
    let calibration = &scenario.loaded.config.calibration;
    let calibrates_imu = calibration.calibrates_imu_each_run();
    let calibrates_cells = calibration.calibrates_load_cells_each_run();
    let imu_uncertain = scenario.loaded.config.sensors.imu_alignment_uncertain();
    if calibrates_imu && !imu_uncertain {
        operator.tell(Message::Note(
            "calibration.measure_imu: the rig description gives the IMU's alignment exactly \
             (sensors.imu misalignment_deg and position_tolerance_m, sensors.gyro scale_error \
             and sensors.timing imu_skew_s all 0), so there is nothing to calibrate",
        ));
    }
    let passes = [
        (Pass::Imu, calibrates_imu && imu_uncertain),
        (Pass::LoadCells, calibrates_cells && !calibrating_cells),
    ];
    for (pass, wanted) in passes {
        if options.calibrate_imu.is_some() || !wanted {
            continue;
        }
        let log = log_path
            .clone()
            .unwrap_or_else(|| options.measure.log_path(runlog::run_log::unix_now_ns()));
        if let Some(ended) =
            calibration_pass(options, pass, &log, &mut scenario, operator, interrupt)?
        {
            return Ok(ended);
        }
        log_path = Some(log);
    }
    let scenario = scenario;
    let loaded = &scenario.loaded;
    let config = &loaded.config;
    measurement::warn_old_calibrations(config, operator);
    let geometry = setup::geometry(loaded)?;
    // The controllers checked here are the ones that run.
    let trajectory = setup::trajectory(loaded, &geometry, config.run.duration_s)?;
    let loaded_controller =
        setup::controller(loaded, &geometry, trajectory, measure::Measurement::Loaded)?;
    let tare = options.measure.tare_plan(loaded, &geometry)?;
    let tare_run = matches!(tare, TarePlan::Measure(_));
    // The loaded world must be accepted too, before the tare run moves anything.
    let loaded_world = scenario.simulator(geometry, true)?;
    let sim = if tare_run {
        scenario.simulator(geometry, false)?
    } else {
        loaded_world
    };

    let start_ns = runlog::run_log::unix_now_ns();
    let log_path = log_path.unwrap_or_else(|| options.measure.log_path(start_ns));
    let calibrating = options.calibrate_imu.is_some();
    let (command, calibrate) = match (&options.calibrate_imu, &options.calibrate_load_cells) {
        (Some(path), _) => ("simulate --calibrate-imu", Calibrate::Imu(path.clone())),
        (None, Some(path)) => (
            "simulate --calibrate-load-cells",
            Calibrate::LoadCells(path.clone()),
        ),
        (None, None) => ("simulate", Calibrate::Nothing),
    };
    let station = SimStation {
        sim,
        payload: body.to_sim(),
    };
    measurement::run(
        Spec {
            loaded,
            geometry,
            tare,
            loaded_controller: (!calibrating).then_some(loaded_controller),
            save_tare: options.measure.save_tare.as_deref(),
            log: (log_path, start_ns),
            // Watched live, the simulation keeps to the wall clock.
            delivery: (Delivery::Lossless, runlog::Pace::WallClock),
            live: options.measure.live,
            command,
            backend: "sim",
            seed: scenario.world.seed,
            noise: scenario.noise.name(),
            sample_period_s: None,
            truth_msg: Some(TruthMsg {
                fixture: body_truth(&scenario.world.fixture),
                payload: body_truth(&body),
                world_toml: scenario.world_toml(),
            }),
            truth: Some(body.quantities()),
            calibrate,
            report: true,
        },
        station,
        operator,
        interrupt,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::Silent;
    use measure::Report;
    use rig_description::calibration::CalibrationDocument;

    /// A short simulate run of `extra` laid over a short default, in `dir`.
    fn short_run(dir: &std::path::Path, name: &str, extra: &str) -> Outcome {
        let config = dir.join(format!("{name}.toml"));
        let text = format!("[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n{extra}");
        std::fs::write(&config, text).unwrap();
        let args = SimulateOptions {
            measure: MeasureOptions {
                config: Some(config),
                log: Some(dir.join(format!("{name}.mcap"))),
                ..MeasureOptions::default()
            },
            ..SimulateOptions::default()
        };
        run(&args, &mut Silent, &AtomicBool::new(false)).unwrap()
    }

    /// `--calibrate-imu` runs the tare alone and writes a calibration file that a rig
    /// description then applies: the accelerometer's position it found reaches the estimator.
    #[test]
    fn calibrate_imu_writes_a_file_that_a_rig_description_applies() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("short.toml");
        std::fs::write(&config, "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n").unwrap();
        let file = dir.path().join("imu.toml");
        let args = SimulateOptions {
            measure: MeasureOptions {
                config: Some(config),
                log: Some(dir.path().join("cal.mcap")),
                ..MeasureOptions::default()
            },
            calibrate_imu: Some(file.clone()),
            ..SimulateOptions::default()
        };
        let outcome = run(&args, &mut Silent, &AtomicBool::new(false)).unwrap();
        assert!(outcome.report.is_none(), "no payload is measured");
        let written = outcome.calibration.expect("a calibration");
        let read = rig_description::calibration::CalibrationFile::read(&file).unwrap();
        assert_eq!(read, written);
        // The default IMU sits at the P origin within its 1 mm tolerance.
        let r = read.imu.accelerometer_position_m;
        assert!(r.iter().all(|v| v.abs() < 5e-3), "{r:?}");
        let rig = dir.path().join("rig.toml");
        std::fs::write(&rig, "[calibration]\nimu = \"imu.toml\"\n").unwrap();
        let loaded = rig_description::load::load(Some(&rig)).unwrap();
        let p = measure::setup::accelerometer_position(&loaded.config);
        assert_eq!([p.x, p.y, p.z], r);
    }

    /// `[calibration] measure_load_cells`: the calibration pass runs before the measurement,
    /// its file and log beside the run's, and the measurement applies its gains (the report
    /// names it, the log carries it, the budget counts its joints once).
    #[test]
    fn measure_load_cells_calibrates_before_the_measurement_and_applies_it() {
        let dir = tempfile::tempdir().unwrap();
        let outcome = short_run(
            dir.path(),
            "cells",
            "[calibration]\nmeasure_imu = false\nmeasure_load_cells = true\n",
        );
        let (pass_log, pass_file) = pass_paths(Pass::LoadCells, &outcome.log_path);
        assert!(pass_log.exists());
        let file = rig_description::calibration::LoadCellFile::read(&pass_file).unwrap();
        assert_eq!(file.load_cells.joint_sensitivity.len(), 36);
        let report = outcome.report.unwrap();
        let applied: Vec<&str> = report
            .run
            .calibrations
            .iter()
            .map(|c| c.kind.as_str())
            .collect();
        assert_eq!(applied, ["load_cells"]);
        let log = runlog::LogContents::read(&outcome.log_path).unwrap();
        assert_eq!(
            log.metadata
                .as_ref()
                .and_then(|m| m.load_cell_calibration_toml.as_deref()),
            Some(file.to_toml().as_str())
        );
    }

    /// The estimator's assumptions and the budget come from the rig description's datasheet:
    /// a worse accelerometer bias figure widens its line of the budget and the reported
    /// sigma, and the logged
    /// estimator settings carry the datasheet's gyro noise.
    #[test]
    fn a_datasheet_figure_reaches_the_estimator_and_the_systematic_sigma() {
        let dir = tempfile::tempdir().unwrap();
        // The accelerometer's offset left in the readings, so that its datasheet bias is the
        // budget's line.
        let base = short_run(
            dir.path(),
            "base",
            "[estimator]\nlocal_gravity_m_s2 = 0.0\n",
        );
        let worse = short_run(
            dir.path(),
            "worse",
            "[estimator]\nlocal_gravity_m_s2 = 0.0\n\
             [sensors.accelerometer]\nbias_m_s2 = 0.01\n[sensors.gyro]\nnoise_density_rad_s_sqrt_hz = 2.0e-4\n",
        );
        let (b, w) = (base.report.clone().unwrap(), worse.report.clone().unwrap());
        assert_eq!(b.systematic.accel_bias_sigma_m_s2, 1e-3);
        assert_eq!(w.systematic.accel_bias_sigma_m_s2, 1e-2);
        // The bias's effect on the mass is about m·b_z/g: ten times the figure, ten times it.
        let bias = |r: &Report| r.budget_line("accel_bias").map_or(0.0, |q| q.mass);
        let ratio = bias(&w) / bias(&b);
        assert!(
            (5.0..20.0).contains(&ratio),
            "systematic mass sigma ratio {ratio}"
        );
        assert!(w.sigma.mass > b.sigma.mass);
        for (outcome, gyro) in [(&base, 5e-5), (&worse, 2e-4)] {
            let log = runlog::LogContents::read(&outcome.log_path).unwrap();
            let settings = log.settings_of("loaded").unwrap();
            let expected = gyro * 1000f64.sqrt();
            assert!(
                (settings.gyro_noise_rad_s - expected).abs() < 1e-12,
                "{} vs {expected}",
                settings.gyro_noise_rad_s
            );
        }
    }

    /// Lost frames reach the host as gaps in the sequence: the supervisor, the controller and
    /// the estimator take them (a 5 % loss, so gaps of two and more periods occur by the
    /// dozen), and the frame loss alone leaves the estimate near the truth.
    #[test]
    fn a_rig_that_loses_frames_is_measured() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("lossy.toml");
        let text = "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n\
                    [sensors.timing]\nframe_loss = 0.05\n";
        std::fs::write(&config, text).unwrap();
        let args = SimulateOptions {
            measure: MeasureOptions {
                config: Some(config),
                log: Some(dir.path().join("lossy.mcap")),
                ..MeasureOptions::default()
            },
            only: Some(ErrorSource::FrameLoss),
            ..SimulateOptions::default()
        };
        let outcome = run(&args, &mut Silent, &AtomicBool::new(false)).unwrap();
        assert_eq!(outcome.end, End::Completed);
        let r = outcome.report.unwrap();
        // Lost frames are counted over every frame the estimator was fed (hold, settle and
        // excitation, about 8.5 s), the samples over the fit window alone (6 s less the lost):
        // a 5 % loss gives a share near 425 / (425 + 5700) ≈ 0.07, ±0.004 by chance.
        let share = r.data.frames_lost as f64 / (r.samples + r.data.frames_lost) as f64;
        assert!((0.05..0.09).contains(&share), "lost share {share}");
        assert_eq!(r.data.restarts, 0);
        let t = r.truth.unwrap();
        assert!(
            (r.estimate.mass - t.mass).abs() < 1e-3 * t.mass,
            "{}",
            r.estimate.mass
        );
    }

    #[test]
    fn an_older_scenario_file_is_refused_saying_where_its_keys_went() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("old.toml");
        std::fs::write(&config, "[payload]\nmass_kg = 900.0\n").unwrap();
        let args = SimulateOptions {
            measure: MeasureOptions {
                config: Some(config),
                ..MeasureOptions::default()
            },
            ..SimulateOptions::default()
        };
        let err = run(&args, &mut Silent, &AtomicBool::new(false)).unwrap_err();
        assert!(matches!(err, Error::Config(_)), "{err}");
        assert!(err.to_string().contains("[world.payload]"), "{err}");
    }

    /// `simulate --calibrate-load-cells FILE --seed 7 --only load_cell_scale` recovers the
    /// gains the simulated rig drew: the fit alone to its truncation error (no other
    /// imperfection), the applied gains (with the datasheet's prior) within three of their
    /// sigmas and their mean (what the mass reads) within one of the mean's.
    #[test]
    fn calibrate_load_cells_recovers_the_simulated_gains() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("short.toml");
        std::fs::write(
            &config,
            "[run]\nduration_s = 10.0\ntare_duration_s = 10.0\n",
        )
        .unwrap();
        let file = dir.path().join("cells.toml");
        let args = SimulateOptions {
            measure: MeasureOptions {
                config: Some(config),
                log: Some(dir.path().join("cal.mcap")),
                ..MeasureOptions::default()
            },
            seed: Some(7),
            only: Some(ErrorSource::LoadCellScale),
            calibrate_load_cells: Some(file.clone()),
            ..SimulateOptions::default()
        };
        let outcome = run(&args, &mut Silent, &AtomicBool::new(false)).unwrap();
        let written = outcome.load_cell_calibration.expect("a calibration");
        assert_eq!(
            rig_description::calibration::LoadCellFile::read(&file).unwrap(),
            written
        );
        // The simulator's truth, read here only to check the calibration.
        let scenario = args.scenario().unwrap();
        let geometry = measure::setup::geometry(&scenario.loaded).unwrap();
        let truth = scenario
            .simulator(geometry, false)
            .unwrap()
            .true_load_cell_gains();
        let c = &written.load_cells;
        for (i, t) in truth.iter().enumerate() {
            let z = (c.gains[i] - t) / c.sigma(i);
            println!(
                "cell {i}: {:+.3e} truth {:+.3e} sigma {:.1e} z {z:+.2}",
                c.gains[i],
                truth[i],
                c.sigma(i)
            );
            assert!(z.abs() < 3.0, "cell {i}: z {z}");
            // This world has no other imperfection (its joints as drawn, its legs as
            // described, no noise): the fit alone is exact to the derivatives' truncation.
            assert!((c.fitted_gains[i] - t).abs() < 2e-5, "cell {i}");
        }
        let mean = |g: &[f64; 6]| g.iter().sum::<f64>() / 6.0;
        let ones = nalgebra::DVector::from_element(6, 1.0 / 6.0);
        let mean_sigma = (ones.transpose() * c.covariance_matrix() * &ones)[(0, 0)].sqrt();
        let z = (mean(&c.gains) - mean(&truth)) / mean_sigma;
        println!("mean z {z:+.2} (sigma {mean_sigma:.1e})");
        assert!(z.abs() < 1.0, "mean gain: z {z}");
    }
}
