//! Every message a real `stewart simulate` log carries on a `stewart.*` channel (and on the
//! Foxglove channels) is valid against that channel's JSON schema, as an independent
//! validator (the `jsonschema` crate, draft 2020-12) reads the schema documents of the channel
//! catalogue (`runlog::messages::channels()`); each schema document is itself a valid JSON
//! schema; and a broken message is refused, so the check can fail.

use crate::support;

use std::collections::BTreeMap;

use serde_json::Value;

/// The catalogue's schema document of every channel, compiled: topic → (schema name,
/// validator).
fn validators() -> BTreeMap<&'static str, (&'static str, jsonschema::Validator)> {
    runlog::messages::channels()
        .into_iter()
        .map(|spec| {
            let document = spec.schema.document(spec.schema_name);
            if let Err(e) = jsonschema::meta::validate(&document) {
                panic!(
                    "{} ({}): not a JSON schema: {e}",
                    spec.topic, spec.schema_name
                );
            }
            let validator = jsonschema::validator_for(&document)
                .unwrap_or_else(|e| panic!("{}: the schema does not compile: {e}", spec.topic));
            (spec.topic, (spec.schema_name, validator))
        })
        .collect()
}

/// The validator's complaints about `value`, one line each.
fn errors(validator: &jsonschema::Validator, value: &Value) -> Vec<String> {
    validator
        .iter_errors(value)
        .map(|e| format!("at {}: {e}", e.instance_path()))
        .collect()
}

/// `value` with its first required property removed, or `None` if the schema requires none.
fn without_a_required_property(schema: &Value, value: &Value) -> Option<(String, Value)> {
    let key = schema["required"]
        .as_array()?
        .first()?
        .as_str()?
        .to_string();
    let mut broken = value.clone();
    broken.as_object_mut()?.remove(&key)?;
    Some((key, broken))
}

#[test]
fn every_logged_message_matches_its_channel_schema() {
    let run = support::simulate_with(
        "[run]\nduration_s = 6.0\ntare_duration_s = 6.0\n",
        |_, _| {},
    );
    let validators = validators();
    let messages = support::read_messages(&run.log);

    // Every message of every catalogued channel, validated; a channel that is not in the
    // catalogue fails the test.
    let mut checked: BTreeMap<&str, u64> = BTreeMap::new();
    let mut first: BTreeMap<&str, &Value> = BTreeMap::new();
    let mut failures = Vec::new();
    for m in &messages {
        let Some((topic, (name, validator))) = validators.get_key_value(m.topic.as_str()) else {
            panic!("{} is not in the channel catalogue", m.topic);
        };
        assert_eq!(m.schema_name, *name, "{topic}");
        let problems = errors(validator, &m.value);
        if !problems.is_empty() && failures.len() < 20 {
            failures.push(format!(
                "{topic} ({name}): {}\n  {}",
                m.value,
                problems.join("\n  ")
            ));
        }
        *checked.entry(topic).or_default() += 1;
        first.entry(topic).or_insert(&m.value);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));

    // Every `stewart.*` channel a simulate run writes was seen (the rig link is the rig's).
    for (topic, (name, _)) in &validators {
        if name.starts_with("stewart.") && *topic != runlog::rig_record::LINK {
            assert!(
                checked.get(topic).copied().unwrap_or(0) > 0,
                "no message on {topic} ({name}) to validate"
            );
        }
    }
    eprintln!("validated: {checked:?}");
    // Blocks of 10 frames: over 10 000 frames.
    assert!(checked[runlog::messages::SENSORS] > 1_000);

    // A broken message is refused: each channel's first message without a required property,
    // and a sensor block with a number turned into a string and a count that is not an integer.
    for (topic, value) in &first {
        let (name, validator) = &validators[topic];
        let schema = runlog::messages::channels()
            .into_iter()
            .find(|c| c.topic == *topic)
            .unwrap()
            .schema
            .document(name);
        if let Some((key, broken)) = without_a_required_property(&schema, value) {
            assert!(
                !validator.is_valid(&broken),
                "{topic}: a message without `{key}` passes"
            );
        }
    }
    let (_, sensors) = &validators[runlog::messages::SENSORS];
    let frame = first[runlog::messages::SENSORS];
    assert!(sensors.is_valid(frame));
    let mut broken = frame.clone();
    broken["time_ns"] = Value::String("soon".into());
    let problems = errors(sensors, &broken);
    assert!(
        problems.iter().any(|p| p.contains("/time_ns")),
        "{problems:?}"
    );
    let mut broken = frame.clone();
    broken["leg_lengths_nm"][0] = serde_json::json!(1.5);
    assert!(
        !sensors.is_valid(&broken),
        "a length that is not a count passes"
    );
}
