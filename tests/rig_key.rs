//! Authenticated by default: `stewart key new` writes the user's key file (owner-only, never
//! overwritten without `--force`), `stewart emulate` makes one when there is none and says so,
//! `stewart rig` uses it without flags, a host without the rig's key is refused with how to
//! pair, and keyless runs need `--insecure` (warned). The binary runs as a child process with
//! `XDG_CONFIG_HOME` in a temporary directory: the user's real configuration is never touched.

use crate::support;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};

use support::*;

fn stewart(xdg: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_stewart"));
    command.env("XDG_CONFIG_HOME", xdg).env_remove("HOME");
    command
}

fn text(out: &Output) -> String {
    format!(
        "status {:?}\nstdout: {}\nstderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// A child `stewart emulate`, the address it listens on and the lines of its standard output.
struct Emulator {
    child: Child,
    address: String,
    stderr: std::process::ChildStderr,
    lines: std::sync::mpsc::Receiver<String>,
}

impl Emulator {
    fn start(xdg: &Path, config: &Path, extra: &[&str]) -> Self {
        let mut child = stewart(xdg)
            .args([
                "emulate",
                "--listen",
                "udp://127.0.0.1:0",
                "--lockstep",
                "--config",
            ])
            .arg(config)
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let first = lines.next().expect("a first line").unwrap();
        let address = first
            .split_whitespace()
            .find(|w| w.starts_with("udp://"))
            .unwrap_or_else(|| panic!("no address in {first:?}"))
            .to_string();
        // Keep draining its output so that it never blocks on a full pipe; the lines go to
        // `wait_for_line` (or nowhere once the receiver is gone).
        let (sender, receiver) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                let _ = sender.send(line);
            }
        });
        let stderr = child.stderr.take().unwrap();
        Self {
            child,
            address,
            stderr,
            lines: receiver,
        }
    }

    /// Waits (at most 30 s) for a line of its standard output that contains `what`.
    fn wait_for_line(&self, what: &str) -> String {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.contains(what) => return line,
                Ok(_) => {}
                Err(e) => panic!("the emulator printed no line with {what:?}: {e}"),
            }
        }
    }

    /// Stops it; returns what it printed on standard error.
    fn stop(mut self) -> String {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let mut err = String::new();
        let _ = std::io::Read::read_to_string(&mut self.stderr, &mut err);
        err
    }
}

impl Drop for Emulator {
    /// A failed assertion must not leave the child running.
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn keyless_scenario(scratch: &Scratch) -> std::path::PathBuf {
    let path = scratch.path("keyless.toml");
    std::fs::write(&path, quick().replace("key_file = \"rig.key\"\n", "")).unwrap();
    path
}

#[test]
fn key_new_writes_an_owner_only_key_and_refuses_to_overwrite_it() {
    let xdg = support::scratch_dir();
    let out = stewart(xdg.path()).args(["key", "new"]).output().unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let path = xdg.path().join("stewart").join("rig.key");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        path.display().to_string(),
        "prints the path"
    );
    let first = std::fs::read_to_string(&path).unwrap();
    assert_eq!(first.trim().len(), 64, "{first}");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600, "{mode:o}");
    }
    let again = stewart(xdg.path()).args(["key", "new"]).output().unwrap();
    assert_eq!(again.status.code(), Some(2), "{}", text(&again));
    assert!(text(&again).contains("--force"), "{}", text(&again));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), first, "kept");
    let forced = stewart(xdg.path())
        .args(["key", "new", "--force"])
        .output()
        .unwrap();
    assert!(forced.status.success(), "{}", text(&forced));
    assert_ne!(std::fs::read_to_string(&path).unwrap(), first, "replaced");
}

#[test]
fn emulate_makes_the_key_rig_uses_it_and_a_keyless_host_is_told_how_to_pair() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let config = keyless_scenario(&scratch);
    let xdg = support::scratch_dir();
    let key_file = xdg.path().join("stewart").join("rig.key");

    // A host with no key file refuses before contacting anything, saying how to pair.
    let unpaired = stewart(xdg.path())
        .args([
            "rig",
            "tare",
            "--quiet",
            "--connect",
            &dead_address(),
            "--out",
        ])
        .arg(scratch.path("t0.json"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert_eq!(unpaired.status.code(), Some(2), "{}", text(&unpaired));
    assert!(
        text(&unpaired).contains("stewart key new"),
        "{}",
        text(&unpaired)
    );
    assert!(!key_file.exists(), "the host does not make a key");

    let emulator = Emulator::start(xdg.path(), &config, &[]);
    assert!(key_file.exists(), "the emulator wrote the user's key file");

    // `rig` with no key flag: the user's key file, the same as the emulator's.
    let log = scratch.path("rig.mcap");
    let paired = stewart(xdg.path())
        .args([
            "rig",
            "tare",
            "--quiet",
            "--connect",
            &emulator.address,
            "--out",
        ])
        .arg(scratch.path("t1.json"))
        .arg("--config")
        .arg(&config)
        .arg("--log")
        .arg(&log)
        .output()
        .unwrap();
    assert_eq!(paired.status.code(), Some(0), "{}", text(&paired));

    // A host that goes without a key is refused by the keyed rig, with how to pair (once the
    // paired host's session has timed out, which the emulator prints: until then any other
    // host is told BUSY).
    let ended = emulator.wait_for_line("the host was silent");
    assert!(ended.starts_with("session 1 "), "{ended}");
    let insecure = stewart(xdg.path())
        .args([
            "rig",
            "tare",
            "--quiet",
            "--insecure",
            "--connect",
            &emulator.address,
            "--out",
        ])
        .arg(scratch.path("t2.json"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert_eq!(insecure.status.code(), Some(2), "{}", text(&insecure));
    let said = text(&insecure);
    assert!(said.contains("WARNING: --insecure"), "{said}");
    assert!(said.contains("requires a shared key"), "{said}");
    assert!(said.contains("copy the rig's key file"), "{said}");

    let emulator_said = emulator.stop();
    assert!(
        emulator_said.contains("wrote a new one to") && emulator_said.contains("rig.key"),
        "{emulator_said}"
    );
}

#[test]
fn a_keyless_rig_is_warned_about_and_refuses_a_keyed_host() {
    let _lock = real_time();
    let scratch = Scratch::new(&quick());
    let config = keyless_scenario(&scratch);
    let xdg = support::scratch_dir();
    let keyed = stewart(xdg.path()).args(["key", "new"]).output().unwrap();
    assert!(keyed.status.success(), "{}", text(&keyed));
    let emulator = Emulator::start(xdg.path(), &config, &["--insecure"]);
    let host = stewart(xdg.path())
        .args([
            "rig",
            "tare",
            "--quiet",
            "--connect",
            &emulator.address,
            "--out",
        ])
        .arg(scratch.path("t.json"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert_eq!(host.status.code(), Some(2), "{}", text(&host));
    assert!(
        text(&host).contains("rig runs without a key"),
        "{}",
        text(&host)
    );
    let said = emulator.stop();
    assert!(said.contains("WARNING: --insecure"), "{said}");
}
