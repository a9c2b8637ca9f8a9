//! One measurement's `/sensors` frames put back in sequence order as `estimate` reads them, and
//! what came out of place said by span.
//!
//! A log's frames come in file order, and a file is not always what its writer wrote: a link
//! reorders and repeats datagrams by a few frames (`measure::reorder` handles those in the
//! live loop), and a disk or a copy can move, repeat or lose a whole chunk (about a thousand
//! frames). [`Sequencer`] holds up to [`HOLD_FRAMES`] frames sorted by their counter and hands
//! on the lowest once more are held, so a span that comes up to that many frames late takes
//! its place; a frame whose counter was already held or handed on is dropped as a duplicate;
//! one that comes later still is dropped as late. The order a clean log's frames are handed
//! on in is the order they came in, so a clean log estimates exactly as it is written.
//!
//! A duplicate is an exact copy: the readings of the last [`PRINTS`] counters are
//! remembered by a fingerprint, and a frame that carries a counter already met with other
//! readings is a conflict ([`SequenceCounts::conflicts`]): one measurement's counter gives
//! every frame its own number, so two frames of one number are two runs written into one
//! file.
//!
//! Spans are named ([`measure::report::FrameSpan`]): frames put back in order, dropped as
//! duplicates or as late when they came more than [`measure::reorder::REORDER_WINDOW`]
//! frames out of place (a link's reordering is counted only), and gaps of [`NAMED_GAP_FRAMES`]
//! frames or more that no frame of the log fills (a link loses frames one or a few at a time).
//!
//! A counter that stands still (an import without `sequence`) passes the frames as they came,
//! and one that jumps back by more than [`HOLD_FRAMES`] while the time moves on restarted:
//! ordering starts afresh from it, as `measure::reorder` does.

use std::collections::{BTreeMap, VecDeque};

use control::io::SensorFrame;
use measure::report::FrameSpan;

/// Frames held back: a span may come this many frames late (about sixteen chunks of a 1 kHz
/// log) and still take its place; about 3 MB of frames.
pub const HOLD_FRAMES: usize = 16_384;

/// Counters whose readings are remembered by a fingerprint, to tell a duplicate from a
/// conflicting frame (1 MB).
pub const PRINTS: usize = 1 << 16;

/// Counters handed on that are remembered to tell a duplicate from a late frame (beyond, a
/// frame that comes again is dropped as late): about 17 minutes at 1 kHz.
pub const REMEMBERED: u64 = 1 << 20;

/// A frame more than this many frames out of place has its span named; closer, a link's
/// reordering, it is counted only.
pub const NAMED_DISPLACEMENT: u64 = measure::reorder::REORDER_WINDOW as u64;

/// A gap of this many frames or more is named as missing: a whole `/sensors` message.
pub const NAMED_GAP_FRAMES: u64 = crate::compact::BLOCK_FRAMES as u64;

/// Spans named of each kind; beyond, they are counted ([`SequenceReport::unnamed`]).
pub const MAX_SPANS: usize = 32;

/// What [`FrameSpan::action`] says of frames put back in order.
pub const PUT_BACK: &str = "put back in order";
/// ... of frames dropped because their counter already came with the same readings.
pub const DUPLICATES: &str = "dropped as duplicates";
/// ... of frames that came after later frames had been handed on.
pub const LATE: &str = "dropped as late";
/// ... of a gap no frame fills.
pub const MISSING: &str = "missing";

/// Frames the sequencer moved, dropped or found in conflict.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SequenceCounts {
    /// Came after a frame with a higher counter and took their place.
    pub moved: u64,
    /// Came after later frames had been handed on; dropped.
    pub late: u64,
    /// Carried a counter already met, with the same readings; dropped.
    pub duplicates: u64,
    /// Carried a counter already met, with other readings; dropped.
    pub conflicts: u64,
    /// The first such counter.
    pub first_conflict: Option<u64>,
}

/// What the sequencer did, by span.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SequenceReport {
    /// The counts.
    pub counts: SequenceCounts,
    /// Spans moved, duplicated or late, in the order they came.
    pub reordered: Vec<FrameSpan>,
    /// Gaps, in sequence order.
    pub missing: Vec<FrameSpan>,
    /// Spans beyond [`MAX_SPANS`] of a kind, counted only.
    pub unnamed: u64,
}

/// The counter's verdict so far (as `measure::reorder`'s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Counter {
    #[default]
    Unknown,
    Counting,
    Ignored,
}

