//! The command line of `stewart rig`: the link flags, the modes and their flags, and the plan
//! they resolve to (which runs, which files), refused when the flags contradict each other.

use std::path::PathBuf;

use clap::{Args, Subcommand};
use ops::rig::RigPlan;

use crate::common::{refuse, CommandError, MeasureArgs, SharedArgs};

/// The link flags of `stewart rig`.
#[derive(Clone, Debug, Default, Args)]
pub struct LinkArgs {
    /// The rig's address: udp://HOST:PORT or serial:///dev/DEVICE?baud=N [default: rig.address,
    /// udp://127.0.0.1:7700].
    #[arg(long, value_name = "ADDR")]
    pub connect: Option<String>,
    /// Shared-key file (hex), instead of rig.key_file and the user's key file
    /// ($XDG_CONFIG_HOME/stewart/rig.key, else ~/.config/stewart/rig.key).
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// No shared key: commands go untagged and anyone on the network can forge them. The rig
    /// must run without a key too (`emulate --insecure`). For isolated networks only.
    #[arg(long)]
    pub insecure: bool,
    /// Stay at normal priority: do not ask for SCHED_FIFO and locked memory.
    #[arg(long)]
    pub no_realtime: bool,
    /// Fault when no valid sensor frame arrived for this long, ms (rig.link_silence_ms,
    /// default 50).
    #[arg(long, value_name = "MS")]
    pub link_silence_ms: Option<f64>,
    /// Start the loaded run right after the tare run, without waiting for the operator to put
    /// the payload on and press Enter (scripts, the emulator).
    #[arg(long)]
    pub no_prompt: bool,
}

/// Link and run flags, accepted by `rig`, `rig tare` and `rig measure`.
#[derive(Clone, Debug, Default, Args)]
pub struct RigRunArgs {
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// The measurement's flags.
    #[command(flatten)]
    pub run: MeasureArgs,
}

/// `stewart rig`.
#[derive(Clone, Debug, Default, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct RigArgs {
    /// Tare only or measurement only; without one: tare run, payload on, loaded run.
    #[command(subcommand)]
    pub mode: Option<RigMode>,
    /// Flags of the two-run mode.
    #[command(flatten)]
    pub common: RigRunArgs,
}

/// The single-run modes of `stewart rig`.
#[derive(Clone, Debug, Subcommand)]
pub enum RigMode {
    /// Measure the empty fixture (tare) and save it for `rig measure --tare FILE`.
    Tare(RigTareArgs),
    /// Measure the payload, subtracting a saved tare (`--tare FILE`, required).
    Measure(RigMeasureArgs),
    /// Calibrate the IMU: the empty fixture moves through the tare run's excitation and the
    /// IMU's alignment against the forward kinematics (axes, gyro scales, the accelerometer's
    /// position, the delay) is fitted and written with its uncertainty to `--out FILE`, which
    /// `[calibration] imu = "FILE"` in the rig description then applies (docs/calibration.md).
    CalibrateImu(RigTareArgs),
    /// Calibrate the load cells' gains: a tare run of the empty fixture, then the operator puts
    /// the reference weight on (`calibration.reference_mass_kg`, its certificate's sigma
    /// `reference_mass_tolerance_kg`) and confirms (`--no-prompt`: at once), then the loaded
    /// run; the gains are fitted with their covariance and written to `--out FILE`, which
    /// `[calibration] load_cells = "FILE"` in the rig description then applies
    /// (docs/calibration.md). A load-cell file the rig description names is left out of these
    /// runs; its IMU calibration is applied as in a measurement.
    CalibrateLoadCells(RigTareArgs),
}

/// `stewart rig tare`: only the flags that act on a tare run.
#[derive(Clone, Debug, Args)]
pub struct RigTareArgs {
    /// Save the tare here (JSON).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// Flags of every run.
    #[command(flatten)]
    pub shared: SharedArgs,
}

/// `stewart rig measure`: only the flags that act on a loaded run with a saved tare.
#[derive(Clone, Debug, Args)]
pub struct RigMeasureArgs {
    /// The saved tare (JSON) to subtract, from `rig tare --out FILE`.
    #[arg(long, value_name = "FILE")]
    pub tare: PathBuf,
    /// Excitation time of the loaded run including the fades, s (run.duration_s).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Write the report as one self-contained HTML page here (see `stewart rig --help`).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Also print the error budget (one row per error source; see `stewart rig --help`).
    #[arg(long)]
    pub budget: bool,
    /// How to reach the rig.
    #[command(flatten)]
    pub link: LinkArgs,
    /// Flags of every run.
    #[command(flatten)]
    pub shared: SharedArgs,
}

