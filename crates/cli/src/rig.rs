//! `stewart rig`: the measurement on a rig behind the wire protocol (a real platform's I/O
//! controller, or `stewart emulate`), with the same procedure, log and report as `simulate`
//! minus the truth, plus the link's counters and the loop's timing.
//!
//! Modes: `rig` (tare run, the operator puts the payload on, loaded run), `rig tare --out FILE`
//! (tare only) and `rig measure --tare FILE` (loaded run with a saved tare; `rig --tare FILE`
//! is the same); the calibrations `rig calibrate-imu --out FILE` (the empty fixture's run) and
//! `rig calibrate-load-cells --out FILE` (tare run, the operator puts the reference weight on,
//! loaded run; docs/calibration.md). Each measurement is one session of the protocol: the tare's session ends
//! braked, and the loaded run opens a new one once the operator confirms the payload is on.
//!
//! Before anything moves: the configuration, the trajectories, the tare file and the key are
//! checked, then the handshake (protocol version, sensor layout, sample period, accelerometer
//! position, and the rig's stroke and speed limits against the configuration). After that,
//! any link silence longer than `rig.link_silence_ms`, an invalid sensor value, a fault
//! reported by the rig or a supervisor limit ends the measurement with a safe stop, a message
//! naming the cause, the log finished, and exit code 3. Ctrl-C parks, finishes the log and
//! exits with 130. Commands are clamped to the tighter of the rig's force limits and
//! `control.max_force_n` whatever the controller computes.
//!
//! The modules: the command line and its plan (`args`), reaching the rig (`connection`), one
//! invocation from flags to outcome (`session`), the sessions' station on the link
//! (`station`), the calibration commands (`calibration`), and what is produced and printed
//! (`outcome`).

mod args;
mod calibration;
mod connection;
mod outcome;
mod session;
mod station;

use std::sync::atomic::AtomicBool;

use crate::common::CommandError;

pub use args::{
    parse, resolve, LinkArgs, Plan, RigArgs, RigMeasureArgs, RigMode, RigRunArgs, RigTareArgs,
};
pub(crate) use connection::flag_issue;
pub use connection::{check_rig, link_settings, LinkSettings};
pub use outcome::{finish, link_lines, LinkReport, RigOutcome};
pub use session::rig_with_abort;

/// Runs `stewart rig`. `interrupt` is the Ctrl-C flag: when set, the platform parks, the log
/// is finished and the outcome says [`measure::End::Interrupted`]. A refused input or handshake
/// is an error (nothing moved); a fault is an outcome with [`measure::End::Fault`] naming the
/// cause.
pub fn rig(args: &RigArgs, interrupt: &AtomicBool) -> Result<RigOutcome, CommandError> {
    static NEVER: AtomicBool = AtomicBool::new(false);
    rig_with_abort(args, interrupt, &NEVER)
}

/// `stewart rig` from the command line: runs, prints, writes the report; returns the exit
/// code (0 done, 1 failed, 2 refused before anything moved, 3 fault, 130 interrupted).
pub fn main(args: &RigArgs, interrupt: &AtomicBool, abort: &AtomicBool) -> u8 {
    if let Ok((_, common)) = resolve(args) {
        if !common.link.no_realtime {
            // On this (the loop's) thread, before the log writer and the heartbeat start.
            let granted = rig::realtime::request();
            match granted.refusal_line() {
                Some(line) => eprintln!("warning: {line}"),
                None if !common.run.shared.quiet => eprintln!("{}", granted.granted_line()),
                None => {}
            }
        }
    }
    match rig_with_abort(args, interrupt, abort) {
        Ok(outcome) => outcome::finish(args, &outcome),
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}
