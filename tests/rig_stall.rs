//! A stall does not lose the measurement: the emulator goes silent once (a link that drops out,
//! a host descheduled), the host faults on the silence and brakes the rig, then opens a new
//! session and repeats the run, a completed tare kept (`rig.stall_retries`); the stalled run's
//! log stays as its record. With no retries left the stall ends the run as a fault.

use crate::support;

use measure::End;
use support::*;

/// The quick scenario with a 50 ms silence limit and `retries` repeats allowed.
fn scenario(retries: u32) -> String {
    quick().replace("link_silence_ms = 1000.0", "link_silence_ms = 50.0")
        + &format!("stall_retries = {retries}\n")
}

/// Frames of the quick scenario's tare session at 500 Hz (hold 0.5 s, ramp home 1 s, settle
/// 0.5 s, excitation 4 s, park 1 s: about 3600) and then 1 s into the loaded run.
const INTO_THE_LOADED_RUN: u64 = 3600 + 500 + 1000;

#[test]
fn a_stall_in_the_loaded_run_repeats_it_with_the_tare_kept() {
    let _lock = real_time();
    let scratch = Scratch::new(&scenario(1));
    let emulator = start(&EmulateOptions {
        stall_once_after: Some(INTO_THE_LOADED_RUN),
        ..emulate_args(&scratch)
    });
    let log = scratch.path("rig.mcap");
    let args = rig_against(
        &scratch.config,
        emulator.address(),
        &log,
        ops::rig::RigPlan::Both,
    );
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    let stopped = emulator.stop().unwrap();

    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(outcome.exit_code(), ops::exit::DONE);
    assert!(outcome.report.is_some(), "the repeated run is reported");
    // Tare, the stalled loaded run, its repetition: three sessions.
    assert_eq!(sessions.len(), 3, "{sessions:?}");
    assert_eq!(outcome.repeated.len(), 1, "{:?}", outcome.repeated);
    let repeated = &outcome.repeated[0];
    assert!(repeated.cause.contains("link silent"), "{}", repeated.cause);
    assert_eq!(repeated.log, log, "the stalled run's log is the first one");
    // The stalled log is finished and ends braked; the repeat has a log of its own.
    assert!(!last_logged_enable(&log));
    assert_eq!(outcome.log_path, scratch.path("rig-repeat-1.mcap"));
    assert!(!read_log(&outcome.log_path).is_empty());
    // The tare was kept, not measured again: the report subtracts it from a file.
    assert!(scratch.path("rig.tare.json").exists());
    assert_eq!(outcome.report.as_ref().unwrap().tare.source, "file");
    let json: serde_json::Value =
        serde_json::from_str(&outcome.report_json().expect("a report")).unwrap();
    assert_eq!(json["repeated"][0]["log"], log.display().to_string());
    // The rig braked on the silence: its watchdog may have tripped while silent, but every
    // command it held last is a brake.
    assert!(!stopped.last_command().expect("commanded").enable);
}

#[test]
fn with_no_retries_a_stall_ends_the_run_as_a_fault() {
    let _lock = real_time();
    let scratch = Scratch::new(&scenario(0));
    let emulator = start(&EmulateOptions {
        stall_once_after: Some(1000),
        ..emulate_args(&scratch)
    });
    let outcome = run_rig(&rig_tare(&scratch, emulator.address())).unwrap();
    let sessions = emulator.sessions();
    emulator.stop().unwrap();
    assert!(
        matches!(&outcome.end, End::Fault(c) if c.contains("link silent")),
        "{:?}",
        outcome.end
    );
    assert!(outcome.stalled);
    assert!(outcome.repeated.is_empty());
    assert_eq!(sessions.len(), 1);
    assert_eq!(outcome.exit_code(), ops::exit::FAULT);
}

#[test]
fn a_stall_in_the_tare_run_repeats_the_tare() {
    let _lock = real_time();
    let scratch = Scratch::new(&scenario(2));
    let emulator = start(&EmulateOptions {
        stall_once_after: Some(1000),
        ..emulate_args(&scratch)
    });
    let outcome = run_rig(&rig_tare(&scratch, emulator.address())).unwrap();
    let sessions = emulator.sessions();
    emulator.stop().unwrap();
    assert_eq!(outcome.end, End::Completed, "{:?}", outcome.failure);
    assert_eq!(outcome.repeated.len(), 1);
    assert_eq!(sessions.len(), 2);
    assert!(
        scratch.path("tare.json").exists(),
        "the repeated tare is saved"
    );
}

/// A rig that stays silent cannot be repeated on: the repeat's handshake goes unanswered, and
/// the stall's fault stands (exit 3), not a refusal of the repeat.
#[test]
fn a_repeat_the_rig_does_not_answer_leaves_the_stalls_fault() {
    let _lock = real_time();
    let scratch = Scratch::new(&(scenario(1) + "handshake_timeout_s = 0.5\n"));
    let emulator = start(&EmulateOptions {
        stop_after: Some(1000),
        ..emulate_args(&scratch)
    });
    let outcome = run_rig(&rig_tare(&scratch, emulator.address()))
        .unwrap_or_else(|e| panic!("the stall's outcome, not an error: {e}"));
    emulator.stop().unwrap();
    assert!(
        matches!(&outcome.end, End::Fault(c) if c.contains("link silent")),
        "{:?}",
        outcome.end
    );
    assert!(outcome.repeated.is_empty(), "{:?}", outcome.repeated);
    assert_eq!(outcome.exit_code(), ops::exit::FAULT);
    assert!(!last_logged_enable(&scratch.path("rig.mcap")));
}
