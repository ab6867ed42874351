//! Numbers as a document prints them: `0.157`, `−0.09`, `10 308`, `7.47·10⁻⁴`, `1.2e-5`.
//! The printed precision is what a claim must hold to: half a unit in the last digit.

/// A number found in a document's text.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Cited {
    /// Byte range of the number in its line.
    pub(crate) span: (usize, usize),
    /// Its value.
    pub(crate) value: f64,
    /// Digits after the decimal point of the mantissa.
    pub(crate) decimals: usize,
    /// The power of ten of a scientific form (`·10⁻⁴`, `e-4`), 0 otherwise.
    pub(crate) exponent: i32,
    /// The separator of thousands groups, if the number uses one (`10 308`).
    pub(crate) separator: Option<char>,
    /// How a minus is written (`−` or `-`).
    pub(crate) minus: char,
    /// Whether the exponent is written `·10ⁿ` (else `eN`).
    pub(crate) superscript: bool,
    /// Significant digits as printed: `0.157` 3, `10 308` 5, `1` 1, `0.0` 0.
    pub(crate) significant: usize,
    /// Why the printed number cannot stand for a value (an exponent out of range, a value
    /// too large for a double): such a number is an error, never a silent infinity.
    pub(crate) problem: Option<String>,
}

/// The largest power of ten a cited number may carry: doubles end near 10³⁰⁸, and a
/// rewritten number must print as what it was.
pub(crate) const MAX_EXPONENT: i32 = 300;

/// Thousands separators: the narrow and thin spaces (and a no-break space). A plain space
/// separates two numbers (`nused 25 150`), so a document writes `10\u{202f}308`.
const THOUSANDS: [char; 3] = ['\u{202f}', '\u{2009}', '\u{a0}'];
const SUPERSCRIPTS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

impl Cited {
    /// Whether `value` prints as this number: within half a unit of its last digit.
    pub(crate) fn agrees(&self, value: f64) -> bool {
        (value - self.value).abs() <= self.half_unit() * (1.0 + 1e-9) + 1e-300
    }

    /// Whether `value` is this number exactly (to rounding of the arithmetic): what a
    /// number printed with fewer than two significant digits must be, so that `1×` does
    /// not pass for 1.244.
    pub(crate) fn equals_exactly(&self, value: f64) -> bool {
        (value - self.value).abs() <= 1e-9 * self.value.abs().max(1.0)
    }

    /// The same form with enough decimals for two significant digits of `value`.
    pub(crate) fn two_significant(&self, value: f64) -> Cited {
        let mantissa = (value.abs().max(1e-300)) / 10f64.powi(self.exponent);
        let leading = mantissa.log10().floor() as i32;
        let decimals = (1 - leading).clamp(self.decimals as i32, 20) as usize;
        Cited {
            decimals,
            significant: 2,
            ..self.clone()
        }
    }

    /// `value` written in this number's form for `sweep claims --update`: the same form
    /// when that prints two significant digits or more, or the value exactly; otherwise
    /// with the decimals two significant digits need (`13` rewritten to 8.36 prints `8.4`,
    /// since `8` would not pass the check it is written for).
    pub(crate) fn reprinted(&self, value: f64) -> String {
        let mantissa = (value / 10f64.powi(self.exponent)).abs();
        let scaled = mantissa * 10f64.powi(self.decimals as i32);
        let exact = (scaled - scaled.round()).abs() <= 1e-9 * scaled.max(1.0);
        if exact || scaled.round() >= 10.0 {
            self.format(value)
        } else {
            self.two_significant(value).format(value)
        }
    }

    pub(crate) fn half_unit(&self) -> f64 {
        0.5 * 10f64.powi(self.exponent - self.decimals as i32)
    }

    /// `value` written as this number is: the same decimals, exponent, separator and minus.
    pub(crate) fn format(&self, value: f64) -> String {
        let mantissa = value / 10f64.powi(self.exponent);
        let text = format!("{:.*}", self.decimals, mantissa.abs());
        let (int, frac) = text.split_once('.').unwrap_or((&text, ""));
        let mut grouped = String::new();
        for (i, c) in int.chars().enumerate() {
            if i > 0 && (int.len() - i) % 3 == 0 && self.separator.is_some() && int.len() > 4 {
                grouped.push(self.separator.unwrap_or(' '));
            }
            grouped.push(c);
        }
        let mut out = String::new();
        if mantissa < 0.0 && text.chars().any(|c| c.is_ascii_digit() && c != '0') {
            out.push(self.minus);
        }
        out += &grouped;
        if !frac.is_empty() {
            out.push('.');
            out += frac;
        }
        if self.exponent != 0 {
            if self.superscript {
                out += "·10";
                if self.exponent < 0 {
                    out.push('⁻');
                }
                for d in self.exponent.unsigned_abs().to_string().chars() {
                    out.push(SUPERSCRIPTS[d.to_digit(10).unwrap_or(0) as usize]);
                }
            } else {
                out += &format!("e{}", self.exponent);
            }
        }
        out
    }
}

