//! Run files: one CSV table per run, read with located errors and written so that reading it
//! back gives the same numbers bit for bit.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{SessionError, at};

/// The context columns' names besides `T_<name>` (°C), `P_<name>` (air pressure, hPa) and
/// `H_<name>` (relative humidity, %).
pub const CONTEXT_COLUMNS: &[&str] = &["S", "F"];

/// One run's table as the file gives it, in file units (mm, degrees, µm, µrad, °C, rpm,
/// mm/min).
#[derive(Debug, Clone, PartialEq)]
pub struct RunTable {
    /// The file read, or the file to write.
    pub path: std::path::PathBuf,
    /// The header as the file writes it, in file order. [`write_run`] writes the columns in this
    /// order; leave it empty to write them as `t`, axes, readings, context.
    pub columns: Vec<String>,
    /// Seconds since the session started, strictly increasing.
    pub t: Vec<f64>,
    /// The machine's axis letters, in the order the caller gave them ([`RunColumns::axes`]).
    pub axes: Vec<char>,
    /// Commanded positions, row-major `len() × axes.len()`, mm or degrees.
    pub positions: Vec<f64>,
    /// The instrument's reading columns, in the order the caller gave them.
    pub readings: Vec<String>,
    /// Readings, row-major `len() × readings.len()`; `None` when the run has none of the
    /// reading columns (a validation run may leave them out).
    pub values: Option<Vec<f64>>,
    /// Context columns (`T_<name>`, `P_<name>`, `H_<name>`, `S`, `F`) in file order.
    pub context: Vec<(String, Vec<f64>)>,
    /// The instrument's label columns (text, one value per row: an artefact's `feature`), in
    /// the order the caller gave them ([`RunColumns::labels`]).
    pub labels: Vec<(String, Vec<String>)>,
}

impl RunTable {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Room for `rows` more rows in every numeric column.
    fn reserve(&mut self, rows: usize) {
        self.t.reserve_exact(rows);
        self.positions.reserve_exact(rows * self.axes.len());
        if let Some(v) = &mut self.values {
            v.reserve_exact(rows * self.readings.len());
        }
        for (_, c) in &mut self.context {
            c.reserve_exact(rows);
        }
    }

    /// Whether the table has no rows (a file never gives one).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The commanded positions of row `i`, in the order of [`axes`](Self::axes).
    pub fn q_row(&self, i: usize) -> &[f64] {
        let n = self.axes.len();
        &self.positions[i * n..(i + 1) * n]
    }

    /// The readings of row `i`, in the order of [`readings`](Self::readings).
    pub fn reading_row(&self, i: usize) -> Option<&[f64]> {
        let n = self.readings.len();
        self.values.as_ref().map(|v| &v[i * n..(i + 1) * n])
    }

    /// The context column called `name`.
    pub fn context_column(&self, name: &str) -> Option<&[f64]> {
        self.context
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// Row `i`'s label values, in the order of [`labels`](Self::labels).
    pub fn label_row(&self, i: usize) -> Vec<&str> {
        self.labels.iter().map(|(_, v)| v[i].as_str()).collect()
    }

    /// `t`, the axes, the labels, the readings (if any) and the context columns, in that order.
    pub fn canonical_columns(&self) -> Vec<String> {
        let mut out = vec!["t".to_string()];
        out.extend(self.axes.iter().map(char::to_string));
        out.extend(self.labels.iter().map(|(n, _)| n.clone()));
        if self.values.is_some() {
            out.extend(self.readings.iter().cloned());
        }
        out.extend(self.context.iter().map(|(n, _)| n.clone()));
        out
    }
}

/// Which columns a run must have: the machine's axes and the instrument's readings.
#[derive(Debug, Clone, Copy)]
pub struct RunColumns<'a> {
    /// The machine's axis letters.
    pub axes: &'a [char],
    /// The instrument's reading columns, e.g. `["dx", "dy", "dz"]`.
    pub readings: &'a [&'a str],
    /// Whether the run may leave out all of its reading columns (validation runs).
    pub readings_optional: bool,
    /// The instrument's label columns (text; always required), e.g. `["feature"]`.
    pub labels: &'a [&'a str],
}

