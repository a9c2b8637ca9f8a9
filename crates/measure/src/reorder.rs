//! Sensor frames put back in sequence order before they are turned into samples: a link that
//! reorders datagrams (UDP) hands a host, and its log, frame 101 before frame 100, and the
//! conditioning places samples by their counter and refuses one whose counter does not advance
//! (`estimator::timebase`), so without this a frame that comes a period late would be refused
//! although nothing is wrong with it.
//!
//! [`Reorder`] holds the last [`REORDER_WINDOW`] frames, sorted by sequence, in a fixed array
//! (no heap, plain `Copy` data): a frame is handed on once [`REORDER_WINDOW`] frames with a
//! higher counter have come, or at the end ([`Reorder::flush`]). So a frame that comes up to
//! [`REORDER_WINDOW`] frames late takes its place; one that comes later still, after a frame
//! with a higher counter was handed on, is dropped and counted as late, and a frame whose
//! counter was already held or handed on is dropped and counted as a duplicate (the last 64
//! counters handed on are remembered). A counter that jumps back by more than that is a
//! counter that restarted: what is held goes on first, and ordering starts afresh from it.
//!
//! A stream whose counter does not count (an import without a `sequence` column: every frame
//! 0) is handed on as it came: once two frames carry the same counter at different times
//! before the counter ever advanced, the counter is ignored, as the time base ignores it.

use control::io::SensorFrame;

/// Frames held back: a frame may come this many frames late and still take its place (8 ms
/// at 1 kHz, far beyond a link's reordering; the replay is offline, the delay costs nothing).
pub const REORDER_WINDOW: usize = 8;

/// Counters handed on that are remembered to tell a duplicate from a late frame.
const HISTORY: u64 = 64;

/// Frames dropped by the reordering.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReorderCounts {
    /// Came after a frame with a higher counter had been handed on (more than
    /// [`REORDER_WINDOW`] frames late).
    pub late: u64,
    /// Carried a counter already held or handed on.
    pub duplicates: u64,
}

/// The counter's verdict so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Counter {
    /// Not yet seen advancing.
    #[default]
    Unknown,
    /// Advanced between two frames: it orders them.
    Counting,
    /// Stood still across frames of different times before it advanced: frames pass as they
    /// come.
    Ignored,
}

/// The reorder window; see the [module docs](self).
#[derive(Clone, Copy, Debug, Default)]
pub struct Reorder {
    /// Frames held, ascending by sequence; the first `len` are valid.
    held: [SensorFrame; REORDER_WINDOW],
    len: usize,
    /// The last counter handed on, and which of the [`HISTORY`] before it were (bit k: the
    /// counter last − k).
    last_out: Option<u64>,
    out_mask: u64,
    counter: Counter,
    /// Counter and time of the frame that came last.
    last_in: Option<(u64, f64)>,
    counts: ReorderCounts,
}

impl Reorder {
    /// Frames dropped so far.
    pub fn counts(&self) -> ReorderCounts {
        self.counts
    }

    /// Takes `frame` as it came; hands `out` every frame that is due, in sequence order.
    pub fn push(&mut self, frame: SensorFrame, out: &mut impl FnMut(SensorFrame)) {
        if let (Counter::Unknown, Some((s, t))) = (self.counter, self.last_in) {
            if frame.sequence > s {
                self.counter = Counter::Counting;
            } else if frame.sequence == s && frame.time_s != t {
                self.counter = Counter::Ignored;
            }
        }
        self.last_in = Some((frame.sequence, frame.time_s));
        if self.counter == Counter::Ignored {
            self.flush(out);
            out(frame);
            return;
        }
        if let Some(last) = self.last_out {
            if frame.sequence <= last {
                let back = last - frame.sequence;
                if back < HISTORY {
                    if (self.out_mask >> back) & 1 == 1 {
                        self.counts.duplicates += 1;
                    } else {
                        self.counts.late += 1;
                    }
                    return;
                }
                // The counter restarted: the frames before the restart go on first.
                self.flush(out);
                self.last_out = None;
                self.out_mask = 0;
            }
        }
        let held = &self.held[..self.len];
        if held.iter().any(|h| h.sequence == frame.sequence) {
            self.counts.duplicates += 1;
            return;
        }
        let at = held.partition_point(|h| h.sequence < frame.sequence);
        if self.len == REORDER_WINDOW {
            if at == 0 {
                // Lower than every frame held: it is the one due.
                self.hand_on(frame, out);
                return;
            }
            let first = self.held[0];
            self.held.copy_within(1..at, 0);
            self.held[at - 1] = frame;
            self.hand_on(first, out);
        } else {
            self.held.copy_within(at..self.len, at + 1);
            self.held[at] = frame;
            self.len += 1;
        }
    }

