//! How an error quotes a value read from data: never the whole text, only its length and a
//! few escaped bytes (a short number as it is).

/// How an error shows a data value: its length and its first bytes, escaped.
pub(crate) fn shown(value: &str) -> String {
    format!(
        "a {}-byte text starting `{}`",
        value.len(),
        volphot::escaped_prefix(value.as_bytes(), 3)
    )
}

/// How an error names a group (a seed's value): a short number as it is, anything else
/// as [`shown`] does.
pub(crate) fn shown_short(value: &str) -> String {
    if value.len() <= 6 && value.parse::<f64>().is_ok() {
        volphot::escaped_prefix(value.as_bytes(), 6)
    } else {
        shown(value)
    }
}
