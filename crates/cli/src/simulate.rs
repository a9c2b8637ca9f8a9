//! `stewart simulate`: the whole measurement on the simulator — tare run with the empty
//! fixture (or a saved tare), the payload put on, the loaded run, park — then the report.
//!
//! Every check that can refuse the run (rig description, world, design, both trajectories, the
//! tare file, the simulator's own checks) runs before the first sample. The simulator's truth
//! goes only into the report's `truth`, the table and `/run/truth`; the estimator sees sensor
//! frames only, and assumes what the rig description's datasheet says.

use measure::calibration::CalibrationDocument;
use runlog::compact::AtLogResolution;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use anyhow::anyhow;
use clap::Args;
use measure::observer::{Both, Observer};
use measure::report::RunInfo;
use measure::session::{self, Job, SessionPlan, Station, TarePlan};
use measure::sources::ErrorSource;
use measure::{setup, End, MeasureOutcome, Report, TareFile};
use runlog::mcap_log::Delivery;
use runlog::messages as topics;
use runlog::metadata::{BodyTruth, RunMetadata, TruthMsg};
use runlog::{LogObserver, RunLog};

mod passes;

use passes::{calibration_pass, load_cell_pass, Pass};
pub use passes::{calibration_pass_paths, load_cell_pass_paths};

#[cfg(test)]
use crate::common::SharedArgs;
use crate::common::{self, CommandError, MeasureArgs};
use crate::progress::Progress;
use sim::scenario::Scenario;
use sim::NoisePreset;

/// Flags of `stewart simulate`.
#[derive(Clone, Debug, Default, Args)]
pub struct SimulateArgs {
    /// The measurement's flags.
    #[command(flatten)]
    pub measure: MeasureArgs,
    /// Random seed of the simulated world (world.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Sensor grade of the simulated rig: `realistic` is the rig description's datasheet as
    /// written, `none` ideal sensors, `harsh` ten times every figure (the estimator is told).
    #[arg(long, value_parser = crate::common::noise_preset())]
    pub noise: Option<NoisePreset>,
    /// Accuracy campaign: this many runs with seeds seed, seed+1, …, then per-parameter error
    /// statistics (`--report` writes them as JSON).
    #[arg(long, value_name = "N", conflicts_with = "live")]
    pub runs: Option<u32>,
    /// Runs in parallel with `--runs` (default: one per CPU).
    #[arg(long, value_name = "J", requires = "runs")]
    pub jobs: Option<usize>,
    /// Simulate a rig with only this one of a real rig's error sources (every other switch of
    /// `[world.imperfections]` off), each run of a `--runs` campaign alike. The rig
    /// description, which the estimator reads, stays as written. SOURCE is one of the error
    /// budget's ids: noise (white noise, quantisation, gyro bias), accel_bias,
    /// load_cell_offset (zero offset and drift), load_cell_scale, load_cell_crosstalk,
    /// imu_misalignment (axes and scale errors), imu_lever_arm, time_skew, timestamp_jitter,
    /// frame_loss, leg_dynamics, joint_friction, geometry (the built joints).
    #[arg(long, value_name = "SOURCE", value_parser = error_source())]
    pub only: Option<ErrorSource>,
    /// Calibrate the simulated rig's IMU instead of measuring a payload: the empty fixture
    /// moves through the tare run's excitation, and the IMU's alignment against the platform's
    /// forward kinematics (axes, gyro scales, the accelerometer's position, the delay) is
    /// fitted and written with its uncertainty to FILE, which `[calibration] imu = "FILE"` in a
    /// rig description applies (docs/calibration.md). Any calibration the rig description
    /// already applies is left out of this run.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with_all = ["runs", "tare", "save_tare", "report", "html", "budget"]
    )]
    pub calibrate_imu: Option<PathBuf>,
    /// Calibrate the simulated rig's load cells instead of measuring a payload: a tare run,
    /// then the world's reference body (`[world.reference]`) in the payload's place, and the
    /// cells' gains fitted against the rig description's `calibration.reference_mass_kg` are
    /// written with their covariance to FILE, which `[calibration] load_cells = "FILE"`
    /// applies (docs/calibration.md). A load-cell calibration the rig description already
    /// applies is left out of these runs; its IMU calibration is applied as in a measurement.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["runs", "tare", "calibrate_imu"])]
    pub calibrate_load_cells: Option<PathBuf>,
    /// An IMU calibration to apply in place of the rig description's (the file's path and
    /// contents): the load-cell calibration pass takes the IMU pass's.
    #[arg(skip)]
    pub apply_imu: Option<(PathBuf, Box<measure::calibration::CalibrationFile>)>,
}

