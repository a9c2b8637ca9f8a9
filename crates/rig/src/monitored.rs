//! The host's side of the link as a measurement holds it: the rig backend shared with a brake
//! heartbeat, wrapped for the run loop so that the first failure (its cause, kind and instant)
//! and the loop's timing are kept.
//!
//! **Brake heartbeat.** The run procedure has pauses in which it sends nothing while the
//! platform is braked: between the tare and the loaded session (saving the tare, waiting for
//! the operator to put the payload on) and at the end of a measurement (waiting for the log's
//! writer thread to flush). A rig's command watchdog (20 ms) would trip in each. (The
//! controller, whose trajectory check takes about 0.1 s, is built before the session starts,
//! so nothing slow happens between the brake hold and the motion any more.) While the last command was a brake, a
//! background thread repeats it (a safe stop) whenever the loop has been quiet for a quarter
//! of the watchdog time. It never sends anything but a brake, and never while the actuators are
//! driven: a loop that stalls mid-motion still lets the watchdog brake the rig.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use control::io::{Backend, CommandFrame, SensorFrame};
use serde::Serialize;

use crate::{ErrorKind, RigBackend, RigError};

/// The first failure of the link, the rig or its sensors, as the host saw it.
#[derive(Clone, Debug)]
pub struct Failure {
    /// The cause in words (the rig crate's message, naming it).
    pub cause: String,
    /// Its class.
    pub kind: ErrorKind,
    /// When the host noticed.
    pub at: Instant,
    /// Time from the last valid sensor frame to noticing, s (`None` before the first frame).
    pub after_last_frame_s: Option<f64>,
    /// A stall: the link went silent or the rig's watchdog tripped, the rig braked and nothing
    /// says the platform or its sensors are at fault, so the run may be repeated in a new
    /// session ([`RigError::is_stall`]).
    pub stall: bool,
}

/// Summary of [`LoopTiming`] against the nominal period `T`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TimingSummary {
    /// Loop periods measured.
    pub periods: u64,
    /// Nominal sample period T, s.
    pub nominal_period_s: f64,
    /// Median loop period, s.
    pub median_period_s: f64,
    /// Median of |period − T|, s.
    pub jitter_median_s: f64,
    /// 99th percentile of |period − T|, s.
    pub jitter_p99_s: f64,
    /// Largest |period − T|, s.
    pub jitter_max_s: f64,
    /// Median time from receiving a frame to sending its command, s.
    pub work_median_s: f64,
    /// 99th percentile of that time, s.
    pub work_p99_s: f64,
}

/// The host loop's timing over a measurement: the wall-clock time between successive sensor
/// frames handed to the loop (the loop period), and the time from a frame's arrival to its
/// command going out (the work of one tick).
#[derive(Clone, Debug, Default)]
pub struct LoopTiming {
    periods_s: Vec<f64>,
    work_s: Vec<f64>,
}

/// The `p`-quantile (0..=1) of sorted values by the nearest rank; 0 when empty.
fn quantile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

fn sorted(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v
}

impl LoopTiming {
    /// Summary against the nominal period `nominal_period_s`.
    pub fn summary(&self, nominal_period_s: f64) -> TimingSummary {
        let periods = sorted(self.periods_s.iter().copied());
        let jitter = sorted(self.periods_s.iter().map(|p| (p - nominal_period_s).abs()));
        let work = sorted(self.work_s.iter().copied());
        TimingSummary {
            periods: periods.len() as u64,
            nominal_period_s,
            median_period_s: quantile(&periods, 0.5),
            jitter_median_s: quantile(&jitter, 0.5),
            jitter_p99_s: quantile(&jitter, 0.99),
            jitter_max_s: jitter.last().copied().unwrap_or(0.0),
            work_median_s: quantile(&work, 0.5),
            work_p99_s: quantile(&work, 0.99),
        }
    }
}

