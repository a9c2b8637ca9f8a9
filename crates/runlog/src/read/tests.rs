//! The reader on logs written by the run logger: intact, cut, damaged, and mutated.

use super::*;
use crate::compact::{quantise_frame, SensorBlock, SensorCounts};
use crate::mcap_log::McapLog;
use crate::messages::channels;

/// Frame `i`, at the log's resolution (as the backends read it).
fn frame(i: u64) -> control::io::SensorFrame {
    quantise_frame(&control::io::SensorFrame {
        sequence: i,
        time_s: i as f64 * 1e-3,
        leg_lengths_m: [1.9 + i as f64 * 1e-7; 6],
        leg_forces_n: [f64::NAN, 2.0, 3.0, 4.0, 5.0, 6.0],
        gyro_rad_s: [0.1, -0.2, 1.0 / 3.0],
        accel_m_s2: [0.0, 0.0, 9.80665],
        status: control::io::Status(0),
    })
}

/// A `/sensors` message of the one frame `f`.
fn block(f: &control::io::SensorFrame) -> SensorBlock {
    let mut b = SensorBlock::new("loaded");
    b.push(f, &mut SensorCounts::default());
    b.finish();
    b
}

/// A log of `n` sensor frames in chunks of 100, as bytes.
fn log_bytes(n: u64) -> Vec<u8> {
    log_bytes_chunked(n, 100)
}

/// A log of `n` sensor frames in chunks of `every`, as the run logger writes it.
fn log_bytes_chunked(n: u64, every: u64) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.mcap");
    let mut log = McapLog::create(&path, &channels()).unwrap();
    for i in 0..n {
        log.write_proto(SENSORS_TOPIC, 1_000 + i, &block(&frame(i)))
            .unwrap();
        if i % every == every - 1 {
            log.flush().unwrap();
        }
    }
    log.finish().unwrap();
    std::fs::read(&path).unwrap()
}

const SENSORS_TOPIC: &str = topics::SENSORS;

/// A log as older versions wrote them (`/sensors` in JSON, one frame a message) is refused,
/// saying what it is and what this version reads.
#[test]
fn a_log_in_an_unknown_encoding_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("json.mcap");
    let mut specs = channels();
    for c in &mut specs {
        if c.topic == SENSORS_TOPIC {
            c.encoding = crate::mcap_log::Encoding::Json;
            c.schema_name = "stewart.SensorFrame";
        }
    }
    let mut log = McapLog::create(&path, &specs).unwrap();
    for i in 0..50 {
        log.write(
            SENSORS_TOPIC,
            1_000 + i,
            &serde_json::json!({"sequence": i}),
        )
        .unwrap();
    }
    log.finish().unwrap();
    let err = format!("{:#}", LogContents::read(&path).unwrap_err());
    assert!(
        err.contains("/sensors channel is stewart.SensorFrame in json encoding")
            && err.contains("reads stewart.SensorBlock in protobuf"),
        "{err}"
    );
}

#[test]
fn reads_frames_back_exactly_at_the_logs_resolution_nan_included() {
    let log = LogContents::from_bytes(&log_bytes(250)).unwrap();
    assert!(log.truncated.is_none());
    assert_eq!(log.sensors.len(), 250);
    let info = &log.channels[topics::SENSORS];
    assert_eq!(
        (info.count, info.first_ns, info.last_ns, info.monotonic),
        (250, 1_000, 1_249, true)
    );
    assert_eq!(info.schema_name, "stewart.SensorBlock");
    assert_eq!(info.message_encoding, "protobuf");
    assert_eq!(info.schema_encoding, "protobuf");
    for (i, s) in log.sensors.iter().enumerate() {
        let f = frame(i as u64);
        assert_eq!(s.time_s.to_bits(), f.time_s.to_bits());
        assert_eq!(s.leg_lengths_m, f.leg_lengths_m);
        assert_eq!(s.gyro_rad_s[2].to_bits(), f.gyro_rad_s[2].to_bits());
        assert_eq!(s.gyro_rad_s[2], 0.333_333, "1/3 rad/s at the µrad/s");
        assert!(s.leg_forces_n[0].is_nan());
    }
    assert_eq!(log.runs(), vec!["loaded".to_string()]);
    let err = log
        .require_channel(topics::ESTIMATOR_SETTINGS, "the settings")
        .unwrap_err();
    assert!(err.to_string().contains("/run/estimator"), "{err}");
    assert!(log
        .require_metadata()
        .unwrap_err()
        .to_string()
        .contains("/run/metadata"));
}

