//! LinuxCNC's table-table kinematics (`xyzac-trt-kins`, `xyzbc-trt-kins`): the rotary pivot
//! parameters of an identified machine.
//!
//! These kinematics model a tilting table (A about X, or B about Y) carrying a rotary table (C
//! about Z) by where the two axis lines pass, in LinuxCNC's joint coordinates (at A = C = 0 the
//! workpiece coordinates equal the joint coordinates):
//! - the C line passes through `(x-rot-point, y-rot-point)`;
//! - the A line (xyzac) through `Y = y-rot-point + y-offset`, `Z = z-rot-point + z-offset +
//!   tool-offset`; the B line (xyzbc) through `X = x-rot-point + x-offset`, `Z = z-rot-point +
//!   z-offset + tool-offset`.
//!
//! **Directions**: these kinematics turn the rotary axes the other way from the CNC (ISO 841)
//! convention mtcal follows (LinuxCNC's source says so; later versions add a
//! `conventional-directions` pin): LinuxCNC's A and C are mtcal's negated. The pivots do not
//! depend on it (a line is a line), but an NC program or a joint scale must.
//!
//! mtcal finds each *actual* line (nominal geometry plus the identified errors) as the centre of
//! the circle the tool point describes relative to the workpiece when only that axis turns,
//! and writes `z-offset = 0`, `tool-offset = 0` (mtcal's tool point is the model's; a LinuxCNC
//! tool length adds to `tool-offset` through its own tool table). What these kinematics cannot
//! hold is reported, never dropped silently: the tilts of the axis lines (`EA0C`, `EB0C`,
//! `EB0A`/`EC0A` or `EA0B`/`EC0B`) and every linear-axis error; use the ISG or grid export for
//! them.

use crate::CompensateError;
use mtcal_kinematics::{AxisKind, MachineModel, Side};
use mtcal_machine::card::{ConventionCard, Quantity};
use nalgebra::Vector3;
use std::fmt::Write as _;

/// Which LinuxCNC table-table kinematics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrtKind {
    /// `xyzac-trt-kins`: C on a table tilting about X.
    Xyzac,
    /// `xyzbc-trt-kins`: C on a table tilting about Y.
    Xyzbc,
}

impl TrtKind {
    /// The HAL component name (also the prefix of its pins).
    pub fn name(self) -> &'static str {
        match self {
            TrtKind::Xyzac => "xyzac-trt-kins",
            TrtKind::Xyzbc => "xyzbc-trt-kins",
        }
    }
}

/// The pivot parameters (mm), named after LinuxCNC's HAL pins.
#[derive(Clone, Debug, PartialEq)]
pub struct TrtPivots {
    pub kind: TrtKind,
    pub x_rot_point_mm: f64,
    pub y_rot_point_mm: f64,
    pub z_rot_point_mm: f64,
    /// Used by xyzbc (B line's X minus the C line's X); 0 for xyzac.
    pub x_offset_mm: f64,
    /// Used by xyzac (A line's Y minus the C line's Y); 0 for xyzbc.
    pub y_offset_mm: f64,
    pub z_offset_mm: f64,
    pub tool_offset_mm: f64,
    /// The same parameters of the nominal machine, for comparison.
    pub nominal: Box<Option<TrtPivots>>,
    /// Identified errors these kinematics cannot hold, with their values (µrad or µm).
    pub not_representable: Vec<(String, f64)>,
}

/// Joint positions (SI): linear axes 30 % of the way along their strokes (a point off the
/// rotary axis lines, so the tool point circles about them), rotary axes at 0 but `letter`
/// at `value`.
fn pose(model: &MachineModel, letter: char, value: f64) -> Vec<f64> {
    let m = model.machine();
    let mut q: Vec<f64> = m
        .axes()
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => lo + 0.3 * (hi - lo),
            _ => 0.0,
        })
        .collect();
    if let Some(i) = m.axis_index(letter) {
        q[i] = value;
    }
    q
}

/// The actual tool point in the workpiece frame (m) at `q`.
fn tool_point(model: &MachineModel, coeffs: &[f64], q: &[f64]) -> Vector3<f64> {
    model.tool_pose(q, coeffs, &mut model.workspace()).t
}

/// Centre (2-D) of the circle through three points.
fn circle_centre(p: [[f64; 2]; 3]) -> Option<[f64; 2]> {
    let [a, b, c] = p;
    let d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]));
    if d.abs() < 1e-18 {
        return None;
    }
    let n = |p: [f64; 2]| p[0] * p[0] + p[1] * p[1];
    Some([
        (n(a) * (b[1] - c[1]) + n(b) * (c[1] - a[1]) + n(c) * (a[1] - b[1])) / d,
        (n(a) * (c[0] - b[0]) + n(b) * (a[0] - c[0]) + n(c) * (b[0] - a[0])) / d,
    ])
}

