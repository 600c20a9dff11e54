//! Reading a parameter record back ([`read_fanuc_parameters`]): every block, every problem named
//! by file, line and column.

use super::validate::validate_fanuc;
use super::{FanucAxis, FanucControl, FanucReverse, FanucTable, PARAMETERS, PITCH_BASE};
use crate::text::Source;
use crate::{CompensateError, read_file};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// One word of a record (a parameter's or a point's value) and where it stands.
#[derive(Clone, Copy, Debug)]
struct Word {
    value: i64,
    line: usize,
    column: usize,
}

/// What a record holds: parameter words by (parameter, axis number), point values by point.
#[derive(Default)]
struct Record {
    params: BTreeMap<(u32, u32), Word>,
    points: BTreeMap<u32, Word>,
    /// Line of the closing `%`.
    end_line: usize,
}

/// Reads a parameter record written by [`fanuc_parameter_text`] back into the tables of
/// `axes` (what the record does not say: letters, kinds, reference positions); the control's
/// series, increment system and limits from `control`. Checks what [`validate_fanuc`] checks.
pub fn read_fanuc_parameters(
    path: &Path,
    control: &FanucControl,
    axes: &[FanucAxis],
) -> Result<Vec<FanucTable>, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let record = parse_record(&src, &text, control)?;
    let mut reading = Reading {
        src: &src,
        record: &record,
        control,
        used: BTreeSet::new(),
    };
    let tables = axes
        .iter()
        .map(|axis| reading.table_of(axis))
        .collect::<Result<Vec<_>, _>>()?;
    for (&(param, number), w) in &record.params {
        if !axes.iter().any(|a| a.number == number) {
            let given: Vec<String> = axes
                .iter()
                .map(|a| format!("A{} = {}", a.number, a.letter))
                .collect();
            let msg = format!(
                "parameter {param} is set for axis A{number}, which is not among the axes given \
                 ({})",
                given.join(", ")
            );
            return Err(src.error(w.line, w.column, msg));
        }
    }
    if let Some((p, w)) = record
        .points
        .iter()
        .find(|(p, _)| !reading.used.contains(*p))
    {
        let msg = format!("point {p} belongs to no axis' table (3621…3622 or the 3626 set)");
        return Err(src.error(w.line, w.column, msg));
    }
    validate_fanuc(control, &tables)?;
    Ok(tables)
}

/// Splits the record into its words, located.
fn parse_record(
    src: &Source<'_>,
    text: &str,
    control: &FanucControl,
) -> Result<Record, CompensateError> {
    let mut record = Record::default();
    let mut opened = false;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        last_line = n;
        let line = raw.strip_suffix('\r').unwrap_or(raw).trim_end();
        if line.trim().is_empty() {
            continue;
        }
        // A control punching with NCR (parameter 0100 bit 3) ends each block LF CR CR
        // (B-63524EN p.649): the CRs open the next line.
        let lead = line.len() - line.trim_start_matches('\r').len();
        match (opened, record.end_line > 0, &line[lead..]) {
            (_, true, _) => return Err(src.error(n, 1, "expected nothing after the closing `%`")),
            (false, _, "%") => opened = true,
            (false, _, _) => {
                return Err(src.error(n, 1, "expected `%`, the start of a Fanuc record"));
            }
            (true, _, "%") => record.end_line = n,
            (true, _, _) => parse_block(src, n, line, lead, control, &mut record)?,
        }
    }
    if record.end_line == 0 {
        let what = if opened {
            "the closing `%`"
        } else {
            "`%`, the start of a Fanuc record"
        };
        return Err(src.error(
            last_line + 1,
            1,
            format!("expected {what}, found the end of the file"),
        ));
    }
    Ok(record)
}

/// A cursor over one block, for located errors.
struct Cursor<'a> {
    src: &'a Source<'a>,
    line_no: usize,
    text: &'a str,
    at: usize,
}

