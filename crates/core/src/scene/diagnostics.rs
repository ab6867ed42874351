//! Located diagnostics for TOML files: turns a reader error or a keyed parameter error into
//! `file:line:column: message`, naming the key and quoting the line, and maps between byte
//! offsets and dotted key paths (`lights[1].cone_angle`).

use std::path::Path;

use crate::error::Error;

/// Converts a TOML reader error into a located [`Error::Scene`].
pub fn toml_error(e: &toml::de::Error, src: &str, file: &Path) -> Error {
    let (line, column) = e.span().map(|s| line_col(src, s.start)).unwrap_or((1, 1));
    // Quote the offending line so the key is named even when the reader points at a value.
    let quoted = src
        .lines()
        .nth(line - 1)
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| format!(" (in `{l}`)"))
        .unwrap_or_default();
    Error::Scene {
        file: file.to_path_buf(),
        line,
        column,
        message: format!("{}{quoted}", e.message().trim()),
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(src: &str, byte: usize) -> (usize, usize) {
    let before = src.get(..byte.min(src.len())).unwrap_or(src);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    (line, column)
}

/// Splits a key path such as `lights[1].cone_angle` into `["lights", "1", "cone_angle"]`.
fn key_segments(key: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let mut rest = part;
        if let Some(open) = rest.find('[') {
            out.push(rest[..open].to_string());
            rest = &rest[open..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let close = stripped.find(']').unwrap_or(stripped.len());
                out.push(stripped[..close].to_string());
                rest = stripped.get(close + 1..).unwrap_or("");
            }
        } else {
            out.push(rest.to_string());
        }
    }
    out.retain(|s| !s.is_empty());
    out
}

/// Line and column of the value at `key` (dotted, with `[i]` indices) in `src`, or of its
/// deepest written ancestor when the key itself is absent (a default).
pub fn locate(src: &str, key: &str) -> Option<(usize, usize)> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(src).ok()?;
    let segments = key_segments(key);
    let mut best = None;
    let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
    let mut value: Option<&toml::Spanned<DeValue<'_>>> = None;
    for (i, seg) in segments.iter().enumerate() {
        let next = match (table, value.map(|v| v.get_ref())) {
            (Some(t), _) => match t.get_key_value(seg.as_str()) {
                Some((k, v)) => {
                    best = Some(k.span().start);
                    v
                }
                None => break,
            },
            (None, Some(DeValue::Array(a))) => {
                match seg.parse::<usize>().ok().and_then(|i| a.get(i)) {
                    Some(v) => {
                        best = Some(v.span().start);
                        v
                    }
                    None => break,
                }
            }
            _ => break,
        };
        // The key's own value (not a table header or an array of tables) is where a
        // reader's eye goes.
        let is_leaf_value = i + 1 == segments.len()
            && match next.get_ref() {
                DeValue::Table(_) => false,
                DeValue::Array(a) => {
                    !a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_))) || a.is_empty()
                }
                _ => true,
            };
        if is_leaf_value {
            best = Some(next.span().start);
        }
        value = Some(next);
        table = next.get_ref().as_table();
    }
    best.map(|b| line_col(src, b))
}

/// The dotted key path whose key or value covers byte `offset` of `src` (the inverse of
/// [`locate`]), e.g. to name the key behind a type error in generated TOML.
pub fn key_at(src: &str, offset: usize) -> Option<String> {
    use toml::de::{DeTable, DeValue};
    fn walk(table: &DeTable<'_>, offset: usize, prefix: &str) -> Option<String> {
        for (k, v) in table.iter() {
            let key = if prefix.is_empty() {
                k.get_ref().to_string()
            } else {
                format!("{prefix}.{}", k.get_ref())
            };
            let (ks, vs) = (k.span(), v.span());
            let inside =
                |r: &std::ops::Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
            if let DeValue::Table(t) = v.get_ref()
                && let Some(found) = walk(t, offset, &key)
            {
                return Some(found);
            }
            if inside(&ks) || inside(&vs) {
                return Some(key);
            }
        }
        None
    }
    let root = DeTable::parse(src).ok()?;
    walk(root.get_ref(), offset, "")
}

/// Turns a keyed [`Error::Parameter`] into an [`Error::Scene`] at the key's position.
/// Errors about the scene's volume (a dataset that is not on the search path, a file whose
/// checksum differs) are located at the `[volume]` key that named it.
pub fn locate_error(err: Error, src: &str, file: &Path) -> Error {
    let key = match &err {
        Error::Parameter { key, .. } => key.as_str(),
        Error::DatasetNotFound { .. } => "volume.dataset",
        Error::Checksum { .. } if locate(src, "volume.sha256").is_some() => "volume.sha256",
        Error::Checksum { .. } => "volume.dataset",
        _ => return err,
    };
    let (line, column) = locate(src, key).unwrap_or((1, 1));
    Error::Scene {
        file: file.to_path_buf(),
        line,
        column,
        message: err.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_with_indices() {
        assert_eq!(
            key_segments("lights[1].cone_angle"),
            vec!["lights", "1", "cone_angle"]
        );
        let src = "[[lights]]\ntype = \"point\"\nposition = [0,0,0]\nintensity = 1\n\n[[lights]]\ntype = \"spot\"\nposition = [0,0,0]\ntarget = [1,0,0]\nintensity = 1\ncone_angle = 400\n";
        assert_eq!(locate(src, "lights[1].cone_angle"), Some((11, 14)));
        // An absent key falls back to its deepest written ancestor (the second light).
        let (line, _) = locate(src, "lights[1].beam_width").unwrap();
        assert!((6..=11).contains(&line), "{line}");
    }
}