/// The last number in `text`, if any.
pub(crate) fn last_number(text: &str) -> Option<Cited> {
    numbers(text).pop()
}

/// Every number in `text`, in order (a digit glued to a word, `p99` or `C1`, starts none).
pub(crate) fn numbers(text: &str) -> Vec<Cited> {
    let chars: Vec<(usize, char)> = text.char_indices().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i].1;
        let starts = c.is_ascii_digit()
            && (i == 0 || {
                let p = chars[i - 1].1;
                !(p.is_alphanumeric() || p == '.' || p == '_')
            });
        if starts && let Some((cited, end)) = number_at(text, &chars, i) {
            found.push(cited);
            i = end;
            continue;
        }
        i += 1;
    }
    found
}

/// Reads the number whose first digit is `chars[i]`; returns it and the index past it.
fn number_at(text: &str, chars: &[(usize, char)], i: usize) -> Option<(Cited, usize)> {
    let digit = |k: usize| chars.get(k).is_some_and(|(_, c)| c.is_ascii_digit());
    // <<Sign>>: a minus right before the first digit.
    let (mut start, mut negative, mut minus) = (chars[i].0, false, '−');
    if i > 0 && matches!(chars[i - 1].1, '−' | '-' | '+') {
        let before = if i > 1 { chars[i - 2].1 } else { ' ' };
        if !before.is_alphanumeric() {
            start = chars[i - 1].0;
            negative = chars[i - 1].1 != '+';
            minus = if chars[i - 1].1 == '-' { '-' } else { '−' };
        }
    }
    // <<Integer part with optional thousands groups>>
    let mut k = i;
    let mut int = String::new();
    while digit(k) {
        int.push(chars[k].1);
        k += 1;
    }
    let mut separator = None;
    while int.len() <= 3 || separator.is_some() {
        let Some(&(_, sep)) = chars.get(k) else { break };
        let group = THOUSANDS.contains(&sep)
            && (1..=3).all(|d| digit(k + d))
            && !digit(k + 4)
            && separator.is_none_or(|s| s == sep);
        if !group {
            break;
        }
        separator = Some(sep);
        int.extend((1..=3).map(|d| chars[k + d].1));
        k += 4;
    }
    // <<Fraction>>
    let mut frac = String::new();
    if chars.get(k).is_some_and(|(_, c)| *c == '.') && digit(k + 1) {
        k += 1;
        while digit(k) {
            frac.push(chars[k].1);
            k += 1;
        }
    }
    // <<Exponent>>: `e-5`, or `·10⁻⁴` / `×10⁻⁴`.
    let (exponent, superscript, k) = exponent_at(chars, k);
    let mantissa: f64 = format!("{int}.{frac}0").parse().ok()?;
    let mut problem = None;
    let exponent = match exponent {
        Some(e) if e.abs() <= MAX_EXPONENT => e,
        _ => {
            problem = Some(format!(
                "its power of ten is beyond ±{MAX_EXPONENT}; a cited number must be a finite double"
            ));
            0
        }
    };
    let value = mantissa * 10f64.powi(exponent) * if negative { -1.0 } else { 1.0 };
    if !value.is_finite() && problem.is_none() {
        problem = Some("it is too large for a double; a cited number must be finite".into());
    }
    let digits = format!("{int}{frac}");
    let significant = digits.trim_start_matches('0').len();
    let end_byte = chars.get(k).map_or(text.len(), |(b, _)| *b);
    Some((
        Cited {
            span: (start, end_byte),
            value,
            decimals: frac.len(),
            exponent,
            separator,
            minus,
            superscript,
            significant,
            problem,
        },
        k,
    ))
}

