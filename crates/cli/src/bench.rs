//! `stewart bench`: the flags of [`ops::bench`], which times the full control-and-estimation
//! tick and the simulator on the configured scenario; prints whether the loop rate fits.

use clap::Args;
use sim::NoisePreset;

/// Flags of `stewart bench`.
#[derive(Clone, Debug, Default, Args)]
pub struct BenchArgs {
    /// Scenario TOML, laid over the embedded default (configs/default.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<std::path::PathBuf>,
    /// Excitation time of the measured run including the fades, simulated s (0.01 to 36000, as
    /// run.duration_s).
    #[arg(long, value_name = "SECONDS", default_value_t = 20.0)]
    pub duration: f64,
    /// Sensor grade: `realistic` the rig description's datasheet, `none` ideal, `harsh` ×10.
    #[arg(long, value_parser = crate::common::noise_preset())]
    pub noise: Option<NoisePreset>,
    /// Random seed of the simulated world (world.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Print the result as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `stewart bench`: loads the configuration, measures, prints. Returns the exit code: 0 when
/// the loop fits with margin, 1 when it does not, 2 when the input was refused.
pub fn main(args: &BenchArgs) -> u8 {
    let options = ops::bench::BenchOptions {
        config: args.config.clone(),
        duration_s: args.duration,
        noise: args.noise,
        seed: args.seed,
    };
    match ops::bench::run(&options) {
        Ok(report) => {
            if args.json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&report).unwrap_or_default()
                );
            } else {
                print!("{}", ops::bench::render(&report));
            }
            u8::from(!report.fits_with_margin)
        }
        Err(e @ ops::bench::Error::Config(_)) => {
            eprintln!("error: {e}");
            2
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            1
        }
    }
}
