//! pbrt-v1's scene syntax: tokens, statements and typed parameter lists.
//!
//! A statement is a directive (`LookAt`, `Volume`, …) followed by every string, number and
//! bracket up to the next directive — the grammar of pbrt-v1's `pbrtparse.y` without its
//! per-directive arity, which [`super`] checks when it interprets a statement. Parameters
//! are `"type name" value` pairs; a value is one token or a bracketed list.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// A scalar in a statement: a number or a quoted string.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Value {
    Number(f64),
    Text(String),
}

/// One `"type name" value…` parameter.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Param {
    pub ty: String,
    pub name: String,
    pub values: Vec<Value>,
}

/// One directive with its arguments, where it was written.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Statement {
    pub directive: String,
    /// Leading arguments before the first parameter (numbers of `LookAt`, the type name
    /// of `Volume`, …), brackets flattened.
    pub args: Vec<Value>,
    pub params: Vec<Param>,
    pub file: PathBuf,
    pub line: usize,
}

impl Statement {
    /// `Directive "type"` for messages.
    pub fn head(&self) -> String {
        match self.args.first() {
            Some(Value::Text(t)) => format!("{} \"{t}\"", self.directive),
            _ => self.directive.clone(),
        }
    }

    /// An error located at this statement.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file.clone(),
            line: self.line,
            column: 1,
            message: format!("{}: {}", self.head(), message.into()),
        }
    }

    /// The leading arguments as exactly `n` numbers.
    pub fn numbers(&self, n: usize) -> Result<Vec<f64>> {
        let numbers: Vec<f64> = self
            .args
            .iter()
            .filter_map(|v| match v {
                Value::Number(x) => Some(*x),
                Value::Text(_) => None,
            })
            .collect();
        if numbers.len() != n || self.args.len() != n || !self.params.is_empty() {
            return Err(self.error(format!("expected {n} numbers")));
        }
        Ok(numbers)
    }

    /// The leading type name (`Volume "rawvolumegrid"` → `rawvolumegrid`).
    pub fn type_name(&self) -> Result<&str> {
        match self.args.as_slice() {
            [Value::Text(t)] => Ok(t),
            _ => Err(self.error("expected one quoted type name before the parameters")),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Word(String),
    Text(String),
    Number(f64),
    Open,
    Close,
}

/// Splits `src` into tokens with their 1-based lines.
fn tokenize(src: &str, file: &Path) -> Result<Vec<(Token, usize)>> {
    let mut tokens = Vec::new();
    let mut chars = src.char_indices().peekable();
    let mut line = 1;
    let located = |line: usize, column: usize, message: String| Error::Scene {
        file: file.to_path_buf(),
        line,
        column,
        message,
    };
    let column_of = |at: usize| src[..at].rsplit('\n').next().map_or(1, |s| s.len() + 1);
    while let Some((at, c)) = chars.next() {
        match c {
            '\n' => line += 1,
            c if c.is_whitespace() => {}
            '#' => while chars.next_if(|&(_, c)| c != '\n').is_some() {},
            '[' => tokens.push((Token::Open, line)),
            ']' => tokens.push((Token::Close, line)),
            '"' => {
                let mut text = String::new();
                loop {
                    match chars.next() {
                        Some((_, '"')) => break,
                        Some((_, '\\')) => match chars.next() {
                            Some((_, 'n')) => text.push('\n'),
                            Some((_, 't')) => text.push('\t'),
                            Some((_, other)) => text.push(other),
                            None => break,
                        },
                        Some((_, '\n')) | None => {
                            return Err(located(
                                line,
                                column_of(at),
                                "a string is not closed on its line (missing `\"`)".into(),
                            ));
                        }
                        Some((_, other)) => text.push(other),
                    }
                }
                tokens.push((Token::Text(text), line));
            }
            c if c.is_ascii_alphabetic() || c == '_' => {
                let mut word = c.to_string();
                while let Some((_, c)) =
                    chars.next_if(|&(_, c)| c.is_ascii_alphanumeric() || c == '_')
                {
                    word.push(c);
                }
                tokens.push((Token::Word(word), line));
            }
            c if c.is_ascii_digit() || matches!(c, '-' | '+' | '.') => {
                let mut number = c.to_string();
                while let Some((_, c)) = chars
                    .next_if(|&(_, c)| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+'))
                {
                    number.push(c);
                }
                let value = number.parse::<f64>().ok().filter(|v| v.is_finite());
                let value = value.ok_or_else(|| {
                    located(
                        line,
                        column_of(at),
                        format!("`{number}` is not a finite number"),
                    )
                })?;
                tokens.push((Token::Number(value), line));
            }
            other => {
                return Err(located(
                    line,
                    column_of(at),
                    format!("unexpected character `{other}`"),
                ));
            }
        }
    }
    Ok(tokens)
}

/// Parses a whole file into statements (`Include` is left to the caller).
pub(super) fn parse(src: &str, file: &Path) -> Result<Vec<Statement>> {
    let tokens = tokenize(src, file)?;
    let mut statements = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let (Token::Word(directive), line) = &tokens[i] else {
            let line = tokens[i].1;
            return Err(Error::Scene {
                file: file.to_path_buf(),
                line,
                column: 1,
                message: "expected a directive (`LookAt`, `Volume`, …) here".into(),
            });
        };
        let mut statement = Statement {
            directive: directive.clone(),
            args: Vec::new(),
            params: Vec::new(),
            file: file.to_path_buf(),
            line: *line,
        };
        i += 1;
        i = arguments(&tokens, i, &mut statement)?;
        statements.push(statement);
    }
    Ok(statements)
}

/// Reads the arguments and parameters of `statement` from `tokens[i..]`; returns the index
/// of the next directive.
fn arguments(tokens: &[(Token, usize)], mut i: usize, statement: &mut Statement) -> Result<usize> {
    while i < tokens.len() {
        match &tokens[i].0 {
            Token::Word(_) => break,
            Token::Text(t) if t.split_whitespace().count() == 2 && is_param_decl(t) => {
                let mut words = t.split_whitespace();
                let (ty, name) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
                let (values, next) = value(tokens, i + 1, statement)?;
                statement.params.push(Param {
                    ty: ty.to_string(),
                    name: name.to_string(),
                    values,
                });
                i = next;
            }
            _ if !statement.params.is_empty() => {
                return Err(error_at(
                    statement,
                    tokens[i].1,
                    format!(
                        "a value follows parameter `{}` without a `\"type name\"` before it",
                        statement.params.last().map_or("", |p| p.name.as_str())
                    ),
                ));
            }
            _ => {
                let (values, next) = value(tokens, i, statement)?;
                statement.args.extend(values);
                i = next;
            }
        }
    }
    Ok(i)
}

/// The parameter types pbrt-v1 and its successors declare.
fn is_param_decl(text: &str) -> bool {
    const TYPES: [&str; 13] = [
        "integer",
        "float",
        "point",
        "vector",
        "normal",
        "color",
        "rgb",
        "string",
        "bool",
        "texture",
        "spectrum",
        "xyz",
        "blackbody",
    ];
    text.split_whitespace()
        .next()
        .is_some_and(|ty| TYPES.contains(&ty))
}

/// One value at `tokens[i]`: a scalar or a bracketed list.
fn value(
    tokens: &[(Token, usize)],
    i: usize,
    statement: &Statement,
) -> Result<(Vec<Value>, usize)> {
    let scalar = |t: &Token| match t {
        Token::Number(x) => Some(Value::Number(*x)),
        Token::Text(s) => Some(Value::Text(s.clone())),
        _ => None,
    };
    match tokens.get(i).map(|t| &t.0) {
        Some(Token::Open) => {
            let mut values = Vec::new();
            let mut j = i + 1;
            loop {
                match tokens.get(j).map(|t| &t.0) {
                    Some(Token::Close) => return Ok((values, j + 1)),
                    Some(t) if scalar(t).is_some() => values.extend(scalar(t)),
                    _ => {
                        return Err(error_at(
                            statement,
                            tokens[i].1,
                            "a `[` list is not closed with `]`",
                        ));
                    }
                }
                j += 1;
            }
        }
        Some(t) if scalar(t).is_some() => Ok((scalar(t).into_iter().collect(), i + 1)),
        _ => Err(error_at(
            statement,
            tokens[i.saturating_sub(1)].1,
            "a parameter has no value",
        )),
    }
}

/// An error at `line` inside `statement` (which may span several lines).
fn error_at(statement: &Statement, line: usize, message: impl Into<String>) -> Error {
    Error::Scene {
        file: statement.file.clone(),
        line,
        column: 1,
        message: format!("{}: {}", statement.head(), message.into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(src: &str) -> Result<Vec<Statement>> {
        parse(src, Path::new("t.pbrt"))
    }

    #[test]
    fn statements_arguments_and_parameters() {
        let s = parse_str(
            "# comment\nLookAt 0 1 2  3 4 5 # trailing\n 0 0 1\nVolume \"rawvolumegrid\"\n  \"integer nx\" 256 \"point p0\" [ .0 -1e-1 0 ]\n  \"bool transfer\" [\"true\"]\n",
        )
        .unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].numbers(9).unwrap()[8], 1.0);
        assert_eq!((s[1].line, s[1].type_name().unwrap()), (4, "rawvolumegrid"));
        assert_eq!(s[1].params[1].values[1], Value::Number(-0.1));
        assert_eq!(s[1].params[2].values, vec![Value::Text("true".into())]);
    }

    #[test]
    fn errors_name_the_line() {
        for (src, line, needle) in [
            ("LookAt 0 0 0\nCamera \"perspective\n", 2, "not closed"),
            (
                "Film \"image\"\n \"integer xresolution\" [512\n",
                2,
                "`[` list",
            ),
            (
                "Film \"image\"\n \"integer xresolution\" 5 6\n",
                2,
                "without a",
            ),
            ("Translate 1 2 3x\n", 1, "finite number"),
            ("\n\n@\n", 3, "unexpected character"),
            ("[ 1 ]", 1, "expected a directive"),
        ] {
            let e = parse_str(src).unwrap_err();
            let Error::Scene {
                line: l, message, ..
            } = &e
            else {
                panic!("{e}")
            };
            assert_eq!(*l, line, "{src:?}: {e}");
            assert!(message.contains(needle), "{src:?}: {e}");
        }
        let s = parse_str("LookAt 0 0 0 1 1 1").unwrap();
        assert!(
            s[0].numbers(9)
                .unwrap_err()
                .to_string()
                .contains("expected 9 numbers")
        );
    }
}
