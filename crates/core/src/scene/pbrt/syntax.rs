//! pbrt-v1's scene syntax: tokens, statements and typed parameter lists.
//!
//! A statement is a directive (`LookAt`, `Volume`, …) followed by every string, number and
//! bracket up to the next directive — the grammar of pbrt-v1's `pbrtparse.y` without its
//! per-directive arity, which [`super`] checks when it interprets a statement. Parameters
//! are `"type name" value` pairs; a value is one token or a bracketed list. Every token
//! keeps its line and column, so a mistake is reported where it was written.

use std::fmt;
use std::path::Path;
use std::rc::Rc;

use crate::error::{Error, Result};
use crate::util::escaped_prefix;

/// A scalar in a statement: a number or a quoted string.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Value {
    Number(f64),
    Text(String),
}

/// One `"type name" value…` parameter, located at its `"type name"`.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Param {
    pub ty: String,
    pub name: String,
    pub values: Vec<Value>,
    pub line: usize,
    pub column: usize,
}

impl Param {
    /// `"float fov"`, as written.
    pub fn decl(&self) -> String {
        format!("\"{} {}\"", self.ty, self.name)
    }
}

/// One directive with its arguments, where it was written.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Statement {
    pub directive: String,
    /// Leading arguments before the first parameter (numbers of `LookAt`, the type name
    /// of `Volume`, …), brackets flattened.
    pub args: Vec<Value>,
    pub params: Vec<Param>,
    /// Shared by every statement of the file (an Include may splice a file many times).
    pub file: Rc<Path>,
    pub line: usize,
    pub column: usize,
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
        self.error_at(self.line, self.column, message)
    }

    /// An error at `line:column` inside this statement (which may span several lines).
    fn error_at(&self, line: usize, column: usize, message: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file.to_path_buf(),
            line,
            column,
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

/// The directives of pbrt-v1 and of its successors (v2–v4). A file an `Include` names must
/// start with one of them (see [`check_included`]).
const DIRECTIVES: &[&str] = &[
    "Accelerator",
    "ActiveTransform",
    "AreaLightSource",
    "Attribute",
    "AttributeBegin",
    "AttributeEnd",
    "Camera",
    "ColorSpace",
    "ConcatTransform",
    "CoordSysTransform",
    "CoordinateSystem",
    "Film",
    "Identity",
    "Import",
    "Include",
    "Integrator",
    "LightSource",
    "LookAt",
    "MakeNamedMaterial",
    "MakeNamedMedium",
    "Material",
    "MediumInterface",
    "NamedMaterial",
    "ObjectBegin",
    "ObjectEnd",
    "ObjectInstance",
    "Option",
    "PixelFilter",
    "Renderer",
    "ReverseOrientation",
    "Rotate",
    "Sampler",
    "Scale",
    "SearchPath",
    "Shape",
    "SurfaceIntegrator",
    "Texture",
    "Transform",
    "TransformBegin",
    "TransformEnd",
    "TransformTimes",
    "Translate",
    "Volume",
    "VolumeIntegrator",
    "WorldBegin",
    "WorldEnd",
];

/// Refuses an included file whose first statement does not start with a pbrt directive.
/// An `Include` may name any file (`/etc/passwd`, a token file): its content must not reach
/// messages, stderr or the written scene, so only a few escaped bytes of it are shown. (The
/// scene named on the command line is the user's own and is not checked this way.)
pub(super) fn check_included(src: &str, file: &Path) -> Result<()> {
    let mut rest = src.strip_prefix('\u{feff}').unwrap_or(src);
    let mut line = 1;
    loop {
        rest = rest.trim_start_matches(|c: char| c.is_whitespace() && c != '\n');
        if let Some(after) = rest.strip_prefix('\n') {
            line += 1;
            rest = after;
        } else if rest.starts_with('#') {
            rest = rest.find('\n').map_or("", |i| &rest[i..]);
        } else {
            break;
        }
    }
    let word_end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    if rest.is_empty() || DIRECTIVES.contains(&&rest[..word_end]) {
        return Ok(());
    }
    Err(Error::format(
        file,
        format!(
            "is not a pbrt scene file: line {line} starts with `{}`, where a pbrt directive (`LookAt`, `Camera`, `WorldBegin`, …) was expected",
            escaped_prefix(rest.as_bytes(), 4)
        ),
    ))
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Word(String),
    Text(String),
    Number(f64),
    /// `nan`, `inf`, `1e999`: read as a number but not finite. Refused where it is used,
    /// so that the message names the parameter or argument.
    NonFinite(String),
    Open,
    Close,
}

/// A token, its 1-based line and column, and its byte span (a string written right
/// against the one before it, `"a"""`, is told apart from two strings).
#[derive(Debug, Clone, PartialEq)]
struct Located {
    token: Token,
    line: usize,
    column: usize,
    start: usize,
    end: usize,
}

/// Splits a file into [`Located`] tokens, one at a time.
struct Lexer<'a> {
    src: &'a str,
    file: &'a Path,
    chars: std::iter::Peekable<std::str::CharIndices<'a>>,
    line: usize,
    /// Byte offset up to which the current line's characters are counted, and their count
    /// (columns are counted incrementally: a 16 MiB one-line file stays linear).
    counted_to: usize,
    counted: usize,
    /// The last quote that opened a string right where one closed (`"a""`), as (line,
    /// column): where a line's quotes stop pairing up, it is the likely stray one.
    glued: Option<(usize, usize)>,
}

