//! Line-by-line reading of text exports with located numbers.

use mtcal_located::{Located, Source};

/// One line of a text file: its 1-based number, the byte offset of its start and its text
/// without the line end (`\n` or `\r\n`).
#[derive(Debug, Clone, Copy)]
pub struct Line<'a> {
    pub number: usize,
    pub offset: usize,
    pub text: &'a str,
}

/// The lines of `text`, blank ones included (messages count them).
pub fn lines(text: &str) -> impl Iterator<Item = Line<'_>> {
    let mut offset = 0;
    text.split_inclusive('\n').enumerate().map(move |(i, raw)| {
        let line = Line {
            number: i + 1,
            offset,
            text: raw.trim_end_matches('\n').trim_end_matches('\r'),
        };
        offset += raw.len();
        line
    })
}

/// The byte offset of `part` (a sub-slice of `line.text`) in the file.
pub fn offset_of(line: &Line<'_>, part: &str) -> usize {
    line.offset + (part.as_ptr() as usize - line.text.as_ptr() as usize)
}

/// `field` (a sub-slice of `line.text`) as a finite number; else an error at it saying
/// `expected` and what was found.
pub fn number(src: &Source, line: &Line<'_>, field: &str, expected: &str) -> Result<f64, Located> {
    let trimmed = field.trim();
    match trimmed.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(src.at(
            offset_of(line, field) + (field.len() - field.trim_start().len())
                ..offset_of(line, field) + field.len(),
            format!("expected {expected}, found `{trimmed}`"),
        )),
    }
}