/// What a column of the file holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Time,
    Axis(usize),
    Reading(usize),
    Context(usize),
    Label(usize),
}

/// The header, classified.
struct Layout {
    names: Vec<String>,
    kinds: Vec<Kind>,
    context: Vec<String>,
    has_readings: bool,
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads and checks the run file at `path`.
///
/// Every problem is reported as `file:line:field` with the column's name, what was expected and
/// what was found; see the crate documentation for the rules.
pub fn read_run(path: &Path, cols: &RunColumns) -> Result<RunTable, SessionError> {
    // A good file is parsed as it streams from the disk, so a run of millions of rows never
    // holds its text in memory; anything unusual (a byte-order mark, no rows) or wrong is read
    // again as a whole, which gives the located error (line numbers count CRLF lines right).
    if let Ok(table) = read_run_streaming(path, cols) {
        return Ok(table);
    }
    read_run_text(path, cols)
}

/// The fast path of [`read_run`]: the file parsed from a buffered reader; any error (even one
/// whose message [`read_run_text`] would word differently) means "read it as text".
fn read_run_streaming(path: &Path, cols: &RunColumns) -> Result<RunTable, SessionError> {
    use std::io::{BufRead as _, BufReader};
    let file = std::fs::File::open(path).map_err(|e| SessionError::read(path, e))?;
    let mut input = BufReader::with_capacity(1 << 20, file);
    let first = input.fill_buf().map_err(|e| SessionError::read(path, e))?;
    let unusual = first.starts_with(b"\xef\xbb\xbf")
        || first
            .iter()
            .take_while(|&&b| b != b'\n')
            .any(|&b| b == b';');
    if unusual || first.iter().all(u8::is_ascii_whitespace) {
        let msg = "read as text";
        return Err(SessionError::invalid(at(path, 1, 1), msg));
    }
    let reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(input);
    let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    parse_records(path, cols, reader, bytes)
}

/// [`read_run`] from the whole text, with every check's located error.
fn read_run_text(path: &Path, cols: &RunColumns) -> Result<RunTable, SessionError> {
    let bytes = std::fs::read(path).map_err(|e| SessionError::read(path, e))?;
    parse_run(path, crate::text_of(path, bytes)?, cols)
}

/// [`read_run`] of a run's text held in memory (`path` names it in the messages).
pub fn parse_run(path: &Path, text: String, cols: &RunColumns) -> Result<RunTable, SessionError> {
    let mut text = text;
    if text.contains('\r') {
        // The csv crate counts a CRLF file's lines one short from the second record on.
        text = text.replace("\r\n", "\n");
    }
    if text.trim().is_empty() {
        let msg = format!(
            "the file is empty: expected a header row such as `{}` and one row per sample",
            example_header(cols)
        );
        return Err(SessionError::invalid(at(path, 1, 1), msg));
    }
    let header_line = text.lines().next().unwrap_or("");
    if let Some(pos) = header_line.find(';') {
        let field = header_line[..pos].matches(',').count() + 1;
        let msg = format!(
            "the separator is ';', expected ',' (and '.' as the decimal separator): write the \
             header as `{}`",
            example_header(cols)
        );
        return Err(SessionError::invalid(at(path, 1, field), msg));
    }
    let reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let bytes = text.len() as u64;
    parse_records(path, cols, reader, bytes)
}

/// Rows read before the columns are given their estimated final size.
const ROWS_TO_ESTIMATE: usize = 256;

/// The 1-based line of data row `row` (0-based) of the run file at `path`: the header is line 1,
/// blank lines are skipped as the reader skips them, CRLF counts as one line end. Read again
/// from the file, for the located message of a problem found after reading; `None` if the
/// file cannot be read or has fewer rows.
pub fn row_line(path: &Path, row: usize) -> Option<usize> {
    let bytes = std::fs::read(path).ok()?;
    let text = String::from_utf8_lossy(&bytes);
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .nth(row + 1)
        .map(|(k, _)| k + 1)
}

/// The records of a run file (`file_bytes` long) after the checks on its text.
fn parse_records<R: std::io::Read>(
    path: &Path,
    cols: &RunColumns,
    mut reader: csv::Reader<R>,
    file_bytes: u64,
) -> Result<RunTable, SessionError> {
    // One record, reused row after row.
    let mut record = csv::StringRecord::new();
    let read = |reader: &mut csv::Reader<R>, record: &mut csv::StringRecord| {
        reader.read_record(record).map_err(|e| csv_error(path, &e))
    };
    if !read(&mut reader, &mut record)? {
        let msg = "the file has no header row";
        return Err(SessionError::invalid(at(path, 1, 1), msg));
    }
    let header = record.clone();
    let layout = classify(path, &header, cols)?;
    let mut table = RunTable {
        path: path.to_path_buf(),
        columns: layout.names.clone(),
        t: Vec::new(),
        axes: cols.axes.to_vec(),
        positions: Vec::new(),
        readings: cols.readings.iter().map(|s| s.to_string()).collect(),
        values: layout.has_readings.then(Vec::new),
        context: layout
            .context
            .iter()
            .map(|n| (n.clone(), Vec::new()))
            .collect(),
        labels: cols
            .labels
            .iter()
            .map(|n| (n.to_string(), Vec::new()))
            .collect(),
    };
    let mut row_q = vec![0.0; cols.axes.len()];
    let mut row_r = vec![0.0; cols.readings.len()];
    let mut last_t: Option<(f64, u64)> = None;
    let mut first_row_byte = None;
    while read(&mut reader, &mut record)? {
        let line = record.position().map_or(0, csv::Position::line);
        let byte = record.position().map_or(0, csv::Position::byte);
        let first_byte = *first_row_byte.get_or_insert(byte);
        if table.t.len() == ROWS_TO_ESTIMATE && byte > first_byte {
            // The columns are sized once for the whole file, from the rows so far, instead
            // of doubling as they grow: the buffers a doubling frees stay resident as holes
            // in the heap, a run's worth of them.
            let per_row = (byte - first_byte) as f64 / ROWS_TO_ESTIMATE as f64;
            let rows = ((file_bytes.saturating_sub(first_byte)) as f64 / per_row * 1.05) as usize;
            table.reserve(rows.saturating_sub(table.t.len()));
        }
        if record.len() == 1 && record[0].is_empty() {
            continue; // a line of blanks
        }
        check_field_count(path, line, &layout, &record)?;
        for (j, field) in record.iter().enumerate() {
            if let Kind::Label(k) = layout.kinds[j] {
                if field.is_empty() {
                    let msg = format!(
                        "column \"{}\": expected a label, found an empty field",
                        layout.names[j]
                    );
                    return Err(SessionError::invalid(at(path, line as usize, j + 1), msg));
                }
                table.labels[k].1.push(field.to_string());
                continue;
            }
            let x = number(path, line, j, &layout.names[j], field)?;
            match layout.kinds[j] {
                Kind::Time => {
                    check_increasing(path, line, j, last_t, x)?;
                    last_t = Some((x, line));
                    table.t.push(x);
                }
                Kind::Axis(k) => row_q[k] = x,
                Kind::Reading(k) => row_r[k] = x,
                Kind::Context(k) => table.context[k].1.push(x),
                Kind::Label(_) => unreachable!("labels are read above"),
            }
        }
        table.positions.extend_from_slice(&row_q);
        if let Some(v) = &mut table.values {
            v.extend_from_slice(&row_r);
        }
    }
    if table.t.is_empty() {
        let msg = "the file has a header but no rows: expected at least one row of data";
        return Err(SessionError::invalid(at(path, 2, 1), msg));
    }
    // The columns grew by doubling; a long run would keep up to twice its size allocated.
    table.t.shrink_to_fit();
    table.positions.shrink_to_fit();
    if let Some(v) = &mut table.values {
        v.shrink_to_fit();
    }
    for (_, c) in &mut table.context {
        c.shrink_to_fit();
    }
    for (_, c) in &mut table.labels {
        c.shrink_to_fit();
    }
    Ok(table)
}

fn example_header(cols: &RunColumns) -> String {
    let mut names = vec!["t".to_string()];
    names.extend(cols.axes.iter().map(char::to_string));
    names.extend(cols.labels.iter().map(|s| s.to_string()));
    names.extend(cols.readings.iter().map(|s| s.to_string()));
    names.join(",")
}

fn csv_error(path: &Path, e: &csv::Error) -> SessionError {
    let line = e.position().map_or(1, |p| p.line() as usize);
    SessionError::invalid(at(path, line, 1), format!("unreadable CSV: {e}"))
}

fn list(names: &[String]) -> String {
    names.join(", ")
}

fn allowed_columns(cols: &RunColumns) -> String {
    let axes: Vec<String> = cols.axes.iter().map(char::to_string).collect();
    let readings: Vec<String> = cols.readings.iter().map(|s| s.to_string()).collect();
    let readings = if readings.is_empty() {
        "none".to_string()
    } else {
        list(&readings)
    };
    let labels = if cols.labels.is_empty() {
        String::new()
    } else {
        format!("; the instrument's labels {}", cols.labels.join(", "))
    };
    format!(
        "`t`; the machine's axes {}{labels}; the instrument's readings {readings}; context \
         columns T_<name> (°C), P_<name> (hPa), H_<name> (% RH), S (rpm), F (mm/min)",
        list(&axes)
    )
}

/// Checks the header's names and says what each column holds.
fn classify(
    path: &Path,
    header: &csv::StringRecord,
    cols: &RunColumns,
) -> Result<Layout, SessionError> {
    let names: Vec<String> = header.iter().map(str::to_string).collect();
    let mut kinds = Vec::with_capacity(names.len());
    let mut context = Vec::new();
    for (j, name) in names.iter().enumerate() {
        let here = at(path, 1, j + 1);
        if name.is_empty() {
            let msg = format!(
                "column {} has no name: expected {}",
                j + 1,
                allowed_columns(cols)
            );
            return Err(SessionError::invalid(here, msg));
        }
        if let Some(first) = names[..j].iter().position(|n| n == name) {
            let msg = format!(
                "column \"{name}\" appears twice, as columns {} and {}: each column may appear once",
                first + 1,
                j + 1
            );
            return Err(SessionError::invalid(here, msg));
        }
        let kind = if name == "t" {
            Kind::Time
        } else if let Some(k) = axis_index(cols.axes, name) {
            Kind::Axis(k)
        } else if let Some(k) = cols.readings.iter().position(|r| r == name) {
            Kind::Reading(k)
        } else if let Some(k) = cols.labels.iter().position(|r| r == name) {
            Kind::Label(k)
        } else if is_context(name) {
            context.push(name.clone());
            Kind::Context(context.len() - 1)
        } else {
            let hint = if name.len() == 1 && axis_index(cols.axes, &name.to_uppercase()).is_some() {
                " (axis letters are upper-case)"
            } else {
                ""
            };
            let msg = format!(
                "unknown column \"{name}\"{hint}: a run file has only {}",
                allowed_columns(cols)
            );
            return Err(SessionError::invalid(here, msg));
        };
        kinds.push(kind);
    }
    let has_readings = check_present(path, cols, &kinds)?;
    Ok(Layout {
        names,
        kinds,
        context,
        has_readings,
    })
}

fn axis_index(axes: &[char], name: &str) -> Option<usize> {
    let mut chars = name.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) => axes.iter().position(|&a| a == c),
        _ => None,
    }
}

