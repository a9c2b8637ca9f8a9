//! The operator's prompt at the rig: between the tare and the loaded run, put the payload (or
//! the load-cell calibration's reference weight) on and press Enter.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::anyhow;

/// Asks the operator to put `body` ("the payload", "the reference weight") on and waits for
/// Enter (or goes straight on with `no_prompt`). `Ok(false)`: Ctrl-C while waiting. With no
/// operator on standard input (closed, not a terminal that answers) it refuses rather than
/// wait forever.
pub fn operator_loads_payload(
    body: &str,
    no_prompt: bool,
    interrupt: &AtomicBool,
) -> anyhow::Result<bool> {
    if no_prompt {
        return Ok(!interrupt.load(Ordering::SeqCst));
    }
    eprintln!(
        "tare done; the platform is braked. Put {body} on the fixture, then press Enter \
         (Ctrl-C stops here)."
    );
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let read = std::io::stdin().read_line(&mut line);
        let _ = tx.send(read.map(|n| n > 0));
    });
    loop {
        if interrupt.load(Ordering::SeqCst) {
            return Ok(false);
        }
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(Ok(true)) => return Ok(true),
            Ok(Ok(false)) | Ok(Err(_)) | Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(anyhow!(
                    "no operator on standard input to confirm that {body} is on; pass \
                     --no-prompt to start the loaded run right after the tare"
                ))
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
        }
    }
}
