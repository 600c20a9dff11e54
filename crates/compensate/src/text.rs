//! Line and field reading shared by the readers: positions for error messages.

use crate::CompensateError;
use mtcal_machine::Location;
use std::path::Path;

/// One field of a line and its 1-based column.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Field<'a> {
    pub text: &'a str,
    pub column: usize,
}

/// The file being read, for error messages.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Source<'a> {
    pub file: &'a Path,
}

impl Source<'_> {
    pub fn error(&self, line: usize, column: usize, message: impl Into<String>) -> CompensateError {
        CompensateError::Parse {
            at: Location {
                file: self.file.to_path_buf(),
                line,
                column,
            },
            message: message.into(),
        }
    }

    /// The number in `field` of line `line`.
    pub fn number(&self, line: usize, field: Field<'_>) -> Result<f64, CompensateError> {
        match field.text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.error(
                line,
                field.column,
                format!("expected a finite number, found `{}`", field.text.trim()),
            )),
        }
    }

    /// Checks that line `line` has `n` fields.
    pub fn expect_fields(
        &self,
        line: usize,
        text: &str,
        fields: &[Field<'_>],
        n: usize,
        what: &str,
    ) -> Result<(), CompensateError> {
        if fields.len() == n {
            return Ok(());
        }
        let column = fields.get(n).map_or(text.len() + 1, |f| f.column);
        Err(self.error(
            line,
            column,
            format!("expected {n} fields ({what}), found {}", fields.len()),
        ))
    }
}

/// Lines with their 1-based numbers, without line ends; blank lines dropped, and lines whose
/// first non-blank character is `#` when `comments`.
pub(crate) fn data_lines(text: &str, comments: bool) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .filter(move |(_, l)| {
            let t = l.trim_start();
            !(t.is_empty() || comments && t.starts_with('#'))
        })
}

/// Comma-separated fields.
pub(crate) fn csv_fields(line: &str) -> Vec<Field<'_>> {
    let mut start = 0;
    line.split(',')
        .map(|text| {
            let f = Field {
                text,
                column: start + 1,
            };
            start += text.len() + 1;
            f
        })
        .collect()
}

/// Whitespace-separated fields.
pub(crate) fn ws_fields(line: &str) -> Vec<Field<'_>> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in line
        .char_indices()
        .chain(std::iter::once((line.len(), ' ')))
    {
        match (c.is_whitespace(), start) {
            (true, Some(s)) => {
                out.push(Field {
                    text: &line[s..i],
                    column: s + 1,
                });
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_carry_their_columns() {
        let f = csv_fields("1.0,abc,,3");
        assert_eq!(f.len(), 4);
        assert_eq!((f[1].text, f[1].column), ("abc", 5));
        assert_eq!((f[3].text, f[3].column), ("3", 10));
        let f = ws_fields("  1.0\t -2  3 ");
        assert_eq!(f.len(), 3);
        assert_eq!((f[1].text, f[1].column), ("-2", 8));
        let lines: Vec<_> = data_lines("# c\n\n1,2\r\n  # d\n3", true).collect();
        assert_eq!(lines, vec![(3, "1,2"), (5, "3")]);
    }
}