fn is_context(name: &str) -> bool {
    let prefixed = ["T_", "P_", "H_"]
        .iter()
        .any(|p| name.starts_with(p) && name.len() > 2);
    prefixed || CONTEXT_COLUMNS.contains(&name)
}

/// Checks that `t`, every axis and the readings are there; returns whether the readings are.
fn check_present(path: &Path, cols: &RunColumns, kinds: &[Kind]) -> Result<bool, SessionError> {
    let here = at(path, 1, 1);
    if !kinds.contains(&Kind::Time) {
        let msg = "missing column `t` (seconds since the session started, strictly increasing)";
        return Err(SessionError::invalid(here, msg));
    }
    let axes: Vec<String> = cols.axes.iter().map(char::to_string).collect();
    let missing: Vec<String> = (0..axes.len())
        .filter(|&k| !kinds.contains(&Kind::Axis(k)))
        .map(|k| axes[k].clone())
        .collect();
    if !missing.is_empty() {
        let msg = format!(
            "missing axis column(s) {}: the machine's axes are {} and a run has one column of \
             commanded positions per axis",
            list(&missing),
            list(&axes)
        );
        return Err(SessionError::invalid(here, msg));
    }
    let missing: Vec<String> = (0..cols.labels.len())
        .filter(|&k| !kinds.contains(&Kind::Label(k)))
        .map(|k| cols.labels[k].to_string())
        .collect();
    if !missing.is_empty() {
        let msg = format!(
            "missing label column(s) {}: this instrument names what each row measured in {}",
            list(&missing),
            cols.labels.join(", ")
        );
        return Err(SessionError::invalid(here, msg));
    }
    let readings: Vec<String> = cols.readings.iter().map(|s| s.to_string()).collect();
    let (present, missing): (Vec<_>, Vec<_>) =
        (0..readings.len()).partition(|&k| kinds.contains(&Kind::Reading(k)));
    let names = |ks: &[usize]| list(&ks.iter().map(|&k| readings[k].clone()).collect::<Vec<_>>());
    if missing.is_empty() {
        return Ok(true);
    }
    if present.is_empty() && cols.readings_optional {
        return Ok(false);
    }
    let msg = if cols.readings_optional {
        format!(
            "the run has reading column(s) {} but not {}: a validation run has all of the \
             instrument's reading columns ({}) or none",
            names(&present),
            names(&missing),
            list(&readings)
        )
    } else {
        format!(
            "missing reading column(s) {}: this instrument's readings are {}",
            names(&missing),
            list(&readings)
        )
    };
    Err(SessionError::invalid(here, msg))
}