/// The plan and flags of `args`, or why they do not go together.
pub fn resolve(args: &RigArgs) -> Result<(RigPlan, RigRunArgs), CommandError> {
    let (plan, common) = match &args.mode {
        None if args.common.run.tare.is_some() => (RigPlan::MeasureOnly, args.common.clone()),
        None => (RigPlan::Both, args.common.clone()),
        Some(RigMode::Tare(t)) => (
            RigPlan::TareOnly(t.out.clone()),
            RigRunArgs {
                link: t.link.clone(),
                run: MeasureArgs {
                    shared: t.shared.clone(),
                    ..MeasureArgs::default()
                },
            },
        ),
        Some(RigMode::CalibrateImu(t) | RigMode::CalibrateLoadCells(t)) => (
            match &args.mode {
                Some(RigMode::CalibrateImu(_)) => RigPlan::CalibrateImu(t.out.clone()),
                _ => RigPlan::CalibrateLoadCells(t.out.clone()),
            },
            RigRunArgs {
                link: t.link.clone(),
                run: MeasureArgs {
                    shared: t.shared.clone(),
                    ..MeasureArgs::default()
                },
            },
        ),
        Some(RigMode::Measure(m)) => (
            RigPlan::MeasureOnly,
            RigRunArgs {
                link: m.link.clone(),
                run: MeasureArgs {
                    tare: Some(m.tare.clone()),
                    duration: m.duration,
                    report: m.report.clone(),
                    html: m.html.clone(),
                    shared: m.shared.clone(),
                    save_tare: None,
                    budget: m.budget,
                },
            },
        ),
    };
    if plan == RigPlan::MeasureOnly && common.run.save_tare.is_some() {
        return Err(refuse(
            "--save-tare needs a tare run; this run uses --tare".into(),
        ));
    }
    Ok((plan, common))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        rig: RigArgs,
    }

    fn parse(args: &[&str]) -> Result<RigArgs, clap::Error> {
        let mut all = vec!["rig"];
        all.extend_from_slice(args);
        Cli::try_parse_from(all).map(|c| c.rig)
    }

    #[test]
    fn modes_and_flags_parse() {
        let a = parse(&[]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, RigPlan::Both);
        let a = parse(&[
            "--connect",
            "udp://10.0.0.2:7700",
            "--duration",
            "5",
            "--no-prompt",
        ])
        .unwrap();
        let (plan, c) = resolve(&a).unwrap();
        assert_eq!(plan, RigPlan::Both);
        assert_eq!(c.link.connect.as_deref(), Some("udp://10.0.0.2:7700"));
        assert!(c.link.no_prompt);
        assert_eq!(c.run.duration, Some(5.0));
        let a = parse(&["tare", "--out", "t.json", "--quiet"]).unwrap();
        assert!(resolve(&a).unwrap().1.run.shared.quiet);
        assert_eq!(
            resolve(&a).unwrap().0,
            RigPlan::TareOnly(PathBuf::from("t.json"))
        );
        let a = parse(&["measure", "--tare", "t.json", "--report", "r.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, RigPlan::MeasureOnly);
        let a = parse(&["--tare", "t.json"]).unwrap();
        assert_eq!(resolve(&a).unwrap().0, RigPlan::MeasureOnly);
        let a = parse(&["calibrate-load-cells", "--out", "c.toml", "--no-prompt"]).unwrap();
        let (plan, c) = resolve(&a).unwrap();
        assert_eq!(plan, RigPlan::CalibrateLoadCells(PathBuf::from("c.toml")));
        assert!(c.link.no_prompt);
        assert!(
            parse(&["calibrate-load-cells"]).is_err(),
            "--out is required"
        );
        assert!(parse(&["calibrate-load-cells", "--out", "c", "--tare", "t"]).is_err());
    }

    #[test]
    fn contradictions_are_refused_by_name() {
        let message = |args: &[&str]| match resolve(&parse(args).unwrap()) {
            Err(e) => e.to_string(),
            Ok(_) => String::new(),
        };
        assert!(message(&["--tare", "t", "--save-tare", "s"]).contains("--save-tare"));
        // Flags that would not act are not offered: `rig measure` needs its tare, `rig tare`
        // takes no tare, no report and no loaded-run duration.
        assert!(parse(&["measure"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--tare", "x"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--report", "r"]).is_err());
        assert!(parse(&["tare", "--out", "t", "--duration", "5"]).is_err());
        assert!(parse(&["measure", "--tare", "t", "--save-tare", "s"]).is_err());
        // The simulator's flags are not the rig's: `rig --help` does not offer them.
        assert!(parse(&["--seed", "3"]).is_err());
        assert!(parse(&["measure", "--tare", "t", "--noise", "harsh"]).is_err());
        assert!(parse(&["--runs", "3"]).is_err());
        assert!(parse(&["tare"]).is_err(), "--out is required");
        assert!(parse(&["--duration", "5", "tare", "--out", "t"]).is_err());
    }
}
