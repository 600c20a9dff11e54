//! Nonlinear axis error compensation: `.COM` tables of errors over one axis' position, assigned
//! to their input axis by a `.CMA` file. Conventions in the module documentation of
//! `heidenhain`.

use super::HeidenhainLimit;
use super::table::{TableIn, TableOut, axis_positions, parse_table, table_text};
use crate::pitch::travel_direction;
use crate::text::Source;
use crate::{CompensateError, MAX_NODES, MM, check_inputs, read_file, write_file};
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_machine::card::{AxisMap, ConventionCard, Quantity};
use nalgebra::DMatrix;
use std::path::{Path, PathBuf};

/// The written precision of positions and values (mm): 0.1 µm, the unit in which the TNC 4xx
/// counts its point spacing (2^16 of it is the manual's 6.5536 mm, p.153).
pub const COM_RESOLUTION_MM: f64 = 1e-4;

/// Axes a table may be a function of, and correct: the principal linear axes.
const XYZ: [char; 3] = ['X', 'Y', 'Z'];

/// How the rows of a `.COM` table must be spaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpacingRule {
    /// Equidistant, `2^k × 0.1 µm` apart (TNC 407/415/425, technical manual p.153).
    PowerOfTwo,
    /// Equidistant, any multiple of 0.1 µm.
    Equidistant,
    /// Ascending positions, any spacing (the AXISPOS column lists every position).
    Ascending,
}

/// The limits a control puts on the tables of one `.CMA` line.
#[derive(Clone, Debug, PartialEq)]
pub struct ComLimits {
    /// Most rows of one table.
    pub max_entries: usize,
    pub spacing: SpacingRule,
    /// Most compensation points (rows) of all tables of the active line, when known.
    pub max_total_points: Option<usize>,
    /// Most tables in the active line, when known.
    pub max_tables: Option<usize>,
    /// Largest plausible |value| (mm): a larger one was probably written in µm.
    pub max_abs_value_mm: f64,
}

impl ComLimits {
    /// TNC 407/415/425: at most 256 entries per table (error 3 of PLC module 9095, p.622),
    /// rows `2^k × 0.1 µm` apart (p.153). The total point budget and the number of tables
    /// (errors 4 and 5, p.622) are not given in the pages read: set them when known.
    pub fn tnc_4xx() -> Self {
        ComLimits {
            max_entries: 256,
            spacing: SpacingRule::PowerOfTwo,
            max_total_points: None,
            max_tables: None,
            max_abs_value_mm: 1.0,
        }
    }

    /// MANUALplus 620 (technical manual pp.716–718): positions listed in AXISPOS; the pages
    /// give no limit on entries or spacing, so only ascending positions and plausible values
    /// are checked.
    pub fn manualplus_620() -> Self {
        ComLimits {
            max_entries: usize::MAX,
            spacing: SpacingRule::Ascending,
            max_total_points: None,
            max_tables: None,
            max_abs_value_mm: 1.0,
        }
    }
}

/// One `.COM` table: the errors of one or more axes as functions of one axis' position.
#[derive(Clone, Debug, PartialEq)]
pub struct ComTable {
    /// File name, as the `.CMA` names it (`X.COM`).
    pub name: String,
    /// The axis whose position the rows follow: the `.CMA` column the table is entered in.
    pub input_axis: char,
    /// AXISPOS: positions (mm from the machine datum), ascending.
    pub positions_mm: Vec<f64>,
    /// Per corrected axis (the column name): its error (mm, actual − nominal along that axis)
    /// at each position.
    pub columns: Vec<(char, Vec<f64>)>,
}

impl ComTable {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.positions_mm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions_mm.is_empty()
    }

    /// The error (mm) of `axis` at `position_mm` of the input axis: linear between rows, the
    /// end values outside them; `None` if the table has no column for `axis`.
    pub fn error_at_mm(&self, axis: char, position_mm: f64) -> Option<f64> {
        let (_, v) = self.columns.iter().find(|(a, _)| *a == axis)?;
        Some(crate::lerp(
            v,
            crate::bracket(&self.positions_mm, position_mm),
        ))
    }
}