impl<'a> Lexer<'a> {
    fn new(src: &'a str, file: &'a Path) -> Self {
        // A leading byte-order mark (some editors write one) is skipped, as pbrt-v4 does.
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        Lexer {
            src,
            file,
            chars: src.char_indices().peekable(),
            line: 1,
            counted_to: 0,
            counted: 0,
            glued: None,
        }
    }

    fn error(&self, column: usize, message: String) -> Error {
        Error::Scene {
            file: self.file.to_path_buf(),
            line: self.line,
            column,
            message,
        }
    }

    /// The 1-based column of byte offset `at` on the current line (`at` never decreases).
    fn column(&mut self, at: usize) -> usize {
        self.counted += self.src[self.counted_to..at].chars().count();
        self.counted_to = at;
        self.counted + 1
    }

    /// The next token, or `None` at the end of the file.
    fn next_token(&mut self) -> Result<Option<Located>> {
        while let Some((at, c)) = self.chars.next() {
            let column = self.column(at);
            let token = match c {
                '\n' => {
                    (self.line, self.counted_to, self.counted) = (self.line + 1, at + 1, 0);
                    continue;
                }
                c if c.is_whitespace() => continue,
                '#' => {
                    while self.chars.next_if(|&(_, c)| c != '\n').is_some() {}
                    continue;
                }
                '[' => Token::Open,
                ']' => Token::Close,
                '"' => {
                    if self.src[..at].ends_with('"') {
                        self.glued = Some((self.line, column));
                    }
                    Token::Text(self.string(at, column)?)
                }
                c if c.is_ascii_alphabetic() || c == '_' => self.word(c),
                c if c.is_ascii_digit() || matches!(c, '-' | '+' | '.') => {
                    self.number(c, column)?
                }
                other => {
                    let message = format!("unexpected character {}", describe(other));
                    return Err(self.error(column, message));
                }
            };
            let end = self.chars.peek().map_or(self.src.len(), |&(i, _)| i);
            let (line, start) = (self.line, at);
            return Ok(Some(Located {
                token,
                line,
                column,
                start,
                end,
            }));
        }
        Ok(None)
    }

    /// A quoted string after its opening quote at byte `at`; it must close on its line.
    fn string(&mut self, at: usize, column: usize) -> Result<String> {
        let mut text = String::new();
        loop {
            match self.chars.next() {
                Some((_, '"')) => return Ok(text),
                Some((_, '\\')) => match self.chars.next() {
                    Some((_, 'n')) => text.push('\n'),
                    Some((_, 't')) => text.push('\t'),
                    Some((_, '\n')) | None => return Err(self.unclosed(at, column, &text)),
                    Some((_, other)) => text.push(other),
                },
                Some((_, '\n')) | None => return Err(self.unclosed(at, column, &text)),
                Some((_, other)) => text.push(other),
            }
        }
    }

    /// A string that runs to the end of its line. With nothing after the quote, or after a
    /// quote written right against a closing one earlier on the line, it is a stray quote
    /// (the thesis's own listing has `"…foot.raw""`): adding a `"`, as a missing-quote
    /// message would ask, only moves the error.
    fn unclosed(&self, at: usize, column: usize, text: &str) -> Error {
        let stray = "a stray `\"`";
        if text.trim().is_empty() {
            let after = match self.src[..at].ends_with('"') {
                true => " right after a string",
                false => "",
            };
            let message = format!(
                "{stray}{after}: nothing follows it on its line, and a string must close on the line it opens (remove it)"
            );
            return self.error(column, message);
        }
        match self.glued {
            Some((line, glued)) if line == self.line => self.error(
                glued,
                format!(
                    "{stray} right after a string? From here on the line's quotes do not pair up: the string opened at column {column} is not closed (remove the stray one)"
                ),
            ),
            _ => self.error(
                column,
                "a string is not closed on its line (missing `\"`)".into(),
            ),
        }
    }

