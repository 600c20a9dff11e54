//! SINUMERIK 840D sl five-axis kinematic data for CYCLE800: the swivel data record (the
//! "orientable toolholder", system variables `$TC_CARR1[n]` … `$TC_CARR36[n]`) of an
//! identified machine with two rotary axes.
//!
//! # What the control does with the data (sources)
//! Read from the SINUMERIK 840D sl Commissioning Manual "SINUMERIK Operate (IM9)" (03/2013,
//! p. 508 "Offset vectors I1 to I4", p. 581 "CYCLE800 checklist for the identification of the
//! machine kinematics"), the Function Manual "Tool Compensation (W1)", section "Toolholder with
//! orientation capability" (08/2005: description of a rotation, the kinematic chain of a
//! rotary head, the system variables $TC_CARR1 … $TC_CARR65 and example 4.1), and the
//! Programming Manual's list of system variables ($TC_CARR21/22 are of type AXIS, $TC_CARR23 is
//! a CHAR `T`, `P` or `M`):
//!
//! - **Kinematics type** (`$TC_CARR23`): `T` swivel head (both rotary axes move the tool),
//!   `P` swivel table (both move the workpiece), `M` mixed (rotary axis 1 moves the tool,
//!   rotary axis 2 the workpiece: "with mixed kinematics, rotary axis 1 is always the axis for
//!   the tool orientation"). "Rotary axis 2 is based on rotary axis 1": axis 1 is the one
//!   nearer the machine base, axis 2 the one it carries.
//! - **Offset vectors** I1 … I4 (`$TC_CARR1..3`, `4..6`, `15..17`, `18..20`), mm, in machine
//!   X/Y/Z with the rotary axes at 0 (p. 508):
//!   - swivel head: I3 from the tool adapter (tool reference point) to the pivot of rotary
//!     axis 2, I2 from there to the pivot of rotary axis 1, I1 = −(I2 + I3) closes the chain;
//!   - swivel table: I2 from the machine reference point to the pivot of rotary axis 1, I3
//!     from there to the pivot of rotary axis 2, I4 = −(I2 + I3) closes the chain;
//!   - mixed: I2 from the tool adapter to the pivot of rotary axis 1, I1 = −I2; I3 from the
//!     machine reference point to the pivot of rotary axis 2, I4 = −I3.
//!
//!   A "pivot" may be any point of the axis line (a turn about a line is the same whichever
//!   of its points the chain passes through); mtcal takes the point of the actual line
//!   nearest to where the machine's URDF places the joint.
//! - **Rotary axis vectors** V1, V2 (`$TC_CARR7..9`, `10..12`): the direction of each axis at
//!   the initial setting. W1: "the angle of rotation is counted positively for clockwise
//!   rotation facing the direction of the rotation vector", a right-handed turn of the moving
//!   body about V. Checklist (p. 581): "if the linear axis or the rotary axis moves the
//!   workpiece, the direction of motion of the axis and also the sign of the rotary axis vector
//!   change" — a table A axis has V = (−1, 0, 0), a head B axis V = (0, 1, 0). W1's own example
//!   uses V2 = (−1, 0, 1): the control takes the direction only, so the manual's rule is "not
//!   zero"; mtcal writes unit vectors.
//! - **How the chain is applied** (W1's chain for a head; p. 508's for a table), angles α1, α2
//!   the positions of the axes named in `$TC_CARR21/22`, `R(v, α)` the right-handed rotation:
//!   - the tool: resulting tool length `L = I1 + R1·(I2 + R2·(I3 + t))` (`t` the tool's own
//!     length vector, "positive from the tool tip to the reference point"); the tool tip is
//!     the tool reference point's machine position minus `L`;
//!   - the table: a workpiece point `w` (machine coordinates, axes at 0) goes to
//!     `I2 + R1·(I3 + R2·(I4 + w))` (type P) or `I3 + R2·(I4 + w)` (type M), from the machine
//!     reference point.
//!
//!   With a closed chain both are the identity at α = 0 and turn the tool or the table about
//!   the two axis lines, axis 2 first, as the machine does.
//!
//!   `controllers.md` says "the chain must close"; the manual states it per type (head
//!   I1 + I2 + I3 = 0, table I2 + I3 + I4 = 0, mixed I1 + I2 = 0 and I3 + I4 = 0), and that
//!   is what is written and validated; the vector a type does not use (I1 of a table, I4 of a
//!   head) is written 0.
//!
//! # What mtcal writes
//! [`carr_data`] finds each rotary axis' *actual* line (nominal geometry plus the identified
//! location errors across its direction: `EX0C`, `EY0C` its position, `EA0C`, `EB0C` its tilt)
//! as the screw axis of the tool pose change the model gives when only that axis turns (for
//! location errors that is an exact rotation). Positions go into the offset vectors, tilts into
//! V1/V2; the chain is closed by construction. Conventions:
//! - **Machine coordinates**: the directions in which X, Y, Z move the tool relative to the
//!   workpiece (orthogonal in the nominal model, or the machine is refused: checklist item
//!   one); origin, the "machine reference point", where mtcal's tool point is with every axis
//!   at 0 (mtcal's axis zeros must be the control's, as for LinuxCNC's pivots).
//! - **Tool reference point**: mtcal's tool point with the set-up offsets `TOOL_*` left out.
//!   The control's tool lengths (`$TC_DP…`) count from it; if the control's tool reference
//!   point (usually the spindle gauge line) is elsewhere, I3 (T) or I2 (M) and the closing
//!   vector change by that distance.
//! - **What `$TC_CARR` cannot hold** is listed in the file's comments, the card and
//!   [`CarrData::not_representable`], never dropped silently: every component error, the
//!   squareness and other direction errors of the linear axes (CYCLE800 assumes orthogonal
//!   linear axes), a rotary axis' own-direction location errors (`EZ0C`, `EC0C`: the constants
//!   of its axial and angular positioning errors), and the set-up offsets `TOOL_*`, `WP_*` (they
//!   belong to the tool and work offset data). Use the EEC/CEC tables or a volumetric
//!   compensation for the rest.
//! - **Other fields** written: `$TC_CARR21/22` and `35/36` the rotary axes' channel names
//!   (mtcal's letters), `$TC_CARR23` the type, `$TC_CARR24/25 = 0` (the vectors describe the
//!   axes at position 0), `$TC_CARR30..33` the angular ranges in degrees (0 and 0 for an axis
//!   without limits: W1 "these limits are not evaluated if both the minimum and maximum value
//!   is zero"), `$TC_CARR34` the record's name. Not written, left as commissioned: the angles
//!   `$TC_CARR13/14` (unused when 21/22 name axes), the Hirth settings 26–29, CYCLE800's
//!   screen and retraction settings 37–40 and the fine offsets 41–65 (which add to these values
//!   when SD42974 `$SC_TOCARR_FINE_CORRECTION` = 1: they must be zero).
//!
//! # The file
//! A part program, ASCII: `;` comments (the header and the convention card), one assignment
//! `$TC_CARRk[n]=value` per line with a `;` comment naming it, and `M30` (the end of a main
//! program, as in W1's example 4.1). Offsets with 6 decimals (1 nm), vectors with 9, angles in
//! degrees with 6. Record number `n` ≥ 1: `$TC_CARRk[0]` addresses every record
//! (`$TC_CARR1[0] = 0` clears them all).
//!
//! *Assumptions* (no source found): the part-program file needs no `%_N_…_MPF` header when
//! loaded through the program manager, so none is written; names are limited to the 32
//! characters of W1's `String[32]`.
//!
//! [`read_carr`] reads such a file back (block numbers `N…`, blanks around `=` and several
//! assignments per line are accepted, as in W1's examples); comments, and with them the
//! nominal values and the list of errors not held, are not read back.