/// The tables of the active `.CMA` line, one per input axis.
#[derive(Clone, Debug, PartialEq)]
pub struct ComSet {
    pub tables: Vec<ComTable>,
    /// What the tables were made from (machine, held positions, spacing), for the card; not
    /// read back.
    pub note: String,
}

impl ComSet {
    /// The error (mm) of `axis` the control adds up at axis positions `positions_mm`: the sum
    /// over the tables of their `axis` column at their input axis' position.
    pub fn error_at_mm(&self, axis: char, positions_mm: &[(char, f64)]) -> f64 {
        self.tables
            .iter()
            .filter_map(|t| {
                let p = positions_mm.iter().find(|(a, _)| *a == t.input_axis)?.1;
                t.error_at_mm(axis, p)
            })
            .sum()
    }

    /// Rows of all tables.
    pub fn total_points(&self) -> usize {
        self.tables.iter().map(ComTable::len).sum()
    }
}

/// The spacing (in units of 0.1 µm) `limits` allows for a requested `spacing_mm`: the largest
/// power of two not above it (the manual's "7 mm → 2^16 = 6.5536 mm"), or the nearest multiple.
fn spacing_counts(spacing_mm: f64, rule: SpacingRule) -> Result<u64, CompensateError> {
    let n = spacing_mm / COM_RESOLUTION_MM;
    if !(n.is_finite() && n >= 1.0 && n < 2f64.powi(52)) {
        return Err(CompensateError::BadSpacing { spacing_mm });
    }
    Ok(match rule {
        SpacingRule::PowerOfTwo => {
            let mut h = 1u64;
            while (2 * h) as f64 <= n * (1.0 + 1e-12) {
                h *= 2;
            }
            h
        }
        SpacingRule::Equidistant | SpacingRule::Ascending => n.round() as u64,
    })
}

/// Rounds `mm` to the written precision (`+ 0.0` turns −0 into 0, so no `-0.0000` is written).
fn to_resolution(mm: f64) -> f64 {
    (mm / COM_RESOLUTION_MM).round() * COM_RESOLUTION_MM + 0.0
}

