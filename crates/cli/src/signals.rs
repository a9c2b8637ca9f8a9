//! The signals that end a command, on one thread of their own: SIGINT (Ctrl-C), SIGTERM (a
//! service manager, `kill`), SIGHUP (a closed terminal, an SSH drop) and SIGQUIT (Ctrl-\) all
//! stop a run the same way, so that however `stewart rig` is ended the platform gets a safe
//! stop and the log its footer (docs/rig.md, *Stopping*; docs/exit-codes.md: 130).

use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use signal_hook::consts::{SIGHUP, SIGINT, SIGQUIT, SIGTERM};

/// Set by the first stopping signal; the run loop parks the platform when it sees it.
pub static INTERRUPT: AtomicBool = AtomicBool::new(false);

/// Set by the second stopping signal of a command that drives hardware (`rig`): brakes at once
/// (no park ramp), the log is finished, then the command exits.
pub static ABORT: AtomicBool = AtomicBool::new(false);

/// Stopping signals received so far.
static RECEIVED: AtomicU32 = AtomicU32::new(0);

/// The signals that stop a command.
pub const STOPPING: [i32; 4] = [SIGINT, SIGTERM, SIGHUP, SIGQUIT];

/// What one stopping signal does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnSignal {
    /// Park the platform (ramp home, brakes), finish the log.
    Park,
    /// Brake at once, finish the log, exit.
    StopNow,
    /// Exit at once (nothing that moves hardware is left to stop, or the operator insists).
    Exit,
}

/// The `count`-th stopping signal (1-based) of a command; `drives_hardware`: it commands a
/// rig, which must get a safe stop however the command ends. A simulation has nothing to stop,
/// so its second signal exits; a rig's second brakes at once and finishes the log, and only a
/// third exits without waiting (the rig's command watchdog then brakes it).
pub fn on_signal(count: u32, drives_hardware: bool) -> OnSignal {
    match count {
        0 | 1 => OnSignal::Park,
        2 if drives_hardware => OnSignal::StopNow,
        _ => OnSignal::Exit,
    }
}

/// The signal's name as the operator knows it.
pub fn name(signal: i32) -> &'static str {
    match signal {
        SIGINT => "Ctrl-C",
        SIGTERM => "SIGTERM",
        SIGHUP => "SIGHUP",
        SIGQUIT => "SIGQUIT",
        _ => "a signal",
    }
}

/// Starts the thread that turns the stopping signals into [`INTERRUPT`] and [`ABORT`];
/// `stopping` says what the first one does ("parking the platform and finishing the log"). An
/// error (the signals cannot be registered) is returned for the caller to report; the command
/// then runs with the operating system's default handling.
pub fn listen(drives_hardware: bool, stopping: &'static str) -> std::io::Result<()> {
    let mut signals = signal_hook::iterator::Signals::new(STOPPING)?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            for signal in signals.forever() {
                let count = RECEIVED.fetch_add(1, Ordering::SeqCst) + 1;
                let what = on_signal(count, drives_hardware);
                if what != OnSignal::Exit {
                    INTERRUPT.store(true, Ordering::SeqCst);
                }
                if what == OnSignal::StopNow {
                    ABORT.store(true, Ordering::SeqCst);
                }
                // After SIGHUP the terminal may be gone: a failed write must not end this
                // thread, which the next signal still needs.
                let _ = writeln!(std::io::stderr(), "\n{}", line(what, signal, stopping));
                if what == OnSignal::Exit {
                    std::process::exit(i32::from(crate::common::EXIT_INTERRUPTED));
                }
            }
        })?;
    Ok(())
}

/// What the operator is told when `signal` does `what`, the first one `stopping`.
fn line(what: OnSignal, signal: i32, stopping: &str) -> String {
    let name = name(signal);
    match what {
        OnSignal::Park => format!("{name}: {stopping} (Ctrl-C again to stop at once)"),
        OnSignal::StopNow => format!(
            "{name}: braking now and finishing the log (Ctrl-C again to exit without waiting)"
        ),
        OnSignal::Exit => format!("{name}: exiting now"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A second stopping signal on `rig` brakes and finishes the log (an exit at once would
    /// leave an enabled command on the wire and the log without its footer).
    #[test]
    fn a_second_signal_on_a_rig_brakes_and_only_a_third_exits() {
        assert_eq!(on_signal(1, true), OnSignal::Park);
        assert_eq!(on_signal(2, true), OnSignal::StopNow);
        assert_eq!(on_signal(3, true), OnSignal::Exit);
        assert_eq!(on_signal(1, false), OnSignal::Park);
        assert_eq!(on_signal(2, false), OnSignal::Exit);
    }

    #[test]
    fn each_stopping_signal_is_named() {
        let names: Vec<&str> = STOPPING.iter().map(|s| name(*s)).collect();
        assert_eq!(names, ["Ctrl-C", "SIGTERM", "SIGHUP", "SIGQUIT"]);
        let rig = "parking the platform and finishing the log";
        assert!(line(OnSignal::Park, SIGTERM, rig).starts_with("SIGTERM: parking"));
    }
}