    /// An identifier; `nan`, `inf` and `infinity` (any case) are numbers that are not finite.
    fn word(&mut self, first: char) -> Token {
        let mut word = first.to_string();
        while let Some((_, c)) = self
            .chars
            .next_if(|&(_, c)| c.is_ascii_alphanumeric() || c == '_')
        {
            word.push(c);
        }
        if word.parse::<f64>().is_ok() {
            Token::NonFinite(word)
        } else {
            Token::Word(word)
        }
    }

    fn number(&mut self, first: char, column: usize) -> Result<Token> {
        let mut number = first.to_string();
        while let Some((_, c)) = self
            .chars
            .next_if(|&(_, c)| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+'))
        {
            number.push(c);
        }
        match number.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Token::Number(v)),
            Ok(_) => Ok(Token::NonFinite(number)),
            Err(_) => Err(self.error(column, format!("`{number}` is not a finite number"))),
        }
    }
}

/// A character for a message: an invisible one (a byte-order mark, a zero-width space, a
/// control character) by its code point, so that the message shows what is there.
fn describe(c: char) -> String {
    let code = format!("U+{:04X}", c as u32);
    let invisible = c.is_control()
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2060}'..='\u{2064}');
    match c {
        '\u{feff}' => {
            format!("{code} (a byte-order mark; one is skipped only at the very start of a file)")
        }
        _ if invisible => format!("{code} (an invisible character)"),
        _ if c.is_ascii() => format!("`{c}`"),
        _ => format!("`{c}` ({code})"),
    }
}

/// A file's statements and the number of tokens they were read from.
pub(super) struct Parsed {
    pub statements: Vec<Statement>,
    pub tokens: usize,
}

/// Parses a whole file into statements (`Include` is left to the caller). `None` when the
/// file holds more than `max_tokens` tokens: reading stops there, so memory stays bounded.
pub(super) fn parse(src: &str, file: &Rc<Path>, max_tokens: usize) -> Result<Option<Parsed>> {
    let mut lexer = Lexer::new(src, file);
    let mut tokens = Vec::new();
    while let Some(token) = lexer.next_token()? {
        if tokens.len() == max_tokens {
            return Ok(None);
        }
        tokens.push(token);
    }
    let mut statements = Vec::new();
    let mut i = 0;
    while let Some(t) = tokens.get(i) {
        let Token::Word(directive) = &t.token else {
            return Err(Error::Scene {
                file: file.to_path_buf(),
                line: t.line,
                column: t.column,
                message: "expected a directive (`LookAt`, `Volume`, …) here".into(),
            });
        };
        let mut statement = Statement {
            directive: directive.clone(),
            args: Vec::new(),
            params: Vec::new(),
            file: file.clone(),
            line: t.line,
            column: t.column,
        };
        i = arguments(&tokens, i + 1, &mut statement)?;
        statements.push(statement);
    }
    Ok(Some(Parsed {
        statements,
        tokens: tokens.len(),
    }))
}

/// Where a value stands, for messages: `argument 2` of the directive, or a parameter.
enum Slot<'a> {
    /// The 1-based position of the first value among the leading arguments.
    Argument(usize),
    /// `"float fov"`.
    Parameter(&'a str),
}

impl Slot<'_> {
    /// The slot of the `k`-th value of a list written here.
    fn nth(&self, k: usize) -> String {
        match self {
            Slot::Argument(first) => format!("argument {}", first + k),
            Slot::Parameter(decl) => decl.to_string(),
        }
    }
}

impl fmt::Display for Slot<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.nth(0))
    }
}