/// The sequencer of one measurement; see the [module docs](self).
#[derive(Clone, Debug)]
pub struct Sequencer {
    run: String,
    held: BTreeMap<u64, SensorFrame>,
    /// Counter and time of the last frame handed on.
    last_out: Option<(u64, f64)>,
    /// Counters handed on, as ascending inclusive ranges.
    handed: VecDeque<(u64, u64)>,
    /// (counter, fingerprint) by counter modulo [`PRINTS`].
    prints: Vec<(u64, u64)>,
    counter: Counter,
    last_in: Option<(u64, f64)>,
    /// The highest counter that came, and the latest time.
    max_in: Option<u64>,
    latest_s: f64,
    /// The span being extended (of `reordered`).
    open: Option<FrameSpan>,
    report: SequenceReport,
}

/// A fingerprint of a frame's readings (FNV-1a over their bits).
fn fingerprint(f: &SensorFrame) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut mix = |v: u64| {
        for b in v.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    mix(f.time_s.to_bits());
    for v in f.leg_lengths_m.iter().chain(&f.leg_forces_n) {
        mix(v.to_bits());
    }
    for v in f.gyro_rad_s.iter().chain(&f.accel_m_s2) {
        mix(v.to_bits());
    }
    mix(u64::from(f.status.0));
    h
}

/// What became of a frame that came.
enum Verdict {
    Moved,
    Late,
    Duplicate,
}

impl Sequencer {
    /// The sequencer of measurement `run`.
    pub fn new(run: &str) -> Self {
        Self {
            run: run.to_string(),
            held: BTreeMap::new(),
            last_out: None,
            handed: VecDeque::new(),
            prints: Vec::new(),
            counter: Counter::Unknown,
            last_in: None,
            max_in: None,
            latest_s: f64::NEG_INFINITY,
            open: None,
            report: SequenceReport::default(),
        }
    }

    /// The counts so far.
    pub fn counts(&self) -> SequenceCounts {
        self.report.counts
    }

    /// What was done, once the frames are all in ([`Self::flush`]).
    pub fn report(&self) -> SequenceReport {
        let mut r = self.report.clone();
        if let Some(open) = &self.open {
            Self::name(&mut r.reordered, &mut r.unnamed, open.clone());
        }
        r
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
        let s = frame.sequence;
        let print = fingerprint(&frame);
        if let Some((last, _)) = self.last_out {
            if s <= last && last - s > HOLD_FRAMES as u64 && frame.time_s > self.latest_s {
                // The counter restarted: what is held goes on first, and ordering starts
                // afresh from it.
                self.flush(out);
                self.close_span();
                *self = Self {
                    report: std::mem::take(&mut self.report),
                    counter: self.counter,
                    ..Self::new(&self.run)
                };
            }
        }
        self.latest_s = self.latest_s.max(frame.time_s);
        let displacement = self.max_in.map_or(0, |m| m.saturating_sub(s));
        if let Some(known) = self.seen(s) {
            match known {
                Some(p) if p != print => {
                    let c = &mut self.report.counts;
                    c.conflicts += 1;
                    c.first_conflict.get_or_insert(s);
                }
                _ => {
                    self.report.counts.duplicates += 1;
                    self.note(Verdict::Duplicate, &frame, displacement);
                }
            }
            return;
        }
        if self.last_out.is_some_and(|(last, _)| s <= last) {
            self.report.counts.late += 1;
            self.note(Verdict::Late, &frame, displacement);
            return;
        }
        if displacement > 0 {
            self.report.counts.moved += 1;
            self.note(Verdict::Moved, &frame, displacement);
        }
        self.remember(s, print);
        self.max_in = Some(self.max_in.map_or(s, |m| m.max(s)));
        self.held.insert(s, frame);
        if self.held.len() > HOLD_FRAMES {
            if let Some((_, first)) = self.held.pop_first() {
                self.hand_on(first, out);
            }
        }
    }

    /// Hands on every frame held, in sequence order (the end of the measurement's frames).
    pub fn flush(&mut self, out: &mut impl FnMut(SensorFrame)) {
        while let Some((_, f)) = self.held.pop_first() {
            self.hand_on(f, out);
        }
    }

    /// Whether counter `s` already came: `Some(Some(print))` with its readings' fingerprint,
    /// `Some(None)` when they are no longer remembered, `None` when it did not come.
    fn seen(&self, s: u64) -> Option<Option<u64>> {
        let print = || {
            self.prints
                .get((s % PRINTS as u64) as usize)
                .filter(|(k, _)| *k == s)
                .map(|(_, p)| *p)
        };
        if self.held.contains_key(&s) {
            return Some(print());
        }
        let at = self.handed.partition_point(|(_, end)| *end < s);
        match self.handed.get(at) {
            Some((start, _)) if *start <= s => Some(print()),
            _ => None,
        }
    }

