//! `stewart estimate` on damaged, cut and broken logs of a real run: it never crashes, loses
//! only what is damaged and says so, and refuses to report on a run that measured nothing.

use crate::support;

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
/// the warm-up's samples only (an RLS restarted after the gap would have lost everything
/// before it): its sigmas grow by about what the lost share costs, √(N/N′) − 1 (12 % for the
/// fifth of this short run one chunk holds), at most twice that for the entry whose window
/// covariance is the least steady (c_z: 19 % without the zero-drift fit, 20 % with it), and it
/// moves by a fraction of a sigma.
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
    let counted = (clean.samples as f64 / damaged.samples as f64).sqrt() - 1.0;
    for k in 0..a.len() {
        let growth = sb[k] / sa[k] - 1.0;
        let shift = (b[k] - a[k]) / sa[k];
        assert!(
            growth < 2.0 * counted && shift.abs() < 0.5,
            "entry {k}: sigma {:+.1} % (the lost share costs {:.1} %), shift {shift:+.2} sigma",
            100.0 * growth,
            100.0 * counted
        );
    }
}

/// A damaged chunk of the loaded run was said twice on the terminal: once as damage, once as
/// a span of missing frames. It is said once, by the damage's line, which names the frames'
/// sequence numbers as the report's missing span does.
#[test]
fn a_damaged_chunk_is_said_once_with_its_frames() {
    let (_, bytes) = run();
    let c = chunks(bytes);
    let (at, len) = c[c.len() * 13 / 16];
    let mut d = bytes.clone();
    for b in &mut d[at + 9 + len / 2..at + 9 + len / 2 + 4] {
        *b ^= 0x5a;
    }
    let path = write("damaged_once.mcap", &d);
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    let report = report.expect("a report");
    let missing = report["data"]["missing"].as_array().expect("data.missing");
    assert_eq!(missing.len(), 1, "{missing:?}");
    let (first, last) = (
        missing[0]["first_sequence"].as_u64().unwrap(),
        missing[0]["last_sequence"].as_u64().unwrap(),
    );
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning"))
        .collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].contains("damaged") && lines[0].contains(&format!("sequence {first} to {last}")),
        "{stderr}"
    );
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

// ---------------------------------------------------------------------------------------------
// Chunks duplicated, swapped, removed; settings lost; two runs in one file

/// The log's data section as units: every record from the header's end to the data end, each
/// chunk with the message indexes that follow it as one unit, (offset, length); and the offset
/// of the data end record (the summary and footer from there on are kept as they are).
fn units(bytes: &[u8]) -> (Vec<(usize, usize)>, usize) {
    let record = |pos: usize| {
        let n = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        (bytes[pos], 9 + n)
    };
    let (_, header) = record(8);
    let mut pos = 8 + header;
    let mut out: Vec<(usize, usize)> = Vec::new();
    loop {
        let (op, len) = record(pos);
        match op {
            // Data end.
            0x0f => return (out, pos),
            // A message index belongs to the chunk before it.
            0x07 if !out.is_empty() => {
                if let Some(last) = out.last_mut() {
                    last.1 += len;
                }
            }
            _ => out.push((pos, len)),
        }
        pos += len;
    }
}

/// `bytes` with its data section's units replaced by `order` (units of [`units`], in the
/// order given: a unit may be repeated or left out). The summary keeps its offsets, which no
/// longer match: the reader reads the data section as it finds it, as after a disk's damage.
fn rebuilt(bytes: &[u8], order: &[(usize, usize)]) -> Vec<u8> {
    let (first, _) = units(bytes).0[0];
    let (_, end) = units(bytes);
    let mut out = bytes[..first].to_vec();
    for &(at, len) in order {
        out.extend_from_slice(&bytes[at..at + len]);
    }
    out.extend_from_slice(&bytes[end..]);
    out
}

