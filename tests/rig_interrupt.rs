//! Ctrl-C during a rig run: the platform parks (the controller's park ramp, then the brakes),
//! the log is finished, the exit code is 130, and no tare is saved.

mod support;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use measure::End;
use support::*;

/// `rig tare` against `address`, logging to `log`, saving to `out`.
fn tare_args(
    scratch: &Scratch,
    address: &str,
    log: &std::path::Path,
    out: &std::path::Path,
) -> stewart_cli::rig::RigArgs {
    rig_against(
        &scratch.config,
        address,
        log,
        &["tare", "--out", out.to_str().unwrap()],
    )
}

/// Waits (at most 10 s) until the host has opened a session with the emulator.
fn wait_for_session(emulator: &ops::emulate::RunningEmulator) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while emulator.sessions().is_empty() {
        assert!(Instant::now() < deadline, "no session");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn ctrl_c_parks_the_platform_and_finishes_the_log() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let log = scratch.path("rig.mcap");
    let out = scratch.path("tare.json");
    let args = tare_args(&scratch, emulator.address(), &log, &out);
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    let host = std::thread::spawn({
        let args = args.clone();
        move || support::run_rig_with(&args, &INTERRUPT, &AtomicBool::new(false))
    });
    wait_for_session(&emulator);
    // Into the excitation (brake hold 0.5 s, ramp 1 s, settle 0.5 s), then Ctrl-C.
    std::thread::sleep(Duration::from_millis(3000));
    INTERRUPT.store(true, Ordering::SeqCst);
    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let stopped = emulator.stop().unwrap();

    assert_eq!(outcome.end, End::Interrupted);
    assert_eq!(
        stewart_cli::rig::finish(&args, &outcome),
        stewart_cli::EXIT_INTERRUPTED
    );
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
    assert!(on(&messages, "/supervisor")
        .iter()
        .any(|m| m["interrupted"] == true));
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
    let log = scratch.path("rig.mcap");
    let out = scratch.path("tare.json");
    let args = tare_args(&scratch, emulator.address(), &log, &out);
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    static ABORT: AtomicBool = AtomicBool::new(false);
    let host = std::thread::spawn({
        let args = args.clone();
        move || support::run_rig_with(&args, &INTERRUPT, &ABORT)
    });
    wait_for_session(&emulator);
    std::thread::sleep(Duration::from_millis(3000));
    INTERRUPT.store(true, Ordering::SeqCst);
    // Mid-park: the second Ctrl-C.
    std::thread::sleep(Duration::from_millis(300));
    let aborted_at = Instant::now();
    ABORT.store(true, Ordering::SeqCst);
    let outcome = host.join().unwrap().unwrap_or_else(|e| panic!("rig: {e}"));
    let took = aborted_at.elapsed();
    let stopped = emulator.stop().unwrap();

    assert_eq!(outcome.end, End::Interrupted);
    assert_eq!(
        stewart_cli::rig::finish(&args, &outcome),
        stewart_cli::EXIT_INTERRUPTED
    );
    // The 4 s park was not run out.
    assert!(
        took < Duration::from_secs(3),
        "{took:?} after the second Ctrl-C"
    );
    assert!(!out.exists(), "an interrupted tare is not saved");
    // The rig's watchdog had nothing to do: the host braked it.
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());
    let last = stopped.last_command().expect("commanded");
    assert!(!last.enable, "{last:?}");
    assert_eq!(last.leg_forces_n, [0.0; 6]);
    // The log is finished (read_log checks its summary) and says why it ended.
    let messages = read_log(&log);
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