/// The rig backend and what the heartbeat needs to know about the last command.
pub struct Held {
    /// The backend.
    pub rig: RigBackend,
    braked: bool,
    last_command_at: Instant,
    heartbeats: u64,
}

impl Held {
    /// Sends a command through the backend, noting whether it brakes.
    pub fn write(&mut self, command: &CommandFrame) -> Result<(), RigError> {
        self.braked = !command.enable;
        self.last_command_at = Instant::now();
        self.rig.write(command)
    }

    /// Sends a safe stop (brakes) and returns it.
    pub fn safe_stop(&mut self) -> Result<crate::wire::Command, RigError> {
        self.braked = true;
        self.last_command_at = Instant::now();
        self.rig.safe_stop()
    }

    /// Safe stops the heartbeat sent so far.
    pub fn heartbeats(&self) -> u64 {
        self.heartbeats
    }
}

/// The rig backend shared between the run loop and the brake heartbeat thread.
pub struct Link {
    held: Arc<Mutex<Held>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Link {
    /// Takes over `rig` (just connected: braked) and starts the heartbeat at a quarter of the
    /// rig's watchdog time (at least 1 ms), at the calling (loop's) thread's real-time
    /// priority: the loop waits on the lock the heartbeat takes, so a heartbeat preempted
    /// while it holds it would stall the loop.
    pub fn start(rig: RigBackend) -> Self {
        let priority = crate::realtime::fifo_priority();
        let interval = (rig.info().watchdog / 4).max(Duration::from_millis(1));
        let held = Arc::new(Mutex::new(Held {
            rig,
            braked: true,
            last_command_at: Instant::now(),
            heartbeats: 0,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let held = Arc::clone(&held);
            let stop = Arc::clone(&stop);
            std::thread::Builder::new()
                .name("rig-heartbeat".into())
                .spawn(move || {
                    crate::realtime::follow(priority);
                    heartbeat(&held, &stop, interval)
                })
                .ok()
        };
        Self { held, stop, thread }
    }

    /// The backend, exclusively (the heartbeat waits).
    pub fn lock(&self) -> MutexGuard<'_, Held> {
        self.held.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stops the heartbeat, sends the closing safe stop, and returns the rig's description and
    /// the counters of the whole link: every command sent, heartbeats and the closing stop
    /// included, so that they can be compared with what the rig counted.
    pub fn close(mut self) -> (crate::host::RigInfo, crate::LinkStats) {
        self.stop_heartbeat();
        let mut held = self.lock();
        let stats = held.rig.close();
        (held.rig.info().clone(), stats)
    }

    fn stop_heartbeat(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        self.stop_heartbeat();
    }
}

fn heartbeat(held: &Mutex<Held>, stop: &AtomicBool, interval: Duration) {
    while !stop.load(Ordering::SeqCst) {
        std::thread::sleep(interval);
        let mut h = held.lock().unwrap_or_else(|e| e.into_inner());
        if h.braked && h.last_command_at.elapsed() >= interval {
            // A failed send is the link failing, which the loop's next read reports.
            let _ = h.safe_stop();
            h.heartbeats += 1;
        }
    }
}

/// Why the rig went without a command for longer than its watchdog, from the host's own
/// evidence: each gap between two commands is split into the time the loop spent waiting for
/// the rig's frame (the rig's or the link's share) and the rest (the host's own: computing,
/// or descheduled).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lateness {
    /// Gaps whose host's own share was longer than the watchdog: the host was late.
    pub times: u64,
    /// The longest host's own share of a gap, s.
    pub longest_s: f64,
    /// Gaps longer than the watchdog spent waiting for the rig's frame: the rig or the link
    /// paused, not the host.
    pub rig_waits: u64,
    /// The longest wait for a frame inside such a gap, s.
    pub longest_wait_s: f64,
    /// The loop's `SCHED_FIFO` priority, `None` at normal priority.
    pub fifo_priority: Option<i32>,
}

impl Lateness {
    /// Counts a gap of `gap` between two commands, `waited` of it inside the read of the
    /// rig's frame.
    pub fn add(&mut self, gap: Duration, waited: Duration, watchdog: Duration) {
        let own = gap.saturating_sub(waited);
        self.longest_s = self.longest_s.max(own.as_secs_f64());
        if own > watchdog {
            self.times += 1;
        } else if gap > watchdog {
            self.rig_waits += 1;
            self.longest_wait_s = self.longest_wait_s.max(waited.as_secs_f64());
        }
    }

    /// What a WATCHDOG fault means given this evidence, with the fix that fits.
    pub fn explain(&self, watchdog: Duration) -> String {
        let watchdog_ms = watchdog.as_secs_f64() * 1e3;
        let own_ms = self.longest_s * 1e3;
        if self.times > 0 {
            let (why, fix) = match self.fifo_priority {
                Some(p) => (
                    format!(
                        "although it ran at SCHED_FIFO priority {p}: a task at equal or higher \
                            real-time priority, or the kernel, held the CPU"
                    ),
                    format!(
                        "find it (`ps -eLo rtprio,pid,comm | sort -n | tail`) or raise the \
                            loop's priority above it (`chrt -f {}`)",
                        p + 10
                    ),
                ),
                None => (
                    "at normal priority: the operating system ran something else".to_string(),
                    format!(
                        "run it with real-time priority (CAP_SYS_NICE, `ulimit -r {p}`, or \
                            `chrt -f {p}`) or on a quieter machine",
                        p = crate::realtime::FIFO_PRIORITY
                    ),
                ),
            };
            return format!(
                "this host was late: it sent no command for longer than the rig's \
                    {watchdog_ms:.0} ms watchdog, {} time(s); the longest {own_ms:.1} ms of its own \
                    time, not waiting for the rig ({why}); {fix}",
                self.times
            );
        }
        if self.rig_waits > 0 {
            return format!(
                "this host answered every frame in time (its longest own time {own_ms:.1} ms); \
                    the rig's frames stopped or came late, {} time(s) past the {watchdog_ms:.0} ms \
                    watchdog (the longest wait {:.1} ms): the rig, the emulator or the link paused, \
                    not this host",
                self.rig_waits,
                self.longest_wait_s * 1e3
            );
        }
        format!(
            "this host sent its commands in time (its longest own time {own_ms:.1} ms, watchdog \
                {watchdog_ms:.0} ms): they were lost or delayed on the link"
        )
    }
}

/// The rig backend as the run loop sees it, keeping the first failure and the loop timing.
///
/// **Stopping at once.** With [`abort`](Self::abort) set (a second Ctrl-C), the next read
/// sends a safe stop and fails with [`RigError::Stopped`], and every write sends a safe stop
/// instead of its command: the run ends within one sample period with the rig braked, and its
/// caller still finishes the log.
pub struct Monitored<'a> {
    link: &'a Link,
    timing: &'a mut LoopTiming,
    abort: Option<&'a AtomicBool>,
    failure: Option<Failure>,
    last_frame_at: Option<Instant>,
    last_write_at: Option<Instant>,
    watchdog: Duration,
    late: Lateness,
    last_time_s: Option<f64>,
    /// When the read under way started (the loop waiting for the rig's frame).
    reading_since: Option<Instant>,
    /// How long the last read waited for its frame.
    read_wait: Duration,
}

impl<'a> Monitored<'a> {
    /// Wraps `link` for one measurement; timing goes to `timing`.
    pub fn new(link: &'a Link, timing: &'a mut LoopTiming) -> Self {
        Self {
            link,
            timing,
            abort: None,
            failure: None,
            last_frame_at: None,
            last_write_at: None,
            watchdog: link.lock().rig.info().watchdog,
            late: Lateness {
                // Asked on the loop's thread: the priority the loop runs at.
                fifo_priority: crate::realtime::fifo_priority(),
                ..Lateness::default()
            },
            last_time_s: None,
            reading_since: None,
            read_wait: Duration::ZERO,
        }
    }