use crate::text::Source;
use crate::{CompensateError, read_file, write_file};
use mtcal_kinematics::model::Role;
use mtcal_kinematics::rigid::log_so3;
use mtcal_kinematics::{AxisKind, Machine, MachineModel, Rigid, Side};
use mtcal_machine::card::{AxisMap, ConventionCard, Quantity, ascii};
use nalgebra::{Matrix3, Vector3};
use std::fmt::Write as _;
use std::path::Path;

/// The kinematics type, `$TC_CARR23`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CarrKind {
    /// `T`: swivel head, both rotary axes move the tool.
    Tool,
    /// `P`: swivel table, both rotary axes move the workpiece ("part").
    Part,
    /// `M`: mixed, rotary axis 1 moves the tool, rotary axis 2 the workpiece.
    Mixed,
}

impl CarrKind {
    /// The letter the control reads.
    pub fn letter(self) -> char {
        match self {
            CarrKind::Tool => 'T',
            CarrKind::Part => 'P',
            CarrKind::Mixed => 'M',
        }
    }

    /// The type of letter `c` (either case, as the manual allows).
    pub fn from_letter(c: char) -> Option<Self> {
        match c.to_ascii_uppercase() {
            'T' => Some(CarrKind::Tool),
            'P' => Some(CarrKind::Part),
            'M' => Some(CarrKind::Mixed),
            _ => None,
        }
    }

    /// In the manual's words.
    pub fn describe(self) -> &'static str {
        match self {
            CarrKind::Tool => "swivel head",
            CarrKind::Part => "swivel table",
            CarrKind::Mixed => "swivel head and rotary table (mixed)",
        }
    }

    /// Whether rotary axis `index` (0 or 1) moves the tool (else the workpiece).
    pub fn moves_tool(self, index: usize) -> bool {
        match self {
            CarrKind::Tool => true,
            CarrKind::Part => false,
            CarrKind::Mixed => index == 0,
        }
    }
}

/// One swivel data record as CYCLE800 reads it (mm, unit vectors, degrees).
#[derive(Clone, Debug, PartialEq)]
pub struct CarrData {
    /// The record number `n` of `$TC_CARRk[n]`, 1 or more.
    pub number: u32,
    /// `$TC_CARR34`: the record's name.
    pub name: String,
    /// `$TC_CARR23`.
    pub kind: CarrKind,
    /// I1, I2, I3, I4 (mm, machine X/Y/Z): `$TC_CARR1..3`, `4..6`, `15..17`, `18..20`.
    pub offsets_mm: [[f64; 3]; 4],
    /// V1, V2: `$TC_CARR7..9`, `10..12`.
    pub axis_vectors: [[f64; 3]; 2],
    /// Channel names of rotary axes 1 and 2: `$TC_CARR21/22` and `35/36`.
    pub axes: [String; 2],
    /// Angular range (min, max) of rotary axes 1 and 2, degrees: `$TC_CARR30/32`, `31/33`;
    /// (0, 0) is "not evaluated".
    pub limits_deg: [(f64, f64); 2],
    /// The same record of the nominal machine, for comparison (`None` when read from a file).
    pub nominal: Option<Box<CarrData>>,
    /// Identified errors with a nonzero value that the record does not hold, with their largest
    /// coefficient (µm or µrad). Empty when read from a file.
    pub not_representable: Vec<(String, f64)>,
}

/// Largest offset component accepted, mm: a larger one is a unit mistake (µm or inch read as mm).
pub const CARR_MAX_OFFSET_MM: f64 = 10_000.0;
/// How far the offset chain may be from closed, mm (the file's values have 6 decimals).
pub const CARR_CHAIN_TOL_MM: f64 = 1e-5;
/// Longest name: W1 gives `$TC_CARR34..36` as `String[32]`.
pub const CARR_MAX_NAME: usize = 32;

/// Why a swivel data record would be refused or misread by the control.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CarrError {
    #[error(
        "data record number 0: $TC_CARRk[0] addresses every record ($TC_CARR1[0]=0 clears them \
         all); use 1 or more"
    )]
    RecordZero,
    #[error("{what} is not finite")]
    NotFinite { what: String, field: u32 },
    #[error(
        "{what} = {value_mm} mm is larger than {max_mm} mm: an offset that large is a unit \
         mistake (µm or inch given as mm?)"
    )]
    Implausible {
        what: String,
        value_mm: f64,
        max_mm: f64,
        field: u32,
    },
    #[error(
        "kinematics {kind}: the offset chain does not close, {sum} = ({x_mm:.6}, {y_mm:.6}, {z_mm:.6}) mm; \
         the manual (IM9 p. 508) closes it with {rule}"
    )]
    ChainOpen {
        kind: char,
        sum: &'static str,
        x_mm: f64,
        y_mm: f64,
        z_mm: f64,
        rule: &'static str,
        field: u32,
    },
    #[error(
        "kinematics {kind}: {vector} has no part in this kinematics and must be 0, found {found}"
    )]
    Unused {
        kind: char,
        vector: &'static str,
        found: String,
        field: u32,
    },
    #[error("rotary axis vector {vector} is zero: the axis would not turn anything")]
    ZeroVector { vector: &'static str, field: u32 },
    #[error(
        "rotary axis vector {vector} of {axis} ({body} axis) has {component} {value}: the \
         CYCLE800 checklist turns a {body} axis about {expected} (the vector's sign flips when \
         the axis moves the workpiece)"
    )]
    VectorSign {
        vector: &'static str,
        axis: String,
        body: &'static str,
        component: char,
        value: f64,
        expected: String,
        field: u32,
    },
    #[error("angular range of rotary axis {axis}: minimum {min_deg}° is above maximum {max_deg}°")]
    BadRange {
        axis: String,
        min_deg: f64,
        max_deg: f64,
        field: u32,
    },
    #[error(
        "{what} `{name}`: {why}; a name is 1 to {CARR_MAX_NAME} ASCII characters without `\"` or `;`"
    )]
    BadName {
        what: &'static str,
        name: String,
        why: &'static str,
        field: u32,
    },
}

