//! `stewart estimate LOG.mcap`: the estimator re-run offline from a log's sensor channel, with
//! the settings the log recorded or others, and the same table and report as the run.
//!
//! The work is [`runlog::reestimate`]: the inputs rebuilt exactly as the online run built them
//! ([`measure::replay`]), each measurement's estimator configured from its `/run/estimator`
//! message, the datasheet figures from the rig description the log recorded or from
//! `--rig FILE`. With the recorded settings the result is the online report, to rounding (JSON
//! keeps every f64 exactly, so in practice bit for bit).
//!
//! Options change the settings of every measurement alike: `--cutoff-hz`, `--forgetting-factor`,
//! `--params` and `--window START:END` (seconds from the start of each measurement's recorded
//! window, its excitation; either end may be left open; a window shorter than the recorded one
//! gets the residual half-blocks a measurement of its length would,
//! `measure::quality::block_samples_for`).
//!
//! `--save-tare FILE` writes the tare of the log's tare run ([`save_tare`]); a log with a tare
//! run only (as `stewart import` writes from a tare-only table) gives that file and no report.

use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use clap::Args;
use measure::quality::QualityError;
use measure::{Report, TareFile};
use runlog::read::Damage;
use runlog::reestimate::stream::{reestimate_file, tare_of_file, Streamed, StreamedTare};
use runlog::reestimate::{RunEstimate, SettingsOverride, TareOrigin, Window};
use runlog::LogContents;

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
    /// Low-pass cut-off of the signal conditioning, Hz (0 or `none`: no filter).
    #[arg(long, value_name = "HZ", value_parser = parse_cutoff, allow_negative_numbers = true)]
    pub cutoff_hz: Option<f64>,
    /// RLS forgetting factor λ in (0, 1].
    #[arg(long, value_name = "LAMBDA")]
    pub forgetting_factor: Option<f64>,
    /// Time window START:END in seconds from the start of each measurement's excitation;
    /// either end may be empty (e.g. `5:` or `:30`). A short window gets residual half-blocks
    /// short enough for a measured sigma, as a measurement of that length would (at least
    /// 1.8 s with the default settings).
    #[arg(long, value_name = "START:END", value_parser = parse_window)]
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

/// Parses `--cutoff-hz`: a positive number of Hz, or `0` / `none` for no filter (0.0).
pub fn parse_cutoff(text: &str) -> Result<f64, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("none") {
        return Ok(0.0);
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!(
            "`{text}` is not a cut-off frequency: give a positive number of Hz, or 0 or `none` \
             for no filter"
        )),
    }
}

/// Parses `START:END` with either side optional.
pub fn parse_window(text: &str) -> Result<Window, String> {
    let (a, b) = text
        .split_once(':')
        .ok_or_else(|| format!("expected START:END in seconds, got `{text}`"))?;
    let num = |s: &str| -> Result<Option<f64>, String> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(None);
        }
        let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
        if v.is_finite() {
            Ok(Some(v))
        } else {
            Err(format!("`{s}` is not finite"))
        }
    };
    let w = Window {
        start_s: num(a)?,
        end_s: num(b)?,
    };
    if let (Some(s), Some(e)) = (w.start_s, w.end_s) {
        if s >= e {
            return Err(format!(
                "the window's start {s} s is not before its end {e} s"
            ));
        }
    }
    Ok(w)
}

/// The settings changes of the command line.
pub fn settings_override(args: &EstimateArgs) -> SettingsOverride {
    SettingsOverride {
        params: args.params.as_deref().map(crate::common::parse_params),
        cutoff_hz: args.cutoff_hz,
        forgetting_factor: args.forgetting_factor,
        window: args.window,
    }
}

/// What `estimate` produced.
#[derive(Clone, Debug)]
pub struct EstimateOutcome {
    /// The report, as `simulate` writes it.
    pub report: Report,
    /// The loaded measurement's re-run.
    pub loaded: RunEstimate,
    /// The tare subtracted.
    pub tare: TareFile,
    /// Where it came from.
    pub tare_origin: TareOrigin,
    /// What the log lost.
    pub damage: Damage,
    /// Whether anything was measured ([`measure::quality`]): when not, no table, report or
    /// figures were written.
    pub quality: Result<(), QualityError>,
    /// Figures written.
    pub figures: Vec<PathBuf>,
}

/// Writes `text` to standard output; a closed pipe (`estimate LOG | head -1`) ends the
/// output quietly instead of panicking.
fn out(text: &str) {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    let _ = o.write_all(text.as_bytes()).and_then(|()| o.flush());
}

