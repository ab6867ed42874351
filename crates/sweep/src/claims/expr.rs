//! The query a claim carries: arithmetic over aggregates of a study's data.
//!
//! ```text
//! claim   := '=' expr [tolerance]                       (a cited number)
//!          | 'holds:' expr cmp expr                      (a condition)
//!          | 'verdict:' word ['within' δ] 'over' '(' key ':' expr ')'   (an effect)
//! word    := rises | falls | none | unclear              (δ required for none, unclear)
//! tolerance := ('±' | '+-') number
//! cmp     := '<' | '<=' | '>' | '>='
//! expr    := term (('+' | '-') term)*
//! term    := factor (('*' | '/') factor)*
//! factor  := number | '-' factor | '(' expr ')' | 'abs' '(' expr ')' | call | over
//! call    := agg '(' source ':' column ['where' filter (',' filter)*] ')'
//! agg     := value | mean | min | max | sum | count | median | sd | spread
//! over    := agg '_over' '(' key ':' expr ')'           (agg: min max mean median sd se spread
//!                                                         ci_low ci_high t n)
//! filter  := key ('=' | '!=') text
//! ```
//!
//! `source` is a study folder (its `cells.csv`), a CSV file or a JSON file, relative to the
//! document; `column` a CSV column by its key (the header before its unit, `ms_share` for
//! `ms_share [1]`) or a dotted JSON path (an array on the way is filtered by the filters).
//! Example: `100 * mean(single_vs_multiple-paper: ms_share where scene=foot, sigma.t=80,
//! integrator.multiple=true)`.
//!
//! `min_over(seed: A - B)` evaluates `A - B` once per value of `seed` (every call inside
//! restricted to that seed) and takes the smallest: `holds: min_over(seed: A - B) > 0` says
//! that A exceeds B for every seed, which is how a comparison states that it is more than
//! seed noise (`se_over` is the standard error of the mean over seeds).
//!
//! `verdict: falls over(seed: A - B)` applies the one rule for an effect
//! ([`crate::analyse::Verdict`], a paired t-test at the 5 % level) to the differences
//! `A - B`, one per seed, and fails unless the rule gives the declared word; `none` and
//! `unclear` name δ, the smallest effect the sentence cares about (`verdict: none within
//! 0.005 over(seed: A - B)`). The same interval is a number: `ci_low_over(seed: A - B)`,
//! `ci_high_over`, the t statistic `t_over` and the number of seeds `n_over`.
//!
//! Every claim reads data (a condition that compares numbers written in it, `holds: 1 < 2`,
//! checks nothing), and every value an aggregate reduces is a finite number: a NaN (a CSV
//! cell `NaN`, a seed's 0/0) is an error, never a value left out.
//!
//! The filter list is introduced by `where`, never by `|`: GitHub's renderer splits a table
//! row at every `|`, also inside an HTML comment, and the claim would show as text.

use anyhow::{Context as _, Result, anyhow, bail};

use crate::analyse::{Paired, Verdict};

/// The longest query read: a claim is a sentence's source, not a program. Longer texts
/// (a 200 000-term sum) are refused before they are parsed.
pub(crate) const MAX_QUERY_CHARS: usize = 4096;
/// The deepest nesting of parentheses, minus signs and `_over` aggregates.
pub(crate) const MAX_DEPTH: usize = 32;

