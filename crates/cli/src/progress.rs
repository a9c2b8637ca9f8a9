//! The progress bar of a measurement on the terminal: an [`Observer`] counting ticks and naming
//! the phase (hidden with `--quiet` or when standard error is not a terminal).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use measure::observer::{Observer, TickEvent};
use ops::measurement::{Message, Operator, Pass};

/// The bar. See the [module docs](self).
pub struct Progress {
    bar: ProgressBar,
    phase: Option<control::supervisor::Phase>,
}

impl Progress {
    /// A bar for `total` samples, hidden when `quiet` or when standard error is not a terminal.
    pub fn new(total: u64, quiet: bool) -> Self {
        use std::io::IsTerminal;
        let bar = if quiet || !std::io::stderr().is_terminal() {
            ProgressBar::hidden()
        } else {
            let bar =
                ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(10));
            if let Ok(style) = ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}",
            ) {
                bar.set_style(style);
            }
            bar
        };
        Self { bar, phase: None }
    }

    /// A handle on the bar, to take it off the screen during a prompt.
    pub fn handle(&self) -> ProgressBar {
        self.bar.clone()
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Observer for Progress {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        self.bar.inc(1);
        if self.phase != Some(e.phase) {
            self.phase = Some(e.phase);
            self.bar
                .set_message(format!("{}: {}", e.measurement.name(), e.phase.name()));
        }
        Ok(())
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

/// The terminal as a measurement's operator: the bar, the notes and warnings on standard error (the
/// notes and the live view's address left out with `--quiet`), the calibration passes on
/// standard output.
pub struct Terminal {
    progress: Progress,
    quiet: bool,
}

impl Terminal {
    /// The terminal's operator; `quiet`: no bar, no notes, no passes.
    pub fn new(quiet: bool) -> Self {
        Self {
            progress: Progress::new(0, quiet),
            quiet,
        }
    }

    /// A handle on the bar, to take it off the screen during a prompt.
    pub fn handle(&self) -> ProgressBar {
        self.progress.handle()
    }
}

impl Observer for Terminal {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        self.progress.tick(e)
    }
}

impl Operator for Terminal {
    fn begin(&mut self, total_samples: u64) {
        self.progress.bar.set_length(total_samples);
    }

    fn end(&mut self) {
        self.progress.finish();
    }

    fn tell(&mut self, message: Message<'_>) {
        match message {
            Message::Warning(text) => eprintln!("warning: {text}"),
            _ if self.quiet => {}
            Message::Note(text) => eprintln!("note: {text}"),
            Message::Live(addr) => {
                eprintln!("live view: ws://{addr} (Foxglove: Open connection → Foxglove WebSocket)")
            }
            Message::PassStarted(Pass::Imu) => {
                println!("IMU calibration on the empty fixture (calibration.measure_imu) …")
            }
            Message::PassStarted(Pass::LoadCells) => println!(
                "load-cell calibration with the reference weight (calibration.measure_load_cells) …"
            ),
            Message::ImuCalibrated(file, path) => {
                crate::calibrate::print_imu_calibration(file, path, false)
            }
            Message::LoadCellsCalibrated(file, path) => {
                crate::calibrate::print_load_cell_calibration(file, path, false)
            }
        }
    }
}