fn check_field_count(
    path: &Path,
    line: u64,
    layout: &Layout,
    record: &csv::StringRecord,
) -> Result<(), SessionError> {
    let (expected, found) = (layout.names.len(), record.len());
    if expected == found {
        return Ok(());
    }
    let hint = if found > expected {
        " (a decimal comma such as 1,5 splits a number in two: use '.')"
    } else {
        ""
    };
    let msg = format!("expected {expected} fields, as in the header, found {found}{hint}");
    let column = expected.min(found) + 1;
    Err(SessionError::invalid(at(path, line as usize, column), msg))
}

/// What a number in column `name` means, for messages.
fn unit_of(name: &str) -> &'static str {
    match name {
        "t" => "a time in seconds",
        "X" | "Y" | "Z" | "U" | "V" | "W" => "a position in mm",
        "A" | "B" | "C" => "an angle in degrees",
        "S" => "a spindle speed in rpm",
        "F" => "a feed in mm/min",
        n if n.starts_with("T_") => "a temperature in °C",
        n if n.starts_with("P_") => "an air pressure in hPa",
        n if n.starts_with("H_") => "a relative humidity in %",
        _ => "a number",
    }
}

fn number(path: &Path, line: u64, j: usize, name: &str, field: &str) -> Result<f64, SessionError> {
    let fail = |found: String| {
        let msg = format!(
            "column \"{name}\": expected {}, found {found}",
            unit_of(name)
        );
        Err(SessionError::invalid(at(path, line as usize, j + 1), msg))
    };
    match field.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(x) if x.is_nan() => fail(format!(
            "\"{field}\": NaN is not a measurement; leave the row out"
        )),
        Ok(_) if field.to_ascii_lowercase().contains("inf") => fail(format!(
            "\"{field}\": an infinite value is not a measurement; leave the row out"
        )),
        Ok(_) => fail(format!(
            "\"{field}\", which is too large for a 64-bit float"
        )),
        Err(_) if field.is_empty() => fail("an empty field".to_string()),
        Err(_) if field.contains(',') && field.replacen(',', ".", 1).parse::<f64>().is_ok() => {
            fail(format!(
                "\"{field}\" with a decimal comma: use '.' as the decimal separator"
            ))
        }
        Err(_) => fail(format!("\"{field}\"")),
    }
}

