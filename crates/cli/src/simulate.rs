//! `stewart simulate`: the flags of the measurement on the simulator ([`ops::simulate`]), and
//! what is printed of it.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use clap::Args;
use ops::simulate::SimulateOptions;
use rig_description::sources::ErrorSource;
use sim::NoisePreset;

use crate::common::{self, MeasureArgs};
use crate::progress::Terminal;

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
    /// statistics (`--report` writes them as JSON). N is 1 to 100000.
    #[arg(long, value_name = "N", conflicts_with = "live")]
    pub runs: Option<u32>,
    /// Runs in parallel with `--runs`, 1 to 1024 (default: one per CPU).
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
}

/// The parser of `--only`: the error sources' ids (listed in `--help`, and by clap when a
/// value is not one of them).
fn error_source() -> impl clap::builder::TypedValueParser<Value = ErrorSource> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(ErrorSource::ALL.map(ErrorSource::id))
        .map(|id| id.parse().unwrap_or(ErrorSource::Noise))
}

impl SimulateArgs {
    /// The simulation's options.
    pub fn options(&self) -> SimulateOptions {
        SimulateOptions {
            measure: self.measure.options(),
            seed: self.seed,
            noise: self.noise,
            only: self.only,
            calibrate_imu: self.calibrate_imu.clone(),
            calibrate_load_cells: self.calibrate_load_cells.clone(),
            apply_imu: None,
        }
    }
}

/// `stewart simulate` from the command line: runs, prints, writes the report; returns the
/// exit code (0 done, 1 failed, 2 refused before anything ran, 3 fault, 130 interrupted).
pub fn main(args: &SimulateArgs, interrupt: &AtomicBool) -> u8 {
    let mut terminal = Terminal::new(args.measure.shared.quiet);
    match ops::simulate::run(&args.options(), &mut terminal, interrupt) {
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
            let json = outcome.report_json().unwrap_or_default();
            let report = outcome.report.as_ref().map(|r| (r, json));
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
        let s = a.options().scenario().unwrap();
        assert_eq!(
            s.world.imperfections,
            sim::Imperfections::only(ErrorSource::Geometry)
        );
        let plain = parse(&[]).unwrap().options().scenario().unwrap();
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
}
