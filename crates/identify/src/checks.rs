//! Plausibility checks of a run file against the machine and the instrument, made when a
//! session is loaded, before anything is fitted or written:
//!
//! - **metres where mm are expected**: every commanded position of the linear axes lies within
//!   ±[`METRES_LIKE_MM`] mm (and not all at zero) while their strokes span at least
//!   [`LONG_STROKE_MM`] mm;
//! - **beyond the axis limits**: a commanded position outside its axis' limits by more than
//!   [`LIMIT_TOLERANCE_MM`] mm (linear) or [`LIMIT_TOLERANCE_DEG`]° (rotary);
//! - **beyond the instrument's range**: a reading whose magnitude exceeds the set-up's
//!   [`SetupFormat::reading_range`]; when most of the column does, the message says the column looks
//!   1000 times too large (nm where µm are expected).
//!
//! Each error names the file, line and column of the cell and says what was expected.

use crate::IdentifyError;
use mtcal_instrument::Setup;
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_session::RunTable;

/// A run whose linear positions all lie within ±this many mm looks like metres.
pub const METRES_LIKE_MM: f64 = 1.0;
/// ... when the strokes of its linear axes span at least this many mm.
pub const LONG_STROKE_MM: f64 = 50.0;
/// How far beyond a linear axis' limit a commanded position may be (rounding, mm).
pub const LIMIT_TOLERANCE_MM: f64 = 0.01;
/// How far beyond a rotary axis' limit a commanded angle may be (rounding, degrees).
pub const LIMIT_TOLERANCE_DEG: f64 = 0.01;

/// `file:line:column` of data row `i` (0-based) and column `name` (the header is line 1).
pub(crate) fn cell(table: &RunTable, i: usize, name: &str) -> String {
    let column = table
        .columns
        .iter()
        .position(|c| c == name)
        .map_or(String::new(), |j| format!(":{}", j + 1));
    // Read the file again for the line: blank lines move the rows (only on an error).
    let line = mtcal_session::row_line(&table.path, i).unwrap_or(i + 2);
    format!("{}:{line}{column}", table.path.display())
}

/// Checks a run table given in memory ([`crate::Study::from_parts`]) for what reading a run
/// file guarantees: the machine's axes and the set-up's reading and label columns, readings
/// unless the run is only validated, at least one row, every column as long as `t`, finite
/// numbers and `t` strictly increasing.
pub(crate) fn check_table(
    model: &MachineModel,
    setup: &dyn Setup,
    table: &RunTable,
    fit: bool,
) -> Result<(), IdentifyError> {
    check_table_columns(model, setup, table, fit).map_err(|message| IdentifyError::RunData {
        at: table.path.display().to_string(),
        message,
    })
}

fn check_table_columns(
    model: &MachineModel,
    setup: &dyn Setup,
    table: &RunTable,
    fit: bool,
) -> Result<(), String> {
    let axes: Vec<char> = model.machine().letters().chars().collect();
    let channels: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
    let labels: Vec<&str> = table.labels.iter().map(|(n, _)| n.as_str()).collect();
    if table.axes != axes {
        return Err(format!(
            "the table's axes are {:?}, the machine's {axes:?}",
            table.axes
        ));
    }
    if table.readings != channels {
        return Err(format!(
            "the table's reading columns are {:?}, the instrument's {channels:?}",
            table.readings
        ));
    }
    if labels != setup.label_columns() {
        return Err(format!(
            "the table's label columns are {labels:?}, the instrument's {:?}",
            setup.label_columns()
        ));
    }
    if fit && table.values.is_none() {
        return Err("a fitted run needs its readings".into());
    }
    let n = table.len();
    if n == 0 {
        return Err("the table has no rows".into());
    }
    let mut columns: Vec<(&str, &[f64], usize)> = vec![
        ("t", &table.t, n),
        ("positions", &table.positions, n * axes.len()),
    ];
    if let Some(values) = &table.values {
        columns.push(("readings", values, n * channels.len()));
    }
    columns.extend(table.context.iter().map(|(c, v)| (c.as_str(), &v[..], n)));
    for (name, values, len) in columns {
        if values.len() != len {
            return Err(format!(
                "`{name}` has {} values, expected {len}",
                values.len()
            ));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!("`{name}` holds {} at index {i}", values[i]));
        }
    }
    if let Some((name, _)) = table.labels.iter().find(|(_, v)| v.len() != n) {
        return Err(format!("label column \"{name}\" is not {n} rows long"));
    }
    if let Some(i) = table.t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(format!("t must increase strictly: row {} does not", i + 2));
    }
    Ok(())
}