/// Where the line of rotary axis `letter` passes, in the two workpiece-frame coordinates
/// across its direction `plane` (indices), found from three positions of the axis.
fn axis_line(
    model: &MachineModel,
    coeffs: &[f64],
    letter: char,
    plane: [usize; 2],
) -> Result<[f64; 2], CompensateError> {
    let m = model.machine();
    let i = m.axis_index(letter).expect("checked by the caller");
    // Three angles inside the axis' limits, as far apart as they allow (up to 120°).
    let (lo, hi) = m.axes()[i]
        .limits()
        .unwrap_or((-std::f64::consts::PI, std::f64::consts::PI));
    let span = (hi - lo).min(2.0 * std::f64::consts::PI * 2.0 / 3.0);
    let mid = if lo <= 0.0 && hi >= 0.0 {
        0.0
    } else {
        0.5 * (lo + hi)
    };
    let (a0, a1) = ((mid - 0.5 * span).max(lo), (mid + 0.5 * span).min(hi));
    let angles = [a0, 0.5 * (a0 + a1), a1];
    let pts = angles.map(|v| {
        let p = tool_point(model, coeffs, &pose(model, letter, v));
        [p[plane[0]], p[plane[1]]]
    });
    let centre = circle_centre(pts);
    match centre {
        // A radius under 1 mm leaves the centre to rounding.
        Some(c) if (c[0] - pts[0][0]).hypot(c[1] - pts[0][1]) > 1e-3 => Ok(c),
        _ => Err(CompensateError::Model {
            message: format!(
                "axis {letter}: the tool point passes within 1 mm of its line at the chosen pose; \
                 its pivot cannot be found from it"
            ),
        }),
    }
}

/// The pivot parameters of a table-table machine with rotary axes C on A (xyzac) or C on B
/// (xyzbc), both on the workpiece side, for coefficients `coeffs`.
pub fn trt_pivots(model: &MachineModel, coeffs: &[f64]) -> Result<TrtPivots, CompensateError> {
    if coeffs.len() != model.n_coeffs() {
        return Err(CompensateError::CoeffsLength {
            got: coeffs.len(),
            expected: model.n_coeffs(),
        });
    }
    let m = model.machine();
    let rotary: Vec<_> = m
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Rotary)
        .collect();
    let letters: String = rotary.iter().map(|a| a.letter().as_char()).collect();
    let kind = match letters.as_str() {
        "CA" | "AC" => TrtKind::Xyzac,
        "CB" | "BC" => TrtKind::Xyzbc,
        _ => {
            return Err(CompensateError::Model {
                message: format!(
                    "LinuxCNC's table-table kinematics need rotary axes A and C or B and C; the \
                     machine has {}",
                    if letters.is_empty() {
                        "none".to_string()
                    } else {
                        letters
                    }
                ),
            });
        }
    };
    if rotary.iter().any(|a| a.side() != Side::Workpiece) {
        return Err(CompensateError::Model {
            message: "LinuxCNC's table-table kinematics need both rotary axes on the table \
                      (workpiece side)"
                .to_string(),
        });
    }
    // Joint coordinates = workpiece coordinates minus the nominal tool point at the zero pose.
    let origin = m.tool_in_workpiece(&vec![0.0; m.n_axes()]).t;
    let c = axis_line(model, coeffs, 'C', [0, 1])?;
    let (xr, yr) = ((c[0] - origin[0]) * 1e3, (c[1] - origin[1]) * 1e3);
    let mut p = TrtPivots {
        kind,
        x_rot_point_mm: xr,
        y_rot_point_mm: yr,
        z_rot_point_mm: 0.0,
        x_offset_mm: 0.0,
        y_offset_mm: 0.0,
        z_offset_mm: 0.0,
        tool_offset_mm: 0.0,
        nominal: Box::new(None),
        not_representable: Vec::new(),
    };
    match kind {
        TrtKind::Xyzac => {
            let a = axis_line(model, coeffs, 'A', [1, 2])?;
            p.y_offset_mm = (a[0] - origin[1]) * 1e3 - yr;
            p.z_rot_point_mm = (a[1] - origin[2]) * 1e3;
        }
        TrtKind::Xyzbc => {
            let b = axis_line(model, coeffs, 'B', [0, 2])?;
            p.x_offset_mm = (b[0] - origin[0]) * 1e3 - xr;
            p.z_rot_point_mm = (b[1] - origin[2]) * 1e3;
        }
    }
    p.not_representable = not_representable(model, coeffs, kind);
    Ok(p)
}