fn check_increasing(
    path: &Path,
    line: u64,
    j: usize,
    last: Option<(f64, u64)>,
    t: f64,
) -> Result<(), SessionError> {
    match last {
        Some((prev, prev_line)) if t <= prev => {
            let msg = format!(
                "column \"t\": t must increase strictly, found t = {t} here after t = {prev} \
                 at line {prev_line}"
            );
            Err(SessionError::invalid(at(path, line as usize, j + 1), msg))
        }
        _ => Ok(()),
    }
}

// ---------------------------------------------------------------------------------------------
// Writing

/// Writes `table` to `path` (atomically: a temporary file, then a rename): a header row, `,`
/// separators, `.` decimals, `\n` line ends and the shortest decimal form of each number that
/// reads back to the same `f64`, so [`read_run`] gives the table back bit for bit.
///
/// Refuses, writing nothing, a table that [`read_run`] would reject: no rows, lengths that do
/// not match, non-finite numbers, `t` not strictly increasing, column names that are repeated,
/// empty or not allowed, or a non-empty [`columns`](RunTable::columns) that does not list
/// exactly the table's columns.
pub fn write_run(path: &Path, table: &RunTable) -> Result<(), SessionError> {
    let text = run_text(path, table)?;
    mtcal_located::write_atomically(path, text.as_bytes()).map_err(|source| SessionError::Write {
        path: path.to_path_buf(),
        cause: source,
    })
}