    fn remember(&mut self, s: u64, print: u64) {
        if self.prints.is_empty() {
            self.prints = vec![(u64::MAX, 0); PRINTS];
        }
        self.prints[(s % PRINTS as u64) as usize] = (s, print);
    }

    fn hand_on(&mut self, frame: SensorFrame, out: &mut impl FnMut(SensorFrame)) {
        let s = frame.sequence;
        if let Some((last, time_s)) = self.last_out {
            let gap = s.saturating_sub(last + 1);
            if gap >= NAMED_GAP_FRAMES {
                let span = FrameSpan {
                    run: self.run.clone(),
                    first_sequence: last + 1,
                    last_sequence: s - 1,
                    frames: gap,
                    from_time_s: time_s,
                    to_time_s: frame.time_s,
                    action: MISSING.into(),
                };
                let r = &mut self.report;
                Self::name(&mut r.missing, &mut r.unnamed, span);
            }
        }
        match self.handed.back_mut() {
            Some((_, end)) if *end + 1 == s => *end = s,
            _ => self.handed.push_back((s, s)),
        }
        while self
            .handed
            .front()
            .is_some_and(|(_, end)| end.saturating_add(REMEMBERED) < s)
        {
            self.handed.pop_front();
        }
        self.last_out = Some((s, frame.time_s));
        out(frame);
    }

    /// Counts `frame` into the span being extended (the same verdict, a counter after the
    /// span's last by less than a block: the frames a link lost do not split it), or starts
    /// one when it came far enough out of place to be named: a span named goes on to its last
    /// frame, however close that came.
    fn note(&mut self, verdict: Verdict, frame: &SensorFrame, displacement: u64) {
        let action = match verdict {
            Verdict::Moved => PUT_BACK,
            Verdict::Late => LATE,
            Verdict::Duplicate => DUPLICATES,
        };
        let s = frame.sequence;
        if let Some(open) = &mut self.open {
            let next = open.last_sequence + 1..open.last_sequence + 1 + NAMED_GAP_FRAMES;
            if open.action == action && next.contains(&s) {
                open.last_sequence = s;
                open.frames += 1;
                open.to_time_s = frame.time_s;
                return;
            }
        }
        if displacement <= NAMED_DISPLACEMENT {
            return;
        }
        self.close_span();
        self.open = Some(FrameSpan {
            run: self.run.clone(),
            first_sequence: s,
            last_sequence: s,
            frames: 1,
            from_time_s: frame.time_s,
            to_time_s: frame.time_s,
            action: action.into(),
        });
    }

    fn close_span(&mut self) {
        if let Some(span) = self.open.take() {
            let r = &mut self.report;
            Self::name(&mut r.reordered, &mut r.unnamed, span);
        }
    }

    fn name(spans: &mut Vec<FrameSpan>, unnamed: &mut u64, span: FrameSpan) {
        if spans.len() < MAX_SPANS {
            spans.push(span);
        } else {
            *unnamed += 1;
        }
    }
}

