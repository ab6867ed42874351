//! Dotted key paths in TOML tables (`integrator.nused`): setting, reading and flattening
//! them, comparing axis values, and short labels for captions.

use toml::{Table, Value};

/// Flattens nested tables into `(dotted key, value)`, recursing into a table value unless
/// `is_leaf(key, table)` says it is a value itself.
fn flatten(
    table: &Table,
    prefix: &str,
    is_leaf: &dyn Fn(&str, &Table) -> bool,
    out: &mut Vec<(String, Value)>,
) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(t) if !is_leaf(k, t) => flatten(t, &key, is_leaf, out),
            other => out.push((key, other.clone())),
        }
    }
}

/// Flattens nested axis tables into dotted keys; leaves are arrays or range tables.
pub(crate) fn flatten_axes(table: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    flatten(table, prefix, &|_, t| t.contains_key("from"), out);
}

/// Flattens a `[tune.space]` table into dotted keys; leaves are tables with `range`, `int`
/// or `choices`.
pub(crate) fn flatten_space(table: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    flatten(
        table,
        prefix,
        &|_, t| {
            ["range", "int", "choices"]
                .iter()
                .any(|k| t.contains_key(*k))
        },
        out,
    );
}

/// Flattens nested override tables into `(dotted key, value)`. Inline values of keys that
/// take a table (`phantom`, `box`) are set whole.
pub(crate) fn flatten_set(table: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    flatten(table, prefix, &|k, _| matches!(k, "phantom" | "box"), out);
}

/// A key that names a scene setting must be a dotted path of names (`integrator.nused`):
/// anything else (`../../integrator/nused`, `a..b`) would reach the scene reader as an
/// empty or garbled field name.
pub(crate) fn scene_key(key: &str) -> std::result::Result<(), String> {
    let name = |part: &str| {
        !part.is_empty() && part.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    if key.split('.').all(name) {
        Ok(())
    } else {
        Err(format!(
            "`{key}` is not a scene key: expected a dotted path of names such as `integrator.nused` or `sigma.t` (or `scene` for an axis of scene files)"
        ))
    }
}

/// Compares axis values, treating 80 and 80.0 as equal.
pub(crate) fn values_equal(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Integer(x), Value::Float(y)) | (Value::Float(y), Value::Integer(x)) => {
            (*x as f64) == *y
        }
        _ => a == b,
    }
}

/// Sets a dotted key in a table, creating intermediate tables.
pub(crate) fn set_key(
    table: &mut Table,
    key: &str,
    value: Value,
) -> std::result::Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let mut t = table;
    for (i, part) in parts.iter().enumerate() {
        if i == parts.len() - 1 {
            t.insert(part.to_string(), value);
            return Ok(());
        }
        let entry = t
            .entry(part.to_string())
            .or_insert_with(|| Value::Table(Table::new()));
        t = match entry {
            Value::Table(inner) => inner,
            other => {
                return Err(format!(
                    "cannot set `{key}`: `{}` is {other}, not a table",
                    parts[..=i].join(".")
                ));
            }
        };
    }
    Ok(())
}

/// Reads a dotted key from a table.
pub(crate) fn get_key<'a>(table: &'a Table, key: &str) -> Option<&'a Value> {
    let mut parts = key.split('.').peekable();
    let mut t = table;
    while let Some(part) = parts.next() {
        let v = t.get(part)?;
        if parts.peek().is_none() {
            return Some(v);
        }
        t = v.as_table()?;
    }
    None
}

/// The last segment of a key path (`integrator.nused` → `nused`).
pub(crate) fn short_key(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}

/// A value as plain text (strings without quotes).
pub(crate) fn value_text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Float(f) => format!("{f}"),
        other => other.to_string(),
    }
}

/// Converts a TOML value to JSON for records.
pub(crate) fn toml_to_json(v: &toml::Value) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}