/// The log times of the `/run/estimator` messages of measurement `run`, in file order.
fn settings_times(bytes: &[u8], run: &str) -> Vec<u64> {
    mcap::MessageStream::new(bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == runlog::messages::ESTIMATOR_SETTINGS)
        .filter(|m| {
            serde_json::from_slice::<runlog::metadata::EstimatorSettings>(&m.data)
                .unwrap()
                .run
                == run
        })
        .map(|m| m.log_time)
        .collect()
}

/// The data units that are chunks of the loaded run's excitation: their messages' log times
/// from its first `/run/estimator` message on, up to its last `/sensors` block, by the
/// summary's chunk index.
fn loaded_chunks(bytes: &[u8]) -> Vec<(usize, usize)> {
    let summary = mcap::Summary::read(bytes).unwrap().expect("a summary");
    let start = settings_times(bytes, "loaded")[0];
    let sensors = summary
        .channels
        .values()
        .find(|c| c.topic == runlog::messages::SENSORS)
        .unwrap()
        .id;
    let end = summary
        .chunk_indexes
        .iter()
        .filter(|c| c.message_index_offsets.contains_key(&sensors))
        .map(|c| c.message_end_time)
        .max()
        .unwrap();
    let within: Vec<usize> = summary
        .chunk_indexes
        .iter()
        .filter(|c| c.message_start_time > start && c.message_end_time < end)
        .filter(|c| c.message_index_offsets.contains_key(&sensors))
        .map(|c| c.chunk_start_offset as usize)
        .collect();
    units(bytes)
        .0
        .into_iter()
        .filter(|(at, _)| within.contains(at))
        .collect()
}

/// `stewart estimate LOG --report R` run as a user runs it: (exit code, standard error, the
/// report's JSON when one was written).
fn estimate_cli(log: &Path) -> (Option<i32>, String, Option<serde_json::Value>) {
    let report = log.with_extension("json");
    let _ = std::fs::remove_file(&report);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_stewart"))
        .arg("estimate")
        .arg(log)
        .arg("--quiet")
        .arg("--report")
        .arg(&report)
        .output()
        .expect("the binary runs");
    let json = std::fs::read(&report)
        .ok()
        .map(|b| serde_json::from_slice(&b).unwrap());
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        json,
    )
}

/// The report's estimate and sigma as the JSON has them, to compare reports to the digit.
fn quantities(report: &serde_json::Value) -> (serde_json::Value, serde_json::Value, u64) {
    (
        report["estimate"].clone(),
        report["sigma"].clone(),
        report["samples"].as_u64().unwrap(),
    )
}

/// The clean log's report, by the binary.
fn clean_report() -> &'static serde_json::Value {
    static CLEAN: OnceLock<serde_json::Value> = OnceLock::new();
    CLEAN.get_or_init(|| {
        let (run, bytes) = run();
        let path = run.dir.path().join("clean_copy.mcap");
        std::fs::write(&path, bytes).unwrap();
        let (code, stderr, json) = estimate_cli(&path);
        assert_eq!(code, Some(0), "{stderr}");
        assert!(!stderr.contains("warning"), "{stderr}");
        json.expect("a report")
    })
}

/// The issue: `/run/estimator` was written once per measurement, so one flipped bit in its
/// chunk gave "its excitation never started" and no estimate. The settings are repeated
/// while the measurement runs and at its end: the damage costs its own span, and the report
/// and the terminal say which record was lost and where its settings were read from.
#[test]
fn a_damaged_estimator_settings_chunk_costs_its_span_only() {
    let (run, bytes) = run();
    assert!(
        settings_times(bytes, "loaded").len() >= 2,
        "the loaded run's settings are written more than once"
    );
    let first = settings_times(bytes, "loaded")[0];
    let summary = mcap::Summary::read(bytes).unwrap().unwrap();
    let chunk = summary
        .chunk_indexes
        .iter()
        .find(|c| c.message_start_time <= first && first <= c.message_end_time)
        .expect("the chunk of the first copy");
    let (at, len) = (
        chunk.chunk_start_offset as usize,
        chunk.chunk_length as usize,
    );
    let mut d = bytes.clone();
    d[at + len / 2] ^= 0x10;
    let path = write("settings_damaged.mcap", &d);
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.contains("/run/estimator") && stderr.contains("damaged"),
        "{stderr}"
    );
    let report = report.expect("a report");
    let data = &report["data"];
    assert_eq!(data["damaged"].as_array().unwrap().len(), 1, "{data}");
    let recovered = data["recovered"].as_array().expect("data.recovered");
    assert!(
        recovered
            .iter()
            .any(|r| r.as_str().unwrap().contains("/run/estimator")),
        "{recovered:?}"
    );
    // The span lost (about half a second) is all the estimate loses.
    let clean = clean_report()["samples"].as_u64().unwrap();
    let samples = report["samples"].as_u64().unwrap();
    assert!(samples * 10 > clean * 7, "{samples} samples of {clean}");
    let _ = run;
}