/// The power of ten after a mantissa ending at `k`: `(Some(e), superscript, end)`, or
/// `None` for an exponent too long to be one (it is refused, never wrapped or dropped).
fn exponent_at(chars: &[(usize, char)], k: usize) -> (Option<i32>, bool, usize) {
    let at = |k: usize| chars.get(k).map(|(_, c)| *c);
    // Accumulates decimal digits, None past i32 (an exponent of 10 digits is no exponent).
    let push = |e: Option<i32>, d: u32| e?.checked_mul(10)?.checked_add(d as i32);
    if matches!(at(k), Some('e' | 'E')) {
        let mut j = k + 1;
        let negative = matches!(at(j), Some('-' | '−'));
        if matches!(at(j), Some('-' | '−' | '+')) {
            j += 1;
        }
        let (mut e, mut any) = (Some(0), false);
        while let Some(d) = at(j).and_then(|c| c.to_digit(10)) {
            e = push(e, d);
            any = true;
            j += 1;
        }
        if any {
            return (e.map(|e| if negative { -e } else { e }), false, j);
        }
    }
    if matches!(at(k), Some('·' | '×')) && at(k + 1) == Some('1') && at(k + 2) == Some('0') {
        let mut j = k + 3;
        let negative = at(j) == Some('⁻');
        if negative {
            j += 1;
        }
        let (mut e, mut any) = (Some(0), false);
        while let Some(d) = at(j).and_then(|c| SUPERSCRIPTS.iter().position(|s| *s == c)) {
            e = push(e, d as u32);
            any = true;
            j += 1;
        }
        if any {
            return (e.map(|e| if negative { -e } else { e }), true, j);
        }
    }
    (Some(0), false, k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn last(text: &str) -> Cited {
        last_number(text).unwrap_or_else(|| panic!("no number in {text:?}"))
    }

    #[test]
    fn a_rewritten_number_keeps_its_form_unless_that_prints_too_few_digits() {
        // `13` rewritten to 8.36 would print `8`, which its own check refuses (fewer than
        // two significant digits, not exact): it gets the decimal it needs.
        assert_eq!(last("cost 13 %").reprinted(8.355795), "8.4");
        assert_eq!(last("cost 13 %").reprinted(25.3), "25");
        assert_eq!(
            last("3 seeds").reprinted(4.0),
            "4",
            "an exact count stays a count"
        );
        assert_eq!(last("0.157").reprinted(0.1612), "0.161");
        assert_eq!(last("−0.09 %").reprinted(-0.0042), "−0.0042");
    }

    #[test]
    fn reads_the_forms_the_documents_use() {
        let c = last("skeleton σt 6: 0.157 ");
        assert_eq!((c.value, c.decimals), (0.157, 3));
        assert!(c.agrees(0.1574) && c.agrees(0.1565) && !c.agrees(0.1576));
        let c = last("bias −0.09 %");
        assert_eq!(c.value, -0.09);
        assert_eq!(c.format(-0.094), "−0.09");
        let c = last("it took 10\u{202f}308 s");
        assert_eq!((c.value, c.separator), (10308.0, Some('\u{202f}')));
        assert_eq!(c.format(9876.4), "9876");
        assert_eq!(c.format(12345.0), "12\u{202f}345");
        let c = last("RMSE²×CPU-s 7.47·10⁻⁴ (");
        assert!((c.value - 7.47e-4).abs() < 1e-15 && c.superscript);
        assert_eq!(c.format(7.4449e-4), "7.44·10⁻⁴");
        let c = last("(1.2e-5)");
        assert_eq!((c.value, c.exponent), (1.2e-5, -5));
        assert_eq!(last("1.86× as efficient").value, 1.86);
        // Not numbers: parts of names.
        assert_eq!(last("nused 150 in p0_rmse").value, 150.0);
        assert_eq!(last("x 25 150").value, 150.0, "two numbers, not 25 150");
        assert!(last_number("σt(d_min)").is_none());
        let c = last("a-1");
        assert_eq!(c.value, 1.0, "a hyphen after a word is not a minus");
        assert_eq!(last("0.157").significant, 3);
        assert_eq!(last("0.0").significant, 0);
        assert_eq!(last("1×").significant, 1);
        assert!(!last("1×").equals_exactly(1.244) && last("2").equals_exactly(2.0));
    }

    /// Case 10 of the fourth reliability round: `1e400` was read as infinity (and agreed
    /// with 5), `1e-400` as 0, and a long superscript exponent wrapped.
    #[test]
    fn numbers_beyond_a_double_are_problems_not_values() {
        for text in [
            "1e400",
            "1e-400",
            "1e308",
            "2·10⁻¹⁰⁹⁷²⁶²⁵⁷²",
            "3e99999999999",
            &"9".repeat(400),
        ] {
            let c = last(text);
            assert!(c.problem.is_some(), "{text}: {c:?}");
        }
        assert!(last("1e300").problem.is_none());
        assert!(last("7.47·10⁻⁴").problem.is_none());
    }
}
