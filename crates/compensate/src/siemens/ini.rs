//! The statements of a SINUMERIK INI file (`%_N_…_INI`) as mtcal writes and reads them: the
//! name line, `;` comments, `CHANDATA(n)`, assignments `$NAME[a,b]=value` and `M17`.

use crate::text::{Field, Source};
use crate::{CompensateError, ConventionCard};
use mtcal_machine::card::ascii;
use std::fmt::Write as _;

/// A place in the file: 1-based line and column.
pub(super) type Place = (usize, usize);

/// One statement of the file and where it starts.
pub(super) struct Statement<'a> {
    pub at: Place,
    pub kind: Kind<'a>,
}

pub(super) enum Kind<'a> {
    /// The name line, `%_N_AX_EEC_INI`.
    Header(&'a str),
    /// `CHANDATA(n)`: the channel the data belong to; mtcal writes 1 and ignores it on reading.
    Chandata,
    /// `M17`, the end of the file.
    End,
    /// `$NAME[args]=value`.
    Assign {
        name: Field<'a>,
        args: Vec<Field<'a>>,
        value: Field<'a>,
    },
}

/// The statements of `text`, comments and blank lines dropped.
pub(super) fn statements<'a>(
    src: &Source<'_>,
    text: &'a str,
) -> Result<Vec<Statement<'a>>, CompensateError> {
    let mut out = Vec::new();
    // A byte-order mark is no part of the name line.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        // `;` starts a comment to the end of the line; no statement mtcal reads holds a `;`.
        let code = raw.split(';').next().unwrap_or("").trim_end();
        let start = code.len() - code.trim_start().len();
        let body = &code[start..];
        if body.is_empty() {
            continue;
        }
        let at = (line, start + 1);
        out.push(Statement {
            at,
            kind: statement(src, at, body)?,
        });
    }
    Ok(out)
}

fn statement<'a>(src: &Source<'_>, at: Place, body: &'a str) -> Result<Kind<'a>, CompensateError> {
    if body.starts_with('%') {
        return Ok(Kind::Header(body));
    }
    if body == "M17" {
        return Ok(Kind::End);
    }
    if let Some(channel) = body
        .strip_prefix("CHANDATA(")
        .and_then(|r| r.strip_suffix(')'))
    {
        if !channel.is_empty() && channel.bytes().all(|b| b.is_ascii_digit()) {
            return Ok(Kind::Chandata);
        }
    }
    if body.starts_with('$') {
        return assignment(src, at, body);
    }
    Err(src.error(
        at.0,
        at.1,
        format!("expected an assignment `$NAME[…]=value`, `CHANDATA(1)` or `M17`, found `{body}`"),
    ))
}

/// `$NAME[a,b]=value` starting at column `at.1`.
fn assignment<'a>(src: &Source<'_>, at: Place, body: &'a str) -> Result<Kind<'a>, CompensateError> {
    let (line, col) = at;
    let err = |offset: usize, msg: String| src.error(line, col + offset, msg);
    let Some(open) = body.find('[') else {
        return Err(err(0, format!("expected `$NAME[…]=value`, found `{body}`")));
    };
    let name_text = &body[..open];
    if name_text.len() < 2
        || !name_text[1..]
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_')
    {
        return Err(err(
            0,
            format!("`{name_text}` is not a system variable name"),
        ));
    }
    let Some(close) = body[open..].find(']').map(|c| open + c) else {
        return Err(err(open, "expected `]` closing the indices".to_string()));
    };
    let mut args = Vec::new();
    let mut offset = open + 1;
    for part in body[open + 1..close].split(',') {
        args.push(trimmed(part, col + offset));
        offset += part.len() + 1;
    }
    let rest = &body[close + 1..];
    let eq = close + 1 + (rest.len() - rest.trim_start().len());
    let Some(value_text) = body[eq..].strip_prefix('=') else {
        return Err(err(eq, "expected `=` after the indices".to_string()));
    };
    let value = trimmed(value_text, col + eq + 1);
    if value.text.is_empty() {
        return Err(err(eq + 1, "expected a value after `=`".to_string()));
    }
    let name = Field {
        text: name_text,
        column: col,
    };
    Ok(Kind::Assign { name, args, value })
}

