//! The progress bar of a measurement on the terminal: an [`Observer`] counting ticks and naming
//! the phase (hidden with `--quiet` or when standard error is not a terminal).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use measure::observer::{Observer, TickEvent};

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
