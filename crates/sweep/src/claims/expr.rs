//! The query a claim carries: arithmetic over aggregates of a study's data.
//!
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := factor (('*' | '/') factor)*
//! factor  := number | '-' factor | '(' expr ')' | call
//! call    := agg '(' source ':' column ['|' filter (',' filter)*] ')'
//! agg     := value | mean | min | max | sum | count | median
//! filter  := key ('=' | '!=') text
//! ```
//!
//! `source` is a study folder (its `cells.csv`), a CSV file or a JSON file, relative to the
//! document; `column` a CSV column by its key (the header before its unit, `ms_share` for
//! `ms_share [1]`) or a dotted JSON path (an array on the way is filtered by the filters).
//! Example: `100 * mean(single_vs_multiple-paper: ms_share | scene=foot, sigma.t=80,
//! integrator.multiple=true)`.

use anyhow::{Result, anyhow, bail};

/// How the rows of a call are reduced to one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Aggregate {
    /// The one row's value (an error unless exactly one row matches).
    Value,
    Mean,
    Min,
    Max,
    Sum,
    Count,
    Median,
}

impl Aggregate {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "value" => Aggregate::Value,
            "mean" => Aggregate::Mean,
            "min" => Aggregate::Min,
            "max" => Aggregate::Max,
            "sum" => Aggregate::Sum,
            "count" => Aggregate::Count,
            "median" => Aggregate::Median,
            _ => return None,
        })
    }

    /// Reduces the matched values.
    pub(crate) fn apply(self, values: &[f64]) -> Result<f64> {
        if values.is_empty() && self != Aggregate::Count {
            bail!("no row matches");
        }
        let n = values.len() as f64;
        Ok(match self {
            Aggregate::Value if values.len() != 1 => {
                bail!(
                    "{} rows match where value() needs exactly one",
                    values.len()
                )
            }
            Aggregate::Value => values[0],
            Aggregate::Mean => values.iter().sum::<f64>() / n,
            Aggregate::Min => values.iter().copied().fold(f64::INFINITY, f64::min),
            Aggregate::Max => values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Aggregate::Sum => values.iter().sum(),
            Aggregate::Count => n,
            Aggregate::Median => {
                let mut v = values.to_vec();
                v.sort_by(f64::total_cmp);
                let mid = v.len() / 2;
                if v.len() % 2 == 1 {
                    v[mid]
                } else {
                    0.5 * (v[mid - 1] + v[mid])
                }
            }
        })
    }
}

/// `key=value` or `key!=value`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Filter {
    pub(crate) key: String,
    pub(crate) value: String,
    pub(crate) negated: bool,
}

/// One aggregate over a source.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Call {
    pub(crate) aggregate: Aggregate,
    pub(crate) source: String,
    pub(crate) column: String,
    pub(crate) filters: Vec<Filter>,
}

/// A parsed claim expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Number(f64),
    Negate(Box<Expr>),
    Binary(Box<Expr>, char, Box<Expr>),
    Call(Call),
}

impl Expr {
    /// Evaluates with `call` answering each aggregate.
    pub(crate) fn eval(&self, call: &mut impl FnMut(&Call) -> Result<f64>) -> Result<f64> {
        Ok(match self {
            Expr::Number(n) => *n,
            Expr::Negate(e) => -e.eval(call)?,
            Expr::Binary(a, op, b) => {
                let (a, b) = (a.eval(call)?, b.eval(call)?);
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    _ => a / b,
                }
            }
            Expr::Call(c) => call(c)?,
        })
    }
}

/// Parses a claim expression.
pub(crate) fn parse(text: &str) -> Result<Expr> {
    let mut p = Parser {
        chars: text.chars().collect(),
        at: 0,
    };
    let e = p.expr()?;
    p.skip_space();
    if p.at < p.chars.len() {
        bail!(
            "unexpected `{}` at character {}",
            p.rest().chars().take(12).collect::<String>(),
            p.at + 1
        );
    }
    Ok(e)
}

struct Parser {
    chars: Vec<char>,
    at: usize,
}

impl Parser {
    fn rest(&self) -> String {
        self.chars[self.at..].iter().collect()
    }