/// The tables of nonlinear axis error compensation for `model` with coefficients `coeffs`:
/// for each principal linear axis (X, Y, Z) the machine has, a table `<axis>.COM` over its
/// stroke whose columns are the errors along every principal axis (its positioning error and
/// its straightness in the others), the other axes held at `hold_q` (SI; see
/// [`crate::default_hold`]). Rows lie on a lattice through the held position, `spacing_mm`
/// apart as `limits` allows (a power of two of 0.1 µm for the TNC 4xx), covering the stroke;
/// values are rounded to 0.1 µm. The straightness columns are zero at the held position and
/// the positioning column carries the error there, so that the active line adds up to the
/// model's error on the three lines through the held position (see the module documentation).
pub fn heidenhain_com_set(
    model: &MachineModel,
    coeffs: &[f64],
    spacing_mm: f64,
    hold_q: &[f64],
    limits: &ComLimits,
) -> Result<ComSet, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let axes: Vec<(char, usize, f64, f64)> = XYZ
        .iter()
        .filter_map(|&c| {
            let i = machine.axis_index(c)?;
            let ax = &machine.axes()[i];
            match (ax.kind(), ax.limits()) {
                (AxisKind::Linear, Some((lo, hi))) => Some((c, i, lo, hi)),
                _ => None,
            }
        })
        .collect();
    if axes.is_empty() {
        return Err(CompensateError::NoSuchAxis {
            letter: 'X',
            letters: machine.letters(),
        });
    }
    let h = spacing_counts(spacing_mm, limits.spacing)?;
    // Anchor every lattice at the held position, snapped to 0.1 µm, so that the held position
    // is a row of every table.
    let mut hold = hold_q.to_vec();
    let mut anchors = Vec::with_capacity(axes.len());
    for &(_, i, ..) in &axes {
        let a = (hold[i] * MM / COM_RESOLUTION_MM).round() as i64;
        hold[i] = a as f64 * COM_RESOLUTION_MM / MM;
        anchors.push(a);
    }
    let to_axes = axes_pseudo_inverse(model, &hold, &axes)?;
    let mut ws = model.workspace();
    let mut errors_mm = |q: &[f64]| -> Vec<f64> {
        let e = model.pose_error(q, coeffs, &mut ws).translation;
        let v = &to_axes * nalgebra::DVector::from_column_slice(e.as_slice());
        v.iter().map(|x| x * MM).collect()
    };
    // The positioning column's rounded value at the held position: the straightness columns
    // are written relative to it, so that each component adds up from one rounding only.
    let at_hold: Vec<f64> = errors_mm(&hold).into_iter().map(to_resolution).collect();
    let mut tables = Vec::with_capacity(axes.len());
    for (k, &(letter, i, lo, hi)) in axes.iter().enumerate() {
        let (k_lo, k_hi) = lattice(anchors[k], h, lo * MM, hi * MM);
        let entries = usize::try_from(k_hi - k_lo + 1).unwrap_or(usize::MAX);
        let max = limits.max_entries.min(MAX_NODES);
        if entries > max {
            return Err(HeidenhainLimit::TooManyEntries {
                table: format!("{letter}.COM"),
                entries,
                max,
            }
            .into());
        }
        let counts: Vec<i64> = (k_lo..=k_hi).map(|n| anchors[k] + n * h as i64).collect();
        let positions_mm: Vec<f64> = counts
            .iter()
            .map(|&c| c as f64 * COM_RESOLUTION_MM)
            .collect();
        let mut columns: Vec<(char, Vec<f64>)> = axes
            .iter()
            .map(|a| (a.0, Vec::with_capacity(counts.len())))
            .collect();
        let mut q = hold.clone();
        for &p in &positions_mm {
            q[i] = p / MM;
            let v = errors_mm(&q);
            for (j, (_, col)) in columns.iter_mut().enumerate() {
                let value = if j == k { v[j] } else { v[j] - at_hold[j] };
                col.push(to_resolution(value));
            }
        }
        tables.push(ComTable {
            name: format!("{letter}.COM"),
            input_axis: letter,
            positions_mm,
            columns,
        });
    }
    let set = ComSet {
        tables,
        note: com_note(model, &hold, &axes, h),
    };
    validate_heidenhain_com(&set, limits)?;
    Ok(set)
}

/// The range of `k` of the lattice points `anchor + k·h` (0.1 µm counts) from the last at or
/// below `lo_mm` to the first at or above `hi_mm`, always including the anchor (`k = 0`).
fn lattice(anchor: i64, h: u64, lo_mm: f64, hi_mm: f64) -> (i64, i64) {
    let h_mm = h as f64 * COM_RESOLUTION_MM;
    let a_mm = anchor as f64 * COM_RESOLUTION_MM;
    // A lattice point within 1 nm of a stroke end is that end.
    let k_lo = ((lo_mm - a_mm + 1e-6) / h_mm).floor() as i64;
    let k_hi = ((hi_mm - a_mm - 1e-6) / h_mm).ceil() as i64;
    (k_lo.min(0), k_hi.max(0))
}

/// The matrix taking a tool-point error (workpiece frame) to the axis coordinates of the
/// corrected axes: `(DᵀD)⁻¹Dᵀ`, `D` the axes' directions of travel at the held position.
fn axes_pseudo_inverse(
    model: &MachineModel,
    hold: &[f64],
    axes: &[(char, usize, f64, f64)],
) -> Result<DMatrix<f64>, CompensateError> {
    let machine = model.machine();
    let mut d = DMatrix::zeros(3, axes.len());
    for (k, &(_, i, ..)) in axes.iter().enumerate() {
        d.set_column(k, &travel_direction(machine, hold, i));
    }
    let dtd = d.transpose() * &d;
    let inv = dtd.try_inverse().ok_or_else(|| CompensateError::Model {
        message: format!(
            "the directions of travel of {} are not independent",
            axes.iter().map(|a| a.0).collect::<String>()
        ),
    })?;
    Ok(inv * d.transpose())
}