/// `text` without surrounding blanks, its column moved to the first non-blank.
fn trimmed(text: &str, column: usize) -> Field<'_> {
    let lead = text.len() - text.trim_start().len();
    Field {
        text: text.trim(),
        column: column + lead,
    }
}

/// The statements between the name line `file_name` (first) and `M17` (last).
pub(super) fn frame<'s, 'a>(
    src: &Source<'_>,
    text: &str,
    st: &'s [Statement<'a>],
    file_name: &str,
) -> Result<&'s [Statement<'a>], CompensateError> {
    let first_ok =
        matches!(st.first(), Some(Statement { kind: Kind::Header(h), .. }) if *h == file_name);
    if !first_ok {
        let (line, column) = st.first().map_or((1, 1), |s| s.at);
        return Err(src.error(
            line,
            column,
            format!("expected the file's name line `{file_name}` first"),
        ));
    }
    let Some(end) = st.iter().position(|s| matches!(s.kind, Kind::End)) else {
        let line = text.lines().count() + 1;
        return Err(src.error(line, 1, "the file ends without `M17`"));
    };
    if let Some(after) = st.get(end + 1) {
        let (line, column) = after.at;
        return Err(src.error(line, column, "nothing may follow `M17`"));
    }
    Ok(&st[1..end])
}

/// A decimal number as SINUMERIK writes it: optional sign, digits, optional fraction; no
/// exponent (its exponent is `EX`, which mtcal neither writes nor reads).
pub(super) fn real(src: &Source<'_>, line: usize, f: Field<'_>) -> Result<f64, CompensateError> {
    let t = f.text;
    let body = t.strip_prefix(['+', '-']).unwrap_or(t);
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if body.is_empty() || (int.is_empty() && frac.is_empty()) || !digits(int) || !digits(frac) {
        return Err(src.error(
            line,
            f.column,
            format!("expected a decimal number such as -0.0125 (no exponent), found `{t}`"),
        ));
    }
    t.parse::<f64>()
        .map_err(|_| src.error(line, f.column, format!("expected a number, found `{t}`")))
}

/// An index or count: digits only.
pub(super) fn index(src: &Source<'_>, line: usize, f: Field<'_>) -> Result<usize, CompensateError> {
    let t = f.text;
    if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) {
        if let Ok(v) = t.parse::<usize>() {
            return Ok(v);
        }
    }
    Err(src.error(
        line,
        f.column,
        format!("expected a non-negative whole number, found `{t}`"),
    ))
}

/// A whole number with an optional sign.
pub(super) fn integer(src: &Source<'_>, line: usize, f: Field<'_>) -> Result<i64, CompensateError> {
    let t = f.text;
    let body = t.strip_prefix(['+', '-']).unwrap_or(t);
    if !body.is_empty() && body.bytes().all(|b| b.is_ascii_digit()) {
        if let Ok(v) = t.parse::<i64>() {
            return Ok(v);
        }
    }
    Err(src.error(
        line,
        f.column,
        format!("expected a whole number, found `{t}`"),
    ))
}

/// `0` or `1`.
pub(super) fn flag(src: &Source<'_>, line: usize, f: Field<'_>) -> Result<bool, CompensateError> {
    match f.text {
        "0" => Ok(false),
        "1" => Ok(true),
        t => Err(src.error(line, f.column, format!("expected 0 or 1, found `{t}`"))),
    }
}

/// A machine axis name as an index (`X1`).
pub(super) fn axis(src: &Source<'_>, line: usize, f: Field<'_>) -> Result<String, CompensateError> {
    super::check_axis_name(f.text).map_err(|e| src.error(line, f.column, e.to_string()))?;
    Ok(f.text.to_string())
}