    /// Stops at once, brakes on, when `abort` is set (see the type's documentation).
    pub fn abort(mut self, abort: &'a AtomicBool) -> Self {
        self.abort = Some(abort);
        self
    }

    fn aborted(&self) -> bool {
        self.abort.is_some_and(|a| a.load(Ordering::SeqCst))
    }

    /// The first failure, if any.
    pub fn failure(&self) -> Option<&Failure> {
        self.failure.as_ref()
    }

    /// Rig time of the last frame handed to the loop, s.
    pub fn last_time_s(&self) -> Option<f64> {
        self.last_time_s
    }

    /// Times this loop left the rig without a command for longer than its watchdog.
    pub fn lateness(&self) -> Lateness {
        self.late
    }

    fn note(&mut self, error: &RigError) {
        if self.failure.is_none() {
            let at = Instant::now();
            let mut cause = error.to_string();
            if let RigError::RigFault { code, .. } = error {
                if *code == crate::wire::FaultCode::WATCHDOG {
                    // The gap still open (no command since) counts too: it may be the one
                    // that tripped the watchdog.
                    let mut late = self.late;
                    if let Some(last) = self.last_write_at {
                        let waited = self.reading_since.map_or(Duration::ZERO, |r| at - r);
                        late.add(at - last, waited, self.watchdog);
                    }
                    cause = format!("{cause}; {}", late.explain(self.watchdog));
                }
            }
            self.failure = Some(Failure {
                cause,
                kind: error.kind(),
                stall: error.is_stall(),
                at,
                after_last_frame_s: self.last_frame_at.map(|t| (at - t).as_secs_f64()),
            });
        }
    }
}

impl Backend for Monitored<'_> {
    type Error = RigError;

