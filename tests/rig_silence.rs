//! The emulator stops answering in the middle of a run: `stewart rig` notices once the link has
//! been silent for its limit (50 ms, the default), commands a safe stop, ends with a fault naming
//! the cause and exit code 3, and its MCAP log is finished and readable to the last frame.

use crate::support;

use std::time::Duration;

use measure::End;
use rig::transport::Peer;
use runlog::rig_record::LINK;
use support::*;

#[test]
fn the_emulator_going_silent_is_a_fault_the_host_notices() {
    let _lock = real_time();
    // Not repeated (tests/rig_stall.rs repeats stalls): the fault itself is under test.
    let scratch = Scratch::new(&(quick() + "stall_retries = 0\n"));
    // 500 Hz: 1000 frames are 2 s, past the brake hold (0.5 s) and into the ramp home, settle
    // and the start of the excitation: the platform is being driven.
    let stop_after = 1000u64;
    let emulator = start(&EmulateOptions {
        stop_after: Some(stop_after),
        ..emulate_args(&scratch)
    });
    let log = scratch.path("rig.mcap");
    let mut args = rig_tare(&scratch, emulator.address());
    args.options.link.link_silence_ms = Some(50.0);
    let outcome = run_rig(&args).unwrap_or_else(|e| panic!("rig: {e}"));
    let sessions = emulator.sessions();
    // Give the safe stop time to arrive before the emulator is stopped.
    std::thread::sleep(Duration::from_millis(50));
    let stopped = emulator.stop().unwrap();

    // A fault naming the cause, exit code 3.
    let End::Fault(cause) = &outcome.end else {
        panic!("expected a fault, got {:?}", outcome.end)
    };
    assert!(cause.contains("link silent"), "{cause}");
    // The host was waiting for the rig's frames, not late: it is not blamed.
    assert!(!cause.contains("this host was late"), "{cause}");
    assert!(
        cause.contains(&format!("last sequence {stop_after}")),
        "{cause}"
    );
    assert_eq!(outcome.exit_code(), ops::exit::FAULT);
    // The safe stop the host sent after the fault is in its own record (the log's last
    // command had the legs enabled: what the host sent last could not be read back).
    assert!(
        !last_logged_enable(&log),
        "the log's last command enables the legs"
    );
    assert!(
        !scratch.path("tare.json").exists(),
        "no tare from a failed run"
    );

    // Noticed by the host's silence limit, not before it: no earlier than 50 ms after the last
    // frame the emulator sent (how much later depends on the machine's load, so no upper bound
    // on the wall clock; the cause and the last sequence above say which silence it was). The
    // rig's side saw nothing wrong: the host braked it, no watchdog of the rig's tripped.
    let failure = outcome.failure.as_ref().expect("the failure is kept");
    let last_sent = stopped.last_sensor_sent_at().expect("frames were sent");
    let latency = failure.at.duration_since(last_sent);
    eprintln!(
        "fault detected {:.1} ms after the last frame was sent ({:.1} ms after the host read it)",
        latency.as_secs_f64() * 1e3,
        failure.after_last_frame_s.unwrap_or(f64::NAN) * 1e3
    );
    assert!(latency >= Duration::from_millis(50), "{latency:?}");
    assert!(
        failure.after_last_frame_s.is_some_and(|s| s >= 0.050),
        "{failure:?}"
    );
    assert_eq!(failure.kind, rig::ErrorKind::Link, "{failure:?}");
    assert!(stopped.faults().is_empty(), "{:?}", stopped.faults());

    // The safe stop reached the rig: its last command from the host brakes.
    let last = stopped.last_command().expect("commands were sent");
    assert!(!last.enable, "{last:?}");
    assert_eq!(stopped.session_peer(), Some(sessions[0].peer));
    assert!(matches!(sessions[0].peer, Peer::Udp(_)));

    // The log: finished, every record readable, the last frame is the last one sent, and the
    // fault is named in /supervisor and /rig/link.
    let messages = read_log(&log);
    let sensors = support::sensor_frames(&log);
    let last_sequence = sensors.last().unwrap().sequence;
    assert_eq!(last_sequence, stop_after);
    let supervisor = on(&messages, "/supervisor");
    let last = supervisor.last().unwrap();
    assert_eq!(last["phase"], "fault");
    assert!(last["fault"].as_str().unwrap().contains("link silent"));
    let link = on(&messages, LINK);
    let end = link.last().unwrap();
    assert_eq!(end["event"], "end");
    assert!(end["fault"].as_str().unwrap().contains("link silent"));
    assert_eq!(
        end["counters"]["accepted"].as_u64().unwrap(),
        sensors.len() as u64
    );
}