/// The parser of `--only`: the error sources' ids (listed in `--help`, and by clap when a
/// value is not one of them).
fn error_source() -> impl clap::builder::TypedValueParser<Value = ErrorSource> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(ErrorSource::ALL.map(ErrorSource::id))
        .map(|id| id.parse().unwrap_or(ErrorSource::Noise))
}

impl SimulateArgs {
    /// The rig description and the world of the flags, checked; with `--only`, the world's
    /// switches are that source alone.
    pub fn scenario(&self) -> Result<Scenario, CommandError> {
        let mut scenario = Scenario::new(self.measure.load_config()?, self.seed, self.noise)?;
        if let Some(source) = self.only {
            scenario.world.imperfections = sim::Imperfections::only(source);
        }
        Ok(scenario)
    }
}

/// What a `simulate` run produced.
#[derive(Debug)]
pub struct SimulateOutcome {
    /// The report (estimate, sigma, truth, ...); `None` when the run ended before an estimate.
    pub report: Option<Report>,
    /// The MCAP log written.
    pub log_path: PathBuf,
    /// How the run ended (anything but `Completed` is a non-zero exit).
    pub end: End,
    /// The measured tare, when a tare run was made.
    pub tare: Option<TareFile>,
    /// The IMU calibration written (`--calibrate-imu`).
    pub calibration: Option<measure::calibration::CalibrationFile>,
    /// The load-cell calibration written (`--calibrate-load-cells`).
    pub load_cell_calibration: Option<measure::calibration::LoadCellFile>,
}

/// Time the braked plate is left to settle after the payload is put on, s.
pub const PAYLOAD_SETTLE_S: f64 = 2.0;

/// The simulator as a session's station: the payload change puts the world's payload on.
struct SimStation {
    sim: sim::Simulator,
    payload: sim::BodyProperties,
}