/// The issue: every loaded chunk written twice gave a rejected share of 0.5 (three times:
/// exit 4, "check the leg force and length sensors"). The copies are dropped as duplicates by
/// their sequence numbers, counted and named: the estimate is the clean log's to the digit.
#[test]
fn every_loaded_chunk_written_two_or_three_times_is_read_once() {
    let (_, bytes) = run();
    let loaded = loaded_chunks(bytes);
    assert!(loaded.len() >= 4, "{} loaded chunks", loaded.len());
    let clean = clean_report();
    for times in [2, 3] {
        let order: Vec<_> = units(bytes)
            .0
            .into_iter()
            .flat_map(|u| std::iter::repeat_n(u, if loaded.contains(&u) { times } else { 1 }))
            .collect();
        let path = write(
            &format!("written_{times}_times.mcap"),
            &rebuilt(bytes, &order),
        );
        let (code, stderr, report) = estimate_cli(&path);
        assert_eq!(code, Some(0), "{times} times: {stderr}");
        let report = report.expect("a report");
        assert_eq!(quantities(&report), quantities(clean), "{times} times");
        let data = &report["data"];
        assert_eq!(data["rejected_share"], clean["data"]["rejected_share"]);
        assert!(data["frames_duplicate"].as_u64().unwrap() > 500, "{data}");
        let spans = data["reordered"].as_array().expect("data.reordered");
        assert!(
            !spans.is_empty() && spans.iter().all(|s| s["action"] == "dropped as duplicates"),
            "{spans:?}"
        );
        assert!(stderr.contains("duplicate"), "{stderr}");
    }
}

/// The issue: two chunks swapped moved the mass by −1.08 kg (σ 0.32 → 1.02) with no warning.
/// The frames are put back in sequence order, the estimate is the clean log's to the digit,
/// and the span that came out of place is named.
#[test]
fn two_swapped_chunks_are_put_back_in_order_and_named() {
    let (_, bytes) = run();
    let loaded = loaded_chunks(bytes);
    let (a, b) = (loaded[loaded.len() / 2], loaded[loaded.len() / 2 + 1]);
    let order: Vec<_> = units(bytes)
        .0
        .into_iter()
        .map(|u| {
            if u == a {
                b
            } else if u == b {
                a
            } else {
                u
            }
        })
        .collect();
    let path = write("swapped.mcap", &rebuilt(bytes, &order));
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    let report = report.expect("a report");
    assert_eq!(quantities(&report), quantities(clean_report()));
    let spans = report["data"]["reordered"]
        .as_array()
        .expect("data.reordered");
    assert_eq!(spans.len(), 1, "{spans:?}");
    let span = &spans[0];
    assert_eq!(span["action"], "put back in order", "{span}");
    assert_eq!(span["run"], "loaded", "{span}");
    let frames = span["frames"].as_u64().unwrap();
    assert!((100..2000).contains(&frames), "{span}");
    assert!(
        stderr.contains("out of order") && stderr.contains("put back"),
        "{stderr}"
    );
}

