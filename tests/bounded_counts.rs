//! A count a user gives sizes work or memory, so each has a maximum and a count beyond it is
//! refused before anything runs, with exit 2 and a message naming the flag or key and the
//! range: `simulate --runs` (every run's report is held) and `world.physics_substeps` (each
//! substep is a whole physics step per sample). The binary runs under a 2 GiB address-space
//! limit, so that an unbounded allocation fails the test instead of the machine.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `stewart ARGS` in `dir` under a 2 GiB address-space limit, killed after a minute (a
/// refusal takes milliseconds); (exit code, stderr).
fn stewart(dir: &Path, args: &[&str]) -> (i32, String) {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2097152 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_stewart"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("sh runs the stewart binary");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("the child can be waited for") {
            break Some(status);
        }
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut stderr = String::new();
    if let Some(mut pipe) = child.stderr.take() {
        let _ = pipe.read_to_string(&mut stderr);
    }
    (status.and_then(|s| s.code()).unwrap_or(-1), stderr)
}

#[test]
fn a_billion_runs_are_refused_instead_of_aborting_on_the_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let (code, err) = stewart(dir.path(), &["simulate", "--quiet", "--runs", "1000000000"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--runs") && err.contains("100000"), "{err}");
    let (code, err) = stewart(
        dir.path(),
        &["simulate", "--quiet", "--runs", "2", "--jobs", "1000000000"],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--jobs") && err.contains("1024"), "{err}");
}

#[test]
fn a_billion_physics_substeps_are_refused_instead_of_running_until_killed() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("rig.toml"),
        "[world]\nphysics_substeps = 1000000000\n",
    )
    .unwrap();
    let (code, err) = stewart(
        dir.path(),
        &[
            "simulate", "--quiet", "--config", "rig.toml", "--log", "run.mcap",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("world.physics_substeps"), "{err}");
    assert!(err.contains("between 1 and 64"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "no log: {err}");
}
