//! Ctrl-C during a rig run: the platform parks (the controller's park ramp, then the brakes),
//! the log is finished, the exit code is 130, and no tare is saved.

mod support;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use measure::End;
use support::*;

#[test]
fn ctrl_c_parks_the_platform_and_finishes_the_log() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let emulator = start(&emulate_args(&scratch));
    let log = scratch.path("rig.mcap");
    let out = scratch.path("tare.json");
    let args = rig_args(&[
        "tare",
        "--out",
        out.to_str().unwrap(),
        "--config",
        scratch.config_str(),
        "--connect",
        emulator.address(),
        "--log",
        log.to_str().unwrap(),
        "--quiet",
    ]);
    static INTERRUPT: AtomicBool = AtomicBool::new(false);
    let host = std::thread::spawn({
        let args = args.clone();
        move || stewart_cli::rig::rig(&args, &INTERRUPT)
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    while emulator.sessions().is_empty() {
        assert!(Instant::now() < deadline, "no session");
        std::thread::sleep(Duration::from_millis(10));
    }
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
