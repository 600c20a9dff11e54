//! The parameter record as the control reads it, the values table beside it, the convention card.

use super::validate::validate_fanuc;
use super::{
    AXIS_POINTS_SOURCE, FanucControl, FanucConversion, FanucTable, PARAMETERS, PITCH_BASE,
};
use crate::{AxisMap, CompensateError, ConventionCard, Quantity, ROTARY_RIGHT_HAND, Travel};
use std::fmt::Write as _;

/// `units` detection units as a decimal number with `decimals` places, exactly.
fn decimal(units: i64, decimals: usize) -> String {
    let scale = 10i64.pow(decimals as u32);
    let sign = if units < 0 { "-" } else { "" };
    let a = units.unsigned_abs();
    format!("{sign}{}.{:0decimals$}", a / scale as u64, a % scale as u64)
}

/// The parameters' values of table `t` as written: 3620 … 3627, `None` where not written.
fn parameter_texts(control: &FanucControl, t: &FanucTable) -> [(u32, Option<String>); 8] {
    let length = |units: i64| {
        if control.series.real_intervals() {
            decimal(units, control.increment.decimals())
        } else {
            units.to_string()
        }
    };
    let rev = t.reverse.as_ref();
    [
        (3620, Some(t.reference_point.to_string())),
        (3621, Some(t.first_point.to_string())),
        (3622, Some(t.last_point.to_string())),
        (3623, Some(t.magnification.to_string())),
        (3624, Some(length(t.interval_units))),
        (3625, t.revolution_units.map(length)),
        (3626, rev.map(|r| r.first_point.to_string())),
        (3627, rev.map(|r| r.opposite_at_reference_units.to_string())),
    ]
}

/// The parameter record of `tables` (see the module doc), after [`validate_fanuc`].
pub fn fanuc_parameter_text(
    control: &FanucControl,
    tables: &[FanucTable],
) -> Result<String, CompensateError> {
    validate_fanuc(control, tables)?;
    let q = control.series.parameter_marker();
    let per_table: Vec<_> = tables
        .iter()
        .map(|t| (t.axis.number, parameter_texts(control, t)))
        .collect();
    let mut text = String::from("%\n");
    for (k, number) in PARAMETERS.iter().enumerate() {
        let words: String = per_table
            .iter()
            .filter_map(|(axis, p)| p[k].1.as_ref().map(|v| format!("A{axis}P{v}")))
            .collect();
        if !words.is_empty() {
            let _ = writeln!(text, "N{number:05}{q}{words}");
        }
    }
    let mut points: Vec<(u32, i64)> = Vec::new();
    for t in tables {
        let sets = std::iter::once((t.first_point, &t.values))
            .chain(t.reverse.iter().map(|r| (r.first_point, &r.values)));
        for (first, values) in sets {
            points.extend(
                values
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (first + i as u32, v)),
            );
        }
    }
    points.sort_unstable();
    let q0 = control.series.pitch_marker();
    for (point, value) in points {
        let _ = writeln!(text, "N{}{q0}P{value}", PITCH_BASE + point);
    }
    text.push_str("%\n");
    Ok(text)
}

/// The values table: the card as `#` comments, then one row per node and set.
pub fn fanuc_values_csv(
    control: &FanucControl,
    conversions: &[FanucConversion],
    card: &ConventionCard,
) -> String {
    let mut text = String::from(
        "# mtcal Fanuc pitch error compensation values: the numbers of the parameter file\n",
    );
    text.push_str(&card.file_lines("# "));
    for c in conversions {
        let t = &c.table;
        let _ = writeln!(
            text,
            "# {} = axis {}: reference position {} {} = point {}; interval {} {}; \
             magnification {}; detection unit {} {} ({})",
            t.axis.letter,
            t.axis.number,
            t.axis.reference_position,
            t.axis.unit(),
            t.reference_point,
            t.interval(),
            t.axis.unit(),
            t.magnification,
            control.increment.detection_unit(),
            t.axis.unit(),
            control.increment.name()
        );
        for l in c.note.lines() {
            let _ = writeln!(text, "#   {l}");
        }
    }
    text.push_str(
        "# position: mm or deg, mtcal's axis coordinates; increment: the point's value \
         (detection units x magnification); cumulative: total at the position in detection \
         units; compensation: the same in um (linear) or millidegrees (rotary); the first row \
         of each set is the node where its first interval starts\n",
    );
    text.push_str("axis,direction,point,position,increment,cumulative,compensation\n");
    for c in conversions {
        value_rows(&mut text, &c.table);
    }
    text
}