    fn read(&mut self) -> Result<SensorFrame, RigError> {
        if self.aborted() {
            let error = RigError::Stopped {
                reason: "second Ctrl-C".into(),
            };
            self.note(&error);
            // Best effort: a link that failed too is braked by the rig's watchdog.
            let _ = self.link.lock().safe_stop();
            return Err(error);
        }
        let started = Instant::now();
        self.reading_since = Some(started);
        let result = self.link.lock().rig.read();
        match result {
            Ok(frame) => {
                let now = Instant::now();
                self.reading_since = None;
                self.read_wait = now - started;
                if let Some(previous) = self.last_frame_at {
                    self.timing.periods_s.push((now - previous).as_secs_f64());
                }
                self.last_frame_at = Some(now);
                self.last_time_s = Some(frame.time_s);
                Ok(frame)
            }
            Err(e) => {
                self.note(&e);
                // The safe stop that follows a failed read answers this wait, not the host.
                self.reading_since = None;
                self.read_wait = started.elapsed();
                Err(e)
            }
        }
    }

    fn write(&mut self, command: &CommandFrame) -> Result<(), RigError> {
        if let Some(at) = self.last_frame_at {
            self.timing.work_s.push(at.elapsed().as_secs_f64());
        }
        let now = Instant::now();
        if let Some(last) = self.last_write_at.replace(now) {
            self.late.add(now - last, self.read_wait, self.watchdog);
        }
        let result = if self.aborted() {
            self.link.lock().safe_stop().map(|_| ())
        } else {
            self.link.lock().write(command)
        };
        result.inspect_err(|e| self.note(e))
    }

