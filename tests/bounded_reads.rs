//! Every file a user names is read with a cap on its size (`rig_description::bounded`): an
//! endless source (`/dev/zero`) or a file one byte over its cap is refused with exit 2, a
//! message naming the file, its size or that it runs on, and the cap; and no log is written.
//! The binary runs under a 2 GiB address-space limit, so that a read without a cap fails the
//! test (the allocation fails) instead of growing until the kernel kills it.

use crate::support;

use std::path::Path;

use support::stewart_limited as stewart;

/// A file of `len` bytes of TOML comment: valid text, too big only by its size.
fn oversized(dir: &Path, name: &str, len: u64) -> String {
    let path = dir.join(name);
    let mut text = vec![b'#'; len as usize];
    if let Some(last) = text.last_mut() {
        *last = b'\n';
    }
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// The refusal of an oversized or endless `file`: exit 2, the file and the cap named, no log.
fn assert_refused(dir: &Path, code: i32, err: &str, file: &str, cap: &str) {
    assert_eq!(code, 2, "{err}");
    assert!(err.contains(file), "names {file}: {err}");
    assert!(err.contains(cap), "names the cap {cap}: {err}");
    let written: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("run.") || n == "runs")
        .collect();
    assert!(
        written.is_empty(),
        "no log, no calibration pass: {written:?}\n{err}"
    );
}

const SIMULATE: [&str; 5] = ["simulate", "--quiet", "--log", "run.mcap", "--config"];

#[test]
fn a_calibration_file_naming_dev_zero_is_refused_not_read_until_killed() {
    let dir = support::scratch_dir();
    std::fs::write(
        dir.path().join("rig.toml"),
        "[calibration]\nimu = \"/dev/zero\"\n",
    )
    .unwrap();
    let (code, err) = stewart(dir.path(), &[&SIMULATE[..], &["rig.toml"]].concat());
    assert_refused(dir.path(), code, &err, "/dev/zero", "1 MiB");
    assert!(err.contains("without a stated size"), "{err}");
}

#[test]
fn a_rig_description_one_byte_over_its_cap_is_refused_with_its_size() {
    let dir = support::scratch_dir();
    let cap = rig_description::bounded::DESCRIPTION_CAP_BYTES;
    let file = oversized(dir.path(), "rig.toml", cap + 1);
    let (code, err) = stewart(dir.path(), &[&SIMULATE[..], &[file.as_str()]].concat());
    assert_refused(dir.path(), code, &err, &file, "1 MiB");
    assert!(err.contains(&format!("{} bytes", cap + 1)), "{err}");
}

#[test]
fn a_rig_description_that_is_dev_zero_or_a_directory_is_refused() {
    let dir = support::scratch_dir();
    let (code, err) = stewart(dir.path(), &[&SIMULATE[..], &["/dev/zero"]].concat());
    assert_refused(dir.path(), code, &err, "/dev/zero", "1 MiB");
    std::fs::create_dir(dir.path().join("configs")).unwrap();
    let (code, err) = stewart(dir.path(), &[&SIMULATE[..], &["configs"]].concat());
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is a directory"), "{err}");
}

#[test]
fn an_excitation_or_tare_file_naming_dev_zero_is_refused() {
    let dir = support::scratch_dir();
    for flag in ["--excitation", "--tare"] {
        let (code, err) = stewart(
            dir.path(),
            &[
                "simulate",
                "--quiet",
                "--log",
                "run.mcap",
                flag,
                "/dev/zero",
            ],
        );
        assert_refused(dir.path(), code, &err, "/dev/zero", "1 MiB");
    }
}

#[test]
fn a_key_file_one_byte_over_its_cap_is_refused() {
    let dir = support::scratch_dir();
    let file = oversized(
        dir.path(),
        "rig.key",
        rig_description::bounded::KEY_CAP_BYTES + 1,
    );
    // Nothing listens there: the key is read before the link is tried.
    let (code, err) = stewart(
        dir.path(),
        &[
            "rig",
            "--quiet",
            "--no-prompt",
            "--log",
            "run.mcap",
            "--connect",
            "udp://127.0.0.1:9",
            "--key",
            &file,
        ],
    );
    assert_refused(dir.path(), code, &err, &file, "4 KiB");
    let (code, err) = stewart(
        dir.path(),
        &[
            "emulate",
            "--key",
            "/dev/zero",
            "--listen",
            "udp://127.0.0.1:0",
        ],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("/dev/zero") && err.contains("4 KiB"), "{err}");
}

#[test]
fn a_report_or_rig_description_naming_dev_zero_is_refused_by_export_report_and_import() {
    let dir = support::scratch_dir();
    let (code, err) = stewart(dir.path(), &["export", "/dev/zero", "--format", "urdf"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("/dev/zero") && err.contains("64 MiB"), "{err}");
    let (code, err) = stewart(dir.path(), &["report", "/dev/zero", "--html", "r.html"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("/dev/zero") && err.contains("64 MiB"), "{err}");
    std::fs::write(dir.path().join("data.csv"), "").unwrap();
    let (code, err) = stewart(
        dir.path(),
        &["import", "data.csv", "--rig", "/dev/zero", "-o", "run.mcap"],
    );
    assert_refused(dir.path(), code, &err, "/dev/zero", "1 MiB");
}

#[test]
fn a_directory_given_as_a_log_or_a_table_is_called_a_directory() {
    let dir = support::scratch_dir();
    std::fs::create_dir(dir.path().join("runs")).unwrap();
    let (code, err) = stewart(dir.path(), &["estimate", "runs"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("runs is a directory, not an MCAP log"),
        "{err}"
    );
    assert!(!err.contains("MCAP magic"), "{err}");
    std::fs::write(dir.path().join("rig.toml"), "").unwrap();
    let (code, err) = stewart(
        dir.path(),
        &["import", "runs", "--rig", "rig.toml", "-o", "run.mcap"],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("runs is a directory, not a table"), "{err}");
}

#[test]
fn an_import_table_that_is_dev_zero_is_refused_not_read_into_one_endless_row() {
    let dir = support::scratch_dir();
    std::fs::write(dir.path().join("rig.toml"), "").unwrap();
    let (code, err) = stewart(
        dir.path(),
        &["import", "/dev/zero", "--rig", "rig.toml", "-o", "run.mcap"],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("/dev/zero") && err.contains("64 KiB"), "{err}");
    assert!(!dir.path().join("run.mcap").exists(), "no log: {err}");
}