fn com_note(
    model: &MachineModel,
    hold: &[f64],
    axes: &[(char, usize, f64, f64)],
    h: u64,
) -> String {
    let machine = model.machine();
    let held: Vec<String> = machine
        .axes()
        .iter()
        .zip(hold)
        .map(|(a, &v)| match a.kind() {
            AxisKind::Linear => format!("{} = {:.4} mm", a.letter().as_char(), v * MM),
            AxisKind::Rotary => format!("{} = {:.6} deg", a.letter().as_char(), v.to_degrees()),
        })
        .collect();
    let power = if h.is_power_of_two() {
        format!(" = 2^{} × 0.1 µm", h.trailing_zeros())
    } else {
        String::new()
    };
    format!(
        "machine {}; tables {} over their strokes, rows {:.4} mm apart{power}; \
         held position (a row of every table): {}",
        machine.name(),
        axes.iter()
            .map(|a| format!("{}.COM", a.0))
            .collect::<Vec<_>>()
            .join(", "),
        h as f64 * COM_RESOLUTION_MM,
        held.join(", ")
    )
}

/// Checks `set` against `limits`: shapes, ascending and spaced positions, entries per table,
/// the total of points and tables, plausible values.
pub fn validate_heidenhain_com(set: &ComSet, limits: &ComLimits) -> Result<(), CompensateError> {
    for (k, t) in set.tables.iter().enumerate() {
        if let Some(other) = set.tables[..k]
            .iter()
            .find(|o| o.input_axis == t.input_axis)
        {
            return Err(HeidenhainLimit::Shape {
                table: t.name.clone(),
                what: format!(
                    "a second table for input axis {} (after {}): the .CMA holds one per axis",
                    t.input_axis, other.name
                ),
            }
            .into());
        }
        validate_table(t, limits)?;
    }
    if let Some(max) = limits.max_tables
        && set.tables.len() > max
    {
        return Err(HeidenhainLimit::TooManyTables {
            tables: set.tables.len(),
            max,
        }
        .into());
    }
    if let Some(max) = limits.max_total_points
        && set.total_points() > max
    {
        return Err(HeidenhainLimit::TotalPoints {
            points: set.total_points(),
            max,
        }
        .into());
    }
    Ok(())
}

fn validate_table(t: &ComTable, limits: &ComLimits) -> Result<(), HeidenhainLimit> {
    let shape = |what: String| HeidenhainLimit::Shape {
        table: t.name.clone(),
        what,
    };
    if t.is_empty() || t.columns.is_empty() {
        return Err(shape(
            "a table needs at least one row and one value column".into(),
        ));
    }
    for (axis, v) in &t.columns {
        if v.len() != t.len() {
            return Err(shape(format!(
                "column {axis} has {} values for {} positions",
                v.len(),
                t.len()
            )));
        }
    }
    if t.len() > limits.max_entries {
        return Err(HeidenhainLimit::TooManyEntries {
            table: t.name.clone(),
            entries: t.len(),
            max: limits.max_entries,
        });
    }
    check_spacing(&t.name, &t.positions_mm, limits.spacing)?;
    for (axis, v) in &t.columns {
        for (row, &value) in v.iter().enumerate() {
            if !value.is_finite() || value.abs() > limits.max_abs_value_mm {
                return Err(HeidenhainLimit::ValueTooLarge {
                    table: t.name.clone(),
                    column: axis.to_string(),
                    row,
                    value,
                    max: limits.max_abs_value_mm,
                    unit: "mm",
                });
            }
        }
    }
    Ok(())
}