impl CarrError {
    /// The `$TC_CARR` number the problem is in (for a located message when reading).
    pub fn field(&self) -> u32 {
        match self {
            CarrError::RecordZero => 1,
            CarrError::NotFinite { field, .. }
            | CarrError::Implausible { field, .. }
            | CarrError::ChainOpen { field, .. }
            | CarrError::Unused { field, .. }
            | CarrError::ZeroVector { field, .. }
            | CarrError::VectorSign { field, .. }
            | CarrError::BadRange { field, .. }
            | CarrError::BadName { field, .. } => *field,
        }
    }
}

/// First `$TC_CARR` number of each offset vector I1..I4.
const OFFSET_FIELDS: [u32; 4] = [1, 4, 15, 18];
/// First `$TC_CARR` number of V1, V2.
const VECTOR_FIELDS: [u32; 2] = [7, 10];
const OFFSET_NAMES: [&str; 4] = ["I1", "I2", "I3", "I4"];
const VECTOR_NAMES: [&str; 2] = ["V1", "V2"];

impl CarrData {
    /// Checks what the control would refuse or misread: the record number, finite and
    /// plausible values, a closed chain, unused vectors zero, axis vectors not zero and signed
    /// by the checklist's rule for the kinematics type, angular ranges, names.
    pub fn validate(&self) -> Result<(), CarrError> {
        if self.number == 0 {
            return Err(CarrError::RecordZero);
        }
        check_name("record name ($TC_CARR34)", &self.name, 34, true)?;
        for (k, axis) in self.axes.iter().enumerate() {
            check_axis_name(axis, 21 + k as u32)?;
        }
        for (k, v) in self.offsets_mm.iter().enumerate() {
            for (c, &value_mm) in v.iter().enumerate() {
                let field = OFFSET_FIELDS[k] + c as u32;
                let what = format!("{} {} ($TC_CARR{field})", OFFSET_NAMES[k], xyz(c));
                if !value_mm.is_finite() {
                    return Err(CarrError::NotFinite { what, field });
                }
                if value_mm.abs() > CARR_MAX_OFFSET_MM {
                    return Err(CarrError::Implausible {
                        what,
                        value_mm,
                        max_mm: CARR_MAX_OFFSET_MM,
                        field,
                    });
                }
            }
        }
        self.check_chain()?;
        for k in 0..2 {
            self.check_vector(k)?;
            let (min_deg, max_deg) = self.limits_deg[k];
            let field = 30 + k as u32;
            if !(min_deg.is_finite() && max_deg.is_finite()) {
                let what = format!("angular range of rotary axis {}", self.axes[k]);
                return Err(CarrError::NotFinite { what, field });
            }
            if min_deg > max_deg {
                let axis = self.axes[k].clone();
                return Err(CarrError::BadRange {
                    axis,
                    min_deg,
                    max_deg,
                    field,
                });
            }
        }
        Ok(())
    }

    /// The closure rule of the type (p. 508) and that the vectors it does not use are zero.
    fn check_chain(&self) -> Result<(), CarrError> {
        let i = |k: usize| Vector3::from(self.offsets_mm[k]);
        let kind = self.kind.letter();
        let closed = |sum: Vector3<f64>, name, rule, field| {
            if sum.amax() <= CARR_CHAIN_TOL_MM {
                return Ok(());
            }
            Err(CarrError::ChainOpen {
                kind,
                sum: name,
                x_mm: sum.x,
                y_mm: sum.y,
                z_mm: sum.z,
                rule,
                field,
            })
        };
        let unused = |k: usize| {
            if i(k).amax() <= CARR_CHAIN_TOL_MM {
                return Ok(());
            }
            Err(CarrError::Unused {
                kind,
                vector: OFFSET_NAMES[k],
                found: vector_text(&self.offsets_mm[k], 6),
                field: OFFSET_FIELDS[k],
            })
        };
        match self.kind {
            CarrKind::Tool => {
                unused(3)?;
                closed(i(0) + i(1) + i(2), "I1 + I2 + I3", "I1 = -(I2 + I3)", 1)
            }
            CarrKind::Part => {
                unused(0)?;
                closed(i(1) + i(2) + i(3), "I2 + I3 + I4", "I4 = -(I2 + I3)", 18)
            }
            CarrKind::Mixed => {
                closed(i(0) + i(1), "I1 + I2", "I1 = -I2", 1)?;
                closed(i(2) + i(3), "I3 + I4", "I4 = -I3", 18)
            }
        }
    }

    /// V{k+1}: finite, not zero, and along +axis for a head axis, −axis for a table axis when
    /// the axis is named A, B or C (the checklist's rule).
    fn check_vector(&self, k: usize) -> Result<(), CarrError> {
        let v = Vector3::from(self.axis_vectors[k]);
        let field = VECTOR_FIELDS[k];
        let vector = VECTOR_NAMES[k];
        if !v.iter().all(|c| c.is_finite()) {
            let what = format!("rotary axis vector {vector}");
            return Err(CarrError::NotFinite { what, field });
        }
        if v.norm() < 1e-6 {
            return Err(CarrError::ZeroVector { vector, field });
        }
        let Some(c) = rotary_cartesian(&self.axes[k]) else {
            return Ok(());
        };
        let tool = self.kind.moves_tool(k);
        let sign = if tool { 1.0 } else { -1.0 };
        if v[c] * sign > 0.0 {
            return Ok(());
        }
        Err(CarrError::VectorSign {
            vector,
            axis: self.axes[k].clone(),
            body: if tool { "head" } else { "table" },
            component: xyz(c),
            value: v[c],
            expected: format!("{}{}", if tool { '+' } else { '-' }, xyz(c)),
            field: field + c as u32,
        })
    }
}

/// 'X', 'Y', 'Z' for 0, 1, 2.
fn xyz(c: usize) -> char {
    ['X', 'Y', 'Z'][c]
}

/// The Cartesian direction an axis named A, B or C turns about (ISO 841), if it is so named.
fn rotary_cartesian(name: &str) -> Option<usize> {
    match name {
        "A" => Some(0),
        "B" => Some(1),
        "C" => Some(2),
        _ => None,
    }
}

