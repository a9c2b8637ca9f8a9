//! docs/foxglove-layout.json opens a log with the 3D view and the plots ready: every panel the
//! layout places has a configuration, and every topic and message path it plots exists in the
//! log's channel catalogue and resolves in that channel's JSON schema.

use std::collections::{BTreeMap, BTreeSet};

use serde_json::Value;

fn layout() -> Value {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/docs/foxglove-layout.json"
    ))
    .unwrap();
    serde_json::from_str(&text).unwrap()
}

fn schemas() -> BTreeMap<String, (String, Value)> {
    runlog::messages::channels()
        .into_iter()
        .map(|c| {
            (
                c.topic.to_string(),
                (c.schema_name.to_string(), c.schema.document(c.schema_name)),
            )
        })
        .collect()
}

/// Panel ids placed by a mosaic tree (strings are leaves).
fn leaves(node: &Value, out: &mut BTreeSet<String>) {
    match node {
        Value::String(id) => {
            out.insert(id.clone());
        }
        Value::Object(m) => {
            for key in ["first", "second"] {
                if let Some(child) = m.get(key) {
                    leaves(child, out);
                }
            }
        }
        _ => panic!("unexpected layout node {node}"),
    }
}

/// Follows `.field` and `[i]` steps of a message path through a JSON schema.
fn resolve<'a>(schema: &'a Value, path: &str) -> Result<&'a Value, String> {
    let mut node = schema;
    let mut rest = path;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('.') {
            let end = r.find(['.', '[']).unwrap_or(r.len());
            let field = &r[..end];
            node = node["properties"]
                .get(field)
                .ok_or_else(|| format!("no field `{field}` in {path}"))?;
            rest = &r[end..];
        } else if let Some(r) = rest.strip_prefix('[') {
            let end = r.find(']').ok_or("unclosed [")?;
            let index: u64 = r[..end].parse().map_err(|_| "bad index")?;
            if let Some(max) = node["maxItems"].as_u64() {
                if index >= max {
                    return Err(format!("index {index} beyond {max} items in {path}"));
                }
            }
            node = node
                .get("items")
                .ok_or_else(|| format!("not an array in {path}"))?;
            rest = &r[end + 1..];
        } else {
            return Err(format!("cannot read `{rest}` in {path}"));
        }
    }
    Ok(node)
}

fn is_type(node: &Value, t: &str) -> bool {
    match &node["type"] {
        Value::String(s) => s == t,
        Value::Array(a) => a.iter().any(|v| v == t),
        _ => false,
    }
}

#[test]
fn the_layout_places_configured_panels_and_plots_real_paths() {
    let layout = layout();
    let configs = layout["configById"].as_object().unwrap();
    let mut placed = BTreeSet::new();
    leaves(&layout["layout"], &mut placed);
    for config in configs.values() {
        for tab in config["tabs"].as_array().into_iter().flatten() {
            leaves(&tab["layout"], &mut placed);
        }
    }
    for id in &placed {
        assert!(configs.contains_key(id), "panel {id} has no configuration");
    }
    assert!(placed.iter().any(|id| id.starts_with("3D!")), "a 3D panel");
    let schemas = schemas();

    // The 3D panel shows the scene and both transforms, fixed to the base frame.
    let three_d = &configs["3D!platform"];
    assert_eq!(three_d["followTf"], runlog::foxglove::BASE_FRAME);
    for topic in three_d["topics"].as_object().unwrap().keys() {
        let (name, _) = &schemas[topic];
        assert!(name.starts_with("foxglove."), "{topic}: {name}");
    }
    for frame in [
        runlog::foxglove::BASE_FRAME,
        runlog::foxglove::PLATFORM_FRAME,
        runlog::foxglove::PAYLOAD_FRAME,
    ] {
        assert!(
            three_d["transforms"][format!("frame:{frame}")].is_object(),
            "{frame}"
        );
    }

    // Every plotted path is a number of a logged channel.
    let mut plotted = 0;
    for (id, config) in configs {
        let paths = config["paths"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| p["value"].as_str().unwrap().to_string())
            .chain(config["topicPath"].as_str().map(str::to_string));
        for path in paths {
            let dot = path.find('.').unwrap_or(path.len());
            let (topic, fields) = path.split_at(dot);
            let (_, schema) = schemas
                .get(topic)
                .unwrap_or_else(|| panic!("{id}: {topic} is not a log channel"));
            let node = resolve(schema, fields).unwrap_or_else(|e| panic!("{id}: {e}"));
            if id.starts_with("Plot!") {
                assert!(is_type(node, "number"), "{id}: {path} is not a number");
                plotted += 1;
            }
        }
    }
    // Leg lengths (12), forces (6), tracking error (6), and every estimated quantity with its
    // sigma (θ and σθ: 20; mass, centre of mass and J_C with sigmas: 20) at least.
    assert!(plotted >= 12 + 6 + 6 + 20 + 20, "{plotted} plotted paths");
}
