//! Line-by-line CSV reading for the continuous stream and the log: a header of named columns,
//! then rows of numbers, an empty cell given as `None` for the caller to judge. The file is
//! read a line at a time, so a stream of millions of rows is never held as text.
//!
//! Accepted as the session's run files accept them: a byte-order mark, `\r\n` line ends, blanks
//! around cells, blank lines. Every refusal names the file, the line and the column.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use mtcal_located::{Located, Location, NOT_UTF8};

use crate::ImportError;

/// One data row: its cells in header order and where each one starts.
#[derive(Debug)]
pub struct Row<'a> {
    path: &'a Path,
    /// 1-based line number.
    pub line: usize,
    pub cells: &'a [Option<f64>],
    /// 1-based character column of each cell.
    columns: &'a [usize],
}

impl Row<'_> {
    /// `message` located at cell `k` of this row.
    pub fn error(&self, k: usize, message: impl Into<String>) -> ImportError {
        located(self.path, self.line, self.columns[k], message)
    }
}

/// A header cell a caller refuses: its index and the message.
pub type HeaderProblem = (usize, String);

/// Reads `path`: the first non-blank line is the header, given to `header`, which makes the
/// caller's layout `L` of it or refuses a cell by index (a missing column by an index past the
/// end: located at the line's start); every later non-blank line is a row given to `row` with
/// the layout. Returns the layout and the number of rows.
pub fn read_rows<L>(
    path: &Path,
    header: impl FnOnce(&[String]) -> Result<L, HeaderProblem>,
    mut row: impl FnMut(&L, &Row<'_>) -> Result<(), ImportError>,
) -> Result<(L, usize), ImportError> {
    let file = std::fs::File::open(path).map_err(|cause| io_error(path, cause))?;
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let mut lines = Lines::default();
    let (made, names) = loop {
        let Some((number, text)) = lines.next(&mut reader, path)? else {
            return Err(located(
                path,
                1,
                1,
                "expected a header row of column names, found an empty file",
            ));
        };
        if text.trim().is_empty() {
            continue;
        }
        let (names, columns) = split_header(text);
        let made = header(&names).map_err(|(k, message)| {
            located(path, number, columns.get(k).copied().unwrap_or(1), message)
        })?;
        break (made, names);
    };
    let (mut cells, mut rows) = (Vec::new(), 0usize);
    while let Some((number, text)) = lines.next(&mut reader, path)? {
        if text.trim().is_empty() {
            continue;
        }
        let columns = parse_cells(path, number, text, &names, &mut cells)?;
        let at = Row {
            path,
            line: number,
            cells: &cells,
            columns: &columns,
        };
        row(&made, &at)?;
        rows += 1;
    }
    Ok((made, rows))
}

/// The file's lines, read into one reused buffer.
#[derive(Default)]
struct Lines {
    buf: Vec<u8>,
    number: usize,
}

impl Lines {
    /// The next line's number and text without its end, or `None` at the end of the file.
    fn next<'a>(
        &'a mut self,
        reader: &mut impl BufRead,
        path: &Path,
    ) -> Result<Option<(usize, &'a str)>, ImportError> {
        self.buf.clear();
        let n = reader
            .read_until(b'\n', &mut self.buf)
            .map_err(|cause| io_error(path, cause))?;
        if n == 0 {
            return Ok(None);
        }
        self.number += 1;
        let text = std::str::from_utf8(&self.buf).map_err(|e| {
            let valid = String::from_utf8_lossy(&self.buf[..e.valid_up_to()]);
            located(path, self.number, valid.chars().count() + 1, NOT_UTF8)
        })?;
        let text = text.trim_end_matches('\n').trim_end_matches('\r');
        // The byte-order mark editors on Windows write: not part of the first column's name.
        let text = if self.number == 1 {
            text.strip_prefix('\u{feff}').unwrap_or(text)
        } else {
            text
        };
        Ok(Some((self.number, text)))
    }
}

/// The header's names (trimmed) and the column where each starts.
fn split_header(text: &str) -> (Vec<String>, Vec<usize>) {
    let mut names = Vec::new();
    let mut columns = Vec::new();
    let mut column = 1;
    for cell in text.split(',') {
        let lead = cell.len() - cell.trim_start().len();
        columns.push(column + lead);
        names.push(cell.trim().to_string());
        column += cell.chars().count() + 1;
    }
    (names, columns)
}