/// The frames of `input` through a [`Sequencer`] of `run`: (frames handed on, report).
pub fn sequenced(
    run: &str,
    input: impl IntoIterator<Item = SensorFrame>,
) -> (Vec<SensorFrame>, SequenceReport) {
    let mut s = Sequencer::new(run);
    let mut out = Vec::new();
    for f in input {
        s.push(f, &mut |f| out.push(f));
    }
    s.flush(&mut |f| out.push(f));
    (out, s.report())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sequence: u64) -> SensorFrame {
        SensorFrame {
            sequence,
            time_s: sequence as f64 * 1e-3,
            leg_forces_n: [sequence as f64; 6],
            ..SensorFrame::default()
        }
    }

    fn run(sequences: impl IntoIterator<Item = u64>) -> (Vec<u64>, SequenceReport) {
        let (out, report) = sequenced("loaded", sequences.into_iter().map(frame));
        (out.iter().map(|f| f.sequence).collect(), report)
    }

    /// In order, the frames pass untouched and nothing is said.
    #[test]
    fn frames_in_order_pass_as_they_came() {
        let (out, report) = run(0..50_000);
        assert_eq!(out, (0..50_000).collect::<Vec<_>>());
        assert_eq!(report, SequenceReport::default());
    }

    /// Two chunks' worth of frames swapped: put back, the moved span named once.
    #[test]
    fn a_span_a_thousand_frames_late_takes_its_place_and_is_named() {
        let input = (0..1000)
            .chain(2000..3000)
            .chain(1000..2000)
            .chain(3000..5000);
        let (out, report) = run(input);
        assert_eq!(out, (0..5000).collect::<Vec<_>>());
        assert_eq!(report.counts.moved, 1000);
        assert_eq!(report.reordered.len(), 1, "{:?}", report.reordered);
        let span = &report.reordered[0];
        assert_eq!((span.first_sequence, span.last_sequence), (1000, 1999));
        assert_eq!(span.action, PUT_BACK);
        assert!(report.missing.is_empty());
    }

    /// A span written twice, and three times: the copies dropped and named as duplicates.
    #[test]
    fn a_span_written_again_is_dropped_as_duplicates() {
        let input = (0..2000)
            .chain(1000..2000)
            .chain(1000..2000)
            .chain(2000..3000);
        let (out, report) = run(input);
        assert_eq!(out, (0..3000).collect::<Vec<_>>());
        assert_eq!(report.counts.duplicates, 2000);
        assert_eq!(report.counts.conflicts, 0);
        assert_eq!(report.reordered.len(), 2, "{:?}", report.reordered);
        for span in &report.reordered {
            assert_eq!(span.action, DUPLICATES);
            assert_eq!((span.first_sequence, span.last_sequence), (1000, 1999));
        }
    }

    /// A link's reordering and repeats by a few frames are counted, not named.
    #[test]
    fn a_links_reordering_is_counted_not_named() {
        let (out, report) = run([1, 3, 2, 4, 4, 5, 7, 6, 8, 5, 9]);
        assert_eq!(out, (1..=9).collect::<Vec<_>>());
        assert_eq!(report.counts.duplicates, 2);
        assert!(report.reordered.is_empty() && report.missing.is_empty());
    }

    /// A gap of a block or more is named with its counters and the times either side; a few
    /// frames lost are not.
    #[test]
    fn a_gap_of_a_block_is_named_as_missing() {
        let (out, report) = run((0..100).chain(103..500).chain(600..700));
        assert_eq!(out.len(), 100 + 397 + 100);
        assert_eq!(report.missing.len(), 1, "{:?}", report.missing);
        let span = &report.missing[0];
        assert_eq!(
            (span.first_sequence, span.last_sequence, span.frames),
            (500, 599, 100)
        );
        assert!((span.from_time_s - 0.499).abs() < 1e-12 && (span.to_time_s - 0.6).abs() < 1e-12);
    }

    /// A frame that carries a counter already met with other readings is a conflict.
    #[test]
    fn one_counter_with_two_readings_is_a_conflict() {
        let mut other = frame(40);
        other.leg_forces_n[0] += 1.0;
        let mut s = Sequencer::new("loaded");
        let mut out = Vec::new();
        for f in (0..100).map(frame).chain([other]) {
            s.push(f, &mut |f| out.push(f));
        }
        s.flush(&mut |f| out.push(f));
        assert_eq!(out.len(), 100);
        assert_eq!(s.counts().conflicts, 1);
        assert_eq!(s.counts().first_conflict, Some(40));
    }

    /// A frame later than the hold is dropped as late and named.
    #[test]
    fn a_frame_later_than_the_hold_is_dropped_as_late() {
        let h = HOLD_FRAMES as u64;
        let input = (0..10).chain(20..h + 40).chain(10..20);
        let (out, report) = run(input);
        assert_eq!(out.len() as u64, h + 30);
        assert_eq!(report.counts.late, 10);
        assert_eq!(report.reordered.len(), 1);
        assert_eq!(report.reordered[0].action, LATE);
    }

    /// A counter that restarts far back while the time goes on starts afresh.
    #[test]
    fn a_restarted_counter_starts_afresh() {
        let mut s = Sequencer::new("loaded");
        let mut out = Vec::new();
        let first = (30_000..50_000).map(frame);
        let restarted = (0..100).map(|k| SensorFrame {
            time_s: 60.0 + k as f64 * 1e-3,
            ..frame(k)
        });
        for f in first.chain(restarted) {
            s.push(f, &mut |f| out.push(f.sequence));
        }
        s.flush(&mut |f| out.push(f.sequence));
        assert_eq!(out.len(), 20_100);
        assert_eq!(s.counts(), SequenceCounts::default());
    }

    /// A counter that stands still passes the frames as they came.
    #[test]
    fn a_counter_that_stands_still_is_ignored() {
        let frames = (0..20).map(|k| SensorFrame {
            sequence: 0,
            time_s: f64::from(k),
            ..SensorFrame::default()
        });
        let (out, report) = sequenced("loaded", frames);
        let times: Vec<f64> = out.iter().map(|f| f.time_s).collect();
        assert_eq!(times, (0..20).map(f64::from).collect::<Vec<_>>());
        assert_eq!(report, SequenceReport::default());
    }
}