/// The rows of one table: the node where its first interval starts (no increment, and no
/// point number unless it is the reference point), then every point.
fn value_rows(text: &mut String, t: &FanucTable) {
    let du = t.increment.detection_unit();
    let positions = t.positions();
    let mut sets = vec![(Travel::Forward, "+", t.first_point, &t.values)];
    if let Some(r) = &t.reverse {
        sets.push((Travel::Reverse, "-", r.first_point, &r.values));
    }
    let reference_offset = t.reference_point as i64 - t.first_point as i64;
    for (travel, sign, first, values) in sets {
        let totals = t.cumulative_units(travel);
        for (i, (p, total)) in positions.iter().zip(&totals).enumerate() {
            let k = first as i64 - 1 + i as i64;
            let (point, increment) = match i {
                0 if k == first as i64 + reference_offset => (k.to_string(), String::new()),
                0 => (String::new(), String::new()),
                _ => (k.to_string(), values[i - 1].to_string()),
            };
            let _ = writeln!(
                text,
                "{},{sign},{point},{p:.6},{increment},{total},{:.4}",
                t.axis.letter,
                *total as f64 * du * 1e3
            );
        }
    }
}

/// The convention card of a Fanuc export.
pub fn fanuc_card(control: &FanucControl, conversions: &[FanucConversion]) -> ConventionCard {
    let axis_mapping = conversions
        .iter()
        .map(|c| AxisMap {
            mtcal: c.table.axis.letter,
            control: format!(
                "axis {} (A{} in the file)",
                c.table.axis.number, c.table.axis.number
            ),
        })
        .collect();
    let references: Vec<String> = conversions
        .iter()
        .map(|c| {
            let a = &c.table.axis;
            format!("{} = {} {}", a.letter, a.reference_position, a.unit())
        })
        .collect();
    let du = control.increment.detection_unit();
    ConventionCard {
        made_from: Vec::new(),
        format: format!(
            "Fanuc pitch error compensation, {} parameter record (3620–3627 and pitch data \
             N10000 + point)",
            control.series.name()
        ),
        quantity: Quantity::Correction,
        sign: "a positive total moves the axis towards its positive direction: the control adds \
               it to the position it commands; each point's value is the increment of the \
               total over the interval ending at that point, viewed from the negative direction"
            .into(),
        squareness: "not held (a pitch table holds positioning along the axis only)".into(),
        rotary_direction: format!(
            "{ROTARY_RIGHT_HAND}; the control's positive direction is taken to be mtcal's"
        ),
        axis_mapping,
        units: format!(
            "values in detection units ({}: {du} mm or {du}°) × magnification 3623; 3624 and \
             3625 in {}; positions relative to the reference position (the control's machine \
             zero) at {} in mtcal's axis coordinates",
            control.increment.name(),
            if control.series.real_intervals() {
                "mm or degrees"
            } else {
                "detection units"
            },
            references.join(", ")
        ),
        control_will: control_will(control, conversions),
    }
}

/// The card's sentences on what the control does with the file.
fn control_will(control: &FanucControl, conversions: &[FanucConversion]) -> Vec<String> {
    let mut will = vec![
        "need power off and on after 3620–3627 change, and a reference position return after \
         the values change: the table is counted from the reference position"
            .to_string(),
        "output each point's value while the axis passes through that point's interval \
         (B-63980EN: \"the compensation value is output at the compensation position No. \
         corresponding to each section\"): the total is exact at the points (within half a \
         detection unit × magnification of the model); between two points it is not \
         interpolated to the model, so the interval bounds what is corrected between them"
            .to_string(),
        "add nothing beyond the farthest points (3621 − 1 and 3622): the strips of stroke \
         shorter than one interval beyond them keep the end total"
            .to_string(),
        format!(
            "hold at most {} points per axis from 3621 to 3622 — the limit checked here, from \
             {AXIS_POINTS_SOURCE}; --fanuc-axis-points sets your control's",
            control.axis_points
        ),
        "read pitch data blocks as N(10000 + point)P(value) and, on Series 30i, parameter \
         blocks marked Q1 (B-63950EN) and pitch data marked Q0 (assumed by analogy: check \
         against a record punched by your control before loading)"
            .to_string(),
    ];
    for c in conversions {
        let a = &c.table.axis;
        will.push(format!(
            "not hold axis {}'s compensation at its reference position, {:.3} {}: Fanuc's \
             total is 0 there, so it is a reference position shift (grid shift or work offset), \
             not part of the table",
            a.letter,
            c.reference_compensation * 1e3,
            a.milli_unit()
        ));
        if c.table.revolution_units.is_some() {
            will.push(format!(
                "repeat axis {}'s table every revolution (3625 = 360°): its values sum to 0 \
                 over a turn and point 3620 carries point 3622's value (B-63980EN)",
                a.letter
            ));
        }
        if c.table.is_bidirectional() {
            will.push(format!(
                "use axis {}'s points from 3626 while it moves in the negative direction once \
                 3605#0 = 1 (A-77810E); set 3605#0 by hand: the file does not write 3605, whose \
                 other bits belong to other functions; negative = positive + B (ISO 230-2 \
                 reversal value B = x̄↑ − x̄↓){}",
                a.letter,
                c.reversal_source
                    .as_ref()
                    .map(|s| format!(", from {s}"))
                    .unwrap_or_default()
            ));
        }
    }
    will
}
