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
//! A refusal before anything moved exits with 2, a fault (safe stop, the log finished) with 3,
//! Ctrl-C (parked) with 130.
//!
//! The measurement itself is [`ops::rig`]; here are the command line and its plan (`args`), the
//! operator at the terminal (the prompt, the key), and what is printed (`outcome`).

mod args;
mod outcome;

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use ops::measurement::Outcome;
use ops::rig::{Attendant, LinkOptions, RigOptions};

use crate::common::CommandError;
use crate::progress::Terminal;

pub use args::{resolve, LinkArgs, RigArgs, RigMeasureArgs, RigMode, RigRunArgs, RigTareArgs};
pub use outcome::finish;

/// The measurement's options from the flags, or why the flags do not go together.
pub fn options(args: &RigArgs) -> Result<RigOptions, CommandError> {
    let (plan, common) = resolve(args)?;
    Ok(RigOptions {
        plan,
        measure: common.run.options(),
        link: LinkOptions {
            connect: common.link.connect.clone(),
            link_silence_ms: common.link.link_silence_ms,
        },
    })
}

/// The operator at the terminal: asked to put the payload on (the bar off the screen while
/// asked; `--no-prompt`: at once), and the shared key of `--key`, `rig.key_file` or the user's
/// key file (`--insecure`: none), its notice on standard error.
pub struct AtTheTerminal {
    /// The progress bar to take off the screen during the prompt.
    pub bar: indicatif::ProgressBar,
    /// The link flags.
    pub link: LinkArgs,
}

impl Attendant for AtTheTerminal {
    fn put_on(&mut self, body: &str, stop: &AtomicBool) -> anyhow::Result<bool> {
        let no_prompt = self.link.no_prompt;
        self.bar
            .suspend(|| crate::prompt::operator_loads_payload(body, no_prompt, stop))
    }

    fn shared_key(
        &mut self,
        configured: Option<PathBuf>,
    ) -> Result<Option<rig::Key>, ops::measurement::Error> {
        let (key, insecure) = (self.link.key.as_deref(), self.link.insecure);
        shared_key(key, configured, insecure, ops::key::Side::Host, "")
    }
}

/// Runs `stewart rig` at the terminal: `interrupt` parks, `abort` (a second Ctrl-C) brakes at
/// once ([`ops::rig::run`]).
pub fn rig(
    args: &RigArgs,
    interrupt: &AtomicBool,
    abort: &AtomicBool,
) -> Result<Outcome, CommandError> {
    let options = options(args)?;
    let (_, common) = resolve(args)?;
    let mut terminal = Terminal::new(common.run.shared.quiet);
    let mut attendant = AtTheTerminal {
        bar: terminal.handle(),
        link: common.link,
    };
    ops::rig::run(&options, &mut terminal, &mut attendant, interrupt, abort)
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
    match rig(args, interrupt, abort) {
        Ok(outcome) => outcome::finish(args, &outcome),
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

/// The shared key of `flag` (`--key`), `configured` (`rig.key_file`) or the user's key file
/// (`insecure`: none) for `side`, its notice on standard error after `prefix`.
pub fn shared_key(
    flag: Option<&std::path::Path>,
    configured: Option<PathBuf>,
    insecure: bool,
    side: ops::key::Side,
    prefix: &str,
) -> Result<Option<rig::Key>, ops::measurement::Error> {
    let chosen = crate::key::choose(flag, configured, ops::key::user_key_path, insecure, side)?;
    if let Some(notice) = &chosen.notice {
        eprintln!("{prefix}{notice}");
    }
    Ok(chosen.key)
}
