//! A small builder for the JSON schemas of the log's channels, and a checker that a message
//! matches its schema (used by the tests so that schema and message type cannot drift apart).
//!
//! Only the JSON-schema subset the log needs: objects with required properties, fixed or free
//! length arrays, numbers, integers, strings, booleans, and nullable values.
//!
//! Each log message type's schema is beside its type (crate `runlog`: `messages`, `metadata`,
//! `rig_record`, `foxglove`); the schemas of measure's saved records the log carries are in
//! [`tare`], here because `measure` is below the log and needs no JSON schema of its own.

pub mod tare;

use serde_json::{json, Map, Value};

/// A schema node.
#[derive(Clone, Debug)]
pub enum Schema {
    /// A JSON number (f64).
    Number(&'static str),
    /// A JSON integer.
    Integer(&'static str),
    /// A string.
    String(&'static str),
    /// A boolean.
    Boolean(&'static str),
    /// An array of one item schema, with a fixed length when `Some`.
    Array(Box<Schema>, Option<usize>, &'static str),
    /// An object whose listed properties are all required.
    Object(Vec<(&'static str, Schema)>, &'static str),
    /// The inner schema or `null`.
    Nullable(Box<Schema>),
}

/// A number with a description (give the unit).
pub fn num(description: &'static str) -> Schema {
    Schema::Number(description)
}

/// An integer.
pub fn int(description: &'static str) -> Schema {
    Schema::Integer(description)
}

/// A string.
pub fn string(description: &'static str) -> Schema {
    Schema::String(description)
}

/// A boolean.
pub fn boolean(description: &'static str) -> Schema {
    Schema::Boolean(description)
}

/// An array of exactly `n` numbers (JSON has no NaN: serde_json writes a non-finite value as
/// `null`, so each item may be null).
pub fn numbers(n: usize, description: &'static str) -> Schema {
    Schema::Array(Box::new(nullable(Schema::Number(""))), Some(n), description)
}

/// An array of `n` items.
pub fn array(item: Schema, n: Option<usize>, description: &'static str) -> Schema {
    Schema::Array(Box::new(item), n, description)
}

/// An object with every property required.
pub fn object(properties: Vec<(&'static str, Schema)>, description: &'static str) -> Schema {
    Schema::Object(properties, description)
}

/// `inner` or null.
pub fn nullable(inner: Schema) -> Schema {
    Schema::Nullable(Box::new(inner))
}

impl Schema {
    /// The JSON-schema document for a channel whose schema is called `title`.
    pub fn document(&self, title: &str) -> Value {
        let mut v = self.to_json();
        if let Value::Object(map) = &mut v {
            map.insert("title".into(), Value::String(title.into()));
            map.insert(
                "$schema".into(),
                Value::String("https://json-schema.org/draft/2020-12/schema".into()),
            );
        }
        v
    }

    /// This node as JSON schema.
    pub fn to_json(&self) -> Value {
        fn with_description(mut v: Value, d: &str) -> Value {
            if !d.is_empty() {
                if let Value::Object(map) = &mut v {
                    map.insert("description".into(), Value::String(d.into()));
                }
            }
            v
        }
        match self {
            Schema::Number(d) => with_description(json!({"type": "number"}), d),
            Schema::Integer(d) => with_description(json!({"type": "integer"}), d),
            Schema::String(d) => with_description(json!({"type": "string"}), d),
            Schema::Boolean(d) => with_description(json!({"type": "boolean"}), d),
            Schema::Array(item, n, d) => {
                let mut v = json!({"type": "array", "items": item.to_json()});
                if let (Some(n), Value::Object(map)) = (n, &mut v) {
                    map.insert("minItems".into(), json!(n));
                    map.insert("maxItems".into(), json!(n));
                }
                with_description(v, d)
            }
            Schema::Object(props, d) => {
                let mut properties = Map::new();
                for (name, s) in props {
                    properties.insert((*name).into(), s.to_json());
                }
                let required: Vec<&str> = props.iter().map(|(n, _)| *n).collect();
                with_description(
                    json!({"type": "object", "properties": properties, "required": required}),
                    d,
                )
            }
            Schema::Nullable(inner) => {
                let mut v = inner.to_json();
                if let Value::Object(map) = &mut v {
                    if let Some(Value::String(t)) = map.get("type").cloned() {
                        map.insert("type".into(), json!([t, "null"]));
                    }
                }
                v
            }
        }
    }

    /// Checks that `value` matches this schema; returns the path and problem of the first
    /// mismatch.
    pub fn check(&self, value: &Value) -> Result<(), String> {
        self.check_at(value, "$")
    }

    fn check_at(&self, value: &Value, path: &str) -> Result<(), String> {
        let fail = |what: &str| Err(format!("{path}: expected {what}, got {value}"));
        match self {
            Schema::Number(_) if value.is_number() => Ok(()),
            Schema::Number(_) => fail("number"),
            Schema::Integer(_) if value.is_i64() || value.is_u64() => Ok(()),
            Schema::Integer(_) => fail("integer"),
            Schema::String(_) if value.is_string() => Ok(()),
            Schema::String(_) => fail("string"),
            Schema::Boolean(_) if value.is_boolean() => Ok(()),
            Schema::Boolean(_) => fail("boolean"),
            Schema::Nullable(_) if value.is_null() => Ok(()),
            Schema::Nullable(inner) => inner.check_at(value, path),
            Schema::Array(item, n, _) => {
                let Some(items) = value.as_array() else {
                    return fail("array");
                };
                if let Some(n) = n {
                    if items.len() != *n {
                        return fail(&format!("{n} items"));
                    }
                }
                for (i, v) in items.iter().enumerate() {
                    item.check_at(v, &format!("{path}[{i}]"))?;
                }
                Ok(())
            }
            Schema::Object(props, _) => {
                let Some(map) = value.as_object() else {
                    return fail("object");
                };
                for (name, s) in props {
                    match map.get(*name) {
                        Some(v) => s.check_at(v, &format!("{path}.{name}"))?,
                        None => return Err(format!("{path}: missing property `{name}`")),
                    }
                }
                for key in map.keys() {
                    if !props.iter().any(|(n, _)| n == key) {
                        return Err(format!("{path}: property `{key}` not in the schema"));
                    }
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Schema {
        object(
            vec![
                ("t", num("s")),
                ("n", int("")),
                ("v", numbers(3, "m")),
                ("o", nullable(num(""))),
            ],
            "test",
        )
    }

    #[test]
    fn accepts_a_matching_value() {
        let v = json!({"t": 1.5, "n": 3, "v": [1, 2, 3], "o": null});
        assert_eq!(sample().check(&v), Ok(()));
    }

    #[test]
    fn refuses_wrong_length_missing_and_extra() {
        assert!(sample()
            .check(&json!({"t": 1.5, "n": 3, "v": [1, 2], "o": 1}))
            .unwrap_err()
            .contains("3 items"));
        assert!(sample()
            .check(&json!({"n": 3, "v": [1, 2, 3], "o": 1}))
            .unwrap_err()
            .contains("missing"));
        assert!(sample()
            .check(&json!({"t": 1, "n": 3, "v": [1, 2, 3], "o": 1, "x": 0}))
            .unwrap_err()
            .contains("not in the schema"));
        assert!(sample()
            .check(&json!({"t": 1, "n": 3.5, "v": [1, 2, 3], "o": 1}))
            .unwrap_err()
            .contains("integer"));
    }

    #[test]
    fn document_is_a_json_schema() {
        let d = sample().document("stewart.Test");
        assert_eq!(d["title"], "stewart.Test");
        assert_eq!(d["type"], "object");
        assert_eq!(d["properties"]["v"]["maxItems"], 3);
        assert_eq!(d["properties"]["o"]["type"], json!(["number", "null"]));
        assert_eq!(d["required"].as_array().unwrap().len(), 4);
    }
}