/// Ascending positions, spaced as `rule` asks (to 1 nm).
fn check_spacing(table: &str, p: &[f64], rule: SpacingRule) -> Result<(), HeidenhainLimit> {
    const TOL_MM: f64 = 1e-6;
    for row in 1..p.len() {
        // NaN counts as out of order.
        if p[row].partial_cmp(&p[row - 1]) != Some(std::cmp::Ordering::Greater) {
            return Err(HeidenhainLimit::NotAscending {
                table: table.to_string(),
                row,
                position: p[row],
                previous_row: row - 1,
                previous: p[row - 1],
            });
        }
    }
    if rule == SpacingRule::Ascending || p.len() < 2 {
        return Ok(());
    }
    let first = p[1] - p[0];
    for row in 1..p.len() {
        let step = p[row] - p[row - 1];
        if (step - first).abs() > TOL_MM {
            return Err(HeidenhainLimit::NotEquidistant {
                table: table.to_string(),
                row: row - 1,
                next: row,
                step_mm: step,
                expected_mm: first,
            });
        }
    }
    let counts = first / COM_RESOLUTION_MM;
    let whole = counts.round();
    let off_grid = (counts - whole).abs() * COM_RESOLUTION_MM > TOL_MM;
    let not_power =
        rule == SpacingRule::PowerOfTwo && !(whole >= 1.0 && (whole as u64).is_power_of_two());
    if off_grid || not_power {
        return Err(HeidenhainLimit::SpacingNotPowerOfTwo {
            table: table.to_string(),
            row: 0,
            next: 1,
            step_mm: first,
        });
    }
    Ok(())
}

/// Writes the tables of `set` beside `cma_path` (`<dir>/X.COM` …), then the `.CMA` assigning
/// them (one active line), then the convention card (`card_path(cma_path)`), each atomically,
/// after checking `set` against `limits`. Returns the files written.
pub fn write_heidenhain_com(
    cma_path: &Path,
    set: &ComSet,
    limits: &ComLimits,
    made_from: &[String],
) -> Result<Vec<PathBuf>, CompensateError> {
    validate_heidenhain_com(set, limits)?;
    let cma_name = table_file_name(cma_path, "CMA")?;
    let dir = cma_path.parent().unwrap_or(Path::new(""));
    let mut written = Vec::new();
    for t in &set.tables {
        let path = dir.join(&t.name);
        write_file(&path, &com_text(t))?;
        written.push(path);
    }
    let assigned: Vec<(char, &str)> = set
        .tables
        .iter()
        .map(|t| (t.input_axis, t.name.as_str()))
        .collect();
    write_file(cma_path, &cma_text(&cma_name, &assigned))?;
    written.push(cma_path.to_path_buf());
    written.push(super::write_card(
        cma_path,
        &cma_name,
        &ConventionCard {
            made_from: made_from.to_vec(),
            ..heidenhain_com_card(set)
        },
        &set.note,
    )?);
    Ok(written)
}

/// The table name of `path` as its `BEGIN` line gives it: the file name in capitals, which
/// must end in `.suffix`.
pub(super) fn table_file_name(path: &Path, suffix: &str) -> Result<String, CompensateError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_uppercase())
        .unwrap_or_default();
    let ok = name.rsplit_once('.').is_some_and(|(stem, s)| {
        !stem.is_empty() && s == suffix && name.is_ascii() && !name.contains(' ')
    });
    if !ok {
        return Err(HeidenhainLimit::Shape {
            table: path.display().to_string(),
            what: format!(
                "a .{suffix} file needs an ASCII name without blanks ending in .{suffix}"
            ),
        }
        .into());
    }
    Ok(name)
}

fn com_text(t: &ComTable) -> String {
    let mut columns = vec!["NR".to_string(), "AXISPOS".to_string()];
    columns.extend(t.columns.iter().map(|(a, _)| a.to_string()));
    let columns: Vec<&str> = columns.iter().map(String::as_str).collect();
    let rows = t
        .positions_mm
        .iter()
        .enumerate()
        .map(|(r, p)| {
            let mut row = vec![r.to_string(), format!("{p:.4}")];
            row.extend(t.columns.iter().map(|(_, v)| format!("{:.4}", v[r])));
            row
        })
        .collect();
    table_text(&TableOut {
        name: &t.name,
        columns: &columns,
        rows,
    })
}

/// A `.CMA` with one active line assigning each table (file name) to its input axis.
pub(super) fn cma_text(cma_name: &str, tables: &[(char, &str)]) -> String {
    let mut columns = vec!["NR".to_string()];
    columns.extend(tables.iter().map(|(axis, _)| axis.to_string()));
    columns.push("ACTIVE".into());
    let columns: Vec<&str> = columns.iter().map(String::as_str).collect();
    let mut row = vec!["0".to_string()];
    row.extend(tables.iter().map(|(_, name)| name.to_string()));
    row.push("*".into());
    table_text(&TableOut {
        name: cma_name,
        columns: &columns,
        rows: vec![row],
    })
}