impl Cursor<'_> {
    fn column(&self) -> usize {
        self.at + 1
    }

    fn error(&self, message: String) -> CompensateError {
        self.src.error(self.line_no, self.column(), message)
    }

    fn found(&self) -> String {
        match self.text[self.at..].chars().next() {
            Some(c) => format!("`{c}`"),
            None => "the end of the line".to_string(),
        }
    }

    fn done(&self) -> bool {
        self.at >= self.text.len()
    }

    /// Consumes `word` (a letter or a marker such as `Q1`).
    fn expect(&mut self, word: &str, what: &str) -> Result<(), CompensateError> {
        if self.text[self.at..].starts_with(word) {
            self.at += word.len();
            return Ok(());
        }
        Err(self.error(format!("expected `{word}` {what}, found {}", self.found())))
    }

    /// An unsigned integer.
    fn digits(&mut self, what: &str) -> Result<u32, CompensateError> {
        let rest = &self.text[self.at..];
        let len = rest
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(rest.len());
        match rest[..len].parse::<u32>() {
            Ok(v) => {
                self.at += len;
                Ok(v)
            }
            Err(_) => Err(self.error(format!("expected {what}, found {}", self.found()))),
        }
    }

    /// A signed number in units of 10^−`decimals` (integers when `decimals` is 0), exactly.
    fn units(&mut self, decimals: usize, what: &str) -> Result<Word, CompensateError> {
        let (line, column) = (self.line_no, self.column());
        let rest = &self.text[self.at..];
        let len = rest
            .find(|c: char| !(c.is_ascii_digit() || "+-.".contains(c)))
            .unwrap_or(rest.len());
        let token = &rest[..len];
        let value = parse_units(token, decimals).ok_or_else(|| {
            let kind = if decimals == 0 {
                "an integer".to_string()
            } else {
                format!("a number with at most {decimals} decimals")
            };
            self.error(format!("expected {what}: {kind}, found `{token}`"))
        })?;
        self.at += len;
        Ok(Word {
            value,
            line,
            column,
        })
    }
}

/// `token` (sign, digits, optional point and at most `decimals` more digits) in units of
/// 10^−`decimals`.
fn parse_units(token: &str, decimals: usize) -> Option<i64> {
    let (negative, body) = match token.as_bytes().first()? {
        b'-' => (true, &token[1..]),
        b'+' => (false, &token[1..]),
        _ => (false, token),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if int.is_empty() || !digits(int) || !digits(frac) || frac.len() > decimals {
        return None;
    }
    let padded = format!("{int}{frac:0<decimals$}");
    let v: i64 = padded.parse().ok()?;
    Some(if negative { -v } else { v })
}

/// One block: a parameter with its axis words, or a pitch data point.
/// Block `line` (line `n`), read from byte `start` on (after the CRs of an LF CR CR ending).
fn parse_block(
    src: &Source<'_>,
    n: usize,
    line: &str,
    start: usize,
    control: &FanucControl,
    record: &mut Record,
) -> Result<(), CompensateError> {
    let mut c = Cursor {
        src,
        line_no: n,
        text: line,
        at: start,
    };
    c.expect("N", "and a parameter or pitch data number")?;
    let number_column = c.column();
    let number = c.digits("a parameter or pitch data number")?;
    if number >= PITCH_BASE {
        c.expect(control.series.pitch_marker(), "(pitch data)")?;
        c.expect("P", "and the point's value")?;
        let word = c.units(0, "the point's value")?;
        if !c.done() {
            return Err(c.error(format!(
                "expected the end of the block, found {}",
                c.found()
            )));
        }
        let point = number - PITCH_BASE;
        if record.points.insert(point, word).is_some() {
            return Err(src.error(n, number_column, format!("point {point} is given twice")));
        }
        return Ok(());
    }
    if !PARAMETERS.contains(&number) {
        let msg = format!(
            "expected one of the parameters 3620–3627 or pitch data (N10000 and up), found \
             parameter {number}"
        );
        return Err(src.error(n, number_column, msg));
    }
    c.expect(control.series.parameter_marker(), "(parameter data)")?;
    let decimals = match number {
        3624 | 3625 if control.series.real_intervals() => control.increment.decimals(),
        _ => 0,
    };
    loop {
        c.expect("A", "and an axis number")?;
        let axis_column = c.column();
        let axis = c.digits("an axis number")?;
        c.expect("P", "and the parameter's value")?;
        let word = c.units(decimals, "the parameter's value")?;
        if record.params.insert((number, axis), word).is_some() {
            let msg = format!("parameter {number} is given twice for axis A{axis}");
            return Err(src.error(n, axis_column, msg));
        }
        if c.done() {
            return Ok(());
        }
    }
}

/// A record being turned into tables: where it came from, what it holds, the control, and
/// the points the tables so far use.
struct Reading<'a> {
    src: &'a Source<'a>,
    record: &'a Record,
    control: &'a FanucControl,
    used: BTreeSet<u32>,
}

