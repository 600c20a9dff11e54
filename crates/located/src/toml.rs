//! TOML read with every problem located.
//!
//! Two ways in, one for each shape of format:
//! - [`from_str`] / [`from_item`]: serde into typed structs (`#[serde(deny_unknown_fields)]`,
//!   `toml::Spanned` on the values a later check must locate). A serde error becomes a
//!   [`Problem`] at the key or value it is about; a format chooses its own wording for unknown
//!   keys and wrong types through [`Messages`] (the default keeps serde's, as `toml` prints it).
//! - [`document`] and the accessors beside it: the spanned tree itself, for formats whose keys
//!   are data (parameter names as table keys) and whose checks need every span.
//!
//! Both report a [`Problem`] (a byte span and a message); [`crate::Source::at`] turns it into
//! `file:line:column: message`.

use std::ops::{Range, RangeInclusive};

use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

mod number;
pub use number::Number;

/// Byte range in the file.
pub type Span = Range<usize>;
/// A value of the spanned tree and where it is written.
pub type Item<'i> = Spanned<DeValue<'i>>;
/// The result of reading a part of a file.
pub type Parsed<T> = Result<T, Problem>;

/// Something wrong at a span; the caller adds the file and turns the span into line:column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    pub span: Span,
    pub message: String,
}

/// A [`Problem`] at `span`.
pub fn problem(span: Span, message: impl Into<String>) -> Problem {
    Problem {
        span,
        message: message.into(),
    }
}

// ---------------------------------------------------------------------------------------------
// Serde

/// How a format words the problems serde finds. Each method returns `None` to keep serde's
/// own message (what `toml` prints); the default keeps them all.
pub trait Messages {
    /// A syntax error; `message` is the parser's.
    fn syntax(&self, message: &str) -> String {
        message.to_string()
    }

    /// Key `key` is not one of `expected` in the table at `table` (dotted key path, empty at
    /// the top level).
    fn unknown_key(&self, table: &str, key: &str, expected: &[&str]) -> Option<String> {
        let _ = (table, key, expected);
        None
    }

    /// The value at `path` (dotted key path) is `found` where the type wants `expected`
    /// (serde's wording of what it expects).
    fn wrong_type(&self, path: &str, found: &Found, expected: &str) -> Option<String> {
        let _ = (path, found, expected);
        None
    }
}

/// The value a type did not accept.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Found {
    /// Its kind as a noun with its article: "a string", "an integer"…
    pub noun: &'static str,
    /// The value as TOML writes it (`"x"`, `[1, 2]`), where the reader has it ([`from_table`]).
    pub value: Option<String>,
}

/// serde's messages, as `toml` prints them.
#[derive(Clone, Copy, Debug, Default)]
pub struct SerdeMessages;

impl Messages for SerdeMessages {}

/// Reads a whole TOML text into `T`.
pub fn from_str<T: DeserializeOwned>(text: &str, messages: &dyn Messages) -> Parsed<T> {
    let de = toml::de::Deserializer::parse(text).map_err(|e| {
        let msg = messages.syntax(&e.message().trim_end().replace('\n', "; "));
        problem(e.span().unwrap_or(0..0), msg)
    })?;
    from_deserializer(de, "", messages)
}

/// Reads one value of a spanned tree into `T`, keeping the spans (`toml::Spanned` fields
/// point into the whole file). `path` is the value's dotted key path, for messages.
pub fn from_item<T: DeserializeOwned>(
    item: Item<'_>,
    path: &str,
    messages: &dyn Messages,
) -> Parsed<T> {
    let fallback = item.span();
    from_deserializer(toml::de::ValueDeserializer::from(item), path, messages).map_err(|mut p| {
        if p.span.is_empty() && p.span.start == 0 {
            p.span = fallback;
        }
        p
    })
}

fn from_deserializer<'de, T, D>(de: D, prefix: &str, messages: &dyn Messages) -> Parsed<T>
where
    T: DeserializeOwned,
    D: serde::Deserializer<'de, Error = toml::de::Error>,
{
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = join(prefix, &key_path(e.path()));
        let inner = e.inner();
        let message = reword(inner.message(), &path, messages, None);
        problem(inner.span().unwrap_or(0..0), message)
    })
}

/// A problem in a table that has no spans (a set-up table the session hands on): the dotted
/// key path it is at (empty for the table itself) and the message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyProblem {
    pub key: String,
    pub message: String,
}

