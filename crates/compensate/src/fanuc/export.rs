//! One call from a machine model to the checked pitch data of its axes ([`fanuc_export`]), and
//! the files ([`write_fanuc`]).

use super::convert::{fanuc_from_pitch, fanuc_from_rotary};
use super::text::{fanuc_card, fanuc_parameter_text, fanuc_values_csv};
use super::validate::validate_fanuc;
use super::{FanucAxis, FanucControl, FanucConversion, FanucError, FanucLayout, FanucTable};
use crate::rotary::{held_note, rotary_axis, rotary_table_at};
use crate::{
    CompensateError, ConventionCard, MAX_NODES, MM, PitchTable, UM, check_inputs, linear_axis,
    travel_direction, write_file,
};
use mtcal_kinematics::MachineModel;
use std::path::Path;

/// One axis of a Fanuc export.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FanucRequest {
    pub axis: FanucAxis,
    /// Node interval, mm or degrees (a whole number of detection units; dividing 360° on an
    /// axis without limits).
    pub interval: f64,
    pub layout: FanucLayout,
    /// Linear axes: the reversal ([`crate::Reversal`]: the signed ISO 230-2 reversal value B,
    /// µm, which may change along the stroke) for a bidirectional table.
    pub reversal: Option<crate::Reversal>,
}

/// The tables of `requests` from the model, their points laid out one axis after the other
/// where a layout leaves `first_point` open; checked together ([`validate_fanuc`]).
pub fn fanuc_export(
    model: &MachineModel,
    coeffs: &[f64],
    requests: &[FanucRequest],
    control: &FanucControl,
    hold_q: &[f64],
) -> Result<Vec<FanucConversion>, CompensateError> {
    let mut next = 0;
    let mut out = Vec::with_capacity(requests.len());
    for req in requests {
        let mut layout = req.layout;
        layout.first_point = layout.first_point.or(Some(next));
        let c = export_one(model, coeffs, req, control, &layout, hold_q)?;
        let end = c.table.blocks().iter().map(|b| b.1).max().unwrap_or(0);
        next = next.max(end as u32 + 1);
        out.push(c);
    }
    let tables: Vec<FanucTable> = out.iter().map(|c| c.table.clone()).collect();
    validate_fanuc(control, &tables)?;
    Ok(out)
}

fn export_one(
    model: &MachineModel,
    coeffs: &[f64],
    req: &FanucRequest,
    control: &FanucControl,
    layout: &FanucLayout,
    hold_q: &[f64],
) -> Result<FanucConversion, CompensateError> {
    let a = &req.axis;
    if !a.rotary {
        let table = fanuc_pitch_table(
            model,
            coeffs,
            a.letter,
            req.interval,
            a.reference_position,
            hold_q,
        )?;
        let table = match &req.reversal {
            Some(r) => table.with_reversal(r, crate::stroke_mm(model.machine(), a.letter)?),
            None => table,
        };
        return fanuc_from_pitch(&table, control, a, layout);
    }
    if req.reversal.is_some() {
        let message = "mtcal writes rotary tables unidirectional only".to_string();
        return Err(FanucError::Layout {
            axis: a.letter,
            message,
        }
        .into());
    }
    check_inputs(model, coeffs, hold_q)?;
    let (i, lo, hi, full_turn) = rotary_axis(model.machine(), a.letter)?;
    let what = format!("Fanuc table of axis {}", a.letter);
    let positions = if full_turn {
        crate::nodes_in(lo, hi, req.interval, &what)?
    } else {
        aligned_nodes(
            a.letter,
            (lo, hi),
            a.reference_position,
            req.interval,
            &what,
        )?
    };
    let table = rotary_table_at(model, coeffs, i, positions, hold_q, full_turn);
    fanuc_from_rotary(&table, control, a, layout)
}

/// Nodes `interval` apart through `reference`, within `[lo, hi]` (one unit, mm or degrees).
fn aligned_nodes(
    axis: char,
    (lo, hi): (f64, f64),
    reference: f64,
    interval: f64,
    what: &str,
) -> Result<Vec<f64>, CompensateError> {
    if !(interval.is_finite() && interval > 0.0) {
        return Err(CompensateError::BadSpacing {
            spacing_mm: interval,
        });
    }
    if !reference.is_finite() {
        let message = format!("the reference position must be finite, got {reference}");
        return Err(FanucError::Layout { axis, message }.into());
    }
    // A node this close outside the stroke is on its end (mm or degrees).
    const SNAP: f64 = 1e-6;
    let k_lo = ((lo - SNAP - reference) / interval).ceil();
    let k_hi = ((hi + SNAP - reference) / interval).floor();
    let nodes = (k_hi - k_lo + 1.0).max(0.0);
    if nodes > MAX_NODES as f64 {
        return Err(CompensateError::TooManyNodes {
            what: what.to_string(),
            nodes: nodes as usize,
            max: MAX_NODES,
        });
    }
    Ok((0..nodes as i64)
        .map(|k| reference + (k_lo + k as f64) * interval)
        .collect())
}

/// The pitch table of linear axis `axis` on the control's grid: nodes `interval_mm` apart
/// through the reference position `reference_mm` (mtcal's axis coordinates), within the
/// stroke; compensations as [`crate::pitch_table`] computes them.
pub fn fanuc_pitch_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    interval_mm: f64,
    reference_mm: f64,
    hold_q: &[f64],
) -> Result<PitchTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let machine = model.machine();
    let (i, lo, hi) = linear_axis(machine, axis)?;
    let what = format!("Fanuc pitch table of axis {axis}");
    let positions_mm = aligned_nodes(axis, (lo * MM, hi * MM), reference_mm, interval_mm, &what)?;
    let mut q = hold_q.to_vec();
    let dir = travel_direction(machine, &q, i);
    let mut ws = model.workspace();
    let forward_um = positions_mm
        .iter()
        .map(|p| {
            q[i] = p / MM;
            -model.pose_error(&q, coeffs, &mut ws).translation.dot(&dir) * UM
        })
        .collect();
    Ok(PitchTable {
        axis,
        positions_mm,
        forward_um,
        reverse_um: None,
        note: held_note(machine, hold_q, i),
    })
}

/// Writes the parameter record and the values table (with the card) of `conversions`,
/// atomically each; returns the card.
pub fn write_fanuc(
    parameter_path: &Path,
    values_path: &Path,
    control: &FanucControl,
    conversions: &[FanucConversion],
    made_from: &[String],
) -> Result<ConventionCard, CompensateError> {
    let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
    let record = fanuc_parameter_text(control, &tables)?;
    let card = ConventionCard {
        made_from: made_from.to_vec(),
        ..fanuc_card(control, conversions)
    };
    write_file(parameter_path, &record)?;
    write_file(values_path, &fanuc_values_csv(control, conversions, &card))?;
    Ok(card)
}
