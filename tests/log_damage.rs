//! `stewart estimate` on damaged, cut and broken logs of a real run: it never crashes, loses
//! only what is damaged and says so, and refuses to report on a run that measured nothing.

mod support;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use measure::quality::QualityError;
use ops::estimate::{run as estimate, EstimateOptions, SettingsOverride};

/// One short simulate run shared by the tests of this file.
fn run() -> &'static (support::Simulated, Vec<u8>) {
    static RUN: OnceLock<(support::Simulated, Vec<u8>)> = OnceLock::new();
    RUN.get_or_init(|| {
        let run = support::simulate();
        let bytes = std::fs::read(&run.log).unwrap();
        (run, bytes)
    })
}

/// (offset, body length) of every chunk record of an intact log.
fn chunks(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut pos = 8;
    while pos + 9 <= bytes.len() - 8 {
        let n = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        if bytes[pos] == 0x06 {
            out.push((pos, n));
        }
        pos += 9 + n;
    }
    out
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let path = run().0.dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn args(log: &Path) -> EstimateOptions {
    EstimateOptions {
        log: log.to_path_buf(),
        ..EstimateOptions::default()
    }
}

/// The exit code of `stewart estimate --quiet` with `extra` flags.
fn exit_code(log: &Path, extra: &[&std::ffi::OsStr]) -> Option<i32> {
    std::process::Command::new(env!("CARGO_BIN_EXE_stewart"))
        .arg("estimate")
        .arg(log)
        .arg("--quiet")
        .args(extra)
        .status()
        .expect("the binary runs")
        .code()
}

/// The crash: one flipped byte in a chunk's uncompressed size made the mcap crate
/// allocate exabytes and abort `estimate` (exit 134). It costs that chunk, said in the report.
#[test]
fn a_flipped_chunk_size_byte_that_aborted_estimate_costs_one_chunk() {
    let (run, bytes) = run();
    let c = chunks(bytes);
    let (at, _) = c[c.len() * 3 / 4];
    let mut d = bytes.clone();
    // The uncompressed size's sixth byte: a size of about 2^40 bytes.
    d[at + 9 + 16 + 5] ^= 0xff;
    let path = write("flipped.mcap", &d);
    let outcome = estimate(&EstimateOptions {
        report: Some(run.dir.path().join("flipped.json")),
        ..args(&path)
    })
    .unwrap();
    assert_eq!(outcome.quality, Ok(()));
    let data = &outcome.report.data;
    assert_eq!(data.truncated, None);
    assert_eq!(data.damaged.len(), 1, "{:?}", data.damaged);
    let lost = &data.damaged[0];
    assert!(lost.reason.contains("damaged chunk"), "{}", lost.reason);
    // One chunk (512 KiB of messages) holds about a second of a 1 kHz run.
    let frames = lost.sensor_frames.unwrap();
    assert!((1..1500).contains(&frames), "{frames} frames lost");
    let (from, to) = (lost.from_s.unwrap(), lost.to_s.unwrap());
    assert!(from < to && to - from < 1.5, "{from}..{to}");
    // The loaded run lost those frames' samples and, as after any gap longer than
    // `max_gap_s`, the conditioning's restart (about 330 samples with the default filter).
    let lost_samples = run.report.samples - outcome.report.samples;
    assert!(
        lost_samples >= frames && lost_samples <= frames + 500,
        "{lost_samples} samples for {frames} frames"
    );
    let written = std::fs::read_to_string(run.dir.path().join("flipped.json")).unwrap();
    assert!(written.contains("\"damaged\""), "{written}");
}

/// A few hundred random single and multi-byte flips over the whole real log: all open.
#[test]
fn random_flips_over_a_real_log_never_crash_the_reader() {
    let (_, bytes) = run();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    struct Count(u64);
    impl runlog::read::Visitor for Count {
        fn message(&mut self, _: &runlog::read::Message<'_>) -> anyhow::Result<Option<String>> {
            self.0 += 1;
            Ok(None)
        }
    }
    let whole = {
        let mut c = Count(0);
        runlog::read::visit(std::io::Cursor::new(&bytes[..]), &mut c).unwrap();
        c.0
    };
    let mut damaged = 0;
    for m in 0..120 {
        let mut d = bytes.clone();
        for _ in 0..1 + m % 4 {
            let at = 8 + (next() as usize) % (d.len() - 8);
            d[at] ^= (next() as u8) | 1;
        }
        let mut c = Count(0);
        let (_, damage) = runlog::read::visit(std::io::Cursor::new(&d[..]), &mut c).unwrap();
        assert!(c.0 <= whole);
        damaged += u64::from(!damage.damaged.is_empty());
    }
    assert!(damaged > 60, "{damaged} of 120 mutants found damaged");
}

/// A report from a log cut short says so.
#[test]
fn a_report_from_a_cut_log_carries_the_truncation() {
    let (_, bytes) = run();
    let path = write("cut.mcap", &bytes[..bytes.len() * 9 / 10]);
    let outcome = estimate(&args(&path)).unwrap();
    let why = outcome.report.data.truncated.expect("a truncation flag");
    assert!(why.contains("ends at byte"), "{why}");
}

/// Rewrites the log with every `/sensors` leg force NaN.
fn without_forces(from: &Path, to: &Path) {
    support::rewrite_sensor_frames(from, to, |mut frames| {
        for f in &mut frames {
            f.leg_forces_n = [f64::NAN; 6];
        }
        frames
    });
}

/// The issue: a log whose forces are all non-finite gave exit 0 and a table of NaN.
#[test]
fn a_log_without_finite_forces_measured_nothing_and_exits_non_zero() {
    let (run, _) = run();
    let path = run.dir.path().join("nan.mcap");
    without_forces(&run.log, &path);
    let report = run.dir.path().join("nan.json");
    let a = EstimateOptions {
        report: Some(report.clone()),
        ..args(&path)
    };
    let outcome = estimate(&a).unwrap();
    assert!(
        matches!(outcome.quality, Err(QualityError::NoSamples { rejected }) if rejected > 0),
        "{:?}",
        outcome.quality
    );
    assert!(!report.exists(), "no report of nothing");
    assert_eq!(
        exit_code(&path, &["--report".as_ref(), report.as_os_str()]),
        Some(i32::from(ops::exit::NOT_MEASURED))
    );
    assert!(!report.exists(), "no report of nothing");
}

/// `--params 6` on a 10-parameter log takes the known mass and centre of mass from the rig
/// description the log recorded.
#[test]
fn params_6_on_a_10_parameter_log_uses_the_recorded_known_mass() {
    let (run, _) = run();
    assert_eq!(run.report.run.params, 10);
    let outcome = estimate(&EstimateOptions {
        settings: SettingsOverride {
            params: Some(rig_description::config::ParamCount::Six),
            ..SettingsOverride::default()
        },
        ..args(&run.log)
    })
    .unwrap();
    assert_eq!(outcome.quality, Ok(()));
    assert_eq!(outcome.report.run.params, 6);
    assert!(support::close(outcome.report.estimate.mass, 1500.0, 1e-9));
}

/// `stewart estimate LOG | head -1` panicked on the closed pipe (exit 101): it ends quietly.
#[test]
fn estimate_into_a_closed_pipe_ends_quietly() {
    use std::io::BufRead;
    let (run, _) = run();
    // The figures take a while: their line is written after the pipe closed.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_stewart"))
        .arg("estimate")
        .arg(&run.log)
        .arg("--plot")
        .arg(run.dir.path().join("figures"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.contains("quantity"), "{first}");
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// (offset, length) of every chunk record holding a `/run/metadata` message, from the
/// summary's chunk index (the chunks' message indexes by channel).
fn metadata_chunks(bytes: &[u8]) -> Vec<(usize, usize)> {
    let summary = mcap::Summary::read(bytes).unwrap().expect("a summary");
    let id = summary
        .channels
        .values()
        .find(|c| c.topic == runlog::messages::METADATA)
        .expect("the metadata channel")
        .id;
    summary
        .chunk_indexes
        .iter()
        .filter(|c| c.message_index_offsets.contains_key(&id))
        .map(|c| (c.chunk_start_offset as usize, c.chunk_length as usize))
        .collect()
}

/// `/run/metadata` is written once per run and every frame needs it: one damaged chunk
/// refused a log whose frames were all intact. A second copy in a chunk of its own makes that
/// damage cost nothing but its report; with both copies lost the error names `--rig FILE`,
/// which then reads the log as it reads the whole one.
#[test]
fn a_damaged_metadata_chunk_costs_nothing_but_its_report() {
    let (run, bytes) = run();
    let chunks = metadata_chunks(bytes);
    assert_eq!(chunks.len(), 2, "{chunks:?}");
    let flip = |d: &mut Vec<u8>, (at, len): (usize, usize)| {
        // Mid-chunk: inside its compressed records.
        for b in &mut d[at + len / 2..at + len / 2 + 4] {
            *b ^= 0x5a;
        }
    };
    let mut one = bytes.clone();
    flip(&mut one, chunks[0]);
    let path = write("metadata_damaged.mcap", &one);
    let clean = estimate(&args(&run.log)).unwrap().report;
    let damaged = estimate(&args(&path)).unwrap().report;
    assert_eq!(damaged.estimate, clean.estimate);
    assert_eq!(damaged.sigma, clean.sigma);
    assert_eq!(damaged.samples, clean.samples);
    assert_eq!(damaged.data.damaged.len(), 1, "{:?}", damaged.data.damaged);
    let lost = &damaged.data.damaged[0];
    assert!(lost.reason.contains("damaged chunk"), "{}", lost.reason);
    assert_eq!(lost.sensor_frames, Some(0));

    let mut both = one.clone();
    flip(&mut both, chunks[1]);
    let path = write("metadata_lost.mcap", &both);
    let err = format!("{:#}", estimate(&args(&path)).unwrap_err());
    assert!(
        err.contains("/run/metadata") && err.contains("--rig FILE"),
        "{err}"
    );
    let with_rig = |log: &Path| EstimateOptions {
        rig: Some(run.dir.path().join("scenario.toml")),
        ..args(log)
    };
    let rig_clean = estimate(&with_rig(&run.log)).unwrap().report;
    let rig_lost = estimate(&with_rig(&path)).unwrap().report;
    assert_eq!(rig_lost.estimate, rig_clean.estimate);
    assert_eq!(rig_lost.sigma, rig_clean.sigma);
    assert_eq!(
        rig_lost.data.damaged.len(),
        1,
        "{:?}",
        rig_lost.data.damaged
    );
}

/// A link that reorders datagrams delivers (and a host logs) frame 101 before frame 100; the
/// conditioning refused the late one as a time that does not increase. With adjacent frames
/// swapped in 1 % of the log and a few frames delivered twice, `estimate` puts them back in
/// order: nothing rejected, nothing lost, the duplicates counted, the estimate the in-order
/// log's.
#[test]
fn reordered_and_duplicated_frames_are_put_back_in_order() {
    let (run, _) = run();
    let path = run.dir.path().join("reordered.mcap");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let (mut swapped, mut doubled) = (0, 0);
    support::rewrite_sensor_frames(&run.log, &path, |mut frames| {
        let mut k = 0;
        while k + 1 < frames.len() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // About 1 % of the frames in swapped pairs: a pair starts at 1 frame in 200.
            if state.is_multiple_of(200) {
                frames.swap(k, k + 1);
                swapped += 2;
                k += 2;
            } else {
                k += 1;
            }
        }
        if state % 200 == 1 {
            let again = frames[0];
            frames.insert(2, again);
            doubled += 1;
        }
        frames
    });
    assert!(
        swapped > 100 && doubled > 3,
        "{swapped} swapped, {doubled} doubled"
    );
    let clean = estimate(&args(&run.log)).unwrap().report;
    let reordered = estimate(&args(&path)).unwrap().report;
    let d = &reordered.data;
    assert_eq!(reordered.rejected_samples, clean.rejected_samples);
    assert_eq!(reordered.samples, clean.samples);
    assert_eq!(d.frames_lost, clean.data.frames_lost);
    assert_eq!(d.frames_late, 0);
    assert!(
        (1..=doubled).contains(&d.frames_duplicate),
        "{} duplicates of {doubled}",
        d.frames_duplicate
    );
    let flat = |q: &measure::report::Quantities| {
        let mut v = vec![q.mass];
        v.extend(q.com);
        v.extend(q.inertia_com.iter().flatten());
        v
    };
    let (a, b, s) = (
        flat(&clean.estimate),
        flat(&reordered.estimate),
        flat(&clean.sigma),
    );
    for ((a, b), s) in a.iter().zip(&b).zip(&s) {
        assert!((a - b).abs() <= 0.1 * s, "{a} vs {b} ± {s}");
    }
}

/// A lost chunk (about a second of frames) is a gap too long to bridge: it restarts the
/// conditioning, whose stencil (three samples) and low-pass warm-up are withheld again, and
/// nothing else. The RLS state carries across the gap, so the estimate loses the gap's and
/// the warm-up's samples only: its sigmas grow by a few per cent (an RLS restarted after the
/// gap would have lost everything before it), and it moves by a fraction of a sigma.
#[test]
fn a_lost_chunk_restarts_the_filters_and_keeps_the_fit() {
    let (run, bytes) = run();
    let c = chunks(bytes);
    let (at, len) = c[c.len() * 13 / 16];
    let mut d = bytes.clone();
    for b in &mut d[at + 9 + len / 2..at + 9 + len / 2 + 4] {
        *b ^= 0x5a;
    }
    let path = write("lost_chunk.mcap", &d);
    let outcome = estimate(&args(&path)).unwrap();
    let clean = estimate(&args(&run.log)).unwrap().report;
    let damaged = &outcome.report;
    assert_eq!(damaged.data.damaged.len(), 1, "{:?}", damaged.data.damaged);
    assert_eq!(damaged.data.restarts, clean.data.restarts + 1);
    let gap = damaged.data.frames_lost - clean.data.frames_lost;
    let warmup = estimator::Conditioner::new(outcome.loaded.replay.config.conditioning())
        .unwrap()
        .warmup_samples() as u64;
    let lost = clean.samples - damaged.samples;
    // The gap's frames, the stencil's first three samples and the low-pass's warm-up (a frame
    // the clean log itself lost next to the gap moves the count by one or two).
    let stencil = estimator::conditioning::STENCIL as u64 - 1;
    assert!(
        lost <= gap + warmup + stencil && lost + 2 >= gap + warmup + stencil,
        "{lost} samples lost for a gap of {gap} frames and a warm-up of {warmup}"
    );
    let flat = |q: &measure::report::Quantities| {
        let mut v = vec![q.mass];
        v.extend(q.com);
        v.extend(q.inertia_com.iter().flatten());
        v
    };
    let (a, b) = (flat(&clean.estimate), flat(&damaged.estimate));
    let (sa, sb) = (flat(&clean.sigma), flat(&damaged.sigma));
    for k in 0..a.len() {
        let growth = sb[k] / sa[k] - 1.0;
        let shift = (b[k] - a[k]) / sa[k];
        assert!(
            growth < 0.2 && shift.abs() < 0.5,
            "entry {k}: sigma {:+.1} %, shift {shift:+.2} sigma",
            100.0 * growth
        );
    }
}

/// Copies the log at `from` to `to` without its `/run/metadata` and without every message of
/// its loaded run (`/sensors` blocks and `/run/estimator` settings): a tare-only log whose
/// metadata was lost.
fn tare_only_without_metadata(from: &Path, to: &Path) {
    use prost::Message as _;
    let bytes = std::fs::read(from).unwrap();
    let file = std::io::BufWriter::new(std::fs::File::create(to).unwrap());
    let mut out = mcap::Writer::new(file).unwrap();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let run = match m.channel.topic.as_str() {
            runlog::messages::METADATA => continue,
            runlog::messages::SENSORS => runlog::proto::SensorBlock::decode(&m.data[..])
                .unwrap()
                .run
                .clone(),
            runlog::messages::ESTIMATOR_SETTINGS => {
                serde_json::from_slice::<runlog::metadata::EstimatorSettings>(&m.data)
                    .unwrap()
                    .run
            }
            _ => String::new(),
        };
        if run != "loaded" {
            out.write(&m).unwrap();
        }
    }
    out.finish().unwrap();
}

/// With `/run/metadata` lost, `estimate --rig FILE` lists the measurements the log's frames
/// hold, not both: `--save-tare` on a tare-only log saves the tare and ends there (exit 0)
/// instead of going on to a loaded run the log does not hold, and a log holding both still
/// goes on to it.
#[test]
fn with_the_metadata_lost_the_runs_listed_are_the_ones_the_frames_hold() {
    let (run, _) = run();
    let rig = run.dir.path().join("scenario.toml");
    let rig_config = rig_description::load::load(Some(&rig)).unwrap();
    let tare_only = run.dir.path().join("tare_only.mcap");
    tare_only_without_metadata(&run.log, &tare_only);
    let whole = run.dir.path().join("no_metadata.mcap");
    support::copy_without(&run.log, &whole, runlog::messages::METADATA);

    for (log, runs) in [(&tare_only, vec!["tare"]), (&whole, vec!["tare", "loaded"])] {
        let mut contents = runlog::LogContents::read(log).unwrap();
        assert!(contents.metadata.is_none());
        contents.or_metadata_of(Some(&rig_config)).unwrap();
        assert_eq!(contents.require_metadata().unwrap().runs, runs, "{log:?}");
        let saved = ops::estimate::save_tare(
            &EstimateOptions {
                rig: Some(rig.clone()),
                ..args(log)
            },
            &run.dir.path().join("saved_tare.json"),
        )
        .unwrap();
        assert_eq!(saved.has_loaded, runs.contains(&"loaded"), "{log:?}");
    }

    let tare = run.dir.path().join("tare_only.json");
    let flags = [
        "--rig".as_ref(),
        rig.as_os_str(),
        "--save-tare".as_ref(),
        tare.as_os_str(),
    ];
    assert_eq!(exit_code(&tare_only, &flags), Some(0));
    assert!(tare.exists());
}