/// Reads a table of plain values into `T`; [`Found::value`] is given to
/// [`Messages::wrong_type`].
pub fn from_table<T: DeserializeOwned>(
    table: &toml::Table,
    messages: &dyn Messages,
) -> Result<T, KeyProblem> {
    serde_path_to_error::deserialize(table.clone()).map_err(|e| {
        let key = key_path(e.path());
        let value_at = |path: &str| value_at(table, path).map(|v| v.to_string());
        let message = reword(e.inner().message(), &key, messages, Some(&value_at));
        KeyProblem { key, message }
    })
}

/// The value at a dotted key path of `table` (array indices as `[i]`).
fn value_at<'a>(table: &'a toml::Table, path: &str) -> Option<&'a toml::Value> {
    let mut parts = path.split('.');
    let first = parts.next()?;
    let (key, index) = split_index(first);
    let mut value = table.get(key)?;
    if let Some(i) = index {
        value = value.get(i)?;
    }
    for part in parts {
        let (key, index) = split_index(part);
        value = value.get(key)?;
        if let Some(i) = index {
            value = value.get(i)?;
        }
    }
    Some(value)
}

/// `key[3]` → (`key`, Some(3)).
fn split_index(part: &str) -> (&str, Option<usize>) {
    match part.split_once('[') {
        Some((key, rest)) => (key, rest.trim_end_matches(']').parse().ok()),
        None => (part, None),
    }
}

/// `i` of a key path `<list>[i]` (as [`Messages`] and [`KeyProblem`] give them).
pub fn index_in(path: &str, list: &str) -> Option<usize> {
    path.strip_prefix(list)?
        .strip_prefix('[')?
        .strip_suffix(']')?
        .parse()
        .ok()
}

fn join(prefix: &str, path: &str) -> String {
    match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (_, true) => prefix.to_string(),
        _ => format!("{prefix}.{path}"),
    }
}

/// The dotted key path of a serde error (`run[2].use`; empty at the top level).
fn key_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    out
}

/// What a serde message says, parsed back from serde's own wording (its default
/// `de::Error` methods, which `toml` uses; a test pins them).
#[derive(Debug, PartialEq, Eq)]
enum Complaint<'a> {
    UnknownKey {
        key: &'a str,
        expected: Vec<&'a str>,
    },
    WrongType {
        found: &'a str,
        expected: &'a str,
    },
    Other,
}

fn complaint(message: &str) -> Complaint<'_> {
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some((key, tail)) = rest.split_once('`')
    {
        // serde lists them as "`a`", "`a` or `b`" or "`a`, `b`, or `c`": every other piece
        // between backticks is a name.
        let expected = tail
            .strip_prefix(", expected ")
            .map(|list| list.split('`').skip(1).step_by(2).collect())
            .unwrap_or_default();
        return Complaint::UnknownKey { key, expected };
    }
    // The found value may itself hold ", expected " (a string); serde's expectation is last.
    if let Some(rest) = message.strip_prefix("invalid type: ")
        && let Some((found, expected)) = rest.rsplit_once(", expected ")
    {
        return Complaint::WrongType { found, expected };
    }
    Complaint::Other
}

/// serde's description of an unexpected value ("string \"x\"", "integer `3`", "sequence") as a
/// noun with its article.
fn found_noun(found: &str) -> &'static str {
    let kind = found.split([' ', '`']).next().unwrap_or("");
    match kind {
        "string" | "character" => "a string",
        "integer" => "an integer",
        "floating" => "a float",
        "boolean" => "a boolean",
        "sequence" => "an array",
        "map" => "a table",
        _ => "another kind of value",
    }
}

/// The value at a key path as TOML writes it, where the reader has the values.
type ValueAt<'a> = dyn Fn(&str) -> Option<String> + 'a;

fn reword(
    message: &str,
    path: &str,
    messages: &dyn Messages,
    value_at: Option<&ValueAt<'_>>,
) -> String {
    let reworded = match complaint(message) {
        Complaint::UnknownKey { key, expected } => {
            // The path ends at the unknown key itself; its table is what comes before.
            let table = path
                .strip_suffix(key)
                .map(|t| t.trim_end_matches('.'))
                .unwrap_or(path);
            messages.unknown_key(table, key, &expected)
        }
        Complaint::WrongType { found, expected } => {
            let found = Found {
                noun: found_noun(found),
                value: value_at.and_then(|v| v(path)),
            };
            messages.wrong_type(path, &found, expected)
        }
        Complaint::Other => None,
    };
    reworded.unwrap_or_else(|| message.trim_end().replace('\n', "; "))
}

// ---------------------------------------------------------------------------------------------
// The spanned tree

/// Parses `text` into its spanned tree.
pub fn document(text: &str) -> Parsed<DeTable<'_>> {
    DeTable::parse(text).map(Spanned::into_inner).map_err(|e| {
        let msg = format!("this is not valid TOML: {}", e.message());
        problem(e.span().unwrap_or(0..0), msg)
    })
}