    fn sample_period_s(&self) -> f64 {
        self.link.lock().rig.sample_period_s()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rig that holds still: enough for the link's timing.
    struct Still {
        sequence: u64,
    }

    impl Backend for Still {
        type Error = String;
        fn read(&mut self) -> Result<SensorFrame, String> {
            Ok(SensorFrame {
                sequence: self.sequence,
                time_s: self.sequence as f64 * 1e-3,
                leg_lengths_m: [0.55; 6],
                accel_m_s2: [0.0, 0.0, 9.80665],
                ..SensorFrame::default()
            })
        }
        fn write(&mut self, _: &CommandFrame) -> Result<(), String> {
            self.sequence += 1;
            Ok(())
        }
        fn sample_period_s(&self) -> f64 {
            1e-3
        }
    }

    #[test]
    fn the_heartbeat_keeps_a_braked_rig_quiet_and_a_driven_one_watched() {
        use crate::emulator::{Emulator, EmulatorConfig};
        use crate::wire::Limits;
        let limits = Limits {
            stroke_min_m: 0.4,
            stroke_max_m: 0.7,
            speed_max_m_s: 0.5,
            force_min_n: -500.0,
            force_max_n: 500.0,
        };
        // A 100 ms watchdog: long enough that a busy machine does not trip it by itself.
        let config = EmulatorConfig {
            watchdog: Duration::from_millis(100),
            seed: 3,
            ..EmulatorConfig::new(limits)
        };
        let mut emulator =
            Emulator::bind("udp://127.0.0.1:0", Still { sequence: 0 }, config).unwrap();
        let address = format!("udp://{}", emulator.local_addr().unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::spawn(move || {
            emulator.run(&flag).unwrap();
            emulator
        });
        let options = crate::RigOptions {
            link_silence: Duration::from_secs(1),
            ..crate::RigOptions::default()
        };
        let link = Link::start(RigBackend::connect(&address, options).unwrap());
        let frame = link.lock().rig.read().unwrap();
        link.lock()
            .write(&CommandFrame::safe_stop(1, frame.sequence))
            .unwrap();
        // Braked and quiet for five watchdog times: the heartbeat keeps the session.
        std::thread::sleep(Duration::from_millis(500));
        let heartbeats = link.lock().heartbeats();
        // Driven and quiet: nothing but the rig's watchdog may act.
        link.lock()
            .write(&CommandFrame {
                sequence: 2,
                sensor_sequence: frame.sequence,
                leg_forces_n: [1.0; 6],
                enable: true,
            })
            .unwrap();
        std::thread::sleep(Duration::from_millis(400));
        let after_driving = link.lock().heartbeats();
        drop(link);
        stop.store(true, Ordering::SeqCst);
        let emulator = thread.join().unwrap();
        assert!(heartbeats >= 5, "{heartbeats} heartbeats");
        assert_eq!(after_driving, heartbeats, "no heartbeat while driven");
        let faults = emulator.faults();
        assert_eq!(faults.len(), 1, "{faults:?}");
        assert_eq!(faults[0].code, crate::wire::FaultCode::WATCHDOG);
        // It tripped after the driven command (wire sequence 1 the brake, then one per
        // heartbeat, then the driven one), not while braked.
        assert_eq!(faults[0].command_sequence, 2 + heartbeats);
    }

    /// When the rig's watchdog trips because this host was late (a loaded host
    /// at normal priority), the fault says so, by how much, and the fix, not only "rig fault:
    /// WATCHDOG".
    #[test]
    fn a_watchdog_fault_after_a_late_host_names_the_lateness_and_the_fix() {
        use crate::emulator::{Emulator, EmulatorConfig};
        let config = EmulatorConfig {
            watchdog: Duration::from_millis(100),
            seed: 5,
            ..EmulatorConfig::new(crate::loopback_tests::limits())
        };
        let mut emulator =
            Emulator::bind("udp://127.0.0.1:0", Still { sequence: 0 }, config).unwrap();
        let address = format!("udp://{}", emulator.local_addr().unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::spawn(move || emulator.run(&flag).unwrap());
        let options = crate::RigOptions {
            link_silence: Duration::from_secs(2),
            ..crate::RigOptions::default()
        };
        let link = Link::start(RigBackend::connect(&address, options).unwrap());
        let mut timing = LoopTiming::default();
        let mut monitored = Monitored::new(&link, &mut timing);
        let driven = |sequence| CommandFrame {
            sequence,
            sensor_sequence: 0,
            leg_forces_n: [1.0; 6],
            enable: true,
        };
        monitored.read().unwrap();
        monitored.write(&driven(1)).unwrap();
        // The host is descheduled for three watchdog times.
        std::thread::sleep(Duration::from_millis(300));
        let mut result = Ok(());
        for sequence in 2..200 {
            result = monitored.read().map(|_| ());
            if result.is_err() {
                break;
            }
            let _ = monitored.write(&driven(sequence));
        }
        assert!(result.is_err(), "the rig's watchdog tripped");
        let cause = monitored.failure().unwrap().cause.clone();
        drop(monitored);
        drop(link);
        stop.store(true, Ordering::SeqCst);
        thread.join().unwrap();
        assert!(cause.contains("watchdog expired"), "{cause}");
        assert!(cause.contains("this host was late"), "{cause}");
        assert!(cause.contains("watchdog, 1 time(s)"), "{cause}");
        assert!(cause.contains("chrt -f"), "{cause}");
    }

    /// Every link fault said "this host was late… a busy machine at normal priority", also when
    /// the emulator had stopped (the host waiting for its frames) and when the host ran at
    /// SCHED_FIFO: the gap's share spent waiting for the rig is the rig's, and the priority
    /// the loop ran at picks the fix.
    #[test]
    fn lateness_blames_whoever_held_the_gap_and_names_the_loops_priority() {
        let ms = Duration::from_millis;
        let watchdog = ms(20);
        let mut waiting = Lateness::default();
        waiting.add(ms(31), ms(30), watchdog);
        assert_eq!((waiting.times, waiting.rig_waits), (0, 1));
        let said = waiting.explain(watchdog);
        assert!(
            said.contains("the rig's frames stopped or came late"),
            "{said}"
        );
        assert!(!said.contains("this host was late"), "{said}");

        let mut normal = Lateness::default();
        normal.add(ms(31), ms(1), watchdog);
        assert_eq!(normal.times, 1);
        let said = normal.explain(watchdog);
        assert!(said.contains("this host was late"), "{said}");
        assert!(said.contains("at normal priority"), "{said}");
        assert!(said.contains("chrt -f 20"), "{said}");

        let mut fifo = Lateness {
            fifo_priority: Some(20),
            ..Lateness::default()
        };
        fifo.add(ms(31), ms(1), watchdog);
        let said = fifo.explain(watchdog);
        assert!(
            said.contains("although it ran at SCHED_FIFO priority 20"),
            "{said}"
        );
        assert!(!said.contains("normal priority"), "{said}");
        assert!(said.contains("chrt -f 30"), "{said}");

        let on_time = Lateness::default();
        assert!(on_time
            .explain(watchdog)
            .contains("lost or delayed on the link"));
        for said in [waiting, normal, fifo, on_time].map(|l| l.explain(watchdog)) {
            assert!(!said.contains("  "), "a run of spaces: {said}");
        }
    }

    #[test]
    fn quantiles_by_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(quantile(&v, 0.5), 50.0);
        assert_eq!(quantile(&v, 0.99), 99.0);
        assert_eq!(quantile(&v, 1.0), 100.0);
        assert_eq!(quantile(&[], 0.5), 0.0);
        assert_eq!(quantile(&[3.0], 0.99), 3.0);
    }

    #[test]
    fn timing_summary_measures_jitter_about_the_nominal_period() {
        let timing = LoopTiming {
            periods_s: vec![0.001, 0.0011, 0.0009, 0.001, 0.003],
            work_s: vec![1e-5, 2e-5],
        };
        let s = timing.summary(0.001);
        assert_eq!(s.periods, 5);
        assert!((s.median_period_s - 0.001).abs() < 1e-12);
        assert!((s.jitter_median_s - 1e-4).abs() < 1e-9);
        assert!((s.jitter_max_s - 0.002).abs() < 1e-12);
        assert!((s.jitter_p99_s - 0.002).abs() < 1e-12);
        assert!((s.work_median_s - 1e-5).abs() < 1e-12);
    }
}
