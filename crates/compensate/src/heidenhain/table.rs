//! The text framing every Heidenhain table shares (`.COM`, `.CMA`, kinematics tables): a
//! `BEGIN <NAME>.<SUFFIX> MM` line, a header line of column names, one row per line with every
//! cell inside its column's span (the span runs from the column name to the next name), and an
//! `[END]` line. The framing is the control's general table format (the iTNC 530 manual's
//! kinematics tables, p.670/684/722, show the header, the rows and `[END]`); the `BEGIN` line
//! follows the control's table files as public readers of them parse it.

use crate::CompensateError;
use crate::text::{Field, Source};
use std::fmt::Write as _;

/// One table to write: its file name (`X.COM`), column names and rows of cell texts.
pub(super) struct TableOut<'a> {
    pub name: &'a str,
    pub columns: &'a [&'a str],
    pub rows: Vec<Vec<String>>,
}

/// The table as text: each column as wide as its widest cell or name plus one blank, cells
/// left-aligned, `\n` line ends.
pub(super) fn table_text(t: &TableOut<'_>) -> String {
    let widths: Vec<usize> = t
        .columns
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let cells = t.rows.iter().map(|r| r[k].len()).max().unwrap_or(0);
            cells.max(name.len()) + 1
        })
        .collect();
    let mut text = format!("BEGIN {} MM\n", t.name);
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut l = String::new();
        for (cell, w) in cells.zip(&widths) {
            let _ = write!(l, "{cell:<w$}");
        }
        l.trim_end().to_string()
    };
    text.push_str(&line(&mut t.columns.iter().copied()));
    text.push('\n');
    for row in &t.rows {
        text.push_str(&line(&mut row.iter().map(String::as_str)));
        text.push('\n');
    }
    text.push_str("[END]\n");
    text
}

/// A table read from text: the name of its `BEGIN` line, its columns and rows.
pub(super) struct TableIn<'a> {
    pub name: String,
    /// Column names with the 1-based text column where each starts.
    pub columns: Vec<Field<'a>>,
    /// The line of the header.
    pub header_line: usize,
    pub rows: Vec<RowIn<'a>>,
    /// The line of `[END]`.
    pub end_line: usize,
}

/// One row: its line and one cell per column (trimmed text; the column of an empty cell is its
/// span's start).
pub(super) struct RowIn<'a> {
    pub line: usize,
    pub cells: Vec<Field<'a>>,
}

impl<'a> TableIn<'a> {
    /// Index of column `name`, if the table has it.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c.text == name)
    }
}

/// The positions of `table`'s column `pos` (`AXISPOS`), checked row by row: rows numbered
/// from 0 in column `nr` when the table has one, positions ascending.
pub(super) fn axis_positions(
    src: &Source<'_>,
    table: &TableIn<'_>,
    nr: Option<usize>,
    pos: usize,
) -> Result<Vec<f64>, CompensateError> {
    let mut positions: Vec<f64> = Vec::with_capacity(table.rows.len());
    for (r, row) in table.rows.iter().enumerate() {
        if let Some(nr) = nr {
            let cell = row.cells[nr];
            if cell.text.parse::<usize>() != Ok(r) {
                let found = format!(
                    "expected NR {r} (rows numbered from 0), found `{}`",
                    cell.text
                );
                return Err(src.error(row.line, cell.column, found));
            }
        }
        let cell = row.cells[pos];
        let p = src.number(row.line, cell)?;
        if let Some(&prev) = positions.last()
            && p <= prev
        {
            let msg = format!("AXISPOS must ascend: {p} follows {prev}");
            return Err(src.error(row.line, cell.column, msg));
        }
        positions.push(p);
    }
    Ok(positions)
}

/// Lines with their 1-based numbers, `\r` removed.
fn numbered(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// Reads the framing of a table whose file suffix must be `suffix` (`COM`, `CMA`, `TAB`).
pub(super) fn parse_table<'a>(
    src: &Source<'_>,
    text: &'a str,
    suffix: &str,
) -> Result<TableIn<'a>, CompensateError> {
    let mut lines = numbered(text).filter(|(_, l)| !l.trim().is_empty());
    let Some((bn, begin)) = lines.next() else {
        return Err(src.error(
            1,
            1,
            format!("expected `BEGIN <NAME>.{suffix} MM`, found an empty file"),
        ));
    };
    let name = begin_name(src, bn, begin, suffix)?;
    let Some((hn, header)) = lines.next() else {
        return Err(src.error(bn + 1, 1, "expected the header line of column names"));
    };
    check_ascii(src, hn, header)?;
    let columns = header_columns(src, hn, header)?;
    let mut rows = Vec::new();
    let mut end_line = None;
    for (n, line) in lines.by_ref() {
        if line.trim() == "[END]" {
            end_line = Some(n);
            break;
        }
        check_ascii(src, n, line)?;
        rows.push(RowIn {
            line: n,
            cells: cells(src, n, line, &columns)?,
        });
    }
    let Some(end_line) = end_line else {
        let last = text.lines().count() + 1;
        return Err(src.error(last, 1, "expected `[END]` closing the table"));
    };
    if let Some((n, l)) = lines.next() {
        let column = l.len() - l.trim_start().len() + 1;
        return Err(src.error(n, column, "expected nothing after `[END]`"));
    }
    Ok(TableIn {
        name,
        columns,
        header_line: hn,
        rows,
        end_line,
    })
}