    /// Hands on every frame held, in sequence order (the end of the stream).
    pub fn flush(&mut self, out: &mut impl FnMut(SensorFrame)) {
        let held = self.held;
        let n = std::mem::take(&mut self.len);
        for f in held.into_iter().take(n) {
            self.hand_on(f, out);
        }
    }

    fn hand_on(&mut self, frame: SensorFrame, out: &mut impl FnMut(SensorFrame)) {
        if self.counter != Counter::Ignored {
            self.out_mask = match self.last_out {
                Some(last) if frame.sequence > last => {
                    let shift = frame.sequence - last;
                    (if shift >= HISTORY {
                        0
                    } else {
                        self.out_mask << shift
                    }) | 1
                }
                Some(_) => self.out_mask,
                None => 1,
            };
            self.last_out = Some(
                self.last_out
                    .map_or(frame.sequence, |l| l.max(frame.sequence)),
            );
        }
        out(frame);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sequence: u64) -> SensorFrame {
        SensorFrame {
            sequence,
            time_s: sequence as f64 * 1e-3,
            ..SensorFrame::default()
        }
    }

    fn run(sequences: &[u64]) -> (Vec<u64>, ReorderCounts) {
        let mut r = Reorder::default();
        let mut out = Vec::new();
        for s in sequences {
            r.push(frame(*s), &mut |f| out.push(f.sequence));
        }
        r.flush(&mut |f| out.push(f.sequence));
        (out, r.counts())
    }

    #[test]
    fn swapped_neighbours_come_out_in_order() {
        let (out, counts) = run(&[1, 3, 2, 4, 5, 7, 6, 8, 9, 10, 12, 11]);
        assert_eq!(out, (1..=12).collect::<Vec<_>>());
        assert_eq!(counts, ReorderCounts::default());
    }

    /// A frame the window's length late still takes its place; one later is dropped as late.
    #[test]
    fn a_frame_later_than_the_window_is_dropped_and_counted() {
        let w = REORDER_WINDOW as u64;
        // Frame 1 after 2..=w+1: w frames late, in time.
        let mut in_time: Vec<u64> = (2..=w + 1).collect();
        in_time.push(1);
        in_time.extend(w + 2..w + 5);
        let (out, counts) = run(&in_time);
        assert_eq!(out, (1..w + 5).collect::<Vec<_>>());
        assert_eq!(counts, ReorderCounts::default());
        // Frame 1 after 2..=w+2: one too late.
        let mut too_late: Vec<u64> = (2..=w + 2).collect();
        too_late.push(1);
        let (out, counts) = run(&too_late);
        assert_eq!(out, (2..=w + 2).collect::<Vec<_>>());
        assert_eq!(counts.late, 1);
    }

    #[test]
    fn duplicates_held_or_handed_on_are_dropped_and_counted() {
        let mut s: Vec<u64> = (1..=20).collect();
        s.insert(5, 5); // held
        s.push(3); // handed on long ago
        let (out, counts) = run(&s);
        assert_eq!(out, (1..=20).collect::<Vec<_>>());
        assert_eq!(counts.duplicates, 2);
        assert_eq!(counts.late, 0);
    }

    /// Lost frames leave their gaps: the reordering neither waits for them nor invents them.
    #[test]
    fn lost_frames_stay_lost() {
        let (out, counts) = run(&[1, 2, 5, 4, 9, 10]);
        assert_eq!(out, [1, 2, 4, 5, 9, 10]);
        assert_eq!(counts, ReorderCounts::default());
    }

    /// A counter that never counts (every frame 0) passes the frames as they came.
    #[test]
    fn a_counter_that_stands_still_is_ignored() {
        let mut r = Reorder::default();
        let mut out = Vec::new();
        for k in 0..20 {
            let f = SensorFrame {
                sequence: 0,
                time_s: k as f64,
                ..SensorFrame::default()
            };
            r.push(f, &mut |f| out.push(f.time_s));
        }
        r.flush(&mut |f| out.push(f.time_s));
        assert_eq!(out, (0..20).map(f64::from).collect::<Vec<_>>());
        assert_eq!(r.counts(), ReorderCounts::default());
    }

    /// A counter that restarts (far back) is not a flood of late frames.
    #[test]
    fn a_restarted_counter_starts_afresh() {
        let mut s: Vec<u64> = (1000..1020).collect();
        s.extend(1..20);
        let (out, counts) = run(&s);
        assert_eq!(out, s);
        assert_eq!(counts, ReorderCounts::default());
    }
}
