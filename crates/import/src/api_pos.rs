//! `api-pos`: API XD laser linear data tables (`.pos`, tab-separated text).
//!
//! ```text
//! (→ is a tab)
//! API X-D Laser Measurement Linear Data Table (Company Name: )
//! File Version:→5
//! TestAxis: →(X)
//! Unit:→inch→0
//! Length: 130→Increm: 5→RunNum: 1→NumofPos: 27
//! NumofPoints:→27
//!     Position→      LasRead→  LinearError→Status→AirTemp→AirPress→MatTemp→MatTemp2→MatTemp3
//!      0.00000→     0.000055→    -0.000055→     0→68.00→29.92→68.00→-1.00→-1.00
//! DecimalPoints:→4
//! … compensation, standard-deviation and ASME B5.54 analysis blocks (skipped)
//! ```
//!
//! Header fields are `Key: value` or `Key:` then the value in the next tab field, several per
//! line. Read: `Unit` (`mm` or `inch`, required), `TestAxis` (`(X)`), `RunNum` (cycles) and
//! `NumofPoints` (the table's row count, checked). The table runs from the line whose first
//! field is `Position` to the first line whose first field is not a number. The deviation is
//! `LinearError` (measured − target; in the public samples `LinearError = −LasRead −
//! Position`: the instrument's reading has the opposite sign of the travel). Rows in file
//! order are the path. A `Status` other than 0 (warm-up, beam lost, over speed) is refused.
//! `AirTemp`, `AirPress` and the first `MatTemp` become `T_air`, `P_air`, `T_material`: °F and
//! inHg in inch files, °C in mm files (pressure then not imported: its unit is not known); a
//! column holding −1 (no sensor) is left out.

use std::path::Path;

use mtcal_located::{Located, Source};

use crate::ImportError;
use crate::recording::Recording;
use crate::text::{Line, lines, number, offset_of};

/// One header value: its text and where it is.
struct Field<'a> {
    value: &'a str,
    line: Line<'a>,
}

/// Column indices of the table.
struct Columns {
    position: usize,
    error: usize,
    status: Option<usize>,
    /// (context column name, index) of AirTemp, AirPress, MatTemp.
    context: Vec<(&'static str, usize)>,
    count: usize,
}

/// The file's length unit: mm per unit, and whether temperatures are in °F.
#[derive(Clone, Copy)]
struct Unit {
    mm: f64,
    inch: bool,
}

/// Reads an API XD `.pos` linear data table.
pub fn read_pos(path: &Path) -> Result<Recording, ImportError> {
    let src = Source::read(path)?;
    let all: Vec<Line<'_>> = lines(&src.text).collect();
    let Some(head_at) = all.iter().position(|l| first_field(l.text) == "Position") else {
        let end = all.last().map_or(0, |l| l.offset + l.text.len());
        return Err(src
            .at(
                end..end,
                "expected the table header `Position\tLasRead\tLinearError\t…`, found none in the file",
            )
            .into());
    };
    let fields = header(&all[..head_at]);
    let unit = unit(&src, &fields)?;
    let columns = columns(&src, &all[head_at])?;
    let rows: Vec<Line<'_>> = all[head_at + 1..]
        .iter()
        .take_while(|l| first_field(l.text).parse::<f64>().is_ok())
        .copied()
        .collect();
    check_count(&src, &fields, &all[head_at], rows.len())?;
    Ok(recording(&src, &fields, &columns, unit, &rows)?)
}

fn first_field(text: &str) -> &str {
    text.split('\t').next().unwrap_or("").trim()
}

/// `Key: value` fields of the header lines, in file order.
fn header<'a>(lines: &[Line<'a>]) -> Vec<(&'a str, Field<'a>)> {
    let mut out = Vec::new();
    for line in lines {
        let parts: Vec<&str> = line.text.split('\t').collect();
        let mut k = 0;
        while k < parts.len() {
            if let Some((key, rest)) = parts[k].split_once(':') {
                let mut value = rest.trim();
                // `Key:` alone: the value is the next field.
                if value.is_empty() && k + 1 < parts.len() && !parts[k + 1].contains(':') {
                    k += 1;
                    value = parts[k].trim();
                }
                out.push((key.trim(), Field { value, line: *line }));
            }
            k += 1;
        }
    }
    out
}

fn get<'f, 'a>(fields: &'f [(&'a str, Field<'a>)], key: &str) -> Option<&'f Field<'a>> {
    fields.iter().find(|(k, _)| *k == key).map(|(_, f)| f)
}