/// The row's cells as numbers (`None` for an empty cell) into `cells`; returns their columns.
fn parse_cells(
    path: &Path,
    line: usize,
    text: &str,
    names: &[String],
    cells: &mut Vec<Option<f64>>,
) -> Result<Vec<usize>, ImportError> {
    cells.clear();
    let mut columns = Vec::with_capacity(names.len());
    let mut column = 1;
    for (k, cell) in text.split(',').enumerate() {
        let lead = cell.len() - cell.trim_start().len();
        let at = column + lead;
        column += cell.chars().count() + 1;
        let Some(name) = names.get(k) else {
            return Err(located(
                path,
                line,
                at,
                format!(
                    "expected {} cells ({}), found more (a decimal comma or a `;` \
                     separator?)",
                    names.len(),
                    names.join(",")
                ),
            ));
        };
        cells.push(cell_value(cell.trim()).map_err(|found| {
            located(
                path,
                line,
                at,
                format!("column \"{name}\": expected a number, found `{found}`"),
            )
        })?);
        columns.push(at);
    }
    if cells.len() < names.len() {
        return Err(located(
            path,
            line,
            column,
            format!(
                "expected {} cells ({}), found {}",
                names.len(),
                names.join(","),
                cells.len()
            ),
        ));
    }
    Ok(columns)
}

/// An empty cell as `None`, a finite number as itself; anything else is returned as found.
fn cell_value(cell: &str) -> Result<Option<f64>, &str> {
    if cell.is_empty() {
        return Ok(None);
    }
    // `parse` takes `inf`, `NaN`: not numbers a file of readings may hold.
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(cell),
    }
}

pub fn located(path: &Path, line: usize, column: usize, message: impl Into<String>) -> ImportError {
    ImportError::Invalid(Located {
        at: Location::at(path, line, column),
        message: message.into(),
    })
}

fn io_error(path: &Path, cause: std::io::Error) -> ImportError {
    ImportError::Io {
        path: PathBuf::from(path),
        cause,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads `text` as a file; the rows' cells, or the error's message.
    fn rows(text: &[u8]) -> Result<Vec<Vec<Option<f64>>>, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        std::fs::write(&path, text).unwrap();
        let mut out = Vec::new();
        read_rows(
            &path,
            |names| match names.iter().position(|n| n == "bad") {
                Some(k) => Err((k, "no bad column".into())),
                None => Ok(()),
            },
            |_, row| {
                out.push(row.cells.to_vec());
                Ok(())
            },
        )
        .map_err(|e| e.to_string().replace(&path.display().to_string(), "s.csv"))?;
        Ok(out)
    }

    #[test]
    fn rows_read_with_empty_cells_bom_crlf_and_blank_lines() {
        let got = rows(b"\xef\xbb\xbft, dx\r\n0,1.5\r\n\r\n1, \r\n").unwrap();
        assert_eq!(got, vec![vec![Some(0.0), Some(1.5)], vec![Some(1.0), None]]);
    }

    #[test]
    fn bad_cells_are_located_by_line_and_column() {
        assert_eq!(
            rows(b"t,dx\n0,1\n1, abc\n").unwrap_err(),
            "s.csv:3:4: column \"dx\": expected a number, found `abc`"
        );
        assert_eq!(
            rows(b"t,dx\n0,NaN\n").unwrap_err(),
            "s.csv:2:3: column \"dx\": expected a number, found `NaN`"
        );
        assert!(
            rows(b"t,dx\n0,1,5\n")
                .unwrap_err()
                .starts_with("s.csv:2:5: expected 2 cells (t,dx), found more")
        );
        assert_eq!(
            rows(b"t,dx\n0\n").unwrap_err(),
            "s.csv:2:3: expected 2 cells (t,dx), found 1"
        );
        assert_eq!(rows(b"t,bad\n").unwrap_err(), "s.csv:1:3: no bad column");
        assert!(
            rows(b"t,dx\n0,\xff\n")
                .unwrap_err()
                .starts_with("s.csv:2:3: expected UTF-8")
        );
        assert!(rows(b"").unwrap_err().contains("found an empty file"));
    }
}
