//! `stewart import --rig RIG.toml DATA.csv -o LOG.mcap`: another rig's sensor samples (leg
//! lengths, load-cell forces, gyro, accelerometer, in CSV) written as a log that `stewart
//! estimate` measures: the flags of [`ops::import`]; docs/import.md gives the columns.

use std::path::PathBuf;

use clap::Args;
use ops::import::ImportOptions;

/// `stewart import` arguments.
#[derive(Clone, Debug, Default, Args)]
pub struct ImportArgs {
    /// The sensor table (docs/import.md: `time_s`, `run`, `leg_length_m_1`…, `leg_force_n_1`…,
    /// `gyro_rad_s_x`…, `accel_m_s2_x`…; optional `sequence`, `window`).
    #[arg(value_name = "DATA.csv")]
    pub csv: PathBuf,
    /// The rig description of the rig that recorded it (geometry, sample rate, datasheets,
    /// legs, estimator settings), laid over the embedded default.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: PathBuf,
    /// The log to write (default: DATA.mcap beside the table).
    #[arg(short = 'o', long = "out", value_name = "LOG.mcap")]
    pub out: Option<PathBuf>,
    /// A saved tare (JSON, as `simulate --save-tare` or `estimate --save-tare` writes) for a
    /// table with loaded rows only.
    #[arg(long, value_name = "FILE")]
    pub tare: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(long)]
    pub quiet: bool,
}

/// `stewart import` as a command: 0 written, 2 refused (the reason on standard error).
pub fn main(args: &ImportArgs) -> u8 {
    let options = ImportOptions {
        csv: args.csv.clone(),
        rig: args.rig.clone(),
        out: args.out.clone(),
        tare: args.tare.clone(),
    };
    match ops::import::run(&options) {
        Ok(imported) => {
            if !args.quiet {
                for r in &imported.runs {
                    println!("{r}");
                }
                println!("log: {}", imported.log.display());
            }
            0
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    }
}