/// The entries of a table in file order: key, key span, value.
pub fn entries<'a, 'i>(table: &'a DeTable<'i>) -> Vec<(&'a str, Span, &'a Item<'i>)> {
    let mut out: Vec<_> = table
        .iter()
        .map(|(k, v)| (k.get_ref().as_ref(), k.span(), v))
        .collect();
    out.sort_by_key(|(_, span, _)| span.start);
    out
}

/// Rejects the first key (in file order) that is not in `allowed`.
pub fn check_keys(table: &DeTable, allowed: &[&str], place: &str) -> Parsed<()> {
    match entries(table)
        .into_iter()
        .find(|(k, _, _)| !allowed.contains(k))
    {
        Some((key, span, _)) => Err(problem(
            span,
            format!(
                "unknown key `{key}` {place}; expected one of: {}",
                allowed.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

/// An optional `schema` key must name this format's version.
pub fn check_schema(top: &DeTable, expected: &str) -> Parsed<()> {
    let Some(item) = top.get("schema") else {
        return Ok(());
    };
    let found = string(item, "`schema`", &format!("\"{expected}\""))?;
    if found == expected {
        Ok(())
    } else {
        let msg = format!(
            "schema \"{found}\" is not supported: this version of mtcal reads \"{expected}\""
        );
        Err(problem(item.span(), msg))
    }
}

/// A value's kind as a noun with its article ("a string", "an integer").
pub fn a_type(value: &DeValue) -> &'static str {
    match value {
        DeValue::String(_) => "a string",
        DeValue::Integer(_) => "an integer",
        DeValue::Float(_) => "a float",
        DeValue::Boolean(_) => "a boolean",
        DeValue::Datetime(_) => "a date-time",
        DeValue::Array(_) => "an array",
        DeValue::Table(_) => "a table",
    }
}

/// "`what` must be `expected`, found a string".
pub fn wrong_type(item: &Item, what: &str, expected: &str) -> Problem {
    let found = a_type(item.get_ref());
    problem(
        item.span(),
        format!("{what} must be {expected}, found {found}"),
    )
}

pub fn table<'a, 'i>(item: &'a Item<'i>, what: &str) -> Parsed<&'a DeTable<'i>> {
    match item.get_ref() {
        DeValue::Table(t) => Ok(t),
        _ => Err(wrong_type(item, what, "a table")),
    }
}

pub fn array<'a, 'i>(item: &'a Item<'i>, what: &str, expected: &str) -> Parsed<&'a [Item<'i>]> {
    match item.get_ref() {
        DeValue::Array(a) => Ok(a),
        _ => Err(wrong_type(item, what, expected)),
    }
}

pub fn string<'a>(item: &'a Item, what: &str, expected: &str) -> Parsed<&'a str> {
    match item.get_ref() {
        DeValue::String(s) => Ok(s),
        _ => Err(wrong_type(item, what, expected)),
    }
}

pub fn boolean(item: &Item, what: &str) -> Parsed<bool> {
    match item.get_ref() {
        DeValue::Boolean(b) => Ok(*b),
        _ => Err(wrong_type(item, what, "true or false")),
    }
}

/// A finite number; integers are accepted for floats.
pub fn number(item: &Item, what: &str) -> Parsed<f64> {
    let value = match item.get_ref() {
        DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
        DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
            .ok()
            .map(|i| i as f64),
        _ => return Err(wrong_type(item, what, "a number")),
    };
    match value {
        Some(v) if v.is_finite() => Ok(v),
        _ => Err(problem(
            item.span(),
            format!("{what} must be a finite number"),
        )),
    }
}

pub fn positive(item: &Item, what: &str) -> Parsed<f64> {
    let v = number(item, what)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(problem(
            item.span(),
            format!("{what} must be positive, got {v}"),
        ))
    }
}

/// An integer within `range`.
pub fn count(item: &Item, what: &str, range: RangeInclusive<usize>) -> Parsed<usize> {
    let (lo, hi) = (*range.start(), *range.end());
    let expected = format!("an integer from {lo} to {hi}");
    let DeValue::Integer(i) = item.get_ref() else {
        return Err(wrong_type(item, what, &expected));
    };
    let value = i64::from_str_radix(i.as_str(), i.radix()).ok();
    match value.and_then(|v| usize::try_from(v).ok()) {
        Some(v) if range.contains(&v) => Ok(v),
        _ => Err(problem(
            item.span(),
            format!("{what} must be {expected}, got {i}"),
        )),
    }
}

#[cfg(test)]
mod tests;