#[test]
fn a_cut_log_gives_its_complete_chunks() {
    let bytes = log_bytes(1000);
    let whole = LogContents::from_bytes(&bytes).unwrap().sensors;
    for cut in [bytes.len() / 3, bytes.len() / 2, bytes.len() - 50] {
        let log = LogContents::from_bytes(&bytes[..cut]).unwrap();
        assert!(log.truncated.is_some(), "cut at {cut}");
        // Whole chunks of 100 frames, the start of the full log.
        assert_eq!(log.sensors.len() % 100, 0, "cut at {cut}");
        // Debug text compares NaN (the logged non-finite force) as equal to itself.
        let prefix = format!("{:?}", &whole[..log.sensors.len()]);
        assert_eq!(format!("{:?}", &log.sensors[..]), prefix, "cut at {cut}");
    }
    assert!(LogContents::from_bytes(b"not an mcap file").is_err());
    assert!(LogContents::from_bytes(&bytes[..5]).is_err());
}

/// (offset, opcode, body length) of every top-level record of an intact log.
fn records(bytes: &[u8]) -> Vec<(usize, u8, usize)> {
    let mut out = Vec::new();
    let mut pos = 8;
    while pos + 9 <= bytes.len() - 8 {
        let op = bytes[pos];
        let n = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        out.push((pos, op, n));
        pos += 9 + n;
    }
    out
}

/// Chunk records holding messages (the first chunk holds only the definitions).
fn data_chunks(bytes: &[u8]) -> Vec<(usize, usize)> {
    records(bytes)
        .into_iter()
        .filter(|r| r.1 == 0x06)
        .skip(1)
        .map(|r| (r.0, r.2))
        .collect()
}

/// Each record read is the frame its sequence number says, bit for bit.
fn assert_exact(log: &LogContents) {
    for s in &log.sensors {
        let f = frame(s.sequence);
        assert_eq!(s.time_s.to_bits(), f.time_s.to_bits());
        assert_eq!(
            s.leg_lengths_m.map(f64::to_bits),
            f.leg_lengths_m.map(f64::to_bits)
        );
        assert_eq!(
            s.leg_forces_n.map(f64::to_bits),
            f.leg_forces_n.map(f64::to_bits)
        );
        assert_eq!(
            s.gyro_rad_s.map(f64::to_bits),
            f.gyro_rad_s.map(f64::to_bits)
        );
        assert_eq!(
            s.accel_m_s2.map(f64::to_bits),
            f.accel_m_s2.map(f64::to_bits)
        );
    }
}

#[test]
fn one_flipped_byte_in_a_chunk_loses_only_that_chunks_frames_and_says_its_span() {
    let bytes = log_bytes(1000);
    let chunks = data_chunks(&bytes);
    assert_eq!(chunks.len(), 10);
    for (k, &(at, n)) in chunks.iter().enumerate() {
        // Inside the compressed records, and in the chunk's uncompressed size (the field whose
        // damage made the mcap crate allocate exabytes and abort).
        for offset in [at + 9 + n / 2, at + 9 + 16 + 5] {
            let mut d = bytes.clone();
            d[offset] ^= 0xff;
            let log = LogContents::from_bytes(&d).unwrap();
            assert!(log.truncated.is_none(), "chunk {k}: {:?}", log.truncated);
            let lost: Vec<u64> = (0..1000)
                .filter(|i| !log.sensors.iter().any(|s| s.sequence == *i))
                .collect();
            let first = k as u64 * 100;
            assert_eq!(lost, (first..first + 100).collect::<Vec<_>>(), "chunk {k}");
            assert_exact(&log);
            let d = &log.damaged.damaged;
            assert_eq!(d.len(), 1, "chunk {k}: {d:?}");
            assert_eq!(d[0].gap.offset, at as u64);
            // The chunk and the message indexes after it, up to the next chunk.
            match chunks.get(k + 1) {
                Some(&(next, _)) => assert_eq!(d[0].gap.bytes, (next - at) as u64),
                None => assert!(d[0].gap.bytes > 9 + n as u64),
            }
            assert!(
                d[0].gap.reason.contains("damaged chunk"),
                "{}",
                d[0].gap.reason
            );
            // The span: from the last frame before the chunk to the first after it.
            let before = (k > 0).then(|| 1_000 + first - 1);
            let after = (k < 9).then(|| 1_000 + first + 100);
            assert_eq!((d[0].gap.after_ns, d[0].gap.before_ns), (before, after));
            let frames = if k < 9 { Some(100) } else { None };
            assert_eq!(d[0].sensor_frames, frames, "chunk {k}");
            assert_eq!(log.damaged.first_ns, if k == 0 { 1_100 } else { 1_000 });
        }
    }
}