/// The text [`write_run`] writes for `table` (to be written with other outputs at once);
/// `path` names the file in the messages.
pub fn run_text(path: &Path, table: &RunTable) -> Result<String, SessionError> {
    let refuse = |message: String| SessionError::NotWritten {
        path: path.to_path_buf(),
        message,
    };
    let columns = check_writable(table).map_err(refuse)?;
    Ok(render(table, &columns))
}

/// One column's numbers: `(data, stride, offset)`, or its labels.
enum Source<'a> {
    Numbers(&'a [f64], usize, usize),
    Labels(&'a [String]),
}

fn sources<'a>(table: &'a RunTable, columns: &[String]) -> Vec<Source<'a>> {
    columns
        .iter()
        .map(|name| {
            if let Some((_, v)) = table.labels.iter().find(|(n, _)| n == name) {
                return Source::Labels(v);
            }
            {
                let (data, stride, offset) = numbers_of(table, name);
                Source::Numbers(data, stride, offset)
            }
        })
        .collect()
}

fn numbers_of<'a>(table: &'a RunTable, name: &str) -> (&'a [f64], usize, usize) {
    if name == "t" {
        return (table.t.as_slice(), 1, 0);
    }
    if let Some(k) = axis_index(&table.axes, name) {
        return (table.positions.as_slice(), table.axes.len(), k);
    }
    if let (Some(k), Some(v)) = (table.readings.iter().position(|r| r == name), &table.values) {
        return (v.as_slice(), table.readings.len(), k);
    }
    let c = table
        .context_column(name)
        .expect("checked by check_writable");
    (c, 1, 0)
}

fn render(table: &RunTable, columns: &[String]) -> String {
    let sources = sources(table, columns);
    let mut text = columns.join(",");
    text.push('\n');
    for i in 0..table.len() {
        for (j, source) in sources.iter().enumerate() {
            if j > 0 {
                text.push(',');
            }
            match source {
                Source::Numbers(data, stride, offset) => {
                    push_number(&mut text, data[i * stride + offset])
                }
                Source::Labels(v) => text.push_str(&v[i]),
            }
        }
        text.push('\n');
    }
    text
}