fn check_name(what: &'static str, name: &str, field: u32, quoted: bool) -> Result<(), CarrError> {
    let why = if name.is_empty() {
        Some("empty")
    } else if name.chars().count() > CARR_MAX_NAME {
        Some("too long")
    } else if !name.chars().all(|c| c.is_ascii() && !c.is_ascii_control()) {
        Some("not printable ASCII")
    } else if quoted && name.contains(['"', ';']) {
        Some("holds `\"` or `;`, which end the string or start a comment")
    } else {
        None
    };
    match why {
        None => Ok(()),
        Some(why) => Err(CarrError::BadName {
            what,
            name: name.to_string(),
            why,
            field,
        }),
    }
}

/// An axis identifier (type AXIS): a letter, then letters, digits or `_`.
fn check_axis_name(name: &str, field: u32) -> Result<(), CarrError> {
    check_name("rotary axis name", name, field, false)?;
    let mut chars = name.chars();
    let first_ok = chars.next().is_some_and(|c| c.is_ascii_alphabetic());
    if first_ok && chars.all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Ok(());
    }
    Err(CarrError::BadName {
        what: "rotary axis name",
        name: name.to_string(),
        why: "not an axis identifier (a letter, then letters, digits or `_`)",
        field,
    })
}

fn vector_text(v: &[f64; 3], decimals: usize) -> String {
    format!("({:.d$}, {:.d$}, {:.d$})", v[0], v[1], v[2], d = decimals)
}

/// `x` rounded to `decimals` decimals, without a negative zero.
fn rounded(x: f64, decimals: i32) -> f64 {
    let s = 10f64.powi(decimals);
    (x * s).round() / s + 0.0
}

// --- From the model ------------------------------------------------------------------------

/// The angle each rotary axis is turned by to find its line (rad): far from 0 and π, where the
/// screw axis is well conditioned.
const PROBE_ANGLE: f64 = 1.0;

/// The two rotary axes of a machine CYCLE800 can describe, in CYCLE800's order.
struct Structure {
    kind: CarrKind,
    /// Indices into `Machine::axes` of rotary axes 1 and 2.
    rotary: [usize; 2],
}

fn refuse(message: impl Into<String>) -> CompensateError {
    CompensateError::CannotDescribe {
        format: "CYCLE800's swivel data ($TC_CARR)",
        message: message.into(),
    }
}

/// Which kinematics type the machine has and which axis is rotary axis 1, or why `$TC_CARR`
/// cannot describe it.
fn structure(machine: &Machine) -> Result<Structure, CompensateError> {
    let linear: String = machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .map(|a| a.letter().as_char())
        .collect();
    if linear != "XYZ" {
        return Err(refuse(format!(
            "they need linear axes X, Y and Z (the geometry axes); the machine has {}",
            if linear.is_empty() { "none" } else { &linear }
        )));
    }
    let mut per_side: [Vec<usize>; 2] = [Vec::new(), Vec::new()];
    for (k, side) in [Side::Tool, Side::Workpiece].into_iter().enumerate() {
        let mut seen_rotary = None;
        for &i in machine.branch(side).joints() {
            let axis = &machine.axes()[i];
            match (axis.kind(), seen_rotary) {
                (AxisKind::Rotary, _) => {
                    seen_rotary = Some(axis.letter().as_char());
                    per_side[k].push(i);
                }
                (AxisKind::Linear, Some(r)) => {
                    return Err(refuse(format!(
                        "rotary axis {r} carries linear axis {}: the data turn the head or \
                         table about lines fixed in the machine coordinates, so every rotary \
                         axis must sit beyond the linear axes of its branch",
                        axis.letter()
                    )));
                }
                (AxisKind::Linear, None) => {}
            }
        }
    }
    let [tool, work] = per_side;
    let (kind, rotary) = match (tool.as_slice(), work.as_slice()) {
        (&[a, b], &[]) => (CarrKind::Tool, [a, b]),
        (&[], &[a, b]) => (CarrKind::Part, [a, b]),
        (&[a], &[b]) => (CarrKind::Mixed, [a, b]),
        _ => {
            let letters: String = machine
                .axes()
                .iter()
                .filter(|a| a.kind() == AxisKind::Rotary)
                .map(|a| a.letter().as_char())
                .collect();
            return Err(refuse(format!(
                "they describe two rotary axes (two in the head, two in the table, or one \
                 in each); the machine has {}",
                if letters.is_empty() {
                    "none".to_string()
                } else {
                    format!("{} ({letters})", letters.len())
                }
            )));
        }
    };
    Ok(Structure { kind, rotary })
}

/// The machine coordinate system in the workpiece frame: its origin (mtcal's tool point with
/// every axis at 0) and the directions in which X, Y, Z move the tool relative to the
/// workpiece (columns), which must be orthonormal and right-handed.
fn machine_coordinates(machine: &Machine) -> Result<(Vector3<f64>, Matrix3<f64>), CompensateError> {
    let zero = vec![0.0; machine.n_axes()];
    let origin = machine.tool_in_workpiece(&zero).t;
    let mut r = Matrix3::zeros();
    for (c, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let mut q = zero.clone();
        q[machine.axis_index(letter).expect("checked: X, Y, Z exist")] = 1.0;
        r.set_column(c, &(machine.tool_in_workpiece(&q).t - origin));
    }
    let orthonormal = (r.transpose() * r - Matrix3::identity()).amax() < 1e-9;
    if !orthonormal || r.determinant() < 0.0 {
        return Err(refuse(
            "the nominal linear axes X, Y, Z do not form a right-handed orthogonal system, \
             which CYCLE800 needs (checklist, IM9 p. 581)",
        ));
    }
    Ok((origin, r))
}

/// The coefficients `$TC_CARR` holds: the rotary axes' location errors across their own
/// direction. Everything else is 0.
fn held_coefficients(model: &MachineModel, coeffs: &[f64]) -> Vec<f64> {
    let mut held = vec![0.0; coeffs.len()];
    for p in model.errors().params() {
        if is_held(model.machine(), &p.role) {
            held[p.offset..p.offset + p.len].copy_from_slice(&coeffs[p.offset..p.offset + p.len]);
        }
    }
    held
}

fn is_held(machine: &Machine, role: &Role) -> bool {
    match *role {
        Role::Location { axis, direction } => {
            let a = &machine.axes()[axis];
            a.kind() == AxisKind::Rotary && direction.cartesian() != a.own_cartesian()
        }
        _ => false,
    }
}

