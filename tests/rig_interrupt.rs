//! Ctrl-C during a rig run: the platform parks (the controller's park ramp, then the brakes),
//! the log is finished, the exit code is 130, and no tare is saved.

use crate::support;

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use measure::End;
use support::*;

/// `rig tare` against `address`, logging to `log`, saving to `out`.
fn tare_args(
    scratch: &Scratch,
    address: &str,
    log: &std::path::Path,
    out: &std::path::Path,
) -> RigRun {
    rig_against(
        &scratch.config,
        address,
        log,
        ops::rig::RigPlan::TareOnly(out.to_path_buf()),
    )
}

/// A UDP relay between the host and the emulator that counts the datagrams the rig sends the
/// host: with the emulator in lockstep one sensor frame a sample, so the count says how far the
/// run has come, whatever the machine's load.
struct Relay {
    /// The address the host connects to.
    address: String,
    frames: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Relay {
    fn new(rig: &str) -> Self {
        let rig: SocketAddr = rig.trim_start_matches("udp://").parse().unwrap();
        let front = UdpSocket::bind("127.0.0.1:0").unwrap();
        let back = UdpSocket::bind("127.0.0.1:0").unwrap();
        back.connect(rig).unwrap();
        for s in [&front, &back] {
            s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
        }
        let address = format!("udp://{}", front.local_addr().unwrap());
        let frames = Arc::new(AtomicU64::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let host: Arc<Mutex<Option<SocketAddr>>> = Arc::default();
        let (front2, back2) = (front.try_clone().unwrap(), back.try_clone().unwrap());
        let to_rig = std::thread::spawn({
            let (stop, host) = (Arc::clone(&stop), Arc::clone(&host));
            move || {
                let mut buf = [0u8; 2048];
                while !stop.load(Ordering::SeqCst) {
                    if let Ok((n, from)) = front.recv_from(&mut buf) {
                        *host.lock().unwrap() = Some(from);
                        let _ = back.send(&buf[..n]);
                    }
                }
            }
        });
        let to_host = std::thread::spawn({
            let (stop, frames) = (Arc::clone(&stop), Arc::clone(&frames));
            move || {
                let mut buf = [0u8; 2048];
                while !stop.load(Ordering::SeqCst) {
                    if let Ok(n) = back2.recv(&mut buf) {
                        if let Some(to) = *host.lock().unwrap() {
                            frames.fetch_add(1, Ordering::SeqCst);
                            let _ = front2.send_to(&buf[..n], to);
                        }
                    }
                }
            }
        });
        Self {
            address,
            frames,
            stop,
            threads: vec![to_rig, to_host],
        }
    }

    /// Datagrams relayed from the rig to the host so far.
    fn frames(&self) -> u64 {
        self.frames.load(Ordering::SeqCst)
    }

    /// Waits (at most 30 s) until `count` datagrams have gone from the rig to the host.
    fn wait_for_frames(&self, count: u64) {
        let deadline = Instant::now() + Duration::from_secs(30);
        while self.frames() < count {
            assert!(
                Instant::now() < deadline,
                "{} of {count} frames",
                self.frames()
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Sensor frames (500 Hz) from the session's start to 1 s into the excitation: brake hold
/// 0.5 s, ramp home 1 s, settle 0.5 s, then 1 s of the 4 s excitation.
const INTO_THE_EXCITATION: u64 = 500 * 3;

/// The phase the log's `/supervisor` messages were in when the Ctrl-C came: the last one other
/// than `park` up to the first message that saw it.
fn phase_interrupted(messages: &[(String, serde_json::Value)]) -> String {
    let supervisor = on(messages, "/supervisor");
    let first = supervisor
        .iter()
        .position(|m| m["interrupted"] == true)
        .expect("the interrupt is logged");
    let phases: Vec<&str> = supervisor[..=first]
        .iter()
        .map(|m| m["phase"].as_str().unwrap())
        .collect();
    phases
        .iter()
        .rev()
        .find(|p| **p != "park")
        .unwrap_or_else(|| panic!("{phases:?}"))
        .to_string()
}

#[test]
fn ctrl_c_parks_the_platform_and_finishes_the_log() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let relay = Relay::new(emulator.address());
    let log = scratch.path("rig.mcap");
    let out = scratch.path("tare.json");
    let args = tare_args(&scratch, &relay.address, &log, &out);
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    let host = std::thread::spawn({
        let args = args.clone();
        move || support::run_rig_with(&args, &INTERRUPT, &AtomicBool::new(false))
    });
    // Into the excitation, then Ctrl-C.
    relay.wait_for_frames(INTO_THE_EXCITATION);
    INTERRUPT.store(true, Ordering::SeqCst);
    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();

    assert_eq!(outcome.end, End::Interrupted);
    assert_eq!(outcome.exit_code(), ops::exit::INTERRUPTED);
    assert!(!out.exists(), "an interrupted tare is not saved");
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    // Parked: the last command brakes.
    assert!(!stopped.last_command().expect("commanded").enable);

    let messages = read_log(&log);
    let phases: Vec<&str> = on(&messages, "/supervisor")
        .iter()
        .map(|m| m["phase"].as_str().unwrap())
        .collect();
    assert!(phases.contains(&"park"), "{phases:?}");
    assert_eq!(phases.last(), Some(&"done"), "{phases:?}");
    // The Ctrl-C came in the excitation, and the park followed it.
    assert_eq!(phase_interrupted(&messages), "excite");
}

/// A second Ctrl-C brakes at once (no park ramp): the last command on the wire
/// is a safe stop, not `enable 1` with ~780 N per leg left to the rig's watchdog; the log is
/// finished and the run ends as interrupted.
#[test]
fn a_second_ctrl_c_brakes_at_once_and_finishes_the_log() {
    let _lock = real_time();
    // A long park, so that a run that still parks after the second Ctrl-C shows.
    let scratch = Scratch::new(&quick().replace("park_s = 1.0", "park_s = 4.0"));
    let emulator = start(&emulate_args(&scratch));
    let relay = Relay::new(emulator.address());
    let log = scratch.path("rig.mcap");
    let out = scratch.path("tare.json");
    let args = tare_args(&scratch, &relay.address, &log, &out);
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    static ABORT: AtomicBool = AtomicBool::new(false);
    let host = std::thread::spawn({
        let args = args.clone();
        move || support::run_rig_with(&args, &INTERRUPT, &ABORT)
    });
    relay.wait_for_frames(INTO_THE_EXCITATION);
    INTERRUPT.store(true, Ordering::SeqCst);
    // Mid-park (0.3 s of frames into the 4 s park): the second Ctrl-C.
    relay.wait_for_frames(INTO_THE_EXCITATION + 150);
    ABORT.store(true, Ordering::SeqCst);
    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();

    assert_eq!(outcome.end, End::Interrupted);
    assert_eq!(outcome.exit_code(), ops::exit::INTERRUPTED);
    assert!(!out.exists(), "an interrupted tare is not saved");
    // The rig's watchdog had nothing to do: the host braked it.
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    let last = stopped.last_command().expect("commanded");
    assert!(!last.enable, "{last:?}");
    assert_eq!(last.leg_forces_n, [0.0; 6]);
    // The log is finished (read_log checks its summary) and says why it ended.
    let messages = read_log(&log);
    // The 4 s park was not run out: on the log's clock the run ended within 3 s of the park's
    // start, the Ctrl-C having come in the excitation.
    assert_eq!(phase_interrupted(&messages), "excite");
    let supervisor = on(&messages, "/supervisor");
    let time = |m: &serde_json::Value| m["time_s"].as_f64().unwrap();
    let park = supervisor
        .iter()
        .find(|m| m["phase"] == "park")
        .map(|m| time(m))
        .expect("a park");
    let end = supervisor.last().map(|m| time(m)).unwrap();
    assert!(end - park < 3.0, "park at {park} s, end at {end} s");
    let ends: Vec<_> = on(&messages, "/rig/link")
        .into_iter()
        .filter(|m| m["event"] == "end")
        .collect();
    assert_eq!(ends.len(), 1, "{ends:?}");
    assert!(
        ends[0]["fault"]
            .as_str()
            .is_some_and(|f| f.contains("second Ctrl-C")),
        "{:?}",
        ends[0]
    );
}

/// `stewart rig tare` as a process of its own against the rig at `address` (keyed by the
/// scenario, at normal priority, no operator), logging to `log`, saving to `out`.
fn rig_process(
    scratch: &Scratch,
    address: &str,
    log: &std::path::Path,
    out: &std::path::Path,
) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(["rig", "tare", "--out"])
        .arg(out)
        .arg("--config")
        .arg(&scratch.config)
        .args(["--connect", address, "--log"])
        .arg(log)
        .args(["--no-prompt", "--quiet", "--no-realtime"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("stewart runs")
}

/// Waits (at most 30 s) for `child` to exit; its exit status and standard error.
fn exited(mut child: std::process::Child) -> (std::process::ExitStatus, String) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            if let Some(mut e) = child.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut e, &mut stderr);
            }
            return (status, stderr);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("stewart rig did not exit after the signal");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sends `signal` to the process `child`.
fn send(child: &std::process::Child, signal: i32) {
    // SAFETY: kill(2) with a live child's pid and a valid signal number.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    assert_eq!(rc, 0, "kill: {}", std::io::Error::last_os_error());
}

/// SIGTERM, SIGHUP and SIGQUIT end `stewart rig` as Ctrl-C does (a service manager, a closed
/// terminal and Ctrl-\ killed it with the legs enabled at 1.4-5.9 kN and the log without its
/// footer): parked, the last command on the wire brakes, the log reads to its summary, exit
/// 130, no tare saved.
#[test]
fn sigterm_sighup_and_sigquit_park_the_platform_and_finish_the_log() {
    let _lock = real_time();
    for (signal, name) in [
        (libc::SIGTERM, "SIGTERM"),
        (libc::SIGHUP, "SIGHUP"),
        (libc::SIGQUIT, "SIGQUIT"),
    ] {
        let scratch = Scratch::new(&quick());
        let emulator = start(&emulate_args(&scratch));
        let relay = Relay::new(emulator.address());
        let (log, out) = (scratch.path("rig.mcap"), scratch.path("tare.json"));
        let child = rig_process(&scratch, &relay.address, &log, &out);
        relay.wait_for_frames(INTO_THE_EXCITATION);
        send(&child, signal);
        let (status, stderr) = exited(child);
        let stopped = emulator.stop().unwrap();

        assert_eq!(
            status.code(),
            Some(i32::from(ops::exit::INTERRUPTED)),
            "{name}: {status:?}\n{stderr}"
        );
        assert!(stderr.contains(&format!("{name}: parking")), "{stderr}");
        assert!(!out.exists(), "{name}: an interrupted tare is not saved");
        assert!(
            stopped.faults().is_empty(),
            "{name}: {:?}",
            stopped.faults()
        );
        let last = stopped.last_command().expect("commanded");
        assert!(!last.enable, "{name}: {last:?}");
        assert!(
            !last_logged_enable(&log),
            "{name}: the log's last command enables the legs"
        );
        // The log is finished (read_log reads its summary) and the park followed the signal.
        let messages = read_log(&log);
        let phases: Vec<&str> = on(&messages, "/supervisor")
            .iter()
            .map(|m| m["phase"].as_str().unwrap())
            .collect();
        assert!(phases.contains(&"park"), "{name}: {phases:?}");
        assert_eq!(phases.last(), Some(&"done"), "{name}: {phases:?}");
    }
}

/// Two SIGTERMs brake at once, as two Ctrl-Cs do: the last command is a safe stop with zero
/// force, the log is finished, exit 130.
#[test]
fn a_second_sigterm_brakes_at_once_and_finishes_the_log() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick().replace("park_s = 1.0", "park_s = 4.0"));
    let emulator = start(&emulate_args(&scratch));
    let relay = Relay::new(emulator.address());
    let (log, out) = (scratch.path("rig.mcap"), scratch.path("tare.json"));
    let child = rig_process(&scratch, &relay.address, &log, &out);
    relay.wait_for_frames(INTO_THE_EXCITATION);
    send(&child, libc::SIGTERM);
    relay.wait_for_frames(INTO_THE_EXCITATION + 150);
    send(&child, libc::SIGTERM);
    let (status, stderr) = exited(child);
    let stopped = emulator.stop().unwrap();
    assert_eq!(
        status.code(),
        Some(i32::from(ops::exit::INTERRUPTED)),
        "{stderr}"
    );
    assert!(stderr.contains("SIGTERM: braking now"), "{stderr}");
    // And says what it did: braked where it stood (it said "parked and braked").
    assert!(
        stderr.contains("braked at once, without parking"),
        "{stderr}"
    );
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    let last = stopped.last_command().expect("commanded");
    assert!(!last.enable, "{last:?}");
    assert_eq!(last.leg_forces_n, [0.0; 6]);
    assert!(
        !last_logged_enable(&log),
        "the log's last command enables the legs"
    );
}

/// Watches the run and panics at its `at`-th tick: a bug in any code the loop calls.
struct PanicsAt {
    at: u64,
    ticks: u64,
}

impl measure::Observer for PanicsAt {
    fn tick(&mut self, _: &measure::TickEvent<'_>) -> anyhow::Result<()> {
        self.ticks += 1;
        assert!(self.ticks < self.at, "a bug at tick {}", self.ticks);
        Ok(())
    }
}

impl ops::measurement::Operator for PanicsAt {}

/// A panic in the middle of a rig run unwinds through the link, which brakes the rig as it is
/// dropped (the last command the rig holds is a safe stop, its watchdog had nothing to do),
/// and through the log, whose writer finishes the file (it reads to its summary).
#[test]
fn a_panic_mid_run_brakes_the_rig_and_finishes_the_log() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let log = scratch.path("rig.mcap");
    let run = rig_tare(&scratch, emulator.address());
    let mut operator = PanicsAt {
        at: INTO_THE_EXCITATION,
        ticks: 0,
    };
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_rig_as(&run, &mut operator)
    }));
    let stopped = emulator.stop().unwrap();
    assert!(result.is_err(), "the run panicked");
    assert!(operator.ticks >= INTO_THE_EXCITATION);
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    let last = stopped.last_command().expect("commanded");
    assert!(!last.enable, "{last:?}");
    assert_eq!(last.leg_forces_n, [0.0; 6]);
    assert!(!read_log(&log).is_empty(), "the log reads to its summary");
}
