//! A count a user gives sizes work or memory, so each has a maximum and a count beyond it is
//! refused before anything runs, with exit 2 and a message naming the flag or key and the
//! range: `simulate --runs` (every run's report is held), `world.physics_substeps` (each
//! substep is a whole physics step per sample) and `bench --duration` (every tick's time is
//! kept). The binary runs under a 2 GiB address-space limit and for a minute at most, so that
//! an unbounded allocation or run fails the test instead of the machine.

use crate::support;

use support::stewart_limited as stewart;

#[test]
fn a_billion_runs_are_refused_instead_of_aborting_on_the_allocation() {
    let dir = support::scratch_dir();
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
    let dir = support::scratch_dir();
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

#[test]
fn a_bench_of_a_trillion_seconds_is_refused_instead_of_recording_every_tick() {
    let dir = support::scratch_dir();
    let (code, err) = stewart(dir.path(), &["bench", "--duration", "1e12"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--duration") && err.contains("36000"), "{err}");
}