/// The identified errors with a nonzero value that the record does not hold.
fn not_representable(model: &MachineModel, coeffs: &[f64]) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for p in model.errors().params() {
        let c = &coeffs[p.offset..p.offset + p.len];
        let size = c.iter().fold(0.0f64, |m, v| m.max(v.abs())) * 1e6;
        if !is_held(model.machine(), &p.role) && size > 0.0 {
            out.push((p.name.to_string(), size));
        }
    }
    out
}

/// The line of rotary axis `i` (a point and the unit vector about which a positive position
/// turns the moving body right-handed), in the workpiece frame with every axis at 0, for
/// coefficients `c` holding location errors only: the screw axis of the tool pose's change
/// when axis `i` alone turns by [`PROBE_ANGLE`]. A tool-side axis turns the tool pose about
/// its line by +θ; a workpiece-side axis turns the workpiece, so the tool pose by −θ.
fn axis_line(
    model: &MachineModel,
    c: &[f64],
    i: usize,
) -> Result<(Vector3<f64>, Vector3<f64>), CompensateError> {
    let m = model.machine();
    let mut ws = model.workspace();
    let q0 = vec![0.0; m.n_axes()];
    let mut q1 = q0.clone();
    q1[i] = PROBE_ANGLE;
    let before = model.tool_pose(&q0, c, &mut ws);
    let after = model.tool_pose(&q1, c, &mut ws);
    let change = after.compose(&before.inverse());
    let (point, u, angle) = screw(&change);
    let letter = m.axes()[i].letter();
    let along_mm = u.dot(&change.t) * 1e3;
    if (angle - PROBE_ANGLE).abs() > 1e-9 || along_mm.abs() > 1e-9 {
        return Err(refuse(format!(
            "axis {letter}: turning it by {PROBE_ANGLE} rad turns the tool pose by {angle} rad \
             and shifts it {along_mm} mm along the axis; the model's rotary axis is not a plain \
             rotation"
        )));
    }
    let sign = match m.axes()[i].side() {
        Side::Tool => 1.0,
        Side::Workpiece => -1.0,
    };
    Ok((point, u * sign))
}

/// The screw axis of a rotation `x ↦ R·x + t` about a line: the line's point nearest the
/// origin, its unit direction and the angle (in (0, π)). `t` along the line is ignored (the
/// caller checks it).
fn screw(motion: &Rigid) -> (Vector3<f64>, Vector3<f64>, f64) {
    let w = log_so3(&motion.r);
    let angle = w.norm();
    let u = w / angle;
    let t = motion.t - u * u.dot(&motion.t);
    // (I − R)·c = t for c ⊥ u: c = (t + cot(φ/2)·u × t) / 2.
    let point = 0.5 * (t + u.cross(&t) / (0.5 * angle).tan());
    (point, u, angle)
}

/// Where axis `i`'s joint frame sits with every axis at 0, in the workpiece frame: the point
/// the URDF makes its pivot.
fn joint_origin(machine: &Machine, i: usize) -> Vector3<f64> {
    let zero = vec![0.0; machine.n_axes()];
    let side = machine.axes()[i].side();
    let mut t = Rigid::IDENTITY;
    for &j in machine.branch(side).joints() {
        t = t.compose(machine.axes()[j].origin());
        if j == i {
            break;
        }
    }
    let f_t_w = machine.branch_pose(Side::Workpiece, &zero);
    f_t_w.inverse().apply(&t.t)
}

/// The record for the location errors in `held` (pivots in machine coordinates, mm).
fn record(
    model: &MachineModel,
    held: &[f64],
    s: &Structure,
    number: u32,
    name: &str,
) -> Result<CarrData, CompensateError> {
    let m = model.machine();
    let (origin, r_mcs) = machine_coordinates(m)?;
    let to_mcs = |v: Vector3<f64>| r_mcs.transpose() * v;
    let mut pivots_mm = [Vector3::zeros(); 2];
    let mut vectors = [[0.0; 3]; 2];
    for (k, &i) in s.rotary.iter().enumerate() {
        let (point, u) = axis_line(model, held, i)?;
        // The point of the actual line nearest the URDF's joint origin.
        let o = joint_origin(m, i);
        let pivot = point + u * u.dot(&(o - point));
        pivots_mm[k] = to_mcs(pivot - origin) * 1e3;
        let v = to_mcs(u).normalize();
        vectors[k] = [0, 1, 2].map(|c| rounded(v[c], 9));
    }
    let round = |v: Vector3<f64>| v.map(|x| rounded(x, 6));
    let (p1, p2) = (round(pivots_mm[0]), round(pivots_mm[1]));
    // Offsets by IM9 p. 508, the closing vector from the rounded ones so the chain closes.
    let z = Vector3::zeros();
    let offsets = match s.kind {
        CarrKind::Tool => [-p1, p1 - p2, p2, z],
        CarrKind::Part => [z, p1, p2 - p1, -p2],
        CarrKind::Mixed => [-p1, p1, p2, -p2],
    };
    let limits_deg = s.rotary.map(|i| match m.axes()[i].limits() {
        Some((lo, hi)) => (rounded(lo.to_degrees(), 6), rounded(hi.to_degrees(), 6)),
        None => (0.0, 0.0),
    });
    Ok(CarrData {
        number,
        name: name.to_string(),
        kind: s.kind,
        // Rounded again: a difference of 6-decimal values is written and read back exactly.
        offsets_mm: offsets.map(|v| [0, 1, 2].map(|c| rounded(v[c], 6))),
        axis_vectors: vectors,
        axes: s.rotary.map(|i| m.axes()[i].letter().as_char().to_string()),
        limits_deg,
        nominal: None,
        not_representable: Vec::new(),
    })
}

/// The CYCLE800 swivel data record `number` named `name` of the identified machine (model and
/// coefficients `coeffs`, as `mtcal_machine::params::load_params` reads them), with the nominal
/// machine's record and the identified errors it does not hold. Refuses machines `$TC_CARR`
/// cannot describe (not exactly X, Y, Z and two rotary axes, a rotary axis carrying a linear
/// one, non-orthogonal nominal linear axes) and records the control would refuse.
pub fn carr_data(
    model: &MachineModel,
    coeffs: &[f64],
    number: u32,
    name: &str,
) -> Result<CarrData, CompensateError> {
    if coeffs.len() != model.n_coeffs() {
        return Err(CompensateError::CoeffsLength {
            got: coeffs.len(),
            expected: model.n_coeffs(),
        });
    }
    if let Some(bad) = coeffs.iter().find(|v| !v.is_finite()) {
        return Err(refuse(format!("a coefficient is not finite ({bad})")));
    }
    let s = structure(model.machine())?;
    let mut data = record(model, &held_coefficients(model, coeffs), &s, number, name)?;
    let nominal = record(model, &vec![0.0; coeffs.len()], &s, number, name)?;
    data.nominal = Some(Box::new(nominal));
    data.not_representable = not_representable(model, coeffs);
    data.validate()?;
    Ok(data)
}