    fn skip_space(&mut self) {
        while self.chars.get(self.at).is_some_and(|c| c.is_whitespace()) {
            self.at += 1;
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.skip_space();
        self.chars.get(self.at).copied()
    }

    fn expect(&mut self, c: char) -> Result<()> {
        if self.peek() == Some(c) {
            self.at += 1;
            Ok(())
        } else {
            Err(anyhow!("expected `{c}` at character {}", self.at + 1))
        }
    }

    fn expr(&mut self) -> Result<Expr> {
        let mut left = self.term()?;
        while let Some(op @ ('+' | '-')) = self.peek() {
            self.at += 1;
            left = Expr::Binary(Box::new(left), op, Box::new(self.term()?));
        }
        Ok(left)
    }

    fn term(&mut self) -> Result<Expr> {
        let mut left = self.factor()?;
        while let Some(op @ ('*' | '/')) = self.peek() {
            self.at += 1;
            left = Expr::Binary(Box::new(left), op, Box::new(self.factor()?));
        }
        Ok(left)
    }

    fn factor(&mut self) -> Result<Expr> {
        match self.peek() {
            Some('-') => {
                self.at += 1;
                Ok(Expr::Negate(Box::new(self.factor()?)))
            }
            Some('(') => {
                self.at += 1;
                let e = self.expr()?;
                self.expect(')')?;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() => self.call(),
            Some(c) => bail!("unexpected `{c}` at character {}", self.at + 1),
            None => bail!("the expression ends early"),
        }
    }

    fn number(&mut self) -> Result<Expr> {
        let start = self.at;
        while self
            .chars
            .get(self.at)
            .is_some_and(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E'))
        {
            self.at += 1;
        }
        let text: String = self.chars[start..self.at].iter().collect();
        text.parse()
            .map(Expr::Number)
            .map_err(|_| anyhow!("`{text}` is not a number"))
    }

    /// Characters up to (not including) any of `stops`, trimmed.
    fn until(&mut self, stops: &[char]) -> String {
        self.skip_space();
        let start = self.at;
        let mut quoted = false;
        while let Some(&c) = self.chars.get(self.at) {
            if c == '"' {
                quoted = !quoted;
            } else if !quoted && stops.contains(&c) {
                break;
            }
            self.at += 1;
        }
        let text: String = self.chars[start..self.at].iter().collect();
        text.trim().trim_matches('"').to_string()
    }

    fn call(&mut self) -> Result<Expr> {
        let name = self.until(&['(']);
        let aggregate = Aggregate::parse(&name).ok_or_else(|| {
            anyhow!(
                "`{name}` is not an aggregate: expected value, mean, min, max, sum, count or median"
            )
        })?;
        self.expect('(')?;
        let source = self.until(&[':', ')']);
        self.expect(':')?;
        let column = self.until(&['|', ')']);
        let mut filters = Vec::new();
        if self.peek() == Some('|') {
            self.at += 1;
            loop {
                let item = self.until(&[',', ')']);
                filters.push(filter(&item)?);
                if self.peek() == Some(',') {
                    self.at += 1;
                } else {
                    break;
                }
            }
        }
        self.expect(')')?;
        if source.is_empty() || column.is_empty() {
            bail!("{name}(…) needs `source: column`");
        }
        Ok(Expr::Call(Call {
            aggregate,
            source,
            column,
            filters,
        }))
    }
}

fn filter(item: &str) -> Result<Filter> {
    let (key, value, negated) = if let Some((k, v)) = item.split_once("!=") {
        (k, v, true)
    } else if let Some((k, v)) = item.split_once('=') {
        (k, v, false)
    } else {
        bail!("filter `{item}` is not `key=value` or `key!=value`");
    };
    Ok(Filter {
        key: key.trim().to_string(),
        value: value.trim().trim_matches('"').to_string(),
        negated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_arithmetic_over_calls() {
        let e =
            parse("100 * (1 - mean(a-paper: rmse | nused=150, scene=foot) / value(b/x.json: c.d))")
                .unwrap();
        let mut seen = Vec::new();
        let v = e
            .eval(&mut |c: &Call| {
                seen.push(c.clone());
                Ok(if c.source == "a-paper" { 0.25 } else { 0.5 })
            })
            .unwrap();
        assert!((v - 50.0).abs() < 1e-9);
        assert_eq!(seen[0].aggregate, Aggregate::Mean);
        assert_eq!(seen[0].column, "rmse");
        assert_eq!(
            seen[0].filters[1],
            Filter {
                key: "scene".into(),
                value: "foot".into(),
                negated: false
            }
        );
        assert_eq!(seen[1].source, "b/x.json");
        assert_eq!(seen[1].column, "c.d");
    }

    #[test]
    fn mistakes_are_named() {
        for (text, says) in [
            ("avg(a: b)", "not an aggregate"),
            ("mean(a b)", "expected `:`"),
            ("mean(a: b | nused)", "not `key=value`"),
            ("1 +", "ends early"),
            ("2 3", "unexpected `3`"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
        assert!(Aggregate::Value.apply(&[1.0, 2.0]).is_err());
        assert!(Aggregate::Mean.apply(&[]).is_err());
        assert_eq!(
            Aggregate::Median.apply(&[3.0, 1.0, 2.0, 10.0]).unwrap(),
            2.5
        );
        assert_eq!(Aggregate::Count.apply(&[]).unwrap(), 0.0);
    }
}