/// How the rows of a call are reduced to one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Aggregate {
    /// The one row's value (an error unless exactly one row matches).
    Value,
    Mean,
    Min,
    Max,
    Sum,
    /// How many rows match (an error when none does: a mistyped filter value is not 0).
    Count,
    Median,
    /// Sample standard deviation (n − 1), at least two rows.
    Sd,
    /// Standard error of the mean, sd/√n, at least two rows.
    Se,
    /// max − min, at least two rows.
    Spread,
    /// The low end of the 95 % interval of the mean (the effect rule's), over groups only.
    CiLow,
    /// Its high end, over groups only.
    CiHigh,
    /// The t statistic of the mean, mean/se, over groups only.
    T,
    /// How many groups, over groups only.
    N,
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
            "sd" => Aggregate::Sd,
            "se" => Aggregate::Se,
            "spread" => Aggregate::Spread,
            _ => return None,
        })
    }

    /// The aggregates before `_over`: those of a call that reduce several values, and the
    /// effect rule's interval, t statistic and count.
    fn parse_over(name: &str) -> Option<Self> {
        Some(match name {
            "ci_low" => Aggregate::CiLow,
            "ci_high" => Aggregate::CiHigh,
            "t" => Aggregate::T,
            "n" => Aggregate::N,
            _ => match Aggregate::parse(name)? {
                a @ (Aggregate::Min
                | Aggregate::Max
                | Aggregate::Mean
                | Aggregate::Median
                | Aggregate::Sd
                | Aggregate::Se
                | Aggregate::Spread) => a,
                _ => return None,
            },
        })
    }

    /// Reduces the matched values. Every aggregate, `count` too, needs a matching row, and
    /// every value must be a finite number (a NaN is refused, never sorted or skipped).
    pub(crate) fn apply(self, values: &[f64]) -> Result<f64> {
        if values.is_empty() {
            bail!("no row matches (check the filters' values)");
        }
        if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
            bail!(
                "{}() refuses a value of {bad} among the {} it reduces: every value must be a finite number (an undefined metric is an empty cell)",
                aggregate_name(self),
                values.len()
            );
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let two = |what: &str| -> Result<()> {
            if values.len() < 2 {
                bail!("{what} needs at least two values; one matches");
            }
            Ok(())
        };
        let sd = || (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        Ok(match self {
            Aggregate::Value if values.len() != 1 => {
                bail!(
                    "{} rows match where value() needs exactly one",
                    values.len()
                )
            }
            Aggregate::Value => values[0],
            Aggregate::Mean => mean,
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
            Aggregate::Sd => {
                two("sd")?;
                sd()
            }
            Aggregate::Se => {
                two("se")?;
                sd() / n.sqrt()
            }
            Aggregate::Spread => {
                two("spread")?;
                Aggregate::Max.apply(values)? - Aggregate::Min.apply(values)?
            }
            Aggregate::N => n,
            Aggregate::CiLow | Aggregate::CiHigh | Aggregate::T => {
                two(aggregate_name(self))?;
                let paired = Paired::of(values)?;
                let (low, high) = paired
                    .interval
                    .ok_or_else(|| anyhow!("{} needs at least two values", aggregate_name(self)))?;
                match self {
                    Aggregate::CiLow => low,
                    Aggregate::CiHigh => high,
                    _ => paired.t().ok_or_else(|| {
                        anyhow!(
                            "t: every value is {}, so the t statistic is not defined (no spread)",
                            paired.mean
                        )
                    })?,
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
    Abs(Box<Expr>),
    Binary(Box<Expr>, char, Box<Expr>),
    Call(Call),
    /// `agg_over(key: expr)`: `expr` once per value of `key`, reduced by `agg`.
    Over(Aggregate, String, Box<Expr>),
}

/// How a condition compares its two sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Comparison {
    Less,
    LessEqual,
    Greater,
    GreaterEqual,
}

impl Comparison {
    pub(crate) fn holds(self, a: f64, b: f64) -> bool {
        match self {
            Comparison::Less => a < b,
            Comparison::LessEqual => a <= b,
            Comparison::Greater => a > b,
            Comparison::GreaterEqual => a >= b,
        }
    }

    pub(crate) fn symbol(self) -> &'static str {
        match self {
            Comparison::Less => "<",
            Comparison::LessEqual => "<=",
            Comparison::Greater => ">",
            Comparison::GreaterEqual => ">=",
        }
    }
}

/// What a claim comment asserts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Assertion {
    /// The number before the comment is this expression's value, within half a unit of its
    /// last digit or within the explicit tolerance.
    Equals { expr: Expr, tolerance: Option<f64> },
    /// A comparison that must hold.
    Holds(Expr, Comparison, Expr),
    /// The effect rule's verdict on the expression's values over the groups of a key.
    Verdict(VerdictClaim),
}

/// `verdict: WORD [within δ] over(key: expr)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct VerdictClaim {
    /// The word the sentence uses.
    pub(crate) declared: Verdict,
    /// The smallest effect the sentence cares about (for `none` and `unclear`).
    pub(crate) delta: Option<f64>,
    /// The key whose values pair the differences (normally `integrator.seed`).
    pub(crate) key: String,
    /// The difference, evaluated once per value of `key`.
    pub(crate) expr: Expr,
}

/// How the evaluation of an expression asks for data: the values of one call (restricted
/// by the extra filters of the `_over` aggregates around it), and the distinct values of a
/// key among the rows a call matches.
pub(crate) trait Data {
    fn values(&mut self, call: &Call) -> Result<Vec<f64>>;
    fn distinct(&mut self, call: &Call, key: &str) -> Result<Vec<String>>;
}

impl Expr {
    /// Evaluates the expression against `data`.
    pub(crate) fn eval(&self, data: &mut dyn Data) -> Result<f64> {
        self.eval_with(data, &[])
    }

    fn eval_with(&self, data: &mut dyn Data, extra: &[Filter]) -> Result<f64> {
        Ok(match self {
            Expr::Number(n) => *n,
            Expr::Negate(e) => -e.eval_with(data, extra)?,
            Expr::Abs(e) => e.eval_with(data, extra)?.abs(),
            Expr::Binary(a, op, b) => {
                let (a, b) = (a.eval_with(data, extra)?, b.eval_with(data, extra)?);
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    _ => a / b,
                }
            }
            Expr::Call(c) => {
                let mut c = c.clone();
                c.filters.extend(extra.iter().cloned());
                let values = data.values(&c)?;
                c.aggregate.apply(&values)?
            }
            Expr::Over(aggregate, key, inner) => {
                let over = || format!("{}_over({key}: …)", aggregate_name(*aggregate));
                let values: Vec<f64> = inner
                    .per_group(data, extra, key)
                    .with_context(over)?
                    .into_iter()
                    .map(|(_, v)| v)
                    .collect();
                aggregate.apply(&values).with_context(over)?
            }
        })
    }

    /// The expression once per value of `key` (every call inside restricted to it), with
    /// that value. A group whose value is not a finite number (0/0) is an error naming it.
    pub(crate) fn per_group(
        &self,
        data: &mut dyn Data,
        extra: &[Filter],
        key: &str,
    ) -> Result<Vec<(String, f64)>> {
        let groups = self.groups(data, extra, key)?;
        let mut values = Vec::with_capacity(groups.len());
        for g in groups {
            let mut with = extra.to_vec();
            with.push(Filter {
                key: key.to_string(),
                value: g.clone(),
                negated: false,
            });
            let v = self
                .eval_with(data, &with)
                .with_context(|| format!("at {key}={}", super::quote::shown_short(&g)))?;
            if !v.is_finite() {
                bail!(
                    "at {key}={} the expression gives {v} (a division by zero?): every group needs a finite value",
                    super::quote::shown_short(&g)
                );
            }
            values.push((g, v));
        }
        Ok(values)
    }

    /// Whether the expression reads any data (else it is arithmetic on numbers written in
    /// the claim, and checks nothing).
    pub(crate) fn reads_data(&self) -> bool {
        let mut calls = Vec::new();
        self.calls(&mut calls);
        !calls.is_empty()
    }

    /// The distinct values of `key` among the rows every call of the expression matches.
    fn groups(&self, data: &mut dyn Data, extra: &[Filter], key: &str) -> Result<Vec<String>> {
        let mut calls = Vec::new();
        self.calls(&mut calls);
        let mut groups: Vec<String> = Vec::new();
        for c in calls {
            let mut c = c.clone();
            c.filters.extend(extra.iter().cloned());
            for g in data.distinct(&c, key)? {
                if !groups.contains(&g) {
                    groups.push(g);
                }
            }
        }
        Ok(groups)
    }

    fn calls<'a>(&'a self, out: &mut Vec<&'a Call>) {
        match self {
            Expr::Number(_) => {}
            Expr::Negate(e) | Expr::Abs(e) | Expr::Over(_, _, e) => e.calls(out),
            Expr::Binary(a, _, b) => {
                a.calls(out);
                b.calls(out);
            }
            Expr::Call(c) => out.push(c),
        }
    }
}