/// Whether `name` is an axis letter the tables may use as a column.
fn axis_column(name: &str) -> Option<char> {
    let mut chars = name.chars();
    let c = chars.next()?;
    (chars.next().is_none() && "XYZUVWABC".contains(c)).then_some(c)
}

/// Reads a `.COM` table; `input_axis` is the `.CMA` column it is entered in. Every problem
/// names the file, line and column.
pub fn read_com_table(path: &Path, input_axis: char) -> Result<ComTable, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let table = parse_table(&src, &text, "COM")?;
    com_from(&src, &table, input_axis)
}

fn com_from(
    src: &Source<'_>,
    table: &TableIn<'_>,
    input_axis: char,
) -> Result<ComTable, CompensateError> {
    let hn = table.header_line;
    let Some(pos) = table.column("AXISPOS") else {
        return Err(src.error(hn, 1, "expected a column AXISPOS (the compensation points)"));
    };
    let nr = table.column("NR");
    let mut value_columns = Vec::new();
    for (k, c) in table.columns.iter().enumerate() {
        if Some(k) == nr || k == pos {
            continue;
        }
        match axis_column(c.text) {
            Some(a) => value_columns.push((k, a)),
            None => {
                return Err(src.error(
                    hn,
                    c.column,
                    format!(
                        "expected NR, AXISPOS or an axis letter (the axis a column corrects), \
                         found `{}`{}",
                        c.text,
                        if c.text == "BACKLASH" {
                            " (negative-direction values are not read: mtcal's tables are \
                             direction-free)"
                        } else {
                            ""
                        }
                    ),
                ));
            }
        }
    }
    if value_columns.is_empty() {
        return Err(src.error(hn, 1, "expected at least one axis column of values"));
    }
    let positions_mm = axis_positions(src, table, nr, pos)?;
    let mut columns: Vec<(char, Vec<f64>)> = value_columns
        .iter()
        .map(|&(_, a)| (a, Vec::new()))
        .collect();
    for row in &table.rows {
        for (col, &(k, _)) in columns.iter_mut().zip(&value_columns) {
            col.1.push(src.number(row.line, row.cells[k])?);
        }
    }
    if positions_mm.is_empty() {
        return Err(src.error(table.end_line, 1, "expected at least one row before [END]"));
    }
    Ok(ComTable {
        name: table.name.clone(),
        input_axis,
        positions_mm,
        columns,
    })
}

/// Reads a `.CMA` file and the `.COM` tables of its active line (the line with `*` in ACTIVE),
/// from the `.CMA`'s folder. Every problem names the file, line and column.
pub fn read_heidenhain_com(cma_path: &Path) -> Result<ComSet, CompensateError> {
    let dir = cma_path.parent().unwrap_or(Path::new(""));
    let mut tables = Vec::new();
    for (axis, name) in read_cma(cma_path)? {
        tables.push(read_com_table(&dir.join(name), axis)?);
    }
    Ok(ComSet {
        tables,
        note: String::new(),
    })
}