/// The issue: a `/sensors` block that came more than about 50 blocks late was counted neither
/// late nor duplicate, but its frames were rejected by the estimator. It takes its place.
#[test]
fn a_block_sixty_blocks_late_takes_its_place() {
    let (run, bytes) = run();
    let messages: Vec<_> = mcap::MessageStream::new(bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .collect();
    let start = settings_times(bytes, "loaded")[0];
    let sensors: Vec<usize> = (0..messages.len())
        .filter(|&k| messages[k].channel.topic == runlog::messages::SENSORS)
        .filter(|&k| messages[k].log_time > start + 2_000_000_000)
        .collect();
    let (from, to) = (sensors[0], sensors[60]);
    let mut order: Vec<usize> = (0..messages.len()).filter(|&k| k != from).collect();
    let at = order.iter().position(|&k| k == to).unwrap() + 1;
    order.insert(at, from);
    let path = run.dir.path().join("late_block.mcap");
    let mut out = mcap::Writer::new(std::io::BufWriter::new(
        std::fs::File::create(&path).unwrap(),
    ))
    .unwrap();
    for k in order {
        out.write(&messages[k]).unwrap();
    }
    out.finish().unwrap();
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    let report = report.expect("a report");
    assert_eq!(quantities(&report), quantities(clean_report()));
    assert_eq!(
        report["rejected_samples"],
        clean_report()["rejected_samples"]
    );
    let spans = report["data"]["reordered"].as_array().unwrap();
    assert_eq!(spans.len(), 1, "{spans:?}");
    assert_eq!(spans[0]["frames"], 10, "{spans:?}");
}

/// The issue: a chunk cleanly missing (no damage to find) gave no warning, only a count of
/// lost frames. The frames' sequence numbers name the missing span, in the report and on the
/// terminal.
#[test]
fn a_cleanly_missing_chunk_is_named() {
    let (_, bytes) = run();
    let loaded = loaded_chunks(bytes);
    let gone = loaded[loaded.len() / 2];
    let order: Vec<_> = units(bytes).0.into_iter().filter(|u| *u != gone).collect();
    let path = write("chunk_removed.mcap", &rebuilt(bytes, &order));
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    let report = report.expect("a report");
    let data = &report["data"];
    let missing = data["missing"].as_array().expect("data.missing");
    assert_eq!(missing.len(), 1, "{missing:?}");
    let span = &missing[0];
    assert_eq!(span["run"], "loaded", "{span}");
    let frames = span["frames"].as_u64().unwrap();
    assert_eq!(
        span["last_sequence"].as_u64().unwrap() - span["first_sequence"].as_u64().unwrap() + 1,
        frames
    );
    assert!((100..2000).contains(&frames), "{span}");
    assert!(
        stderr.contains("missing") && stderr.contains(&span["first_sequence"].to_string()),
        "{stderr}"
    );
}

/// A copy of the log at `from` written as a second run would write it, merged with the first
/// into `to` by log time, as two processes writing one file interleave: the second run starts
/// 0.3 s later (its log times and start time shifted) and its load cells read 1 N more;
/// with `with_metadata` false, the second run's metadata is left out (lost).
fn interleaved(from: &Path, to: &Path, with_metadata: bool) {
    use prost::Message as _;
    const SHIFT_NS: u64 = 300_000_000;
    let bytes = std::fs::read(from).unwrap();
    let mut all = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        all.push(m.clone());
        let mut b = m;
        b.log_time += SHIFT_NS;
        b.publish_time += SHIFT_NS;
        match b.channel.topic.as_str() {
            runlog::messages::METADATA if !with_metadata => continue,
            runlog::messages::METADATA => {
                let mut meta: serde_json::Value = serde_json::from_slice(&b.data).unwrap();
                let start = meta["start_unix_ns"].as_u64().unwrap();
                meta["start_unix_ns"] = (start + SHIFT_NS).into();
                b.data = serde_json::to_vec(&meta).unwrap().into();
            }
            runlog::messages::SENSORS => {
                let p = runlog::proto::SensorBlock::decode(&b.data[..]).unwrap();
                let run = if p.run == "tare" { "tare" } else { "loaded" };
                let mut frames = runlog::compact::sensor_frames(&p).unwrap();
                for f in &mut frames {
                    for force in &mut f.leg_forces_n {
                        *force += 1.0;
                    }
                }
                let block = runlog::compact::SensorBlock::of_frames(run, &frames);
                b.data = runlog::proto::to_bytes(&block).into();
            }
            _ => {}
        }
        all.push(b);
    }
    all.sort_by_key(|m| m.log_time);
    let mut out =
        mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(to).unwrap())).unwrap();
    for m in &all {
        out.write(m).unwrap();
    }
    out.finish().unwrap();
}