fn aggregate_name(a: Aggregate) -> &'static str {
    match a {
        Aggregate::Value => "value",
        Aggregate::Mean => "mean",
        Aggregate::Min => "min",
        Aggregate::Max => "max",
        Aggregate::Sum => "sum",
        Aggregate::Count => "count",
        Aggregate::Median => "median",
        Aggregate::Sd => "sd",
        Aggregate::Se => "se",
        Aggregate::Spread => "spread",
        Aggregate::CiLow => "ci_low",
        Aggregate::CiHigh => "ci_high",
        Aggregate::T => "t",
        Aggregate::N => "n",
    }
}

/// Parses what a claim comment says after `<!--` and before `-->`: `= expr [± tol]`,
/// `holds: expr cmp expr` or `verdict: word [within δ] over(key: expr)`. A claim that reads
/// no data is refused: it would check nothing.
pub(crate) fn parse_assertion(text: &str) -> Result<Assertion> {
    let assertion = parse_any_assertion(text)?;
    let reads = match &assertion {
        Assertion::Equals { expr, .. } => expr.reads_data(),
        Assertion::Holds(left, _, right) => left.reads_data() || right.reads_data(),
        Assertion::Verdict(v) => v.expr.reads_data(),
    };
    if !reads {
        bail!(
            "this claim reads no data (it compares numbers written in it, and would hold whatever the data say): name a source, `mean(study: column where …)`, or mark a number that is not data `<!-- given: why -->`"
        );
    }
    Ok(assertion)
}