/// The `NAME.SUFFIX` of a `BEGIN NAME.SUFFIX MM` line.
fn begin_name(
    src: &Source<'_>,
    n: usize,
    line: &str,
    suffix: &str,
) -> Result<String, CompensateError> {
    let fields = crate::text::ws_fields(line);
    let expected = format!("expected `BEGIN <NAME>.{suffix} MM`");
    if fields.first().map(|f| f.text) != Some("BEGIN") {
        let column = fields.first().map_or(1, |f| f.column);
        return Err(src.error(n, column, format!("{expected}, found `{}`", line.trim())));
    }
    let Some(name) = fields.get(1) else {
        return Err(src.error(
            n,
            line.len() + 1,
            format!("{expected}: the table name is missing"),
        ));
    };
    let has_suffix = name
        .text
        .rsplit_once('.')
        .is_some_and(|(stem, s)| !stem.is_empty() && s.eq_ignore_ascii_case(suffix));
    if !has_suffix {
        return Err(src.error(
            n,
            name.column,
            format!(
                "{expected}: the name `{}` does not end in .{suffix}",
                name.text
            ),
        ));
    }
    // The unit may be left out (a table of names has none); inch tables are not read.
    match fields.get(2) {
        Some(f) if f.text == "MM" => {}
        Some(f) => {
            return Err(src.error(
                n,
                f.column,
                format!(
                    "expected the unit MM, found `{}` (inch tables are not read)",
                    f.text
                ),
            ));
        }
        None => {}
    }
    if let Some(f) = fields.get(3) {
        return Err(src.error(n, f.column, format!("{expected}, found more after MM")));
    }
    Ok(name.text.to_string())
}

fn check_ascii(src: &Source<'_>, n: usize, line: &str) -> Result<(), CompensateError> {
    match line.char_indices().find(|(_, c)| !c.is_ascii()) {
        Some((i, c)) => Err(src.error(
            n,
            line[..i].chars().count() + 1,
            format!("expected ASCII text, found `{c}`"),
        )),
        None => Ok(()),
    }
}

/// Column names of the header and where each starts; names are unique.
fn header_columns<'a>(
    src: &Source<'_>,
    n: usize,
    line: &'a str,
) -> Result<Vec<Field<'a>>, CompensateError> {
    let columns = crate::text::ws_fields(line);
    if columns.is_empty() {
        return Err(src.error(n, 1, "expected the header line of column names"));
    }
    for (k, c) in columns.iter().enumerate() {
        if let Some(first) = columns[..k].iter().find(|p| p.text == c.text) {
            return Err(src.error(
                n,
                c.column,
                format!(
                    "column {} is named twice (first at column {})",
                    c.text, first.column
                ),
            ));
        }
    }
    Ok(columns)
}

/// The cells of a row: the text in each column's span, trimmed.
fn cells<'a>(
    src: &Source<'_>,
    n: usize,
    line: &'a str,
    columns: &[Field<'_>],
) -> Result<Vec<Field<'a>>, CompensateError> {
    let bytes = line.as_bytes();
    let first = columns[0].column - 1;
    if line[..first.min(line.len())].trim() != "" {
        return Err(src.error(n, 1, "expected the row to start in the first column's span"));
    }
    let mut out = Vec::with_capacity(columns.len());
    for (k, c) in columns.iter().enumerate() {
        let start = (c.column - 1).min(line.len());
        let end = columns
            .get(k + 1)
            .map_or(line.len(), |next| (next.column - 1).min(line.len()));
        // A cell that runs on into the next span would be cut in two: refuse it.
        if end < line.len() && end > start && bytes[end - 1] != b' ' && bytes[end] != b' ' {
            return Err(src.error(
                n,
                end + 1,
                format!(
                    "the value of column {} runs on into column {}",
                    c.text,
                    columns[k + 1].text
                ),
            ));
        }
        let raw = &line[start..end];
        let lead = raw.len() - raw.trim_start().len();
        let text = raw.trim();
        out.push(Field {
            text,
            column: if text.is_empty() {
                c.column
            } else {
                start + lead + 1
            },
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn tables_round_trip_through_their_spans() {
        let t = TableOut {
            name: "X.COM",
            columns: &["NR", "AXISPOS", "X"],
            rows: vec![
                vec!["0".into(), "-100.0000".into(), "0.0012".into()],
                vec!["1".into(), "-93.4464".into(), "".into()],
            ],
        };
        let text = table_text(&t);
        assert!(
            text.starts_with("BEGIN X.COM MM\nNR AXISPOS   X\n"),
            "{text}"
        );
        let src = Source {
            file: Path::new("x.com"),
        };
        let back = parse_table(&src, &text, "COM").unwrap();
        assert_eq!(back.name, "X.COM");
        assert_eq!(back.rows.len(), 2);
        assert_eq!(back.rows[0].cells[2].text, "0.0012");
        assert_eq!(back.rows[1].cells[2].text, "");
        assert_eq!(back.rows[1].cells[1].column, 4);
        assert_eq!(back.rows[1].cells[2].column, 14);
        assert_eq!(back.end_line, 5);
    }
}
