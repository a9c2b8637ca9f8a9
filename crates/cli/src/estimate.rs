//! `stewart estimate LOG.mcap`: the flags of [`ops::estimate`], the estimator re-run offline
//! from a log's sensor channel with the settings the log recorded or others; prints the same
//! table and report as the run, and draws the figures.

use std::path::PathBuf;

use clap::Args;
use ops::estimate::{EstimateOptions, EstimateOutcome, SettingsOverride, Window};

use crate::common::EXIT_NOT_MEASURED;

/// `stewart estimate` arguments.
#[derive(Clone, Debug, Default, Args)]
pub struct EstimateArgs {
    /// MCAP log of a `simulate`, `rig` or `import` run (a log cut short is read up to its last
    /// chunk).
    #[arg(value_name = "LOG.mcap")]
    pub log: PathBuf,
    /// Subtract this saved tare (JSON) instead of the log's tare run or tare.
    #[arg(long, value_name = "FILE")]
    pub tare: Option<PathBuf>,
    /// Save the tare re-estimated from the log's tare run (JSON) for later `--tare` runs; a
    /// log with a tare run only gives this file and no report.
    #[arg(long, value_name = "FILE", conflicts_with = "tare")]
    pub save_tare: Option<PathBuf>,
    /// 10: mass, centre of mass and inertia; 6: the paper's inertia-only model (known mass and
    /// centre of mass from the logged configuration).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["10", "6"]))]
    pub params: Option<String>,
    /// Write the JSON report here.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Write the report as one self-contained HTML page here (results with expanded
    /// uncertainty k = 2, principal axes, budget, convergence, rig; prints on A4).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Low-pass cut-off of the signal conditioning, Hz: 0.1 up to 80 % of half the log's sample
    /// rate, as estimator.cutoff_hz (0 or `none`: no filter).
    #[arg(long, value_name = "HZ", value_parser = ops::estimate::parse_cutoff_hz, allow_negative_numbers = true)]
    pub cutoff_hz: Option<f64>,
    /// RLS forgetting factor λ, 0.9 to 1 as estimator.forgetting_factor.
    #[arg(long, value_name = "LAMBDA", value_parser = ops::estimate::parse_forgetting_factor)]
    pub forgetting_factor: Option<f64>,
    /// Time window START:END in seconds from the start of each measurement's excitation;
    /// either end may be empty (e.g. `5:` or `:30`). A short window gets residual half-blocks
    /// short enough for a measured sigma, as a measurement of that length would (at least
    /// 1.8 s with the default settings).
    #[arg(long, value_name = "START:END", value_parser = str::parse::<Window>)]
    pub window: Option<Window>,
    /// Write SVG and PNG figures (estimates with ±σ and truth, tracking error, excitation) here.
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
    /// Take the datasheet figures (sensor noise, biases, IMU mounting, the legs the estimator
    /// compensates) from this rig description instead of the one the log recorded; and the
    /// platform too when the log's metadata was lost to damage.
    #[arg(long, value_name = "FILE")]
    pub rig: Option<PathBuf>,
    /// Also print the error budget: one row per error source with its one sigma of the
    /// mass, the centre of mass and each J_C entry (from the rig description's figures and
    /// the log's own data); the total row is the printed sigma.
    #[arg(long)]
    pub budget: bool,
    /// No table.
    #[arg(long)]
    pub quiet: bool,
}

/// The options of the command line.
pub fn options(args: &EstimateArgs) -> EstimateOptions {
    EstimateOptions {
        log: args.log.clone(),
        tare: args.tare.clone(),
        rig: args.rig.clone(),
        settings: SettingsOverride {
            params: args.params.as_deref().map(crate::common::parse_params),
            cutoff_hz: args.cutoff_hz,
            forgetting_factor: args.forgetting_factor,
            window: args.window,
        },
        report: args.report.clone(),
        html: args.html.clone(),
    }
}

/// Writes `text` to standard output; a closed pipe (`estimate LOG | head -1`) ends the
/// output quietly instead of panicking.
fn out(text: &str) {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    let _ = o.write_all(text.as_bytes()).and_then(|()| o.flush());
}

