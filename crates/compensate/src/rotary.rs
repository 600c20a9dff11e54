//! The positioning table of a rotary axis: its angular positioning error about its own axis,
//! the counterpart of the linear axes' pitch tables (`pitch.rs`).
//!
//! At each node the table holds the **compensation** `−e·u` in µrad: `e` is the orientation
//! part of the model's pose error (`log(R·R₀ᵀ)`, workpiece frame) and `u` the unit vector about
//! which a positive command of the axis turns the tool relative to the workpiece on the nominal
//! machine ([`rotation_direction`]). A positive compensation means the axis falls short of the
//! commanded angle and must be commanded further in its positive direction. Every other axis is
//! held at `hold_q`. The nodes run over one revolution, 0…360° both included, for an axis
//! without limits, and over the limits otherwise.
//!
//! mtcal's rotary component errors are Fourier series in the angle and its location errors
//! enter through rotation matrices, so a full-revolution table is periodic: its values at 0°
//! and 360° agree to rounding (tests/suite/fanuc.rs checks it).

use crate::{CompensateError, UM, bracket, check_inputs, lerp, nodes_in};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use nalgebra::Vector3;

/// Degrees in a revolution.
pub(crate) const TURN_DEG: f64 = 360.0;

/// A positioning table of one rotary axis: compensations (µrad, what the controller adds to the
/// command, `−error` about the axis) at ascending angles (degrees).
#[derive(Clone, Debug, PartialEq)]
pub struct RotaryTable {
    /// Axis letter (`C`).
    pub axis: char,
    pub positions_deg: Vec<f64>,
    pub compensation_urad: Vec<f64>,
    /// The nodes cover one full revolution (0…360°, an axis without limits): the first and the
    /// last node are the same physical position.
    pub full_turn: bool,
    /// Comment text for files (machine, held axes); not read back.
    pub note: String,
}

impl RotaryTable {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.positions_deg.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions_deg.is_empty()
    }

    /// Compensation (µrad) at `position_deg`: linear between nodes; on a full-revolution table
    /// any angle (taken modulo 360°), otherwise the end values outside the nodes.
    pub fn correction_at_urad(&self, position_deg: f64) -> f64 {
        let p = if self.full_turn && !self.is_empty() {
            let first = self.positions_deg[0];
            first + (position_deg - first).rem_euclid(TURN_DEG)
        } else {
            position_deg
        };
        lerp(&self.compensation_urad, bracket(&self.positions_deg, p))
    }
}

/// Unit vector (workpiece frame) about which a positive command of rotary axis `axis` (index)
/// turns the tool relative to the workpiece on the nominal machine at positions `q` (SI).
pub fn rotation_direction(machine: &Machine, q: &[f64], axis: usize) -> Vector3<f64> {
    // A turn R1·R0ᵀ = Rot(u, δ) has R − Rᵀ = 2 sin δ [u]×; any δ in (0, π) gives u.
    const STEP_RAD: f64 = 0.5;
    let mut q1 = q.to_vec();
    q1[axis] += STEP_RAD;
    let r = machine.tool_in_workpiece(&q1).r * machine.tool_in_workpiece(q).r.transpose();
    Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    )
    .normalize()
}

/// The positioning table of rotary axis `axis` (letter): compensation `−e·u` (µrad, see the
/// module doc) at nodes `spacing_deg` apart over 0…360° (an axis without limits) or over its
/// limits, the last node at the end; the other axes held at `hold_q` (SI, every axis in
/// canonical order, the table's own entry ignored).
pub fn rotary_table(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    spacing_deg: f64,
    hold_q: &[f64],
) -> Result<RotaryTable, CompensateError> {
    check_inputs(model, coeffs, hold_q)?;
    let (i, lo_deg, hi_deg, full_turn) = rotary_axis(model.machine(), axis)?;
    let what = format!("rotary table of axis {axis}");
    let positions_deg = nodes_in(lo_deg, hi_deg, spacing_deg, &what)?;
    Ok(rotary_table_at(
        model,
        coeffs,
        i,
        positions_deg,
        hold_q,
        full_turn,
    ))
}

/// Index, node range (degrees) and whether it is a full revolution, of rotary axis `letter`.
pub(crate) fn rotary_axis(
    machine: &Machine,
    letter: char,
) -> Result<(usize, f64, f64, bool), CompensateError> {
    let i = machine
        .axis_index(letter)
        .ok_or_else(|| CompensateError::NoSuchAxis {
            letter,
            letters: machine.letters(),
        })?;
    let a = &machine.axes()[i];
    if a.kind() != AxisKind::Rotary {
        return Err(CompensateError::NotRotary { letter });
    }
    Ok(match a.limits() {
        Some((lo, hi)) => (i, lo.to_degrees(), hi.to_degrees(), false),
        None => (i, 0.0, TURN_DEG, true),
    })
}

/// The table of rotary axis `i` (index) at the given nodes (degrees, ascending).
pub(crate) fn rotary_table_at(
    model: &MachineModel,
    coeffs: &[f64],
    i: usize,
    positions_deg: Vec<f64>,
    hold_q: &[f64],
    full_turn: bool,
) -> RotaryTable {
    let machine = model.machine();
    let mut q = hold_q.to_vec();
    let mut ws = model.workspace();
    let compensation_urad = positions_deg
        .iter()
        .map(|p| {
            q[i] = p.to_radians();
            let e = model.pose_error(&q, coeffs, &mut ws);
            -e.rotation.dot(&rotation_direction(machine, &q, i)) * UM
        })
        .collect();
    RotaryTable {
        axis: machine.axes()[i].letter().as_char(),
        positions_deg,
        compensation_urad,
        full_turn,
        note: held_note(machine, hold_q, i),
    }
}

/// `machine: …` and `held: X = … mm, A = … deg` comment text, without axis `skip`.
pub(crate) fn held_note(machine: &Machine, hold_q: &[f64], skip: usize) -> String {
    let held: Vec<String> = machine
        .axes()
        .iter()
        .zip(hold_q)
        .enumerate()
        .filter(|(k, _)| *k != skip)
        .map(|(_, (a, &v))| {
            let letter = a.letter().as_char();
            match a.kind() {
                AxisKind::Rotary => format!("{letter} = {:.6} deg", v.to_degrees()),
                AxisKind::Linear => format!("{letter} = {:.6} mm", v * crate::MM),
            }
        })
        .collect();
    format!("machine: {}\nheld: {}", machine.name(), held.join(", "))
}