/// Checks one run's commanded positions and readings (file units) against the machine's axis
/// limits and the instrument's range.
pub(crate) fn check_run(
    model: &MachineModel,
    setup: &dyn Setup,
    table: &RunTable,
) -> Result<(), IdentifyError> {
    check_metres(model, table)?;
    check_limits(model, table)?;
    check_range(setup, table)
}

fn check_metres(model: &MachineModel, table: &RunTable) -> Result<(), IdentifyError> {
    let axes = model.machine().axes();
    let mut largest: Option<(f64, usize, usize)> = None; // |value|, row, axis
    let mut strokes = Vec::new();
    for (k, ax) in axes.iter().enumerate() {
        if ax.kind() != AxisKind::Linear {
            continue;
        }
        let Some((lo, hi)) = ax.limits() else {
            continue;
        };
        if (hi - lo) * 1e3 < LONG_STROKE_MM {
            return Ok(());
        }
        strokes.push(format!(
            "{} {} … {} mm",
            ax.letter().as_char(),
            lo * 1e3,
            hi * 1e3
        ));
        for i in 0..table.len() {
            let v = table.q_row(i)[k].abs();
            if v > METRES_LIKE_MM {
                return Ok(());
            }
            if largest.is_none_or(|(m, _, _)| v > m) {
                largest = Some((v, i, k));
            }
        }
    }
    let Some((m, i, k)) = largest else {
        return Ok(());
    };
    if m == 0.0 {
        return Ok(()); // all at zero: a run at the origin, nothing to tell
    }
    let letter = axes[k].letter().as_char().to_string();
    Err(IdentifyError::RunData {
        at: cell(table, i, &letter),
        message: format!(
            "column \"{letter}\": every commanded position of this run lies within \
             ±{METRES_LIKE_MM} mm (largest {}) while the strokes are {}: this looks like \
             metres; expected mm (multiply by 1000)",
            table.q_row(i)[k],
            strokes.join(", ")
        ),
    })
}

fn check_limits(model: &MachineModel, table: &RunTable) -> Result<(), IdentifyError> {
    for (k, ax) in model.machine().axes().iter().enumerate() {
        let Some((lo, hi)) = ax.limits() else {
            continue;
        };
        let (lo, hi, tol, unit) = match ax.kind() {
            AxisKind::Linear => (lo * 1e3, hi * 1e3, LIMIT_TOLERANCE_MM, "mm"),
            AxisKind::Rotary => (
                lo.to_degrees(),
                hi.to_degrees(),
                LIMIT_TOLERANCE_DEG,
                "degrees",
            ),
        };
        for i in 0..table.len() {
            let v = table.q_row(i)[k];
            if v < lo - tol || v > hi + tol {
                let letter = ax.letter().as_char().to_string();
                let (side, by) = if v < lo {
                    ("below", lo - v)
                } else {
                    ("above", v - hi)
                };
                return Err(IdentifyError::RunData {
                    at: cell(table, i, &letter),
                    message: format!(
                        "column \"{letter}\": expected a position within the axis limits \
                         {lo} … {hi} {unit}, found {v} {unit}, {by} {unit} {side} them"
                    ),
                });
            }
        }
    }
    Ok(())
}

fn check_range(setup: &dyn Setup, table: &RunTable) -> Result<(), IdentifyError> {
    if table.values.is_none() {
        return Ok(());
    }
    for (c, ch) in setup.channels().iter().enumerate() {
        let Some(range) = setup.reading_range(c) else {
            continue;
        };
        let range = range * ch.unit.per_si();
        let column = |i: usize| table.reading_row(i).map_or(0.0, |r| r[c]);
        let beyond = (0..table.len())
            .filter(|&i| column(i).abs() > range)
            .count();
        let Some(first) = (0..table.len()).find(|&i| column(i).abs() > range) else {
            continue;
        };
        let hint = if 2 * beyond > table.len() {
            format!(
                "; {beyond} of {} readings are beyond it: the column looks 1000 times too \
                 large, expected {}",
                table.len(),
                ch.unit
            )
        } else {
            String::new()
        };
        return Err(IdentifyError::RunData {
            at: cell(table, first, &ch.name),
            message: format!(
                "column \"{}\": expected a reading within the instrument's range ±{range} {}, \
                 found {} {}{hint}",
                ch.name,
                ch.unit,
                column(first),
                ch.unit
            ),
        });
    }
    Ok(())
}