/// The same, plus the nominal machine's parameters for comparison.
pub fn trt_pivots_with_nominal(
    model: &MachineModel,
    coeffs: &[f64],
) -> Result<TrtPivots, CompensateError> {
    let mut p = trt_pivots(model, coeffs)?;
    let nominal = trt_pivots(model, &vec![0.0; model.n_coeffs()])?;
    p.nominal = Box::new(Some(nominal));
    Ok(p)
}

/// The identified errors with a nonzero value that the pivots cannot hold: location errors
/// other than the line positions the pivots carry, and every component error.
fn not_representable(model: &MachineModel, coeffs: &[f64], kind: TrtKind) -> Vec<(String, f64)> {
    use mtcal_kinematics::model::Role;
    let held = match kind {
        TrtKind::Xyzac => ["EX0C", "EY0C", "EY0A", "EZ0A"],
        TrtKind::Xyzbc => ["EX0C", "EY0C", "EX0B", "EZ0B"],
    };
    let mut out = Vec::new();
    for p in model.errors().params() {
        let name = p.name.to_string();
        let c = &coeffs[p.offset..p.offset + p.len];
        let size = c.iter().fold(0.0f64, |m, v| m.max(v.abs())) * 1e6;
        let skip = match p.role {
            Role::Location { .. } => held.contains(&name.as_str()),
            Role::ToolOffset(_) | Role::WorkpieceOffset(_) => true,
            Role::Component { .. } => false,
        };
        if !skip && size > 0.0 {
            out.push((name, size));
        }
    }
    out
}

/// The HAL commands that set the pivots (`setp <kins>.<pin> value`), with comments.
pub fn trt_hal_text(p: &TrtPivots, machine_name: &str) -> String {
    let k = p.kind.name();
    let mut t = format!(
        "# mtcal: rotary pivot parameters of LinuxCNC's {k} for machine {machine_name}\n\
         # mm, in joint coordinates (at A/B = C = 0 the workpiece coordinates equal the joint\n\
         # coordinates). tool-offset 0: mtcal's tool point; LinuxCNC's tool table adds its own.\n\
         # These kinematics turn A/B and C the other way from mtcal's (ISO 841) convention.\n"
    );
    if let Some(n) = p.nominal.as_ref() {
        let _ = writeln!(
            t,
            "# nominal: x-rot-point {:.6} y-rot-point {:.6} z-rot-point {:.6} x-offset {:.6} \
             y-offset {:.6}",
            n.x_rot_point_mm, n.y_rot_point_mm, n.z_rot_point_mm, n.x_offset_mm, n.y_offset_mm
        );
    }
    if !p.not_representable.is_empty() {
        let list: Vec<String> = p
            .not_representable
            .iter()
            .map(|(n, v)| format!("{n} ({v:.3})"))
            .collect();
        let _ = writeln!(
            t,
            "# not held by these kinematics (largest coefficient, um or urad): {}",
            list.join(", ")
        );
    }
    for (pin, v) in [
        ("x-rot-point", p.x_rot_point_mm),
        ("y-rot-point", p.y_rot_point_mm),
        ("z-rot-point", p.z_rot_point_mm),
        ("x-offset", p.x_offset_mm),
        ("y-offset", p.y_offset_mm),
        ("z-offset", p.z_offset_mm),
        ("tool-offset", p.tool_offset_mm),
    ] {
        let _ = writeln!(t, "setp {k}.{pin} {v:.6}");
    }
    t
}

/// The card of LinuxCNC's table-table pivots.
pub(crate) fn card(
    machine: &mtcal_kinematics::Machine,
    kinematics: &str,
    not_representable: usize,
) -> ConventionCard {
    ConventionCard {
        made_from: Vec::new(),
        format: format!("LinuxCNC HAL settings of {kinematics}"),
        quantity: Quantity::Geometry,
        sign: "pivot points of the actual rotary axis lines in joint coordinates".into(),
        squareness: "not held: the kinematics have no squareness".into(),
        rotary_direction: "LinuxCNC's trt kinematics turn A/B and C the other way from ISO 841"
            .into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "mm".into(),
        control_will: vec![
            "take the setp lines after the kinematics component is loaded in the HAL file".into(),
            format!(
                "ignore the {not_representable} identified errors these kinematics cannot hold \
                 (listed in the file)"
            ),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circle_centre_of_three_points() {
        let c = circle_centre([[3.0, 2.0], [1.0, 4.0], [-1.0, 2.0]]).unwrap();
        assert!((c[0] - 1.0).abs() < 1e-12 && (c[1] - 2.0).abs() < 1e-12);
        assert!(circle_centre([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_none());
    }
}