/// Runs `stewart estimate`: streams the log once (memory bounded whatever its length), prints
/// the table (unless quiet), writes the report and figures. A measurement that measured
/// nothing (see [`measure::quality`]) is not an error here but in [`EstimateOutcome::quality`],
/// with nothing written.
pub fn estimate(args: &EstimateArgs) -> Result<EstimateOutcome> {
    let rig = match &args.rig {
        Some(path) => Some(measure::load::load(Some(path)).map_err(|e| anyhow!("{e}"))?),
        None => None,
    };
    let o = settings_override(args);
    let streamed = reestimate_file(&args.log, &o, args.tare.as_deref(), rig.as_ref())?;
    for w in streamed.damage.warnings(&args.log) {
        eprintln!("warning: {w}");
    }
    let Streamed {
        report,
        loaded,
        tare,
        tare_origin,
        damage,
        ..
    } = streamed;
    let quality = report.check_quality();
    let mut figures = Vec::new();
    if quality.is_ok() {
        if !args.quiet {
            out(&crate::table::render(&report));
            if args.budget {
                out(&crate::table::render_budget(&report));
            }
        }
        crate::table::warn_rigid_body(&report);
        if let Some(path) = &args.report {
            std::fs::write(path, report.to_json())
                .with_context(|| format!("cannot write the report {}", path.display()))?;
            if !args.quiet {
                out(&format!("report: {}\n", path.display()));
            }
        }
        if let Some(path) = &args.html {
            let source = format!("stewart estimate {}", args.log.display());
            crate::report::write_page(&report.to_json(), path, &source, rig.as_ref())
                .map_err(|e| anyhow!("cannot write the page {}: {e}", path.display()))?;
            if !args.quiet {
                out(&format!("page: {}\n", path.display()));
            }
        }
        if let Some(dir) = &args.plot {
            // The figures draw the 1 kHz channels too: the log read whole.
            let mut log = LogContents::read(&args.log)?;
            log.or_metadata_of(rig.as_ref())?;
            let f = crate::plot::figures_from_reestimate(&log, &loaded.run, &loaded.replay, &tare)?;
            figures = crate::plot::write_figures(dir, &f)?;
            if !args.quiet {
                out(&format!(
                    "figures: {} ({} files)\n",
                    dir.display(),
                    figures.len()
                ));
            }
        }
    }
    Ok(EstimateOutcome {
        report,
        loaded,
        tare,
        tare_origin,
        damage,
        quality,
        figures,
    })
}

/// `--save-tare FILE`: the log's tare run re-estimated (streamed once more, its loaded run not
/// replayed) and written to FILE. `None` without the flag.
pub fn save_tare(args: &EstimateArgs) -> Result<Option<StreamedTare>> {
    let Some(path) = &args.save_tare else {
        return Ok(None);
    };
    let rig = match &args.rig {
        Some(p) => Some(measure::load::load(Some(p)).map_err(|e| anyhow!("{e}"))?),
        None => None,
    };
    let saved = tare_of_file(&args.log, &settings_override(args), rig.as_ref())?;
    saved.tare.save(path)?;
    if !args.quiet {
        out(&format!("tare: {}\n", path.display()));
    }
    Ok(Some(saved))
}

/// `stewart estimate` as a command: its exit code, with the reason on standard error (0 done,
/// 2 input refused, [`EXIT_NOT_MEASURED`] nothing measured). With `--save-tare` the tare is
/// saved first; a log without a loaded run ends there.
pub fn main(args: &EstimateArgs) -> u8 {
    match save_tare(args) {
        Ok(Some(saved)) if !saved.has_loaded => return 0,
        Ok(_) => {}
        Err(e) => {
            eprintln!("error: {e:#}");
            return 2;
        }
    }
    match estimate(args) {
        Ok(EstimateOutcome {
            quality: Err(why), ..
        }) => {
            eprintln!("error: {}: {why}", args.log.display());
            EXIT_NOT_MEASURED
        }
        Ok(_) => 0,
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use runlog::reestimate::reestimate;

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
            &mut ops::session::Silent,
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
        let rig = measure::load::load(Some(&other)).unwrap();
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

    #[test]
    fn windows_parse() {
        assert_eq!(
            parse_window("5:30"),
            Ok(Window {
                start_s: Some(5.0),
                end_s: Some(30.0)
            })
        );
        assert_eq!(
            parse_window(":12.5"),
            Ok(Window {
                start_s: None,
                end_s: Some(12.5)
            })
        );
        assert_eq!(parse_window("2:").unwrap().end_s, None);
        assert!(parse_window("5").is_err());
        assert!(parse_window("9:3").is_err());
        assert!(parse_window("a:3").is_err());
        assert!(parse_window("1:inf").is_err());
    }
}