fn unit(src: &Source, fields: &[(&str, Field<'_>)]) -> Result<Unit, Located> {
    let Some(f) = get(fields, "Unit") else {
        return Err(src.at(
            0..0,
            "expected a header line `Unit:\tmm` or `Unit:\tinch`, found none",
        ));
    };
    match f.value {
        "mm" => Ok(Unit {
            mm: 1.0,
            inch: false,
        }),
        "inch" => Ok(Unit {
            mm: 25.4,
            inch: true,
        }),
        other => Err(src.at(
            offset_of(&f.line, f.value)..offset_of(&f.line, f.value),
            format!("expected the unit `mm` or `inch`, found `{other}`"),
        )),
    }
}

fn columns(src: &Source, head: &Line<'_>) -> Result<Columns, Located> {
    let names: Vec<&str> = head.text.split('\t').map(str::trim).collect();
    let find = |n: &str| names.iter().position(|&c| c == n);
    let need = |n: &str| {
        find(n).ok_or_else(|| {
            src.at(
                head.offset..head.offset,
                format!(
                    "expected a column `{n}` in the table header, found `{}`",
                    names.join(" ")
                ),
            )
        })
    };
    let mut context = Vec::new();
    for (name, col) in [
        ("T_air", "AirTemp"),
        ("P_air", "AirPress"),
        ("T_material", "MatTemp"),
    ] {
        if let Some(k) =
            find(col).or_else(|| (col == "MatTemp").then(|| find("MatTemp1")).flatten())
        {
            context.push((name, k));
        }
    }
    Ok(Columns {
        position: need("Position")?,
        error: need("LinearError")?,
        status: find("Status"),
        context,
        count: names.len(),
    })
}

fn check_count(
    src: &Source,
    fields: &[(&str, Field<'_>)],
    head: &Line<'_>,
    rows: usize,
) -> Result<(), Located> {
    let declared = get(fields, "NumofPoints").and_then(|f| f.value.parse::<usize>().ok());
    match declared {
        Some(n) if n != rows => Err(src.at(
            head.offset..head.offset,
            format!("expected {n} table rows (NumofPoints), found {rows}"),
        )),
        _ if rows < 2 => Err(src.at(
            head.offset..head.offset,
            format!("expected at least 2 table rows, found {rows}"),
        )),
        _ => Ok(()),
    }
}

fn recording(
    src: &Source,
    fields: &[(&str, Field<'_>)],
    cols: &Columns,
    unit: Unit,
    rows: &[Line<'_>],
) -> Result<Recording, Located> {
    let mut positions_mm = Vec::with_capacity(rows.len());
    let mut deviations_um = Vec::with_capacity(rows.len());
    let mut context: Vec<(String, Vec<f64>)> = cols
        .context
        .iter()
        .map(|(n, _)| (n.to_string(), Vec::new()))
        .collect();
    for row in rows {
        let cells: Vec<&str> = row.text.split('\t').collect();
        if cells.len() < cols.count {
            return Err(src.at(
                row.offset..row.offset,
                format!(
                    "expected {} tab-separated fields, found {}",
                    cols.count,
                    cells.len()
                ),
            ));
        }
        let cell = |k: usize, what: &str| number(src, row, cells[k], what);
        positions_mm.push(cell(cols.position, "a position")? * unit.mm);
        deviations_um.push(cell(cols.error, "a linear error")? * unit.mm * 1e3);
        if let Some(k) = cols.status {
            check_status(src, row, cells[k], cell(k, "a laser status")?)?;
        }
        for ((_, k), (_, values)) in cols.context.iter().zip(&mut context) {
            values.push(cell(*k, "a number")?);
        }
    }
    let context = environment(context, unit);
    let cycles = get(fields, "RunNum")
        .and_then(|f| f.value.parse().ok())
        .unwrap_or(1);
    Ok(Recording {
        axis: get(fields, "TestAxis").and_then(|f| axis_letter(f.value)),
        targets: distinct(&positions_mm),
        positions_mm: Some(positions_mm),
        deviations_um,
        t_s: None,
        context,
        cycles,
        unit: if unit.inch { "inch" } else { "mm" }.to_string(),
    })
}

fn check_status(src: &Source, row: &Line<'_>, cell: &str, status: f64) -> Result<(), Located> {
    if status == 0.0 {
        return Ok(());
    }
    let why = match status as i64 {
        1 => "warm up",
        2 => "path error",
        3 => "over speed",
        4 => "wireless error",
        _ => "not normal",
    };
    let at = offset_of(row, cell);
    Err(src.at(
        at..at,
        format!("expected laser status 0 (normal), found {status} ({why}): leave the row out or measure again"),
    ))
}

/// The context columns in mtcal's units; a sensor that reads −1 (none fitted) is left out,
/// and so is a pressure whose unit is not known (mm files).
fn environment(columns: Vec<(String, Vec<f64>)>, unit: Unit) -> Vec<(String, Vec<f64>)> {
    columns
        .into_iter()
        .filter(|(name, v)| !v.contains(&-1.0) && (unit.inch || name != "P_air"))
        .map(|(name, v)| {
            let convert = |x: f64| match (name.as_str(), unit.inch) {
                ("P_air", _) => x * 33.8639,   // inHg to hPa
                (_, true) => (x - 32.0) / 1.8, // °F to °C
                _ => x,
            };
            let v = v.into_iter().map(convert).collect();
            (name, v)
        })
        .collect()
}

fn axis_letter(value: &str) -> Option<char> {
    let inner = value.trim().trim_start_matches('(').trim_end_matches(')');
    let mut chars = inner.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) if c.is_ascii_alphabetic() => Some(c.to_ascii_uppercase()),
        _ => None,
    }
}

/// Distinct positions (1 µm apart or more).
fn distinct(positions_mm: &[f64]) -> usize {
    let mut p = positions_mm.to_vec();
    p.sort_by(f64::total_cmp);
    p.dedup_by(|a, b| (*a - *b).abs() < 1e-3);
    p.len()
}