impl Reading<'_> {
    fn word(&self, p: u32, axis: &FanucAxis) -> Option<Word> {
        self.record.params.get(&(p, axis.number)).copied()
    }

    fn need(&self, p: u32, axis: &FanucAxis) -> Result<Word, CompensateError> {
        self.word(p, axis).ok_or_else(|| {
            let msg = format!(
                "expected parameter {p} for axis A{} ({}), found none in the record",
                axis.number, axis.letter
            );
            self.src.error(self.record.end_line, 1, msg)
        })
    }

    /// Word `w` of parameter `p` as a point number (or a magnification).
    fn count(&self, w: Word, p: u32) -> Result<u32, CompensateError> {
        u32::try_from(w.value).map_err(|_| {
            let msg = format!("parameter {p} must be 0 or more, got {}", w.value);
            self.src.error(w.line, w.column, msg)
        })
    }

    /// The table of `axis`; marks the points it uses.
    fn table_of(&mut self, axis: &FanucAxis) -> Result<FanucTable, CompensateError> {
        let reference_point = self.count(self.need(3620, axis)?, 3620)?;
        let first_point = self.count(self.need(3621, axis)?, 3621)?;
        let last_word = self.need(3622, axis)?;
        let last_point = self.count(last_word, 3622)?;
        let magnification = self.count(self.need(3623, axis)?, 3623)?;
        let interval_units = self.need(3624, axis)?.value;
        let revolution = self.word(3625, axis);
        if let (Some(w), false) = (revolution, axis.rotary) {
            let msg = format!(
                "3625 (travel per revolution) is for rotary axes; axis {} is linear",
                axis.letter
            );
            return Err(self.src.error(w.line, w.column, msg));
        }
        if last_point < first_point {
            let msg = format!("3622 = {last_point} must not be below 3621 = {first_point}");
            return Err(self.src.error(last_word.line, last_word.column, msg));
        }
        let count = last_point - first_point + 1;
        let values = self.point_values(axis, first_point, count, last_word)?;
        let reverse = self.reverse_of(axis, count)?;
        Ok(FanucTable {
            axis: *axis,
            increment: self.control.increment,
            reference_point,
            first_point,
            last_point,
            magnification,
            interval_units,
            revolution_units: revolution.map(|w| w.value),
            values,
            reverse,
        })
    }

    /// The negative-direction set of `axis` (3626, 3627), `count` points.
    fn reverse_of(
        &mut self,
        axis: &FanucAxis,
        count: u32,
    ) -> Result<Option<FanucReverse>, CompensateError> {
        match (self.word(3626, axis), self.word(3627, axis)) {
            (None, None) => Ok(None),
            (Some(w), None) | (None, Some(w)) => {
                let msg = "a bidirectional table needs both 3626 and 3627".to_string();
                Err(self.src.error(w.line, w.column, msg))
            }
            (Some(f), Some(o)) => {
                let first_point = self.count(f, 3626)?;
                Ok(Some(FanucReverse {
                    first_point,
                    opposite_at_reference_units: o.value,
                    values: self.point_values(axis, first_point, count, f)?,
                }))
            }
        }
    }

    /// The values of `count` points from `first`, each within the control's range; a missing
    /// point is reported at `at` (the parameter that asks for it).
    fn point_values(
        &mut self,
        axis: &FanucAxis,
        first: u32,
        count: u32,
        at: Word,
    ) -> Result<Vec<i64>, CompensateError> {
        let mut values = Vec::with_capacity(count as usize);
        for p in first..first + count {
            let Some(w) = self.record.points.get(&p) else {
                let msg = format!(
                    "expected a value for point {p} (N{}) of axis {}'s table, found none",
                    PITCH_BASE + p,
                    axis.letter
                );
                return Err(self.src.error(at.line, at.column, msg));
            };
            if w.value.abs() > self.control.value_limit {
                let msg = format!(
                    "value {} of point {p} is outside the control's range ±{}",
                    w.value, self.control.value_limit
                );
                return Err(self.src.error(w.line, w.column, msg));
            }
            if !self.used.insert(p) {
                let msg = format!("point {p} is used by two tables");
                return Err(self.src.error(w.line, w.column, msg));
            }
            values.push(w.value);
        }
        Ok(values)
    }
}
