//! Pitch tables and rotary tables into Fanuc pitch data: the layout (reference, first and last
//! point, interval), the values relative to the reference position, the magnification.

use super::validate::validate_fanuc;
use super::{
    FanucAxis, FanucControl, FanucConversion, FanucError, FanucLayout, FanucReverse, FanucTable,
    MAX_MAGNIFICATION, POS_TOL,
};
use crate::rotary::TURN_DEG;
use crate::{CompensateError, MM, PitchTable, RotaryTable, Travel, UM};

/// The table of a linear axis from a pitch table whose nodes are `interval` apart with one on
/// the reference position (e.g. from [`fanuc_pitch_table`]).
pub fn fanuc_from_pitch(
    table: &PitchTable,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    let to_mm = |v: &[f64]| v.iter().map(|c| c / MM).collect::<Vec<f64>>();
    let samples = Samples {
        letter: table.axis,
        rotary: false,
        full_turn: false,
        positions: &table.positions_mm,
        forward: to_mm(&table.forward_um),
        reverse: table.reverse_um.as_deref().map(to_mm),
    };
    let mut c = convert(&samples, control, axis, layout)?;
    c.note = table.note.clone();
    Ok(c)
}

/// The table of a rotary axis. A full-revolution table ([`RotaryTable::full_turn`]) becomes a
/// rotary-axis table with 3625 = 360°; its nodes must divide the revolution and one of them be
/// at the reference position (modulo 360°). A table over limits becomes a table like a linear
/// axis' (no 3625).
pub fn fanuc_from_rotary(
    table: &RotaryTable,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    let samples = Samples {
        letter: table.axis,
        rotary: true,
        full_turn: table.full_turn,
        positions: &table.positions_deg,
        forward: table
            .compensation_urad
            .iter()
            .map(|c| (c / UM).to_degrees())
            .collect(),
        reverse: None,
    };
    let mut c = convert(&samples, control, axis, layout)?;
    c.note = table.note.clone();
    Ok(c)
}

/// A table's samples: node positions and compensations, both in mm or degrees.
struct Samples<'a> {
    letter: char,
    rotary: bool,
    full_turn: bool,
    positions: &'a [f64],
    forward: Vec<f64>,
    reverse: Option<Vec<f64>>,
}

/// Compensations at the control's nodes relative to the reference, in detection units.
struct Relative {
    forward: Vec<f64>,
    reverse: Option<Vec<f64>>,
    /// Node index of the reference position.
    reference: usize,
    /// The compensation at the reference the table does not hold (mm or degrees).
    base: f64,
    revolution_units: Option<i64>,
}

fn convert(
    s: &Samples<'_>,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
) -> Result<FanucConversion, CompensateError> {
    if s.letter != axis.letter || s.rotary != axis.rotary {
        let message = format!(
            "the table is of {} axis {} but the Fanuc axis is {} axis {}",
            kind(s.rotary),
            s.letter,
            kind(axis.rotary),
            axis.letter
        );
        return Err(FanucError::Layout {
            axis: s.letter,
            message,
        }
        .into());
    }
    let du = control.increment.detection_unit();
    let interval_units = regular_interval(s.letter, s.positions, du, axis.unit())?;
    let rel = if s.full_turn {
        relative_turn(s, axis, du, interval_units)?
    } else {
        relative_stroke(s, axis, du, interval_units)?
    };
    let table = round_table(&rel, control, axis, layout, interval_units)?;
    validate_fanuc(control, std::slice::from_ref(&table))?;
    Ok(FanucConversion {
        table,
        reference_compensation: rel.base,
        note: String::new(),
        reversal_source: None,
    })
}

fn kind(rotary: bool) -> &'static str {
    if rotary { "rotary" } else { "linear" }
}

/// The constant interval of `positions` in detection units.
fn regular_interval(
    axis: char,
    positions: &[f64],
    du: f64,
    unit: &'static str,
) -> Result<i64, FanucError> {
    if positions.len() < 2 {
        let nodes = positions.len();
        return Err(FanucError::TooFewNodes { axis, nodes });
    }
    let expected = positions[1] - positions[0];
    for (i, w) in positions.windows(2).enumerate() {
        let found = w[1] - w[0];
        if found <= 0.0 {
            let (position, previous) = (w[1], w[0]);
            return Err(FanucError::Unsorted {
                axis,
                position,
                previous,
            });
        }
        if (found - expected).abs() > POS_TOL {
            let index = i + 1;
            return Err(FanucError::IrregularInterval {
                axis,
                index,
                found,
                expected,
                unit,
            });
        }
    }
    let units = (expected / du).round();
    if (expected - units * du).abs() > POS_TOL {
        return Err(FanucError::IntervalNotWhole {
            axis,
            interval: expected,
            detection_unit: du,
            unit,
        });
    }
    Ok(units as i64)
}

/// How many intervals `x` is from `origin`, when a whole number.
fn whole_steps(x: f64, origin: f64, interval: f64) -> Option<i64> {
    let k = ((x - origin) / interval).round();
    ((x - (origin + k * interval)).abs() <= POS_TOL * 10.0).then_some(k as i64)
}

fn off_node(s: &Samples<'_>, axis: &FanucAxis, interval: f64) -> FanucError {
    FanucError::ReferenceOffNode {
        axis: s.letter,
        reference: axis.reference_position,
        interval,
        first: s.positions[0],
        last: s.positions[s.positions.len() - 1],
        unit: axis.unit(),
    }
}