/// The active line of a `.CMA` file: each input axis with the name of its `.COM` table.
pub(super) fn read_cma(cma_path: &Path) -> Result<Vec<(char, String)>, CompensateError> {
    let text = read_file(cma_path)?;
    let src = Source { file: cma_path };
    let table = parse_table(&src, &text, "CMA")?;
    let hn = table.header_line;
    let Some(active) = table.column("ACTIVE") else {
        return Err(src.error(
            hn,
            1,
            "expected a column ACTIVE (`*` marks the active line)",
        ));
    };
    let nr = table.column("NR");
    let mut axes = Vec::new();
    for (k, c) in table.columns.iter().enumerate() {
        if Some(k) == nr || k == active {
            continue;
        }
        match axis_column(c.text) {
            Some(a) => axes.push((k, a)),
            None => {
                return Err(src.error(
                    hn,
                    c.column,
                    format!("expected NR, ACTIVE or an axis letter, found `{}`", c.text),
                ));
            }
        }
    }
    let mut chosen = None;
    for row in &table.rows {
        let cell = row.cells[active];
        match cell.text {
            "" => continue,
            "*" => {}
            other => {
                return Err(src.error(
                    row.line,
                    cell.column,
                    format!("expected `*` or nothing in ACTIVE, found `{other}`"),
                ));
            }
        }
        if let Some((first, _)) = chosen {
            return Err(src.error(
                row.line,
                cell.column,
                format!("a second active line (the first is line {first}); only one can be active"),
            ));
        }
        chosen = Some((row.line, row));
    }
    let Some((_, row)) = chosen else {
        return Err(src.error(
            table.end_line,
            1,
            "expected one active line (`*` in ACTIVE), found none",
        ));
    };
    let mut assigned = Vec::new();
    for &(k, axis) in &axes {
        let cell = row.cells[k];
        if cell.text.is_empty() {
            continue;
        }
        let is_com = cell
            .text
            .rsplit_once('.')
            .is_some_and(|(stem, s)| !stem.is_empty() && s.eq_ignore_ascii_case("COM"));
        if !is_com {
            return Err(src.error(
                row.line,
                cell.column,
                format!("expected a .COM table name, found `{}`", cell.text),
            ));
        }
        assigned.push((axis, cell.text.to_string()));
    }
    Ok(assigned)
}

/// The convention card of the `.COM` tables of `set`.
pub fn heidenhain_com_card(set: &ComSet) -> ConventionCard {
    let mut letters: Vec<char> = set
        .tables
        .iter()
        .flat_map(|t| std::iter::once(t.input_axis).chain(t.columns.iter().map(|c| c.0)))
        .collect();
    letters.sort_by_key(|c| "XYZUVWABC".find(*c));
    letters.dedup();
    ConventionCard {
        made_from: Vec::new(),
        format: "Heidenhain nonlinear axis error compensation: .COM tables (NR, AXISPOS, one \
                 column per corrected axis) assigned to their input axis by a .CMA file"
            .into(),
        quantity: Quantity::Error,
        sign: "a value is the error of the column's axis, actual − nominal along it (positive: \
               the tool ends up further in that axis' + direction relative to the workpiece \
               than commanded, as MP720's 'positive if the table travels too far'); the control \
               moves that axis by −value"
            .into(),
        squareness: "carried inside the straightness columns as a slope along the input axis \
                     (not as a parameter)"
            .into(),
        rotary_direction: "not used: the tables are functions of linear axes, rotary axes held \
                           at their held positions"
            .into(),
        axis_mapping: letters
            .iter()
            .map(|&c| AxisMap {
                mtcal: c,
                control: c.to_string(),
            })
            .collect(),
        units: "AXISPOS in mm from the machine datum (mtcal's axis zero), values in mm, both to \
                0.1 µm (4 decimals)"
            .into(),
        control_will: vec![
            "compensate only the axes whose bit MP730 sets to nonlinear compensation (TNC 4xx) \
             and only with a .CMA whose line is active (soft key or PLC module 9095 on the TNC \
             4xx; `*` in ACTIVE on the MANUALplus 620)"
                .into(),
            "add to each axis the values of its column in every table of the active line, each \
             table at the position of its own input axis (the .CMA column it is entered in), \
             linearly between rows"
                .into(),
            "refuse a table of more than 256 entries and a line over its total point budget or \
             table count (TNC 4xx, PLC module 9095 errors 3 to 5); on the TNC 4xx rows must be \
             2^k × 0.1 µm apart"
                .into(),
            "reproduce the model exactly on the three lines through the held position; \
             elsewhere it adds 1-D functions and cannot hold errors that depend on two axes at \
             once (Abbe effects of angular errors): KinematicsComp can"
                .into(),
            "hold no direction-dependent part (no BACKLASH column) and nothing for rotary axes"
                .into(),
            "take the column layout as the MANUALplus 620 manual gives it (pp.716–718); the TNC \
             4xx pages on the layout were not available: check the tables in the control's \
             table editor before activating them"
                .into(),
        ],
    }
}