// --- The card and the file -----------------------------------------------------------------

/// The convention card of a record.
pub fn carr_card(data: &CarrData) -> ConventionCard {
    let mut axis_mapping: Vec<AxisMap> = ['X', 'Y', 'Z']
        .into_iter()
        .map(|c| AxisMap {
            mtcal: c,
            control: format!("{c} (geometry axis)"),
        })
        .collect();
    for (k, axis) in data.axes.iter().enumerate() {
        if let Some(c) = axis.chars().next() {
            let body = if data.kind.moves_tool(k) {
                "head"
            } else {
                "table"
            };
            axis_mapping.push(AxisMap {
                mtcal: c,
                control: format!(
                    "{axis} (rotary axis {}, {body}, $TC_CARR{} and $TC_CARR{})",
                    k + 1,
                    21 + k,
                    35 + k
                ),
            });
        }
    }
    let kind = data.kind.letter();
    ConventionCard {
        made_from: Vec::new(),
        format: format!(
            "SINUMERIK 840D sl CYCLE800 swivel data record {} ($TC_CARR, orientable toolholder), \
             kinematics {kind} ({})",
            data.number,
            data.kind.describe()
        ),
        quantity: Quantity::Geometry,
        sign: "offset vectors as IM9 p. 508 defines them, in machine X/Y/Z with the rotary axes \
               at 0: head I3 tool reference point -> pivot 2, I2 pivot 2 -> pivot 1, \
               I1 = -(I2+I3); table I2 machine reference point -> pivot 1, I3 pivot 1 -> pivot 2, \
               I4 = -(I2+I3); mixed I2 tool reference point -> pivot 1, I1 = -I2, I3 machine \
               reference point -> pivot 2, I4 = -I3"
            .into(),
        squareness: "not carried: CYCLE800 assumes orthogonal linear axes; identified \
                     squareness is listed as not held"
            .into(),
        rotary_direction: "a positive axis position turns its body right-handed about its \
                           vector (W1): a head axis' vector along +X/+Y/+Z, a table axis' along \
                           -X/-Y/-Z (checklist, IM9 p. 581); positive A, B, C as ISO 841"
            .into(),
        axis_mapping,
        units: "offsets mm (the control's basic system must be metric), axis vectors unit \
                vectors, angular ranges degrees"
            .into(),
        control_will: vec![
            format!(
                "turn the tool and/or workpiece about V1 and V2 through the offset chain when \
                 CYCLE800 (or TCARR={}) selects this record",
                data.number
            ),
            "take mtcal's tool point as the tool reference point: tool lengths count from it"
                .into(),
            "take the machine reference point where that point is with every axis at 0: \
             mtcal's axis zeros must be the control's"
                .into(),
            "add the fine offsets $TC_CARR41-65 when SD42974 $SC_TOCARR_FINE_CORRECTION = 1: \
             they must be 0 (mtcal writes none)"
                .into(),
            "keep its own $TC_CARR13/14, 26-29 and 37-40 (angles, Hirth, CYCLE800 screens and \
             retraction): mtcal does not write them"
                .into(),
            "not hold component errors, squareness or the other errors listed as not held: use \
             the EEC/CEC tables or a volumetric compensation for them"
                .into(),
            "store the data when this part program runs once (M30 ends it)".into(),
        ],
    }
}

/// The part program that sets the record: header and card as `;` comments, the assignments,
/// `M30`. Refuses a record [`CarrData::validate`] refuses.
pub fn carr_text(
    data: &CarrData,
    machine_name: &str,
    made_from: &[String],
) -> Result<String, CompensateError> {
    data.validate()?;
    let n = data.number;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "; mtcal: CYCLE800 swivel data record {n} for machine {machine_name}"
    );
    let _ = writeln!(
        t,
        "; kinematics {} ({}): rotary axis 1 = {}, rotary axis 2 = {}",
        data.kind.letter(),
        data.kind.describe(),
        data.axes[0],
        data.axes[1]
    );
    let card = ConventionCard {
        made_from: made_from.to_vec(),
        ..carr_card(data)
    };
    t.push_str(&card.lines("; "));
    if let Some(nom) = &data.nominal {
        let _ = writeln!(t, "; nominal machine, for comparison:");
        for (name, v) in OFFSET_NAMES.iter().zip(&nom.offsets_mm) {
            let _ = writeln!(t, ";   {name} {} mm", vector_text(v, 6));
        }
        for (name, v) in VECTOR_NAMES.iter().zip(&nom.axis_vectors) {
            let _ = writeln!(t, ";   {name} {}", vector_text(v, 9));
        }
    }
    if data.not_representable.is_empty() {
        let _ = writeln!(
            t,
            "; every identified error with a value is held by this record"
        );
    } else {
        let _ = writeln!(
            t,
            "; identified errors NOT held by $TC_CARR (largest coefficient, um or urad):"
        );
        for (name, size) in &data.not_representable {
            let _ = writeln!(t, ";   {name} ({size:.3})");
        }
    }
    for (k, v) in data.offsets_mm.iter().enumerate() {
        for (c, x) in v.iter().enumerate() {
            let f = OFFSET_FIELDS[k] + c as u32;
            let _ = writeln!(
                t,
                "$TC_CARR{f}[{n}]={x:.6} ; {} {} mm",
                OFFSET_NAMES[k],
                xyz(c)
            );
        }
    }
    for (k, v) in data.axis_vectors.iter().enumerate() {
        for (c, x) in v.iter().enumerate() {
            let f = VECTOR_FIELDS[k] + c as u32;
            let _ = writeln!(
                t,
                "$TC_CARR{f}[{n}]={x:.9} ; {} {}",
                VECTOR_NAMES[k],
                xyz(c)
            );
        }
    }
    for k in 0..2 {
        let _ = writeln!(
            t,
            "$TC_CARR{}[{n}]={} ; rotary axis {}",
            21 + k,
            data.axes[k],
            k + 1
        );
    }
    let _ = writeln!(
        t,
        "$TC_CARR23[{n}]=\"{}\" ; kinematics type",
        data.kind.letter()
    );
    for k in 0..2 {
        let _ = writeln!(
            t,
            "$TC_CARR{}[{n}]=0.000000 ; rotary axis {} at its position 0 in the initial setting",
            24 + k,
            k + 1
        );
    }
    for k in 0..2 {
        let (lo, hi) = data.limits_deg[k];
        let note = if lo == 0.0 && hi == 0.0 {
            " (0 and 0: not evaluated)"
        } else {
            ""
        };
        let axis = k + 1;
        let _ = writeln!(
            t,
            "$TC_CARR{}[{n}]={lo:.6} ; rotary axis {axis} minimum, degrees{note}",
            30 + k
        );
        let _ = writeln!(
            t,
            "$TC_CARR{}[{n}]={hi:.6} ; rotary axis {axis} maximum, degrees{note}",
            32 + k
        );
    }
    let _ = writeln!(t, "$TC_CARR34[{n}]=\"{}\" ; record name", data.name);
    for k in 0..2 {
        let _ = writeln!(
            t,
            "$TC_CARR{}[{n}]=\"{}\" ; CYCLE800 name of rotary axis {}",
            35 + k,
            data.axes[k],
            k + 1
        );
    }
    t.push_str("M30\n");
    Ok(ascii(&t))
}