fn parse_any_assertion(text: &str) -> Result<Assertion> {
    let text = text.trim();
    if let Some(rest) = text.strip_prefix('=') {
        let (query, tolerance) = split_tolerance(rest)?;
        return Ok(Assertion::Equals {
            expr: parse(query)?,
            tolerance,
        });
    }
    if let Some(rest) = text.strip_prefix("holds:") {
        let mut p = Parser::new(rest)?;
        let left = p.expr()?;
        let comparison = p.comparison()?;
        let right = p.expr()?;
        p.end()?;
        return Ok(Assertion::Holds(left, comparison, right));
    }
    if let Some(rest) = text.strip_prefix("verdict:") {
        let mut p = Parser::new(rest)?;
        let v = p.verdict()?;
        p.end()?;
        return Ok(Assertion::Verdict(v));
    }
    bail!(
        "a claim starts with `=` (a cited number), `holds:` (a condition) or `verdict:` (an effect over seeds)"
    )
}

/// `expr ± 0.5` → (`expr`, 0.5).
fn split_tolerance(text: &str) -> Result<(&str, Option<f64>)> {
    let Some((query, tolerance)) = text.rsplit_once('±').or_else(|| text.rsplit_once("+-")) else {
        return Ok((text, None));
    };
    let t: f64 = tolerance
        .trim()
        .parse()
        .map_err(|_| anyhow!("the tolerance after `±` is not a number"))?;
    if !t.is_finite() || t <= 0.0 {
        bail!("the tolerance after `±` must be a positive finite number, not {t}");
    }
    Ok((query, Some(t)))
}

/// Parses a claim expression.
pub(crate) fn parse(text: &str) -> Result<Expr> {
    let mut p = Parser::new(text)?;
    let e = p.expr()?;
    p.end()?;
    Ok(e)
}

struct Parser {
    chars: Vec<char>,
    at: usize,
    depth: usize,
}

impl Parser {
    fn new(text: &str) -> Result<Self> {
        let chars: Vec<char> = text.chars().collect();
        if chars.len() > MAX_QUERY_CHARS {
            bail!(
                "the query has {} characters, more than the {MAX_QUERY_CHARS} a claim may have",
                chars.len()
            );
        }
        Ok(Parser {
            chars,
            at: 0,
            depth: 0,
        })
    }