#[test]
fn a_damaged_definitions_chunk_is_recovered_from_the_summary() {
    let bytes = log_bytes(300);
    let (at, n) = records(&bytes)
        .into_iter()
        .find(|r| r.1 == 0x06)
        .map(|r| (r.0, r.2))
        .unwrap();
    let mut d = bytes.clone();
    d[at + 9 + n - 3] ^= 0x10;
    let log = LogContents::from_bytes(&d).unwrap();
    assert_eq!(log.sensors.len(), 300);
    assert_eq!(log.damaged.damaged.len(), 1);
    assert_eq!(log.damaged.damaged[0].sensor_frames, Some(0));
    assert_eq!(
        log.channels[topics::SENSORS].schema_name,
        "stewart.SensorBlock"
    );
}

#[test]
fn damage_without_a_footer_is_skipped_by_scanning_for_the_next_chunk() {
    let bytes = log_bytes(600);
    let chunks = data_chunks(&bytes);
    // Cut the summary off and damage the third data chunk: the reader finds the fourth by
    // scanning, and says the file was cut.
    let end = chunks[5].0 + 9 + chunks[5].1;
    let mut d = bytes[..end + 20].to_vec();
    d[chunks[2].0 + 9 + chunks[2].1 / 3] ^= 0x01;
    let log = LogContents::from_bytes(&d).unwrap();
    assert!(log.truncated.is_some());
    let seqs: Vec<u64> = log.sensors.iter().map(|s| s.sequence).collect();
    let want: Vec<u64> = (0..200).chain(300..600).collect();
    assert_eq!(seqs, want);
    assert_eq!(log.damaged.damaged[0].sensor_frames, Some(100));
    assert_exact(&log);
}