/// The issue: two measurements writing one file gave a log that mixes both runs, and
/// `estimate` exited 0 on it. Two different metadata records, or frames of one measurement
/// that carry one sequence number with different readings, are two runs: refused, saying so.
#[test]
fn a_log_of_two_interleaved_runs_is_refused() {
    let (run, _) = run();
    for with_metadata in [true, false] {
        let path = run
            .dir
            .path()
            .join(format!("two_runs_{with_metadata}.mcap"));
        interleaved(&run.log, &path, with_metadata);
        let (code, stderr, report) = estimate_cli(&path);
        assert_eq!(code, Some(2), "metadata {with_metadata}: {stderr}");
        assert!(report.is_none());
        assert!(
            stderr.contains("two runs") && stderr.contains(&path.display().to_string()),
            "metadata {with_metadata}: {stderr}"
        );
        let err = format!("{:#}", estimate(&args(&path)).unwrap_err());
        assert!(err.contains("two runs"), "{err}");
        // The reader that keeps the whole log in memory (the figures') refuses it alike.
        let err = format!("{:#}", runlog::LogContents::read(&path).unwrap_err());
        assert!(
            err.contains("two runs") && err.contains(&path.display().to_string()),
            "metadata {with_metadata}: {err}"
        );
    }
}

/// Two chunks swapped where the tare run ends and the loaded run begins: the chunk of the
/// loaded run's first `/sensors` block before the chunk of the tare's last. Each run's frames
/// are its own (every block names its run), so both are whole and the estimate is the clean
/// log's.
#[test]
fn two_chunks_swapped_across_the_runs_boundary_are_put_back_in_order() {
    use prost::Message as _;
    let (_, bytes) = run();
    // The log times of the tare's last block and of the loaded run's first.
    let (mut last_tare, mut first_loaded) = (0, u64::MAX);
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic == runlog::messages::SENSORS {
            let p = runlog::proto::SensorBlock::decode(&m.data[..]).unwrap();
            if p.run == "tare" {
                last_tare = last_tare.max(m.log_time);
            } else {
                first_loaded = first_loaded.min(m.log_time);
            }
        }
    }
    let summary = mcap::Summary::read(bytes).unwrap().expect("a summary");
    let holding = |t: u64| {
        summary
            .chunk_indexes
            .iter()
            .filter(|c| c.message_start_time <= t && t <= c.message_end_time)
            .map(|c| c.chunk_start_offset as usize)
            .max()
            .unwrap()
    };
    let all = units(bytes).0;
    let at = |offset: usize| all.iter().position(|u| u.0 == offset).unwrap();
    let (a, b) = (at(holding(last_tare)), at(holding(first_loaded)));
    // When one chunk holds both, the loaded run's next chunk goes before it.
    let (a, b) = if a == b { (a, a + 1) } else { (a, b) };
    let mut order = all.clone();
    order.swap(a, b);
    let path = write("swapped_at_boundary.mcap", &rebuilt(bytes, &order));
    let (code, stderr, report) = estimate_cli(&path);
    assert_eq!(code, Some(0), "{stderr}");
    let report = report.expect("a report");
    assert_eq!(quantities(&report), quantities(clean_report()));
}