/// Prints what `estimate` measured (unless quiet) and draws the figures of `--plot`.
fn print(args: &EstimateArgs, o: &EstimateOutcome) -> anyhow::Result<()> {
    let report = &o.report;
    if !args.quiet {
        out(&crate::table::render(report));
        if args.budget {
            out(&crate::table::render_budget(report));
        }
    }
    crate::table::warn_rigid_body(report);
    let written = [("report", &args.report), ("page", &args.html)];
    for (what, path) in written {
        if let (Some(path), false) = (path, args.quiet) {
            out(&format!("{what}: {}\n", path.display()));
        }
    }
    if let Some(dir) = &args.plot {
        let f = figures::series::figures_of_estimate(&args.log, o)?;
        let figures = figures::write_figures(dir, &f)?;
        if !args.quiet {
            out(&format!(
                "figures: {} ({} files)\n",
                dir.display(),
                figures.len()
            ));
        }
    }
    Ok(())
}

/// `stewart estimate` as a command: its exit code, with the reason on standard error (0 done,
/// 2 input refused, [`EXIT_NOT_MEASURED`] nothing measured). With `--save-tare` the tare is
/// saved first; a log without a loaded run ends there.
pub fn main(args: &EstimateArgs) -> u8 {
    let options = options(args);
    if let Some(path) = &args.save_tare {
        match ops::estimate::save_tare(&options, path) {
            Ok(saved) => {
                if !args.quiet {
                    out(&format!("tare: {}\n", path.display()));
                }
                if !saved.has_loaded {
                    return 0;
                }
            }
            Err(e) => {
                eprintln!("error: {e:#}");
                return 2;
            }
        }
    }
    let outcome = match ops::estimate::run(&options) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e:#}");
            return 2;
        }
    };
    for w in outcome.warnings(&args.log) {
        eprintln!("warning: {w}");
    }
    if let Err(why) = &outcome.quality {
        eprintln!("error: {}: {why}", args.log.display());
        return EXIT_NOT_MEASURED;
    }
    match print(args, &outcome) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use measure::Report;
    use ops::estimate::reestimate;
    use runlog::LogContents;

    /// `estimate --rig FILE` takes the datasheet from FILE: its accelerometer bias figure sets
    /// the budget's `accel_bias` line, its gyro noise the estimator's settings; without it, the log's own
    /// rig description reproduces the run's report.
    #[test]
    fn another_rig_description_changes_the_estimators_settings_and_the_systematic_sigma() {
        use crate::common::MeasureArgs;
        use crate::simulate::SimulateArgs;
        let dir = tempfile::tempdir().unwrap();
        let short = dir.path().join("short.toml");
        // The accelerometer's offset left in the readings: its datasheet bias is the budget's
        // line (measured at rest, the line is that measurement's sigma instead).
        let no_offset = "[estimator]\nlocal_gravity_m_s2 = 0.0\n";
        std::fs::write(
            &short,
            format!("[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n{no_offset}"),
        )
        .unwrap();
        let log_path = dir.path().join("run.mcap");
        let args = SimulateArgs {
            measure: MeasureArgs {
                shared: crate::common::SharedArgs {
                    config: Some(short.clone()),
                    log: Some(log_path.clone()),
                    quiet: true,
                    ..Default::default()
                },
                ..MeasureArgs::default()
            },
            ..SimulateArgs::default()
        };
        let online = ops::simulate::run(
            &args.options(),
            &mut ops::measurement::Silent,
            &std::sync::atomic::AtomicBool::new(false),
        )
        .unwrap()
        .report
        .unwrap();
        let log = LogContents::read(&log_path).unwrap();
        let o = SettingsOverride::default();
        let (same, ..) = reestimate(&log, &o, None, None).unwrap();
        assert!((same.sigma.mass - online.sigma.mass).abs() < 1e-9 * online.sigma.mass);
        let other = dir.path().join("other.toml");
        std::fs::write(
            &other,
            "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n\
             [sensors.accelerometer]\nbias_m_s2 = 0.01\n\
             [sensors.gyro]\nnoise_density_rad_s_sqrt_hz = 2.0e-4\n\
             [estimator]\nlocal_gravity_m_s2 = 0.0\n",
        )
        .unwrap();
        let rig = rig_description::load::load(Some(&other)).unwrap();
        let (changed, loaded, ..) = reestimate(&log, &o, None, Some(&rig)).unwrap();
        assert_eq!(changed.systematic.accel_bias_sigma_m_s2, 0.01);
        let bias = |r: &Report| r.budget_line("accel_bias").map_or(0.0, |q| q.mass);
        let ratio = bias(&changed) / bias(&online);
        assert!(
            (5.0..20.0).contains(&ratio),
            "systematic mass sigma ratio {ratio}"
        );
        let gyro = loaded.replay.config.gyro_noise_rad_s;
        assert!((gyro - 2e-4 * 1000f64.sqrt()).abs() < 1e-12, "{gyro}");
    }
}