/// The shortest decimal that parses back to `x`; exponent form outside [1e-5, 1e16).
fn push_number(out: &mut String, x: f64) {
    let a = x.abs();
    let result = if a == 0.0 || (1e-5..1e16).contains(&a) {
        write!(out, "{x}")
    } else {
        write!(out, "{x:e}")
    };
    result.expect("writing to a String cannot fail");
}

/// The columns to write, in order, or why the table cannot be written.
fn check_writable(table: &RunTable) -> Result<Vec<String>, String> {
    let n = table.len();
    if n == 0 {
        return Err("the table has no rows; a run file needs at least one".into());
    }
    let mut lengths = vec![("positions", table.positions.len(), n * table.axes.len())];
    if let Some(v) = &table.values {
        lengths.push(("values", v.len(), n * table.readings.len()));
    }
    for (name, c) in &table.context {
        lengths.push((name.as_str(), c.len(), n));
    }
    for (name, c) in &table.labels {
        lengths.push((name.as_str(), c.len(), n));
    }
    if let Some((what, found, expected)) = lengths.iter().find(|(_, f, e)| f != e) {
        return Err(format!(
            "`{what}` has {found} numbers, expected {expected} for {n} rows"
        ));
    }
    let canonical = table.canonical_columns();
    check_names(table, &canonical)?;
    check_numbers(table)?;
    if table.columns.is_empty() {
        return Ok(canonical);
    }
    let mut given = table.columns.clone();
    let mut wanted = canonical;
    given.sort();
    wanted.sort();
    if given != wanted {
        return Err(format!(
            "`columns` lists {}, but the table's columns are {}",
            table.columns.join(", "),
            wanted.join(", ")
        ));
    }
    Ok(table.columns.clone())
}

fn check_names(table: &RunTable, canonical: &[String]) -> Result<(), String> {
    for (j, name) in canonical.iter().enumerate() {
        if canonical[..j].contains(name) {
            return Err(format!("column \"{name}\" would appear twice"));
        }
        let clean =
            !name.is_empty() && name.trim() == name && !name.contains([',', ';', '"', '\n', '\r']);
        if !clean {
            return Err(format!(
                "column name \"{}\" cannot be written: names are non-empty, without \
                 surrounding blanks, ',', ';', quotes or line breaks",
                name.escape_debug()
            ));
        }
    }
    for a in &table.axes {
        if !a.is_alphabetic() || *a == 't' {
            return Err(format!("'{a}' is not an axis letter"));
        }
    }
    if let Some((name, _)) = table.context.iter().find(|(n, _)| !is_context(n)) {
        return Err(format!(
            "context column \"{name}\" would not load: context columns are T_<name>, \
             P_<name>, H_<name>, S and F"
        ));
    }
    for (name, values) in &table.labels {
        let bad =
            |v: &str| v.is_empty() || v.trim() != v || v.contains([',', ';', '"', '\n', '\r']);
        if let Some(i) = values.iter().position(|v| bad(v)) {
            return Err(format!(
                "label \"{}\" in column \"{name}\", row {}, cannot be written: labels are \
                 non-empty, without surrounding blanks, ',', ';', quotes or line breaks",
                values[i].escape_debug(),
                i + 1
            ));
        }
    }
    Ok(())
}

fn check_numbers(table: &RunTable) -> Result<(), String> {
    let mut all: Vec<(&str, &[f64])> = vec![("t", &table.t), ("positions", &table.positions)];
    if let Some(v) = &table.values {
        all.push(("values", v));
    }
    all.extend(
        table
            .context
            .iter()
            .map(|(n, c)| (n.as_str(), c.as_slice())),
    );
    for (what, data) in all {
        if let Some(i) = data.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "`{what}` holds {} at index {i}: only finite numbers are measurements",
                data[i]
            ));
        }
    }
    if let Some(i) = table.t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(format!(
            "t must increase strictly: row {} has t = {} after t = {}",
            i + 2,
            table.t[i + 1],
            table.t[i]
        ));
    }
    Ok(())
}