/// A table over a stroke: its own nodes, the reference on one of them.
fn relative_stroke(
    s: &Samples<'_>,
    axis: &FanucAxis,
    du: f64,
    interval_units: i64,
) -> Result<Relative, FanucError> {
    let interval = interval_units as f64 * du;
    let r = whole_steps(axis.reference_position, s.positions[0], interval)
        .filter(|&k| k >= 0 && (k as usize) < s.positions.len())
        .ok_or_else(|| off_node(s, axis, interval))? as usize;
    let base = match (&s.reverse, axis.reference_return) {
        (Some(rev), Travel::Reverse) => rev[r],
        _ => s.forward[r],
    };
    let relative = |v: &Vec<f64>| v.iter().map(|c| (c - base) / du).collect();
    Ok(Relative {
        forward: relative(&s.forward),
        reverse: s.reverse.as_ref().map(relative),
        reference: r,
        base,
        revolution_units: None,
    })
}

/// A full revolution: nodes reference − interval, reference, …, reference + 360°, the values
/// taken modulo one revolution so that the last node is the first.
fn relative_turn(
    s: &Samples<'_>,
    axis: &FanucAxis,
    du: f64,
    interval_units: i64,
) -> Result<Relative, FanucError> {
    let revolution_units = (TURN_DEG / du).round() as i64;
    if revolution_units % interval_units != 0 {
        return Err(FanucError::RevolutionNotWhole {
            axis: s.letter,
            interval_units,
            revolution_units,
        });
    }
    let n = (revolution_units / interval_units) as usize;
    if s.positions.len() != n + 1 {
        let message = format!(
            "a full-revolution table needs {} nodes {} ° apart, got {}",
            n + 1,
            interval_units as f64 * du,
            s.positions.len()
        );
        return Err(FanucError::Layout {
            axis: s.letter,
            message,
        });
    }
    let (start, end) = (s.forward[0], s.forward[n]);
    // 0.001 µrad: far below any detection unit, far above the model's rounding.
    if (end - start).abs().to_radians() > 1e-9 {
        return Err(FanucError::NotPeriodic {
            axis: s.letter,
            start_urad: start.to_radians() * UM,
            end_urad: end.to_radians() * UM,
        });
    }
    let interval = interval_units as f64 * du;
    let r0 = whole_steps(axis.reference_position, s.positions[0], interval)
        .ok_or_else(|| off_node(s, axis, interval))?
        .rem_euclid(n as i64) as usize;
    let base = s.forward[r0];
    // Node j is the reference plus (j − 1) intervals: j = 0 is one interval before it.
    let forward = (0..n + 2)
        .map(|j| (s.forward[(r0 + n + j - 1) % n] - base) / du)
        .collect();
    Ok(Relative {
        forward,
        reverse: None,
        reference: 1,
        base,
        revolution_units: Some(revolution_units),
    })
}

/// Totals rounded to multiples of `m` detection units at each node.
fn rounded(rel: &[f64], m: u32) -> Vec<i64> {
    let m = m as f64;
    rel.iter().map(|x| ((x / m).round() * m) as i64).collect()
}

/// Increments (in units of `m` detection units) between successive rounded totals.
fn increments(cum: &[i64], m: u32) -> Vec<i64> {
    cum.windows(2).map(|w| (w[1] - w[0]) / m as i64).collect()
}

/// The magnification: the layout's, or the smallest that fits the control's range.
fn magnification(
    rel: &Relative,
    control: &FanucControl,
    axis: char,
    fixed: Option<u32>,
) -> Result<u32, FanucError> {
    let bidirectional = rel.reverse.is_some();
    let check = |m: u32| {
        if bidirectional && m != 1 {
            return Err(FanucError::BidirectionalMagnification {
                axis,
                magnification: m,
            });
        }
        Ok(m)
    };
    if let Some(m) = fixed {
        if !(1..=MAX_MAGNIFICATION).contains(&m) {
            return Err(FanucError::BadMagnification {
                axis,
                magnification: m,
            });
        }
        return check(m);
    }
    let largest = |m: u32| {
        let sets = std::iter::once(&rel.forward).chain(rel.reverse.as_ref());
        sets.flat_map(|v| increments(&rounded(v, m), m))
            .map(i64::abs)
            .max()
            .unwrap_or(0)
    };
    let max = if bidirectional { 1 } else { MAX_MAGNIFICATION };
    match (1..=max).find(|&m| largest(m) <= control.value_limit) {
        Some(m) => check(m),
        None => Err(FanucError::NoMagnification {
            axis,
            largest: largest(1),
            limit: control.value_limit,
            max,
        }),
    }
}

/// The table: rounded totals differenced, numbered from the layout's first point.
fn round_table(
    rel: &Relative,
    control: &FanucControl,
    axis: &FanucAxis,
    layout: &FanucLayout,
    interval_units: i64,
) -> Result<FanucTable, FanucError> {
    let m = magnification(rel, control, axis.letter, layout.magnification)?;
    let block_start = layout.first_point.unwrap_or(0);
    let r = rel.reference as u32;
    let reference_point = block_start + r.max(1) - 1;
    let first_point = reference_point + 1 - r;
    let forward = rounded(&rel.forward, m);
    let values = increments(&forward, m);
    let last_point = first_point + values.len() as u32 - 1;
    let reverse = rel.reverse.as_ref().map(|rev| {
        let cum = rounded(rev, m);
        let opposite = match axis.reference_return {
            Travel::Forward => cum[rel.reference],
            Travel::Reverse => forward[rel.reference],
        };
        let block = layout.reverse_first_point.unwrap_or(last_point + 1);
        FanucReverse {
            first_point: block + (first_point - block_start),
            opposite_at_reference_units: opposite,
            values: increments(&cum, m),
        }
    });
    Ok(FanucTable {
        axis: *axis,
        increment: control.increment,
        reference_point,
        first_point,
        last_point,
        magnification: m,
        interval_units,
        revolution_units: rel.revolution_units,
        values,
        reverse,
    })
}