/// A machine axis name as a value, in parentheses (`(X1)`).
pub(super) fn axis_value(
    src: &Source<'_>,
    line: usize,
    f: Field<'_>,
) -> Result<String, CompensateError> {
    let inner = f.text.strip_prefix('(').and_then(|r| r.strip_suffix(')'));
    let Some(inner) = inner else {
        return Err(src.error(
            line,
            f.column,
            format!(
                "expected an axis name in parentheses such as `(X1)`, found `{}`",
                f.text
            ),
        ));
    };
    let inner_field = trimmed(inner, f.column + 1);
    axis(src, line, inner_field)
}

/// Checks that `args` has `n` entries.
pub(super) fn expect_args(
    src: &Source<'_>,
    line: usize,
    name: Field<'_>,
    args: &[Field<'_>],
    n: usize,
    form: &str,
) -> Result<(), CompensateError> {
    if args.len() == n {
        return Ok(());
    }
    Err(src.error(
        line,
        name.column,
        format!("expected {form}, found {} indices", args.len()),
    ))
}

/// `v` with `decimals` decimals, never `-0.000`.
pub(super) fn real_text(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

/// Longest comment line written (the `;` included).
const COMMENT_WIDTH: usize = 100;

/// The name line, a title, the card, the note and `CHANDATA(1)`.
pub(super) fn preamble(
    out: &mut String,
    file_name: &str,
    title: &str,
    card: &ConventionCard,
    note: &str,
) {
    let _ = writeln!(out, "{file_name}");
    comment(out, title);
    for line in card.lines("").lines() {
        comment(out, line);
    }
    for line in note.lines() {
        comment(out, line);
    }
    let _ = writeln!(out, "CHANDATA(1)");
}

/// `text` as `; ` comment lines: ASCII only, wrapped at blanks to [`COMMENT_WIDTH`].
pub(super) fn comment(out: &mut String, text: &str) {
    let text = ascii(text);
    let mut line = String::from(";");
    for word in text.split(' ') {
        if line.len() + 1 + word.len() > COMMENT_WIDTH && line.trim_start_matches(';').trim() != ""
        {
            let _ = writeln!(out, "{}", line.trim_end());
            // Continuations start under the card's values (`; ` and its key column).
            line = format!(";{:25}", "");
        }
        line.push(' ');
        line.push_str(word);
    }
    let _ = writeln!(out, "{}", line.trim_end());
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn assignments_carry_their_columns() {
        let src = Source {
            file: Path::new("t.ini"),
        };
        let text = "%_N_AX_EEC_INI\n; c\n  $AA_ENC_COMP[0, 12 ,X1] = -0.5 ; x\nM17\n";
        let st = statements(&src, text).unwrap();
        assert_eq!(st.len(), 3);
        let Kind::Assign { name, args, value } = &st[1].kind else {
            panic!("not an assignment")
        };
        assert_eq!((name.text, name.column), ("$AA_ENC_COMP", 3));
        assert_eq!((args[1].text, args[1].column), ("12", 19));
        assert_eq!((value.text, value.column), ("-0.5", 29));
        assert_eq!(real(&src, 3, *value).unwrap(), -0.5);
        for bad in ["1e-3", "-", ".", "1.2.3", "inf", "0x1"] {
            let f = Field {
                text: bad,
                column: 1,
            };
            assert!(real(&src, 1, f).is_err(), "{bad}");
        }
        assert_eq!(real_text(-0.0000001, 6), "0.000000");
        assert_eq!(real_text(-0.25, 3), "-0.250");
    }

    #[test]
    fn comments_are_ascii_and_wrapped() {
        let mut out = String::new();
        let long = "x → y µm −1 ".repeat(20);
        comment(&mut out, &long);
        for line in out.lines() {
            assert!(
                line.starts_with(';') && line.len() <= COMMENT_WIDTH,
                "{line}"
            );
            assert!(line.is_ascii());
        }
        assert!(out.contains("x -> y um -1"));
    }
}