    fn end(&mut self) -> Result<()> {
        self.skip_space();
        if self.at < self.chars.len() {
            bail!(
                "unexpected `{}` at character {}",
                self.chars[self.at..].iter().take(12).collect::<String>(),
                self.at + 1
            );
        }
        Ok(())
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

    /// Enters one level of nesting, refusing beyond [`MAX_DEPTH`].
    fn deeper(&mut self) -> Result<()> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            bail!("the query nests deeper than {MAX_DEPTH} levels");
        }
        Ok(())
    }

    fn comparison(&mut self) -> Result<Comparison> {
        let c = match self.peek() {
            Some('<') => Comparison::Less,
            Some('>') => Comparison::Greater,
            _ => bail!(
                "expected a comparison (`<`, `<=`, `>`, `>=`) at character {}",
                self.at + 1
            ),
        };
        self.at += 1;
        if self.chars.get(self.at) == Some(&'=') {
            self.at += 1;
            return Ok(match c {
                Comparison::Less => Comparison::LessEqual,
                _ => Comparison::GreaterEqual,
            });
        }
        Ok(c)
    }

    /// `word [within δ] over(key: expr)`, after `verdict:`.
    fn verdict(&mut self) -> Result<VerdictClaim> {
        let word = self.name();
        let declared = Verdict::from_word(&word).ok_or_else(|| {
            anyhow!(
                "`verdict:` is followed by `{}`: expected rises, falls, none or unclear",
                word.chars().take(12).collect::<String>()
            )
        })?;
        let mut next = self.name();
        let mut delta = None;
        if next == "within" {
            if !self.peek().is_some_and(|c| c.is_ascii_digit() || c == '.') {
                bail!(
                    "expected δ, a positive number, after `within` at character {}",
                    self.at + 1
                );
            }
            let d = self.number_value()?;
            if d <= 0.0 {
                bail!("δ after `within` must be a positive number, not {d}");
            }
            delta = Some(d);
            next = self.name();
        }
        match (declared, delta) {
            (Verdict::None | Verdict::Unclear, None) => bail!(
                "`verdict: {word}` needs `within δ` before `over`: the smallest effect the sentence cares about (no effect is none without saying how small)"
            ),
            (Verdict::Rises | Verdict::Falls, Some(_)) => bail!(
                "`verdict: {word}` takes no `within δ` (an interval above or below 0 rises or falls whatever δ is): drop it"
            ),
            _ => {}
        }
        if next != "over" {
            bail!(
                "expected `over(key: expression)` after `verdict: {word}`{}",
                if delta.is_some() {
                    " within δ"
                } else {
                    " [within δ]"
                }
            );
        }
        self.expect('(')?;
        let key = self.until(&[':', ')'], false);
        self.expect(':')?;
        if key.is_empty() {
            bail!("over(…) needs `key: expression`, the key normally `integrator.seed`");
        }
        let expr = self.expr()?;
        self.expect(')')?;
        Ok(VerdictClaim {
            declared,
            delta,
            key,
            expr,
        })
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
        self.deeper()?;
        let e = match self.peek() {
            Some('-' | '−') => {
                self.at += 1;
                Expr::Negate(Box::new(self.factor()?))
            }
            Some('(') => {
                self.at += 1;
                let e = self.expr()?;
                self.expect(')')?;
                e
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number()?,
            Some(c) if c.is_ascii_alphabetic() => self.call()?,
            Some('|') => bail!(
                "`|` at character {}: filters follow `where` (a `|` splits a table row where GitHub renders it)",
                self.at + 1
            ),
            Some(c) => bail!("unexpected `{c}` at character {}", self.at + 1),
            None => bail!("the expression ends early"),
        };
        self.depth -= 1;
        Ok(e)
    }

    fn number(&mut self) -> Result<Expr> {
        self.number_value().map(Expr::Number)
    }

    fn number_value(&mut self) -> Result<f64> {
        let start = self.at;
        while let Some(&c) = self.chars.get(self.at) {
            let sign_of_exponent =
                matches!(c, '+' | '-') && matches!(self.chars.get(self.at - 1), Some('e' | 'E'));
            if !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E') || sign_of_exponent) {
                break;
            }
            self.at += 1;
        }
        let text: String = self.chars[start..self.at].iter().collect();
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(anyhow!("`{text}` is not a finite number")),
        }
    }

    /// A name: letters, digits and `_`.
    fn name(&mut self) -> String {
        self.skip_space();
        let start = self.at;
        while self
            .chars
            .get(self.at)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == '_')
        {
            self.at += 1;
        }
        self.chars[start..self.at].iter().collect()
    }

    /// Characters up to (not including) any of `stops` or the word `where`, trimmed.
    fn until(&mut self, stops: &[char], stop_at_where: bool) -> String {
        self.skip_space();
        let start = self.at;
        let mut quoted = false;
        while let Some(&c) = self.chars.get(self.at) {
            if c == '"' {
                quoted = !quoted;
            } else if !quoted
                && (stops.contains(&c)
                    || (stop_at_where && c.is_whitespace() && self.where_at(self.at + 1)))
            {
                break;
            }
            self.at += 1;
        }
        let text: String = self.chars[start..self.at].iter().collect();
        text.trim().trim_matches('"').to_string()
    }

    /// Whether the word `where` (followed by a space) starts at character `i`.
    fn where_at(&self, i: usize) -> bool {
        self.chars
            .get(i..i + 5)
            .is_some_and(|w| w == ['w', 'h', 'e', 'r', 'e'])
            && self.chars.get(i + 5).is_some_and(|c| c.is_whitespace())
    }

    fn call(&mut self) -> Result<Expr> {
        let name = self.name();
        if name == "abs" {
            self.expect('(')?;
            let e = self.expr()?;
            self.expect(')')?;
            return Ok(Expr::Abs(Box::new(e)));
        }
        if let Some(base) = name.strip_suffix("_over") {
            return self.over(base);
        }
        let aggregate = Aggregate::parse(&name).ok_or_else(|| {
            anyhow!(
                "`{name}` is not an aggregate: expected value, mean, min, max, sum, count, median, sd, se or spread (or one of them with `_over`, or abs)"
            )
        })?;
        self.expect('(')?;
        let source = self.until(&[':', ')'], false);
        self.expect(':')?;
        let column = self.until(&['|', ')'], true);
        if self.peek() == Some('|') {
            bail!(
                "`|` at character {}: filters follow `where` (a `|` splits a table row where GitHub renders it)",
                self.at + 1
            );
        }
        let mut filters = Vec::new();
        if self.where_at(self.at) {
            self.at += "where".len();
            loop {
                let item = self.until(&[',', ')'], false);
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

    /// `agg_over(key: expr)`.
    fn over(&mut self, base: &str) -> Result<Expr> {
        let Some(aggregate) = Aggregate::parse_over(base) else {
            bail!(
                "`{base}_over` is not an aggregate over groups: expected min, max, mean, median, sd, se, spread, ci_low, ci_high, t or n before `_over`"
            )
        };
        self.deeper()?;
        self.expect('(')?;
        let key = self.until(&[':', ')'], false);
        self.expect(':')?;
        if key.is_empty() {
            bail!("{base}_over(…) needs `key: expression`");
        }
        let inner = self.expr()?;
        self.expect(')')?;
        self.depth -= 1;
        Ok(Expr::Over(aggregate, key, Box::new(inner)))
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

    /// Data from closures, for tests.
    struct Fake<F: FnMut(&Call) -> Result<Vec<f64>>, G: FnMut(&Call, &str) -> Vec<String>>(F, G);

    impl<F: FnMut(&Call) -> Result<Vec<f64>>, G: FnMut(&Call, &str) -> Vec<String>> Data
        for Fake<F, G>
    {
        fn values(&mut self, call: &Call) -> Result<Vec<f64>> {
            (self.0)(call)
        }
        fn distinct(&mut self, call: &Call, key: &str) -> Result<Vec<String>> {
            Ok((self.1)(call, key))
        }
    }

    #[test]
    fn parses_arithmetic_over_calls() {
        let e = parse(
            "100 * (1 - mean(a-paper: rmse where nused=150, scene=foot) / value(b/x.json: c.d))",
        )
        .unwrap();
        let mut seen = Vec::new();
        let v = e
            .eval(&mut Fake(
                |c: &Call| {
                    seen.push(c.clone());
                    Ok(vec![if c.source == "a-paper" { 0.25 } else { 0.5 }])
                },
                |_, _| vec![],
            ))
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
        assert_eq!(parse("2e-3 * 1E+2").unwrap(), {
            Expr::Binary(
                Box::new(Expr::Number(2e-3)),
                '*',
                Box::new(Expr::Number(100.0)),
            )
        });
    }

    #[test]
    fn over_evaluates_once_per_group() {
        // Per seed: A − B is 1 for seed 1 and −0.5 for seed 2.
        let e = parse("min_over(seed: mean(s: x where m=a) - mean(s: x where m=b))").unwrap();
        let v = e
            .eval(&mut Fake(
                |c: &Call| {
                    let seed = c.filters.iter().find(|f| f.key == "seed").unwrap();
                    let m = &c.filters[0].value;
                    Ok(vec![match (m.as_str(), seed.value.as_str()) {
                        ("a", "1") => 3.0,
                        ("b", "1") => 2.0,
                        ("a", _) => 1.0,
                        _ => 1.5,
                    }])
                },
                |_, _| vec!["1".into(), "2".into()],
            ))
            .unwrap();
        assert_eq!(v, -0.5);
        let one = parse("sd_over(seed: value(s: x))")
            .unwrap()
            .eval(&mut Fake(|_: &Call| Ok(vec![1.0]), |_, _| vec!["1".into()]))
            .unwrap_err();
        assert!(format!("{one:#}").contains("at least two"), "{one:#}");
    }

    #[test]
    fn assertions_and_tolerances() {
        assert!(matches!(
            parse_assertion("= value(s: x) ± 0.5").unwrap(),
            Assertion::Equals { tolerance: Some(t), .. } if t == 0.5
        ));
        assert!(matches!(
            parse_assertion("holds: min_over(seed: value(s: x)) >= 0").unwrap(),
            Assertion::Holds(_, Comparison::GreaterEqual, _)
        ));
        for (text, says) in [
            ("value(s: x)", "starts with `=`"),
            ("= value(s: x) ± -1", "positive"),
            ("holds: value(s: x)", "comparison"),
        ] {
            let e = parse_assertion(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn mistakes_are_named() {
        for (text, says) in [
            ("avg(a: b)", "not an aggregate"),
            ("mean(a b)", "expected `:`"),
            ("mean(a: b where nused)", "not `key=value`"),
            ("mean(a: b | nused=1)", "follow `where`"),
            ("1 +", "ends early"),
            ("2 3", "unexpected `3`"),
            ("1e400", "not a finite number"),
            ("count_over(seed: 1)", "over groups"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
        assert!(Aggregate::Value.apply(&[1.0, 2.0]).is_err());
        assert!(Aggregate::Mean.apply(&[]).is_err());
        assert!(Aggregate::Count.apply(&[]).is_err(), "count of no rows");
        assert_eq!(
            Aggregate::Median.apply(&[3.0, 1.0, 2.0, 10.0]).unwrap(),
            2.5
        );
        assert_eq!(Aggregate::Spread.apply(&[3.0, 1.0, 2.0]).unwrap(), 2.0);
    }

    /// Case 7 of the fourth reliability round: deep or long queries overflowed the stack.
    #[test]
    fn deep_and_long_queries_are_refused_not_overflowing() {
        for text in [
            format!("{}1{}", "(".repeat(20_000), ")".repeat(20_000)),
            format!("{}1", "-".repeat(200_000)),
            vec!["1"; 200_000].join("+"),
        ] {
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains("characters, more than") || e.contains("deeper"),
                "{e}"
            );
        }
        let deep = format!("{}1{}", "(".repeat(40), ")".repeat(40));
        assert!(parse(&deep).unwrap_err().to_string().contains("deeper"));
        assert!(parse(&format!("{}1{}", "(".repeat(20), ")".repeat(20))).is_ok());
    }
}
