//! A log from `simulate`, read back with the `mcap` crate: every channel that
//! `docs/log-schema.md` documents is present with its schema name and encodings, the counts
//! fit the run's duration and the documented rates, and the times never go backwards.

use crate::support;

use std::collections::BTreeMap;

use runlog::run_log::rates;
use runlog::LogContents;

/// The channel table of docs/log-schema.md: topic → (schema name, message encoding). The
/// document says which schema encoding goes with each message encoding.
fn documented() -> BTreeMap<String, (String, String)> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/log-schema.md"))
        .expect("docs/log-schema.md");
    assert!(text.contains("message encoding `json` with schema encoding `jsonschema`"));
    assert!(text.contains("message encoding `protobuf` with schema encoding `protobuf`"));
    let mut out = BTreeMap::new();
    for line in text.lines() {
        // | `topic` | `schema` | encoding | rate | content |
        let cells: Vec<&str> = line
            .split('|')
            .map(|c| c.trim().trim_matches('`'))
            .collect();
        if cells.len() > 5 && cells[1].starts_with('/') {
            out.insert(
                cells[1].to_string(),
                (cells[2].to_string(), cells[3].to_string()),
            );
        }
    }
    out
}

/// Channels only a rig run writes.
fn rig_only(topic: &str) -> bool {
    topic.starts_with("/rig/")
}

#[test]
fn every_documented_channel_is_in_the_catalogue() {
    let doc = documented();
    let catalogue = runlog::messages::channels();
    assert_eq!(doc.len(), catalogue.len(), "documented: {:?}", doc.keys());
    for spec in &catalogue {
        let (schema, encoding) = doc
            .get(spec.topic)
            .unwrap_or_else(|| panic!("{} is not documented", spec.topic));
        assert_eq!(schema, spec.schema_name, "{}", spec.topic);
        assert_eq!(encoding, spec.encoding.message_encoding(), "{}", spec.topic);
    }
}