/// Writes [`carr_text`] to `path`, atomically.
pub fn write_carr(
    path: &Path,
    data: &CarrData,
    machine_name: &str,
    made_from: &[String],
) -> Result<(), CompensateError> {
    let text = carr_text(data, machine_name, made_from)?;
    write_file(path, &text)
}

// --- Reading -------------------------------------------------------------------------------

/// One `$TC_CARRk[n]=value` of the file.
#[derive(Clone, Debug)]
struct Assignment<'a> {
    field: u32,
    record: u32,
    value: &'a str,
    quoted: bool,
    line: usize,
    /// Column of `$` and of the value.
    column: usize,
    value_column: usize,
}

/// What kind of value a field takes.
#[derive(Clone, Copy, PartialEq)]
enum ValueKind {
    Number,
    Axis,
    Text,
}

/// The fields mtcal writes and reads, with their kinds.
fn field_kind(field: u32) -> Option<ValueKind> {
    match field {
        1..=12 | 15..=20 | 24 | 25 | 30..=33 => Some(ValueKind::Number),
        21 | 22 => Some(ValueKind::Axis),
        23 | 34..=36 => Some(ValueKind::Text),
        _ => None,
    }
}

/// The part of a line before its `;` comment (outside a `"` string), or where a string is not
/// closed.
fn code_part(line: &str) -> Result<&str, usize> {
    let mut in_string = None;
    for (i, c) in line.char_indices() {
        match (c, in_string) {
            ('"', None) => in_string = Some(i),
            ('"', Some(_)) => in_string = None,
            (';', None) => return Ok(&line[..i]),
            _ => {}
        }
    }
    match in_string {
        Some(i) => Err(i),
        None => Ok(line),
    }
}

/// The digits at the start of `s`.
fn digits(s: &str) -> &str {
    let end = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    &s[..end]
}

/// Reads the assignments and the end of one line's code. `ended` is set by `M30`/`M17`.
fn parse_line<'a>(
    src: &Source<'_>,
    n: usize,
    code: &'a str,
    out: &mut Vec<Assignment<'a>>,
    ended: &mut bool,
) -> Result<(), CompensateError> {
    if let Some(i) = code.find(|c: char| !c.is_ascii()) {
        return Err(src.error(n, i + 1, "expected ASCII text outside comments"));
    }
    let mut pos = 0;
    let mut first = true;
    loop {
        let rest = &code[pos..];
        let skipped = rest.len() - rest.trim_start().len();
        pos += skipped;
        let rest = &code[pos..];
        if rest.is_empty() {
            return Ok(());
        }
        let column = pos + 1;
        if *ended {
            return Err(src.error(n, column, "nothing may follow the program end (M30)"));
        }
        let token_end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let token = &rest[..token_end];
        if first && token.starts_with('N') && token.len() > 1 && digits(&token[1..]) == &token[1..]
        {
            pos += token_end;
        } else if token == "M30" || token == "M17" {
            *ended = true;
            pos += token_end;
        } else if let Some(after) = rest.strip_prefix("$TC_CARR") {
            let (a, used) = assignment(src, n, column, after)?;
            out.push(a);
            pos += "$TC_CARR".len() + used;
        } else {
            return Err(src.error(
                n,
                column,
                format!("expected `$TC_CARRk[n]=value`, `M30` or a `;` comment, found `{token}`"),
            ));
        }
        first = false;
    }
}

/// One assignment after its `$TC_CARR` (at `column`): the assignment and the bytes used.
fn assignment<'a>(
    src: &Source<'_>,
    n: usize,
    column: usize,
    after: &'a str,
) -> Result<(Assignment<'a>, usize), CompensateError> {
    let base = column + "$TC_CARR".len();
    let expected = |offset: usize, what: &str, rest: &str| {
        let found: String = rest.chars().take(12).collect();
        src.error(
            n,
            base + offset,
            format!("expected {what}, found `{found}`"),
        )
    };
    let k = digits(after);
    let mut at = k.len();
    if !after[at..].starts_with('[') {
        return Err(expected(at, "the field number and `[`", &after[at..]));
    }
    at += 1;
    let r = digits(&after[at..]);
    if r.is_empty() || !after[at + r.len()..].starts_with(']') {
        return Err(expected(at, "the record number and `]`", &after[at..]));
    }
    let (Ok(field), Ok(record)) = (k.parse::<u32>(), r.parse::<u32>()) else {
        return Err(expected(0, "a field number", after));
    };
    at += r.len() + 1;
    at += after[at..].len() - after[at..].trim_start().len();
    if !after[at..].starts_with('=') {
        return Err(expected(at, "`=`", &after[at..]));
    }
    at += 1;
    at += after[at..].len() - after[at..].trim_start().len();
    let value_column = base + at;
    let rest = &after[at..];
    let (value, quoted, used) = if let Some(s) = rest.strip_prefix('"') {
        let close = s.find('"').expect("strings were checked closed");
        (&s[..close], true, close + 2)
    } else {
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        if end == 0 {
            return Err(expected(at, "a value", rest));
        }
        (&rest[..end], false, end)
    };
    Ok((
        Assignment {
            field,
            record,
            value,
            quoted,
            line: n,
            column,
            value_column,
        },
        at + used,
    ))
}