/// xorshift64*: reproducible mutants without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Mutation fuzz: thousands of mutants of a run log (byte flips, multi-byte flips, overwritten
/// record lengths and chunk size fields, cuts, zeroed ranges) all open without a panic or an
/// abort, every frame read is exact, and one flip costs at most one chunk.
#[test]
fn thousands_of_mutants_open_without_a_panic_and_lose_only_what_is_damaged() {
    const FRAMES: u64 = 300;
    const EVERY: u64 = 15;
    let bytes = log_bytes_chunked(FRAMES, EVERY);
    let recs = records(&bytes);
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut outcomes = [0u64; 4]; // intact, damaged, cut, refused
    let kinds = 6;
    let per_kind = 500;
    for m in 0..kinds * per_kind {
        let mut d = bytes.clone();
        let kind = m / per_kind;
        match kind {
            0 => {
                let at = 8 + rng.below(d.len() - 8);
                d[at] ^= 1 << rng.below(8);
            }
            1 => {
                for _ in 0..2 + rng.below(9) {
                    let at = rng.below(d.len());
                    d[at] ^= (rng.next() as u8) | 1;
                }
            }
            2 => {
                // A record's length, or a chunk's size fields, overwritten.
                let (at, op, _) = recs[rng.below(recs.len())];
                let field = if op == 0x06 && rng.below(2) == 0 {
                    at + 9 + 16 + 8 * rng.below(2)
                } else {
                    at + 1
                };
                let v = match rng.below(3) {
                    0 => u64::MAX - rng.below(16) as u64,
                    1 => rng.next(),
                    _ => rng.next() % 4096,
                };
                d[field..field + 8].copy_from_slice(&v.to_le_bytes());
            }
            3 => d.truncate(rng.below(d.len())),
            4 => {
                let at = rng.below(d.len());
                let n = 1 + rng.below(2000);
                let end = (at + n).min(d.len());
                d[at..end].fill(0);
            }
            _ => {
                let at = rng.below(d.len() - 8);
                let v = rng.next().to_le_bytes();
                d[at..at + 8].copy_from_slice(&v);
            }
        }
        match LogContents::from_bytes(&d) {
            Err(e) => {
                // Only a file without its magic is refused.
                assert!(!d.starts_with(scan::MAGIC), "mutant {m}: {e:#}");
                outcomes[3] += 1;
            }
            Ok(log) => {
                assert_exact(&log);
                if kind == 0 {
                    assert!(
                        log.sensors.len() as u64 >= FRAMES - EVERY,
                        "mutant {m}: one flip lost {} frames",
                        FRAMES - log.sensors.len() as u64
                    );
                }
                let i = if log.truncated.is_some() {
                    2
                } else if log.damaged.damaged.is_empty() {
                    0
                } else {
                    1
                };
                outcomes[i] += 1;
            }
        }
    }
    eprintln!(
        "mutants: intact {}, damaged {}, cut {}, refused {}",
        outcomes[0], outcomes[1], outcomes[2], outcomes[3]
    );
    assert!(outcomes[1] > 1000 && outcomes[2] > 300, "{outcomes:?}");
}

/// A measurement's settings are written at its excitation's start, every
/// `SETTINGS_REPEAT_S` of its frames and at its end, every copy the same: one damaged chunk
/// cannot take them all.
#[test]
fn estimator_settings_are_repeated_while_a_measurement_runs_and_at_its_end() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("settings.mcap");
    let geometry = kinematics::Geometry::from_radii(
        1.5,
        1.2,
        0.3,
        0.3,
        kinematics::StrokeLimits {
            min_length_m: 1.6,
            max_length_m: 2.4,
        },
    )
    .unwrap();
    let c = estimator::EstimatorConfig::new(geometry, 1e-3);
    let settings = |run: &str| {
        crate::metadata::EstimatorSettings::from_config(run, &c, &kinematics::FkOptions::default())
    };
    let mut log = crate::RunLog::create(&path, 1_000_000_000).unwrap();
    // 12 s of frames from the excitation's start at 1 s: copies at 1, 6 and 11 s, and the end.
    for i in 0..13_000u64 {
        let f = frame(i);
        if i == 1000 {
            log.write_settings(f.time_s, &settings("tare")).unwrap();
        }
        log.write_sensor("tare", &f).unwrap();
    }
    // The next measurement ends the first's copies; its own end is the log's.
    log.write_settings(13.0, &settings("loaded")).unwrap();
    for i in 13_000..14_000u64 {
        log.write_sensor("loaded", &frame(i)).unwrap();
    }
    log.finish().unwrap();
    // Every copy as written (the in-memory reader keeps one per measurement).
    struct Copies(Vec<crate::metadata::EstimatorSettings>);
    impl Visitor for Copies {
        fn message(&mut self, m: &Message<'_>) -> Result<Option<String>> {
            if m.channel.topic == topics::ESTIMATOR_SETTINGS {
                self.0.push(decode(m.data).unwrap());
            }
            Ok(None)
        }
    }
    let mut all = Copies(Vec::new());
    visit(std::fs::File::open(&path).unwrap(), &mut all).unwrap();
    let copies = |run: &str| all.0.iter().filter(|s| s.run == run).count();
    assert_eq!(copies("tare"), 4);
    assert_eq!(copies("loaded"), 2);
    assert!(all.0.iter().all(|s| *s == settings(&s.run)));
    let read = LogContents::read(&path).unwrap();
    assert_eq!(
        read.settings.len(),
        2,
        "one copy of each measurement's kept"
    );
}