#[test]
fn a_simulate_log_reads_back_as_documented() {
    let run = support::simulate();
    // Read with the mcap crate directly: every message, its channel and schema (every channel
    // has one: the reader checks).
    let mut seen: BTreeMap<String, (String, String, String, u64, u64, bool)> = BTreeMap::new();
    let mut last_log_time = 0u64;
    let mut file_monotonic = true;
    for m in support::read_messages(&run.log) {
        let e = seen.entry(m.topic.clone()).or_insert((
            m.schema_name.clone(),
            m.schema_encoding.clone(),
            m.message_encoding.clone(),
            0,
            0,
            true,
        ));
        e.3 += 1;
        if m.log_time < e.4 {
            e.5 = false;
        }
        e.4 = m.log_time;
        file_monotonic &= m.log_time >= last_log_time;
        last_log_time = m.log_time;
        // Every message is a JSON object, protobuf ones decoded (tests/log_schema_validation.rs
        // checks each against its channel's JSON schema).
        assert!(m.value.is_object(), "{}", m.topic);
    }
    assert!(file_monotonic, "log times go backwards in the file");
    for (topic, (schema, encoding)) in documented() {
        if rig_only(&topic) {
            continue;
        }
        let (s, se, me, n, _, mono) = seen
            .get(&topic)
            .unwrap_or_else(|| panic!("channel {topic} missing from the log"));
        assert_eq!(*s, schema, "{topic}");
        assert_eq!(*me, encoding, "{topic}");
        let schema_encoding = if encoding == "json" {
            "jsonschema"
        } else {
            "protobuf"
        };
        assert_eq!(se, schema_encoding, "{topic}");
        assert!(*n > 0 && *mono, "{topic}: {n} messages, monotonic {mono}");
    }
    // Counts against the duration and rates.
    let log = LogContents::read(&run.log).unwrap();
    // Each schema the log carries is the catalogue's: its JSON schema document, or the
    // descriptor set (support::read_messages decoded every protobuf message with it).
    for spec in runlog::messages::channels() {
        if rig_only(spec.topic) {
            continue;
        }
        if spec.encoding != runlog::mcap_log::Encoding::Json {
            // The project's descriptor set, or the Foxglove SDK's for a well-known message.
            let carried = String::from_utf8_lossy(&spec.schema_data().unwrap()).into_owned();
            assert_eq!(
                log.channels[spec.topic].schema_text, carried,
                "{}",
                spec.topic
            );
            continue;
        }
        let carried: serde_json::Value =
            serde_json::from_str(&log.channels[spec.topic].schema_text).unwrap();
        assert_eq!(
            carried,
            spec.schema.document(spec.schema_name),
            "{}",
            spec.topic
        );
    }
    assert!(log.truncated.is_none(), "{:?}", log.truncated);
    let meta = log.metadata.as_ref().unwrap();
    let rate_hz = 1.0 / meta.sample_period_s;
    assert_eq!(log.runs(), meta.runs);
    // Per channel, the fewest and the most messages the runs allow: derived channels start
    // after the brake hold (with half a second in hand), the estimate with the excitation,
    // and each run may add one final estimate and a message at either end.
    let hold_s = ops::estimate::rig_description_of(meta, None)
        .unwrap()
        .config
        .run
        .brake_hold_s;
    let mut bounds = BTreeMap::<&str, (f64, f64)>::new();
    for run_name in log.runs() {
        let frames: Vec<_> = log.sensors_of(&run_name).collect();
        let span = frames.last().unwrap().time_s - frames[0].time_s;
        // One sequence number per sample period, strictly increasing times and sequences; the
        // simulated rig loses a few frames (0.1 % by the datasheet), whose numbers are skipped.
        let periods = frames.last().unwrap().sequence - frames[0].sequence;
        assert!(
            (periods as f64 - span * rate_hz).abs() < 1.0,
            "{run_name}: {periods} sample periods over {span} s"
        );
        let missing = periods + 1 - frames.len() as u64;
        assert!(
            missing as f64 <= 0.01 * periods as f64,
            "{run_name}: {missing} frames lost of {periods}"
        );
        for w in frames.windows(2) {
            assert!(w[1].time_s > w[0].time_s);
            assert!(w[1].sequence > w[0].sequence);
        }
        let settings = log.settings_of(&run_name).unwrap();
        let excite = settings.window_end_s.unwrap() - settings.window_start_s.unwrap();
        for (topic, hz, from_s) in [
            ("/pose", rates::DERIVED_HZ, hold_s + 0.5),
            ("/legs", rates::DERIVED_HZ, hold_s + 0.5),
            ("/control/pid", rates::DERIVED_HZ, hold_s + 0.5),
            ("/tf", rates::TF_HZ, hold_s + 0.5),
            ("/scene", rates::SCENE_HZ, 0.0),
            ("/estimate", rates::ESTIMATE_HZ, span - excite),
        ] {
            let b = bounds.entry(topic).or_default();
            b.0 += (span - from_s) * hz - 1.0;
            b.1 += span * hz + 2.0;
        }
    }
    let n = |t: &str| log.channels[t].count as f64;
    assert_eq!(n("/commands"), n("/sensors"));
    for (topic, (lo, hi)) in bounds {
        let got = n(topic);
        assert!(
            got >= lo && got <= hi,
            "{topic}: {got} messages, expected {lo:.0}..{hi:.0}"
        );
    }
    // The payload frame follows every loaded estimate that has a centre of mass (not the
    // final extra one).
    let payload_estimates = log
        .estimates
        .iter()
        .filter(|e| e.payload.is_some_and(|p| p.mass_kg > 0.0))
        .count() as f64;
    let tf_payload = n("/tf/payload");
    assert!(
        tf_payload <= payload_estimates && tf_payload >= payload_estimates - 2.0,
        "/tf/payload: {tf_payload} messages for {payload_estimates} payload estimates"
    );
    let runs = meta.runs.len() as f64;
    // Twice, each in a chunk of its own (`RunLog::write_metadata`).
    assert_eq!(n("/run/metadata"), runlog::run_log::METADATA_COPIES as f64);
    assert_eq!(n("/run/truth"), 1.0);
    // At each excitation's start, every `SETTINGS_REPEAT_S` of its frames and at its end
    // (`RunLog::write_settings`), every copy the same record.
    // Every copy as written, read by the mcap crate (the log's reader keeps the first of each
    // measurement).
    let written: Vec<runlog::metadata::EstimatorSettings> = support::read_messages(&run.log)
        .into_iter()
        .filter(|m| m.topic == "/run/estimator")
        .map(|m| serde_json::from_value(m.value).unwrap())
        .collect();
    for run_name in log.runs() {
        let copies: Vec<_> = written.iter().filter(|s| s.run == run_name).collect();
        let frames: Vec<_> = log.sensors_of(&run_name).collect();
        let start_s = copies[0].window_start_s.unwrap();
        let after_s = frames.last().unwrap().time_s - start_s;
        let repeats = (after_s / runlog::run_log::SETTINGS_REPEAT_S).floor() as usize;
        assert!(
            (1 + repeats..=2 + repeats).contains(&copies.len()),
            "{run_name}: {} copies of its settings over {after_s} s",
            copies.len()
        );
        assert!(copies.iter().all(|c| c == &copies[0]), "{run_name}");
    }
    assert!(n("/run/estimator") >= 2.0 * runs);
}