/// The assignments of a file, each field once, all of one record, the program ended by M30.
fn assignments<'a>(
    src: &Source<'_>,
    text: &'a str,
) -> Result<Vec<Assignment<'a>>, CompensateError> {
    let mut out = Vec::new();
    let mut ended = false;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        last_line = n;
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        let code = code_part(line)
            .map_err(|at| src.error(n, at + 1, "this string has no closing `\"` on its line"))?;
        parse_line(src, n, code, &mut out, &mut ended)?;
    }
    if !ended {
        return Err(src.error(
            last_line + 1,
            1,
            "expected the program end `M30` after the assignments",
        ));
    }
    let Some(first) = out.first() else {
        return Err(src.error(
            1,
            1,
            "expected `$TC_CARRk[n]=value` assignments, found none",
        ));
    };
    let record = first.record;
    for (k, a) in out.iter().enumerate() {
        if a.record != record {
            return Err(src.error(
                a.line,
                a.column,
                format!(
                    "every assignment must set record {record} (line {}), found record {}",
                    first.line, a.record
                ),
            ));
        }
        if let Some(prev) = out[..k].iter().find(|p| p.field == a.field) {
            return Err(src.error(
                a.line,
                a.column,
                format!(
                    "$TC_CARR{} is set twice (first on line {})",
                    a.field, prev.line
                ),
            ));
        }
        let Some(kind) = field_kind(a.field) else {
            return Err(src.error(
                a.line,
                a.column,
                format!(
                    "$TC_CARR{} is not a field mtcal's swivel data set (1-12, 15-25, 30-36)",
                    a.field
                ),
            ));
        };
        if (kind == ValueKind::Text) != a.quoted {
            let want = match kind {
                ValueKind::Text => "a string in `\"`",
                ValueKind::Number => "a number",
                ValueKind::Axis => "an axis name",
            };
            return Err(src.error(
                a.line,
                a.value_column,
                format!("$TC_CARR{} takes {want}, found `{}`", a.field, a.value),
            ));
        }
    }
    Ok(out)
}

/// A number as the writer writes it: digits, an optional sign and point.
fn number(src: &Source<'_>, a: &Assignment<'_>) -> Result<f64, CompensateError> {
    let plain = a
        .value
        .chars()
        .all(|c| c.is_ascii_digit() || matches!(c, '-' | '+' | '.'));
    match a.value.parse::<f64>() {
        Ok(v) if plain && v.is_finite() => Ok(v),
        _ => Err(src.error(
            a.line,
            a.value_column,
            format!(
                "$TC_CARR{}: expected a number, found `{}`",
                a.field, a.value
            ),
        )),
    }
}

/// Reads a swivel data record written by [`write_carr`]. Every problem names the file, line
/// and column: unknown or repeated fields, a missing field or `M30`, a value of the wrong kind,
/// and what [`CarrData::validate`] refuses (at the field concerned).
pub fn read_carr(path: &Path) -> Result<CarrData, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let all = assignments(&src, &text)?;
    let get = |field: u32| all.iter().find(|a| a.field == field);
    let end_line = text.lines().count() + 1;
    let mut missing = (1..=36).filter(|&f| field_kind(f).is_some() && get(f).is_none());
    if let Some(f) = missing.next() {
        return Err(src.error(end_line, 1, format!("$TC_CARR{f} is missing")));
    }
    let num = |f: u32| number(&src, get(f).expect("checked present"));
    let vec3 =
        |f: u32| -> Result<[f64; 3], CompensateError> { Ok([num(f)?, num(f + 1)?, num(f + 2)?]) };
    let kind_field = get(23).expect("present");
    let mut kind_chars = kind_field.value.chars();
    let kind = match (
        kind_chars.next().and_then(CarrKind::from_letter),
        kind_chars.next(),
    ) {
        (Some(k), None) => k,
        _ => {
            return Err(src.error(
                kind_field.line,
                kind_field.value_column,
                format!(
                    "$TC_CARR23: expected the kinematics type \"T\", \"P\" or \"M\", found \"{}\"",
                    kind_field.value
                ),
            ));
        }
    };
    for f in [24, 25] {
        if num(f)? != 0.0 {
            let a = get(f).expect("present");
            return Err(src.error(
                a.line,
                a.value_column,
                format!(
                    "$TC_CARR{f}: mtcal's swivel data describe the axes at position 0; an axis \
                     offset of {} degrees is not read",
                    a.value
                ),
            ));
        }
    }
    let axes = [21, 22].map(|f| get(f).expect("present").value.to_string());
    for k in 0..2 {
        let a = get(35 + k).expect("present");
        if a.value != axes[k as usize] {
            return Err(src.error(
                a.line,
                a.value_column,
                format!(
                    "$TC_CARR{}: CYCLE800's axis name must be the channel axis of $TC_CARR{} \
                     (`{}`), found \"{}\"",
                    35 + k,
                    21 + k,
                    axes[k as usize],
                    a.value
                ),
            ));
        }
    }
    let data = CarrData {
        number: all[0].record,
        name: get(34).expect("present").value.to_string(),
        kind,
        offsets_mm: [vec3(1)?, vec3(4)?, vec3(15)?, vec3(18)?],
        axis_vectors: [vec3(7)?, vec3(10)?],
        axes,
        limits_deg: [(num(30)?, num(32)?), (num(31)?, num(33)?)],
        nominal: None,
        not_representable: Vec::new(),
    };
    data.validate().map_err(|e| {
        let a = get(e.field()).unwrap_or(&all[0]);
        src.error(a.line, a.value_column, e.to_string())
    })?;
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::rigid::axis_rotation;

    #[test]
    fn the_screw_of_a_rotation_about_a_line_is_that_line() {
        let u = Vector3::new(0.3, -0.5, 0.8).normalize();
        let c = Vector3::new(0.2, 0.7, -0.1);
        let c = c - u * u.dot(&c);
        for angle in [0.2, 1.0, 2.5] {
            let r = axis_rotation(&u, angle);
            let motion = Rigid::new(r, c - r * c);
            let (point, dir, phi) = screw(&motion);
            assert!((phi - angle).abs() < 1e-12);
            assert!((dir - u).norm() < 1e-12);
            assert!((point - c).norm() < 1e-12, "{point} vs {c}");
        }
    }

    #[test]
    fn rounding_drops_negative_zero_and_ascii_spells_the_card() {
        assert_eq!(rounded(-1e-12, 6).to_bits(), 0.0f64.to_bits());
        assert_eq!(rounded(1.23456789, 6), 1.234568);
        assert_eq!(ascii("X → Y −1 µm 5°"), "X -> Y -1 um 5 deg");
    }

    #[test]
    fn comments_end_code_outside_strings_only() {
        assert_eq!(code_part("$TC_CARR1[1]=0 ; I1"), Ok("$TC_CARR1[1]=0 "));
        assert_eq!(
            code_part("$TC_CARR34[1]=\"a\" ; x"),
            Ok("$TC_CARR34[1]=\"a\" ")
        );
        assert_eq!(code_part("$TC_CARR34[1]=\"a"), Err(14));
    }
}