impl Station for SimStation {
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

fn body_truth(b: &sim::scenario::BodyConfig) -> BodyTruth {
    BodyTruth {
        mass_kg: b.mass_kg,
        com_m: b.com_m,
        inertia_com_kg_m2: b.inertia_com_kg_m2,
        theta: sim::InertialParameters::from_body(&b.to_sim()).theta(),
    }
}

/// Runs `stewart simulate` with `args`. `interrupt` is the Ctrl-C flag: when it is set the
/// platform parks, the log is finished and the outcome says [`End::Interrupted`].
pub fn simulate(
    args: &SimulateArgs,
    interrupt: &AtomicBool,
) -> Result<SimulateOutcome, CommandError> {
    // Everything that can refuse the run, before the first sample.
    let mut scenario = args.scenario()?;
    if let Some((path, file)) = &args.apply_imu {
        let c = &mut scenario.loaded.config.calibration;
        c.imu = Some(path.display().to_string());
        c.imu_file = Some((**file).clone());
    }
    if args.calibrate_imu.is_some() {
        // The calibration fits the raw readings: nothing of an older calibration applied.
        scenario.loaded.config.calibration.imu = None;
        scenario.loaded.config.calibration.imu_file = None;
    }
    let calibrating_cells = args.calibrate_load_cells.is_some();
    if calibrating_cells {
        // The gains are fitted on the raw readings, against a rigid reference body.
        crate::calibrate::prepare_reference_runs(&mut scenario.loaded)?;
        scenario.world.suspension.enabled = false;
    }
    // The body put on for the loaded run: the payload, or the reference.
    let body = if calibrating_cells {
        scenario.world.reference
    } else {
        scenario.world.payload
    };
    // The calibration pass's log and file are named after the measurement's log.
    let mut log_path = None;
    let calibrates_imu = scenario.loaded.config.calibration.calibrates_imu_each_run();
    let imu_uncertain = scenario.loaded.config.sensors.imu_alignment_uncertain();
    if calibrates_imu && !imu_uncertain && !args.measure.shared.quiet {
        eprintln!(
            "note: calibration.measure_imu: the rig description gives the IMU's alignment \
             exactly (sensors.imu misalignment_deg and position_tolerance_m, sensors.gyro \
             scale_error and sensors.timing imu_skew_s all 0), so there is nothing to calibrate"
        );
    }
    if args.calibrate_imu.is_none() && calibrates_imu && imu_uncertain {
        let log = common::log_path(&args.measure, runlog::run_log::unix_now_ns());
        let pass = calibration_pass(args, &log, interrupt)?;
        log_path = Some(log);
        match pass {
            Pass::Calibrated(path, file) => {
                let c = &mut scenario.loaded.config.calibration;
                c.imu = Some(path.display().to_string());
                c.imu_file = Some(*file);
            }
            Pass::Skipped => {}
            Pass::Ended(outcome) => return Ok(*outcome),
        }
    }
    if args.calibrate_imu.is_none()
        && !calibrating_cells
        && scenario
            .loaded
            .config
            .calibration
            .calibrates_load_cells_each_run()
    {
        let log = log_path
            .clone()
            .unwrap_or_else(|| common::log_path(&args.measure, runlog::run_log::unix_now_ns()));
        let c = &scenario.loaded.config.calibration;
        let imu = c
            .imu
            .clone()
            .zip(c.imu_file.clone())
            .map(|(p, f)| (PathBuf::from(p), Box::new(f)));
        let pass = load_cell_pass(args, &log, imu, interrupt)?;
        log_path = Some(log);
        match pass {
            Pass::Calibrated(path, file) => {
                let c = &mut scenario.loaded.config.calibration;
                c.load_cells = Some(path.display().to_string());
                c.load_cells_file = Some(*file);
            }
            Pass::Skipped => {}
            Pass::Ended(outcome) => return Ok(*outcome),
        }
    }
    let scenario = scenario;
    let loaded = &scenario.loaded;
    let config = &loaded.config;
    common::warn_old_calibrations(config);
    let geometry = setup::geometry(loaded)?;
    // The controllers checked here are the ones that run.
    let trajectory = setup::trajectory(loaded, &geometry, config.run.duration_s)?;
    let loaded_controller =
        setup::controller(loaded, &geometry, trajectory, measure::Measurement::Loaded)?;
    let tare = common::tare_plan(loaded, &geometry, args.measure.tare.as_deref())?;
    let tare_run = matches!(tare, TarePlan::Measure(_));
    // The loaded world must be accepted too, before the tare run moves anything.
    let loaded_world = scenario.simulator(geometry, true)?;
    let sim = if tare_run {
        scenario.simulator(geometry, false)?
    } else {
        loaded_world
    };

    let start_ns = runlog::run_log::unix_now_ns();
    let log_path = log_path.unwrap_or_else(|| common::log_path(&args.measure, start_ns));
    // The live view's address is bound before the log exists: a refused one leaves no log.
    // Watched live, the simulation keeps to the wall clock.
    let live = live::serve(args.measure.shared.live, live::Pace::WallClock)
        .map_err(CommandError::Input)?;
    let live_addr = live.as_ref().map(live::LiveServer::addr);
    let tap = live.map(live::LiveServer::into_tap);
    let mut log = RunLog::create_tapped(&log_path, start_ns, Delivery::Lossless, tap)
        .map_err(CommandError::Run)?;
    common::announce_live(live_addr, args.measure.shared.quiet);
    let mut runs = Vec::new();
    if tare_run {
        runs.push("tare".to_string());
    }
    let calibrating = args.calibrate_imu.is_some();
    if !calibrating {
        runs.push("loaded".to_string());
    }
    let header = log
        .write_metadata(&RunMetadata {
            seed: scenario.world.seed,
            noise: scenario.noise.name().into(),
            start_unix_ns: log.start_unix_ns(),
            runs,
            tare_file: args.measure.tare.as_ref().map(|p| p.display().to_string()),
            ..RunMetadata::describing(
                loaded,
                &geometry,
                if calibrating {
                    "simulate --calibrate-imu"
                } else if calibrating_cells {
                    "simulate --calibrate-load-cells"
                } else {
                    "simulate"
                },
                "sim",
            )
        })
        .and_then(|()| {
            log.write_now(
                topics::TRUTH,
                &TruthMsg {
                    fixture: body_truth(&scenario.world.fixture),
                    payload: body_truth(&body),
                    world_toml: scenario.world_toml(),
                },
            )
        });
    let total = match &tare {
        TarePlan::Measure(c) => measure::measurement::expected_samples(config, c.trajectory()),
        TarePlan::File(..) => 0,
    } + if calibrating {
        0
    } else {
        measure::measurement::expected_samples(config, loaded_controller.trajectory())
    };
    let result = header.and_then(|()| {
        let mut station = SimStation {
            sim,
            payload: body.to_sim(),
        };
        let mut progress = Progress::new(total, args.measure.shared.quiet);
        let mut observer = Both(LogObserver::new(&mut log, &geometry, config), &mut progress);
        session::run(
            SessionPlan {
                config: loaded,
                geometry,
                tare,
                loaded: (!calibrating).then_some(loaded_controller),
                save_tare: args.measure.save_tare.as_deref(),
                backend: "sim",
            },
            &mut station,
            &mut observer,
            interrupt,
        )
    });
    let finished = log.finish();
    let outcome = result.map_err(CommandError::Run)?;
    finished.map_err(CommandError::Run)?;
    let calibration = match &args.calibrate_imu {
        Some(path) if outcome.end == End::Completed => {
            let file =
                crate::calibrate::imu_calibration(&outcome, loaded, "sim", start_ns, &log_path)
                    .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Some(file)
        }
        _ => None,
    };
    let load_cell_calibration = match &args.calibrate_load_cells {
        Some(path) if outcome.end == End::Completed => {
            let file = crate::calibrate::load_cell_calibration(
                &outcome, loaded, "sim", start_ns, &log_path,
            )
            .map_err(CommandError::Run)?;
            file.write(path).map_err(CommandError::Run)?;
            Some(file)
        }
        _ => None,
    };
    let report = outcome.report(
        config,
        RunInfo {
            config: loaded.source.clone(),
            seed: scenario.world.seed,
            noise: scenario.noise.name().into(),
            params: config.estimator.params.into(),
            log: Some(log_path.display().to_string()),
            backend: "sim".into(),
            tool: measure::calibration::tool(),
            calibrations: config.calibration.applied(),
        },
        Some(body.quantities()),
    );
    Ok(SimulateOutcome {
        report,
        log_path,
        end: outcome.end.clone(),
        tare: outcome.measured_tare().cloned(),
        calibration,
        load_cell_calibration,
    })
}

/// `stewart simulate` from the command line: runs, prints, writes the report; returns the
/// exit code (0 done, 1 failed, 2 refused before anything ran, 3 fault, 130 interrupted).
pub fn main(args: &SimulateArgs, interrupt: &AtomicBool) -> u8 {
    match simulate(args, interrupt) {
        Ok(outcome) => {
            let code = common::end_code(&outcome.end, "");
            if let (Some(path), Some(file)) = (&args.calibrate_imu, &outcome.calibration) {
                crate::calibrate::print_imu_calibration(file, path, args.measure.shared.quiet);
                return code;
            }
            if let (Some(path), Some(file)) =
                (&args.calibrate_load_cells, &outcome.load_cell_calibration)
            {
                crate::calibrate::print_load_cell_calibration(
                    file,
                    path,
                    args.measure.shared.quiet,
                );
                return code;
            }
            if let (Some(path), Some(_)) = (&args.measure.save_tare, &outcome.tare) {
                if !args.measure.shared.quiet {
                    println!("tare: {}", path.display());
                }
            }
            let report = outcome.report.as_ref().map(|r| (r, r.to_json()));
            crate::output::finish_measurement(&args.measure, report, &outcome.log_path, code)
        }
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A short simulate run of `extra` laid over a short default, in `dir`.
    fn short_run(dir: &std::path::Path, name: &str, extra: &str) -> SimulateOutcome {
        let config = dir.join(format!("{name}.toml"));
        let text = format!("[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n{extra}");
        std::fs::write(&config, text).unwrap();
        let args = SimulateArgs {
            measure: MeasureArgs {
                shared: SharedArgs {
                    config: Some(config),
                    log: Some(dir.join(format!("{name}.mcap"))),
                    quiet: true,
                    ..SharedArgs::default()
                },
                ..MeasureArgs::default()
            },
            ..SimulateArgs::default()
        };
        simulate(&args, &AtomicBool::new(false)).unwrap()
    }

    /// `--calibrate-imu` runs the tare alone and writes a calibration file that a rig
    /// description then applies: the accelerometer's position it found reaches the estimator.
    #[test]
    fn calibrate_imu_writes_a_file_that_a_rig_description_applies() {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("short.toml");
        std::fs::write(&config, "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n").unwrap();
        let file = dir.path().join("imu.toml");
        let args = SimulateArgs {
            measure: MeasureArgs {
                shared: SharedArgs {
                    config: Some(config),
                    log: Some(dir.path().join("cal.mcap")),
                    quiet: true,
                    ..SharedArgs::default()
                },
                ..MeasureArgs::default()
            },
            calibrate_imu: Some(file.clone()),
            ..SimulateArgs::default()
        };
        let outcome = simulate(&args, &AtomicBool::new(false)).unwrap();
        assert!(outcome.report.is_none(), "no payload is measured");
        let written = outcome.calibration.expect("a calibration");
        let read = measure::calibration::CalibrationFile::read(&file).unwrap();
        assert_eq!(read, written);
        // The default IMU sits at the P origin within its 1 mm tolerance.
        let r = read.imu.accelerometer_position_m;
        assert!(r.iter().all(|v| v.abs() < 5e-3), "{r:?}");
        let rig = dir.path().join("rig.toml");
        std::fs::write(&rig, "[calibration]\nimu = \"imu.toml\"\n").unwrap();
        let loaded = measure::load::load(Some(&rig)).unwrap();
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
        let (pass_log, pass_file) = load_cell_pass_paths(&outcome.log_path);
        assert!(pass_log.exists());
        let file = measure::calibration::LoadCellFile::read(&pass_file).unwrap();
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

    #[test]
    fn only_keeps_one_source_in_the_world_and_the_description_as_written() {
        use clap::Parser;
        let parse = |args: &[&str]| {
            let cli = crate::Cli::try_parse_from([&["stewart", "simulate"], args].concat())?;
            match cli.command {
                crate::Command::Simulate(a) => Ok::<_, clap::Error>(a),
                _ => panic!("not simulate"),
            }
        };
        let a = parse(&["--only", "geometry"]).unwrap();
        assert_eq!(a.only, Some(ErrorSource::Geometry));
        let s = a.scenario().unwrap();
        assert_eq!(
            s.world.imperfections,
            sim::Imperfections::only(ErrorSource::Geometry)
        );
        let plain = parse(&[]).unwrap().scenario().unwrap();
        assert_eq!(plain.world.imperfections, sim::Imperfections::default());
        assert_eq!(s.loaded.config, plain.loaded.config);
        // An unknown id: clap names every valid one.
        let err = parse(&["--only", "wobble"]).unwrap_err().to_string();
        for source in ErrorSource::ALL {
            assert!(err.contains(source.id()), "{err}");
        }
        let help = parse(&["--help"]).unwrap_err().to_string();
        assert!(help.contains("--only <SOURCE>"), "{help}");
        assert!(help.contains("timestamp_jitter"), "{help}");
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
        let args = SimulateArgs {
            measure: MeasureArgs {
                shared: SharedArgs {
                    config: Some(config),
                    log: Some(dir.path().join("lossy.mcap")),
                    quiet: true,
                    ..SharedArgs::default()
                },
                ..MeasureArgs::default()
            },
            only: Some(ErrorSource::FrameLoss),
            ..SimulateArgs::default()
        };
        let outcome = simulate(&args, &AtomicBool::new(false)).unwrap();
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
        let args = SimulateArgs {
            measure: MeasureArgs {
                shared: SharedArgs {
                    config: Some(config),
                    quiet: true,
                    ..SharedArgs::default()
                },
                ..MeasureArgs::default()
            },
            ..SimulateArgs::default()
        };
        let err = simulate(&args, &AtomicBool::new(false)).unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert!(err.to_string().contains("[world.payload]"), "{err}");
    }
}
