//! Axes: lists and ranges (`{ from, to, steps, scale }`) expanded into values, zipped
//! groups that move together, and the grid's dimensions in order.

use toml::{Table, Value};

use super::keys::{flatten_axes, values_equal};
use super::source::Source;

/// One dimension of the grid: a single axis, or a zip group of axes of equal length.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Dimension {
    pub(crate) keys: Vec<String>,
    /// `values[i][k]` is the value of `keys[k]` at position `i`.
    pub(crate) values: Vec<Vec<Value>>,
}

impl Dimension {
    /// A dimension of one axis.
    pub(crate) fn single(key: String, values: Vec<Value>) -> Self {
        Dimension {
            keys: vec![key],
            values: values.into_iter().map(|v| vec![v]).collect(),
        }
    }

    /// The first value (a row of a zip group) given twice, said as "`key` holds v twice
    /// (positions i and j): …". A repeat would plan the same cells twice under one
    /// address; refusing it keeps the grid what the file says rather than folding it.
    pub(crate) fn repeat(&self) -> Option<String> {
        let (i, j) = self.values.iter().enumerate().find_map(|(j, b)| {
            self.values[..j]
                .iter()
                .position(|a| a.iter().zip(b).all(|(x, y)| values_equal(x, y)))
                .map(|i| (i, j))
        })?;
        let what = match self.keys.as_slice() {
            [key] => format!("`{key}` holds {}", self.values[i][0]),
            keys => format!(
                "row {}",
                keys.iter()
                    .zip(&self.values[i])
                    .map(|(k, v)| format!("{k} = {v}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        Some(format!(
            "{what} twice (positions {} and {}): each value makes its own cells, so remove the repeat",
            i + 1,
            j + 1
        ))
    }
}

/// The grid's dimensions: every `[axes]` entry, then every `[[zip]]` group; an axis named
/// twice, or a value (a zip row) given twice in one axis, is an error.
pub(crate) fn dimensions(
    source: &Source,
    axes: &Table,
    zips: &[Table],
) -> anyhow::Result<Vec<Dimension>> {
    let mut dimensions = Vec::new();
    let mut flat = Vec::new();
    flatten_axes(axes, "", &mut flat);
    for (key, spec) in &flat {
        let values = axis_values(spec)
            .map_err(|m| source.error(&format!("axes.{key}"), format!("axis `{key}`: {m}")))?;
        let dimension = Dimension::single(key.clone(), values);
        if let Some(m) = dimension.repeat() {
            return Err(source.error(&format!("axes.{key}"), format!("axis {m}")));
        }
        dimensions.push(dimension);
    }
    for (zi, zip) in zips.iter().enumerate() {
        dimensions.push(zip_dimension(source, zi, zip)?);
    }
    let mut seen = std::collections::HashSet::new();
    for k in dimensions.iter().flat_map(|d| &d.keys) {
        if !seen.insert(k.clone()) {
            return Err(source.error(
                &format!("axes.{k}"),
                format!("axis `{k}` is given twice (in [axes] and/or [[zip]])"),
            ));
        }
    }
    Ok(dimensions)
}

/// One `[[zip]]` group: axes of equal length that move together.
fn zip_dimension(source: &Source, zi: usize, zip: &Table) -> anyhow::Result<Dimension> {
    let mut zaxes = Vec::new();
    flatten_axes(zip, "", &mut zaxes);
    let mut keys = Vec::new();
    let mut columns = Vec::new();
    for (key, spec) in &zaxes {
        let values = axis_values(spec).map_err(|m| {
            source.error(
                &format!("zip.{key}"),
                format!("zip[{zi}] axis `{key}`: {m}"),
            )
        })?;
        keys.push(key.clone());
        columns.push(values);
    }
    let len = columns.first().map(|c| c.len()).unwrap_or(0);
    if let Some((k, c)) = keys.iter().zip(&columns).find(|(_, c)| c.len() != len) {
        return Err(source.error(
            &format!("zip.{k}"),
            format!(
                "zip[{zi}]: axis `{k}` has {} values but `{}` has {len}; zipped axes move together and need equal lengths",
                c.len(),
                keys[0]
            ),
        ));
    }
    if len == 0 {
        return Err(source.error("zip", format!("zip[{zi}] is empty")));
    }
    let dimension = Dimension {
        values: (0..len)
            .map(|i| columns.iter().map(|c| c[i].clone()).collect())
            .collect(),
        keys,
    };
    match dimension.repeat() {
        Some(m) => Err(source.error(
            &format!("zip.{}", dimension.keys[0]),
            format!("zip[{zi}] holds the {m}"),
        )),
        None => Ok(dimension),
    }
}

/// Expands an axis spec (a list, or `{ from, to, steps, scale }`) into values.
pub(crate) fn axis_values(spec: &Value) -> std::result::Result<Vec<Value>, String> {
    match spec {
        Value::Array(a) => {
            if a.is_empty() {
                Err("an axis needs at least one value".into())
            } else {
                Ok(a.clone())
            }
        }
        Value::Table(t) => {
            for k in t.keys() {
                if !["from", "to", "steps", "scale"].contains(&k.as_str()) {
                    return Err(format!(
                        "unknown range key `{k}` (expected from, to, steps, scale)"
                    ));
                }
            }
            let num = |k: &str| -> std::result::Result<(f64, bool), String> {
                match t.get(k) {
                    Some(Value::Integer(i)) => Ok((*i as f64, true)),
                    Some(Value::Float(f)) if f.is_finite() => Ok((*f, false)),
                    Some(other) => Err(format!("`{k}` = {other}: expected a number")),
                    None => Err(format!("range needs `{k}`")),
                }
            };
            let (from, from_int) = num("from")?;
            let (to, to_int) = num("to")?;
            let steps = match t.get("steps") {
                Some(Value::Integer(n)) if *n >= 1 && *n <= 10_000 => *n as usize,
                Some(other) => {
                    return Err(format!(
                        "`steps` = {other}: expected an integer in [1, 10000]"
                    ));
                }
                None => return Err("range needs `steps`".into()),
            };
            let log = match t.get("scale").map(|v| v.as_str()) {
                None | Some(Some("linear")) => false,
                Some(Some("log")) => true,
                Some(_) => return Err("`scale`: expected \"linear\" or \"log\"".into()),
            };
            if log && (from <= 0.0 || to <= 0.0) {
                return Err(format!("log range needs from, to > 0 (got {from}, {to})"));
            }
            let integer = from_int && to_int;
            let mut values = Vec::new();
            for i in 0..steps {
                let f = if steps == 1 {
                    0.0
                } else {
                    i as f64 / (steps - 1) as f64
                };
                let v = if log {
                    (from.ln() + f * (to.ln() - from.ln())).exp()
                } else {
                    from + f * (to - from)
                };
                let value = if integer {
                    Value::Integer(v.round() as i64)
                } else {
                    // Six significant digits keep labels and cell hashes readable.
                    Value::Float(format!("{v:.6e}").parse().unwrap_or(v))
                };
                if !values.contains(&value) {
                    values.push(value);
                }
            }
            Ok(values)
        }
        other => Err(format!(
            "{other}: expected a list of values or {{ from, to, steps, scale }}"
        )),
    }
}
