//! The leg-speed estimate: a fixed ring of the last `window` sensed leg-length vectors.

use crate::wire::LEG_COUNT;

use super::config::MAX_SPEED_WINDOW;

/// The last `window` leg-length samples (no heap).
#[derive(Clone, Copy, Debug)]
pub(super) struct SpeedWindow {
    window: usize,
    samples: [[f64; LEG_COUNT]; MAX_SPEED_WINDOW],
    /// Slot of the oldest sample once full; the next free slot before.
    next: usize,
    len: usize,
}

impl SpeedWindow {
    /// A ring over `window` samples (0 counts as 1; capped at [`MAX_SPEED_WINDOW`]).
    pub(super) fn new(window: usize) -> Self {
        Self {
            window: window.clamp(1, MAX_SPEED_WINDOW),
            samples: [[0.0; LEG_COUNT]; MAX_SPEED_WINDOW],
            next: 0,
            len: 0,
        }
    }

    /// Samples in the window.
    pub(super) fn window(&self) -> usize {
        self.window
    }

    /// Forgets every sample (braked legs hold still: a stale sample would turn the next
    /// driven sample's length change into a bogus speed).
    pub(super) fn clear(&mut self) {
        self.next = 0;
        self.len = 0;
    }

    /// Stores `lengths` and returns the sample `window` samples older, once there is one
    /// (the speed is then |lᵢ(k) − lᵢ(k − window)| / (window · period)).
    pub(super) fn push(&mut self, lengths: [f64; LEG_COUNT]) -> Option<[f64; LEG_COUNT]> {
        let slot = self.samples.get_mut(self.next)?;
        let old = if self.len == self.window {
            Some(*slot)
        } else {
            self.len += 1;
            None
        };
        *slot = lengths;
        self.next = (self.next + 1) % self.window;
        old
    }
}