/// Reads the arguments and parameters of `statement` from `tokens[i..]`; returns the index
/// of the next directive.
fn arguments(tokens: &[Located], mut i: usize, statement: &mut Statement) -> Result<usize> {
    while let Some(t) = tokens.get(i) {
        match &t.token {
            Token::Word(_) => break,
            Token::Text(text) if text.split_whitespace().count() == 2 && is_param_decl(text) => {
                let (param, next) = parameter(tokens, i, text, statement)?;
                if let Some(first) = statement.params.iter().find(|p| p.name == param.name) {
                    return Err(given_twice(statement, first, &param));
                }
                statement.params.push(param);
                i = next;
            }
            _ if !statement.params.is_empty() => {
                return Err(value_without_decl(tokens, i, statement));
            }
            _ => {
                let slot = Slot::Argument(statement.args.len() + 1);
                let (values, next) = value(tokens, i, statement, &slot)?.ok_or_else(|| {
                    statement.error_at(t.line, t.column, "a `]` without a `[` before it")
                })?;
                statement.args.extend(values);
                i = next;
            }
        }
    }
    Ok(i)
}

/// The parameter declared by the string `decl` at `tokens[i]`, with its value.
fn parameter(
    tokens: &[Located],
    i: usize,
    decl: &str,
    statement: &Statement,
) -> Result<(Param, usize)> {
    let mut words = decl.split_whitespace();
    let (ty, name) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    let shown = format!("\"{ty} {name}\"");
    let at = &tokens[i];
    let (values, next) = value(tokens, i + 1, statement, &Slot::Parameter(&shown))?
        .ok_or_else(|| statement.error_at(at.line, at.column, format!("{shown} has no value")))?;
    let param = Param {
        ty: ty.to_string(),
        name: name.to_string(),
        values,
        line: at.line,
        column: at.column,
    };
    Ok((param, next))
}

/// A parameter named twice in one statement: pbrt-v1 keeps the last without a word, and a
/// lookup by name would silently take one of them.
fn given_twice(statement: &Statement, first: &Param, second: &Param) -> Error {
    let again = if first.ty == second.ty {
        format!("{} is given twice", second.decl())
    } else {
        format!("{} names `{}` again", second.decl(), second.name)
    };
    statement.error_at(
        second.line,
        second.column,
        format!(
            "{again}: first as {} at line {}, column {}; remove one",
            first.decl(),
            first.line,
            first.column
        ),
    )
}

/// The error for a value after the parameters that no `"type name"` declares.
fn value_without_decl(tokens: &[Located], i: usize, statement: &Statement) -> Error {
    let t = &tokens[i];
    let glued = matches!(t.token, Token::Text(_)) && i > 0 && tokens[i - 1].end == t.start;
    let hint = if glued {
        "; it is written right against the string before it: a stray `\"`? (remove it)"
    } else {
        ""
    };
    let last = statement.params.last().map(Param::decl).unwrap_or_default();
    statement.error_at(
        t.line,
        t.column,
        format!("a value follows parameter {last} without a `\"type name\"` before it{hint}"),
    )
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

/// One value at `tokens[i]`: a scalar or a bracketed list; `None` when there is none (the
/// end of the file, a directive or a `]`).
fn value(
    tokens: &[Located],
    i: usize,
    statement: &Statement,
    slot: &Slot,
) -> Result<Option<(Vec<Value>, usize)>> {
    let Some(first) = tokens.get(i) else {
        return Ok(None);
    };
    if first.token != Token::Open {
        return Ok(scalar(first, statement, slot, 0)?.map(|v| (vec![v], i + 1)));
    }
    let mut values = Vec::new();
    for (j, t) in tokens.iter().enumerate().skip(i + 1) {
        match &t.token {
            Token::Close => return Ok(Some((values, j + 1))),
            Token::Word(_) | Token::Open => break,
            _ => values.extend(scalar(t, statement, slot, values.len())?),
        }
    }
    Err(statement.error_at(
        first.line,
        first.column,
        format!("{slot}: a `[` list is not closed with `]`"),
    ))
}

/// A number or string token as a value; a number that is not finite is an error where it
/// was written, naming the `k`-th value of `slot`.
fn scalar(t: &Located, statement: &Statement, slot: &Slot, k: usize) -> Result<Option<Value>> {
    match &t.token {
        Token::Number(x) => Ok(Some(Value::Number(*x))),
        Token::Text(s) => Ok(Some(Value::Text(s.clone()))),
        Token::NonFinite(text) => Err(statement.error_at(
            t.line,
            t.column,
            format!("{}: `{text}` is not a finite number", slot.nth(k)),
        )),
        Token::Word(_) | Token::Open | Token::Close => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(src: &str) -> Result<Vec<Statement>> {
        let file: Rc<Path> = Path::new("t.pbrt").into();
        parse(src, &file, usize::MAX).map(|p| p.expect("under the limit").statements)
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
