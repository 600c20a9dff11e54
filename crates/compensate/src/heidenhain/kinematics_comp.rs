//! KinematicsComp (iTNC 530): the identified ISO 230-1 errors as entries of the kinematics
//! description, component errors as COMPTAB references to columns C1–C6 of one `.COM` table
//! per axis, location errors as COORD values. Conventions in the module documentation of
//! `heidenhain`.

use super::HeidenhainLimit;
use super::com::{cma_text, read_cma, table_file_name};
use super::table::{TableIn, TableOut, axis_positions, parse_table, table_text};
use crate::parameters::{ParameterValue, error_parameters};
use crate::text::{Field, Source};
use crate::{CompensateError, MM, read_file, write_file};
use mtcal_kinematics::model::default_stroke;
use mtcal_kinematics::rigid::{Rigid, axis_rotation, exp_so3};
use mtcal_kinematics::{AxisKind, Direction, MachineModel, ParamName, Side};
use mtcal_machine::card::{ConventionCard, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO};
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};

/// What a kinematics entry is (the KEY column).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KcKey {
    /// A translation along or rotation about AXIS by the entry's value.
    Trans,
    /// Where machine axis AXIS acts in the chain (the control's own nominal entry).
    MachAxis,
    /// The stationary machine base, between the tool-side and the workpiece-side axes.
    MachBase,
}

impl KcKey {
    fn text(self) -> &'static str {
        match self {
            KcKey::Trans => "Trans",
            KcKey::MachAxis => "MachAxis",
            KcKey::MachBase => "MachBase",
        }
    }
}

/// The value of a `Trans` entry.
#[derive(Clone, Debug, PartialEq)]
pub enum KcValue {
    /// No value (`MachAxis`, `MachBase`).
    None,
    /// A constant (COORD): mm for X/Y/Z, degrees for A/B/C.
    Coord(f64),
    /// A column of a `.COM` table (COMPTAB), at the position of the axis the table belongs to.
    Comptab { table: String, column: usize },
}

/// One line of the kinematics description.
#[derive(Clone, Debug, PartialEq)]
pub struct KcEntry {
    /// The DOC column: the ISO 230-1 error the entry carries (`EXX`, `X0C`, `-X0C` for the
    /// inverse after the axis), or what the entry is.
    pub doc: String,
    pub key: KcKey,
    /// The AXIS column (`None` for `MachBase`).
    pub axis: Option<char>,
    pub value: KcValue,
}

/// The `.COM` table of one axis: columns C1–C6 at positions of that axis.
#[derive(Clone, Debug, PartialEq)]
pub struct KcTable {
    /// File name (`KC_X.COM`).
    pub name: String,
    /// The axis whose position the rows follow.
    pub axis: char,
    /// AXISPOS: mm (linear axis) or degrees (rotary axis), ascending.
    pub positions: Vec<f64>,
    /// The column named after the axis (one of the manual's "columns 1–18"): the axis'
    /// positioning error at each row, mm or degrees in mtcal's axis coordinate, as the
    /// nonlinear axis-error compensation holds it (the control moves the axis by −value).
    pub positioning: Vec<f64>,
    /// C1–C3 translations along X, Y, Z (mm), C4–C6 rotations about X, Y, Z (degrees): the
    /// chain transformation `Trans X(C1)·Trans Y(C2)·Trans Z(C3)·Trans A(C4)·Trans B(C5)·
    /// Trans C(C6)` at each position.
    pub columns: [Vec<f64>; 6],
}

impl KcTable {
    /// Column `column` (1–6) at `position`: linear between rows, end values outside.
    pub fn value_at(&self, column: usize, position: f64) -> f64 {
        crate::lerp(
            &self.columns[column - 1],
            crate::bracket(&self.positions, position),
        )
    }
}

/// A machine's errors as KinematicsComp entries: the description from the tool to the table
/// and the tables its COMPTAB entries use.
#[derive(Clone, Debug, PartialEq)]
pub struct KinematicsComp {
    pub entries: Vec<KcEntry>,
    pub tables: Vec<KcTable>,
    /// What the entries were made from, for the card; not read back.
    pub note: String,
}

impl KinematicsComp {
    /// COMPTAB entries, COORD entries and MachAxis entries.
    pub fn counts(&self) -> (usize, usize, usize) {
        let mut c = (0, 0, 0);
        for e in &self.entries {
            match (&e.key, &e.value) {
                (_, KcValue::Comptab { .. }) => c.0 += 1,
                (_, KcValue::Coord(_)) => c.1 += 1,
                (KcKey::MachAxis, _) => c.2 += 1,
                _ => {}
            }
        }
        c
    }
}

/// The limits KinematicsComp puts on the description (iTNC 530 technical manual p.686).
#[derive(Clone, Debug, PartialEq)]
pub struct KcLimits {
    /// Most COMPTAB entries together with the MachAxis entries (100).
    pub max_comptab_with_machaxis: usize,
    /// Most COORD entries (50).
    pub max_coord: usize,
    /// Largest plausible translation (mm).
    pub max_abs_mm: f64,
    /// Largest plausible rotation (degrees).
    pub max_abs_deg: f64,
}

impl Default for KcLimits {
    fn default() -> Self {
        KcLimits {
            max_comptab_with_machaxis: 100,
            max_coord: 50,
            max_abs_mm: 1.0,
            max_abs_deg: 0.1,
        }
    }
}

const TRANS_AXES: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// The KinematicsComp description of `model` with coefficients `coeffs` (SI): each axis' five
/// component errors other than positioning as the chain transformation beside its `MachAxis`
/// (columns of `KC_<axis>.COM`, rows at the nodes [`error_parameters`] uses: `spacing_mm` apart
/// over a linear stroke, `spacing_deg` over a rotary axis' range), its positioning error in the
/// table's column named after the axis, its location errors as COORD entries around it. Needs joint frames parallel to the machine frame at the zero pose (the
/// chain's Trans X/Y/Z/A/B/C are along machine directions). Set-up parameters are left out.
pub fn kinematics_comp(
    model: &MachineModel,
    coeffs: &[f64],
    spacing_mm: f64,
    spacing_deg: f64,
) -> Result<KinematicsComp, CompensateError> {
    let params = error_parameters(model, coeffs, spacing_mm, spacing_deg)?;
    let machine = model.machine();
    for ax in machine.axes() {
        if (ax.zero_rotation() - Matrix3::identity()).amax() > 1e-12 {
            return Err(CompensateError::Model {
                message: format!(
                    "axis {}'s joint frame is turned at the zero pose: KinematicsComp entries are \
                     along machine X/Y/Z, write the machine's URDF origins without rotation",
                    ax.letter().as_char()
                ),
            });
        }
    }
    let mut per_axis = Vec::with_capacity(machine.n_axes());
    for (i, ax) in machine.axes().iter().enumerate() {
        per_axis.push(axis_errors(
            model,
            &params,
            i,
            spacing_mm,
            spacing_deg,
            ax.letter(),
        )?);
    }
    let mut entries = Vec::new();
    let mut tables = Vec::new();
    let tool = machine.branch(Side::Tool).joints();
    let work = machine.branch(Side::Workpiece).joints();
    for &i in tool.iter().rev() {
        axis_entries(model, i, &per_axis[i], &mut entries, &mut tables);
    }
    entries.push(KcEntry {
        doc: "base".into(),
        key: KcKey::MachBase,
        axis: None,
        value: KcValue::None,
    });
    for &i in work {
        axis_entries(model, i, &per_axis[i], &mut entries, &mut tables);
    }
    let note = format!(
        "machine {}; component tables every {spacing_mm} mm (linear) and {spacing_deg} deg \
         (rotary); chain from the tool to the table: {}",
        machine.name(),
        entries
            .iter()
            .filter(|e| e.key != KcKey::Trans)
            .map(|e| e.axis.map_or("base".to_string(), |a| a.to_string()))
            .collect::<Vec<_>>()
            .join(" ")
    );
    Ok(KinematicsComp {
        entries,
        tables,
        note,
    })
}

/// One axis' errors: positions (file units), component values at each (SI, machine directions,
/// a rotary axis' own-direction location errors added) and location errors present (SI).
struct AxisErrors {
    positions: Vec<f64>,
    components: Vec<[f64; 6]>,
    locations: Vec<(Direction, f64)>,
}

fn axis_errors(
    model: &MachineModel,
    params: &crate::ErrorParameters,
    i: usize,
    spacing_mm: f64,
    spacing_deg: f64,
    letter: mtcal_kinematics::AxisLetter,
) -> Result<AxisErrors, CompensateError> {
    let machine = model.machine();
    let ax = &machine.axes()[i];
    let rotary = ax.kind() == AxisKind::Rotary;
    let own = ax.own_cartesian();
    let mut positions: Option<Vec<f64>> = None;
    let mut tables = Vec::new();
    let mut locations = Vec::new();
    let mut own_constants = [0.0; 6];
    for p in &params.params {
        if p.name.axis() != Some(letter) {
            continue;
        }
        let d = p.name.direction();
        let si = if d.is_rotation() { 1.0 } else { 1.0 / MM };
        match (&p.value, &p.name) {
            (ParameterValue::Table { args, values }, _) => {
                if positions.as_ref().is_some_and(|a| a != args) {
                    return Err(CompensateError::Model {
                        message: format!(
                            "the tables of axis {} have different nodes",
                            letter.as_char()
                        ),
                    });
                }
                positions = Some(args.clone());
                tables.push((d.index(), values.iter().map(|v| v * si).collect::<Vec<_>>()));
            }
            (ParameterValue::Constant(v), ParamName::Location { .. }) => {
                if rotary && d.cartesian() == own {
                    own_constants[d.index()] += v * si;
                } else {
                    locations.push((d, v * si));
                }
            }
            _ => {}
        }
    }
    let positions = match positions {
        Some(p) => p,
        None => fallback_nodes(model, i, spacing_mm, spacing_deg)?,
    };
    let components = (0..positions.len())
        .map(|n| {
            let mut c = own_constants;
            for (d, v) in &tables {
                c[*d] += v[n];
            }
            c
        })
        .collect();
    locations.sort_by_key(|(d, _)| d.index());
    Ok(AxisErrors {
        positions,
        components,
        locations,
    })
}

/// Nodes of an axis without component tables, by the rule of [`error_parameters`].
fn fallback_nodes(
    model: &MachineModel,
    i: usize,
    spacing_mm: f64,
    spacing_deg: f64,
) -> Result<Vec<f64>, CompensateError> {
    let machine = model.machine();
    let ax = &machine.axes()[i];
    let what = format!("KinematicsComp table of axis {}", ax.letter().as_char());
    match (ax.kind(), ax.limits()) {
        (AxisKind::Linear, _) => {
            let (lo, hi) = default_stroke(machine, i);
            crate::nodes_mm(lo, hi, spacing_mm, &what)
        }
        (AxisKind::Rotary, Some((lo, hi))) => {
            crate::nodes_in(lo.to_degrees(), hi.to_degrees(), spacing_deg, &what)
        }
        (AxisKind::Rotary, None) => crate::nodes_in(0.0, 360.0, spacing_deg, &what),
    }
}

/// `Trans(t)·Rx(a)·Ry(b)·Rz(c)` as the chain writes it (t in m, angles in rad).
fn elementary(t: Vector3<f64>, abc: [f64; 3]) -> Rigid {
    let r = axis_rotation(&Vector3::x(), abc[0])
        * axis_rotation(&Vector3::y(), abc[1])
        * axis_rotation(&Vector3::z(), abc[2]);
    Rigid::new(r, t)
}

/// `(a, b, c)` with `R = Rx(a)·Ry(b)·Rz(c)`.
fn euler_xyz(r: &Matrix3<f64>) -> [f64; 3] {
    [
        (-r[(1, 2)]).atan2(r[(2, 2)]),
        r[(0, 2)].clamp(-1.0, 1.0).asin(),
        (-r[(0, 1)]).atan2(r[(0, 0)]),
    ]
}

/// The location factor of an axis as its COORD entries write it.
fn location_factor(locations: &[(Direction, f64)]) -> Rigid {
    let mut t = Vector3::zeros();
    let mut abc = [0.0; 3];
    for &(d, v) in locations {
        if d.is_rotation() {
            abc[d.cartesian()] = v;
        } else {
            t[d.cartesian()] = v;
        }
    }
    elementary(t, abc)
}

/// Which side of its `MachAxis` an axis' error entries stand on: where mtcal's model (ISO
/// 230-1) defines the error. A linear axis' errors move with its carriage (before the axis for a
/// tool-side axis, after it for a workpiece-side one, in the chain from the tool to the table); a
/// rotary axis' errors are measured in the frame that does not turn (the base's side). There the
/// axis' factor is the inverse of its functional error exactly, so no Abbe terms enter the
/// columns and each column is the negated error its DOC names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Placement {
    Before,
    After,
}

fn placement(kind: AxisKind, side: Side) -> Placement {
    match (kind, side) {
        (AxisKind::Linear, Side::Tool) | (AxisKind::Rotary, Side::Workpiece) => Placement::Before,
        (AxisKind::Linear, Side::Workpiece) | (AxisKind::Rotary, Side::Tool) => Placement::After,
    }
}

/// An axis' motion by `s` (m or rad) in its joint frame.
fn motion(kind: AxisKind, a: &Vector3<f64>, s: f64) -> Rigid {
    match kind {
        AxisKind::Linear => Rigid::translation(a * s),
        AxisKind::Rotary => Rigid::rotation(axis_rotation(a, s)),
    }
}

/// Column `k` (0–5) of a factor as the chain writes it: translation (m) or angle (rad).
fn column_of(f: &Rigid, k: usize) -> f64 {
    if k < 3 {
        f.t[k]
    } else {
        euler_xyz(&f.r)[k - 3]
    }
}

/// Axis `i`'s error factor at position `q` with its positioning error taken out: the chain's
/// transformation `F` (the inverse of the functional error `E = (exp(ε), δ)`, on the side
/// [`placement`] gives) and the positioning error `v` (m or rad, in the axis' own coordinate)
/// such that the axis standing at `q + v` with `F` beside it is the model's axis at `q`, and
/// `F` has no component in the axis' own column. The `.COM` column named after the axis holds
/// `v`, as the manual assigns positioning errors to columns 1–18 (p.686).
fn split_factor(model: &MachineModel, i: usize, c: &[f64; 6], l: &Rigid) -> (Rigid, f64) {
    let ax = &model.machine().axes()[i];
    let e_inv = Rigid::new(
        exp_so3(&Vector3::new(c[3], c[4], c[5])),
        Vector3::new(c[0], c[1], c[2]),
    )
    .inverse();
    let a = ax.direction();
    let own = ax.own_cartesian() + if ax.kind() == AxisKind::Rotary { 3 } else { 0 };
    // In the chain from the tool, a tool-side axis moves by −q, a workpiece-side one by +q.
    let sigma = match ax.side() {
        Side::Tool => 1.0,
        Side::Workpiece => -1.0,
    };
    let split = |v: f64| {
        let shift = l
            .compose(&motion(ax.kind(), a, sigma * v))
            .compose(&l.inverse());
        match placement(ax.kind(), ax.side()) {
            Placement::Before => e_inv.compose(&shift),
            Placement::After => shift.compose(&e_inv),
        }
    };
    // The own column moves by σ·a_own per unit of v to first order; Newton converges in two
    // steps (the rest is a product of two errors).
    let slope = sigma * a[own % 3];
    let mut v = 0.0;
    for _ in 0..4 {
        v -= column_of(&split(v), own) / slope;
    }
    (split(v), v)
}

fn axis_entries(
    model: &MachineModel,
    i: usize,
    errors: &AxisErrors,
    entries: &mut Vec<KcEntry>,
    tables: &mut Vec<KcTable>,
) {
    let ax = &model.machine().axes()[i];
    let letter = ax.letter().as_char();
    let name = format!("KC_{letter}.COM");
    let l = location_factor(&errors.locations);
    let unit = match ax.kind() {
        AxisKind::Linear => MM,
        AxisKind::Rotary => 1f64.to_degrees(),
    };
    let own = ax.own_cartesian() + if ax.kind() == AxisKind::Rotary { 3 } else { 0 };
    let mut columns: [Vec<f64>; 6] = Default::default();
    let mut positioning = Vec::with_capacity(errors.positions.len());
    for c in &errors.components {
        let (f, v) = split_factor(model, i, c, &l);
        positioning.push(v * unit);
        for (k, column) in columns.iter_mut().enumerate() {
            // The own column is zero to the last bit the Newton steps leave (1e-20).
            let x = if k == own { 0.0 } else { column_of(&f, k) };
            column.push(if k < 3 { x * MM } else { x.to_degrees() });
        }
    }
    let components: Vec<KcEntry> = (0..6)
        .filter(|&k| k != own)
        .map(|k| KcEntry {
            doc: format!("-{}", ParamName::component(Direction::ALL[k], ax.letter())),
            key: KcKey::Trans,
            axis: Some(TRANS_AXES[k]),
            value: KcValue::Comptab {
                table: name.clone(),
                column: k + 1,
            },
        })
        .collect();
    let place = placement(ax.kind(), ax.side());
    if place == Placement::Before {
        entries.extend(components.iter().cloned());
    }
    let coord = |d: Direction, v: f64| {
        if d.is_rotation() {
            v.to_degrees()
        } else {
            v * MM
        }
    };
    for &(d, v) in &errors.locations {
        entries.push(KcEntry {
            doc: location_doc(d, letter),
            key: KcKey::Trans,
            axis: Some(d.letter()),
            value: KcValue::Coord(coord(d, v)),
        });
    }
    entries.push(KcEntry {
        doc: "axis".into(),
        key: KcKey::MachAxis,
        axis: Some(letter),
        value: KcValue::None,
    });
    for &(d, v) in errors.locations.iter().rev() {
        entries.push(KcEntry {
            doc: format!("-{}", location_doc(d, letter)),
            key: KcKey::Trans,
            axis: Some(d.letter()),
            value: KcValue::Coord(-coord(d, v)),
        });
    }
    if place == Placement::After {
        entries.extend(components);
    }
    tables.push(KcTable {
        name,
        axis: letter,
        positions: errors.positions.clone(),
        positioning,
        columns,
    });
}

/// A location error's name without the leading `E` (`X0C`, `C0Y`), as ISO 230-1 lists them.
fn location_doc(d: Direction, axis: char) -> String {
    format!("{}0{axis}", d.letter())
}

/// Checks `kc` against `limits`: entry counts, references, table shapes, plausible values.
pub fn validate_kinematics_comp(
    kc: &KinematicsComp,
    limits: &KcLimits,
) -> Result<(), CompensateError> {
    let (comptab, coord, machaxis) = kc.counts();
    if comptab + machaxis > limits.max_comptab_with_machaxis {
        return Err(HeidenhainLimit::TooManyComptab {
            comptab,
            machaxis,
            max: limits.max_comptab_with_machaxis,
        }
        .into());
    }
    if coord > limits.max_coord {
        return Err(HeidenhainLimit::TooManyCoord {
            coord,
            max: limits.max_coord,
        }
        .into());
    }
    for t in &kc.tables {
        validate_table(t, limits)?;
    }
    for (n, e) in kc.entries.iter().enumerate() {
        validate_entry(kc, n, e, limits)?;
    }
    Ok(())
}

fn validate_entry(
    kc: &KinematicsComp,
    n: usize,
    e: &KcEntry,
    limits: &KcLimits,
) -> Result<(), HeidenhainLimit> {
    let bad = |what: String| HeidenhainLimit::Entry {
        entry: n,
        doc: e.doc.clone(),
        what,
    };
    match (e.key, e.axis, &e.value) {
        (KcKey::MachBase, None, KcValue::None) => Ok(()),
        (KcKey::MachAxis, Some(a), KcValue::None) if "XYZUVWABC".contains(a) => Ok(()),
        (KcKey::Trans, Some(a), KcValue::Coord(v)) if TRANS_AXES.contains(&a) => {
            let (max, unit) = if "XYZ".contains(a) {
                (limits.max_abs_mm, "mm")
            } else {
                (limits.max_abs_deg, "degrees")
            };
            if v.is_finite() && v.abs() <= max {
                Ok(())
            } else {
                Err(bad(format!(
                    "{v} {unit} is larger than {max} {unit} (is it in the wrong unit?)"
                )))
            }
        }
        (KcKey::Trans, Some(a), KcValue::Comptab { table, column }) if TRANS_AXES.contains(&a) => {
            if !(1..=6).contains(column) {
                return Err(bad(format!("column C{column} does not exist (C1 to C6)")));
            }
            if !kc.tables.iter().any(|t| &t.name == table) {
                return Err(bad(format!("no table {table}")));
            }
            Ok(())
        }
        _ => Err(bad(format!(
            "{} with AXIS {} and {:?} is not an entry of a kinematics description",
            e.key.text(),
            e.axis.map_or("-".to_string(), |a| a.to_string()),
            e.value
        ))),
    }
}

fn validate_table(t: &KcTable, limits: &KcLimits) -> Result<(), HeidenhainLimit> {
    let shape = |what: String| HeidenhainLimit::Shape {
        table: t.name.clone(),
        what,
    };
    if t.positions.is_empty() {
        return Err(shape("a table needs at least one row".into()));
    }
    if t.positioning.len() != t.positions.len() {
        return Err(shape(format!(
            "column {} has {} values for {} positions",
            t.axis,
            t.positioning.len(),
            t.positions.len()
        )));
    }
    for (k, c) in t.columns.iter().enumerate() {
        if c.len() != t.positions.len() {
            return Err(shape(format!(
                "column C{} has {} values for {} positions",
                k + 1,
                c.len(),
                t.positions.len()
            )));
        }
    }
    for row in 1..t.positions.len() {
        if t.positions[row].partial_cmp(&t.positions[row - 1]) != Some(std::cmp::Ordering::Greater)
        {
            return Err(HeidenhainLimit::NotAscending {
                table: t.name.clone(),
                row,
                position: t.positions[row],
                previous_row: row - 1,
                previous: t.positions[row - 1],
            });
        }
    }
    let own = if "ABC".contains(t.axis) {
        (limits.max_abs_deg, "degrees")
    } else {
        (limits.max_abs_mm, "mm")
    };
    let columns = t.columns.iter().enumerate().map(|(k, c)| {
        let limit = if k < 3 {
            (limits.max_abs_mm, "mm")
        } else {
            (limits.max_abs_deg, "degrees")
        };
        (format!("C{}", k + 1), c, limit)
    });
    for (column, c, (max, unit)) in
        std::iter::once((t.axis.to_string(), &t.positioning, own)).chain(columns)
    {
        for (row, &value) in c.iter().enumerate() {
            if !value.is_finite() || value.abs() > max {
                return Err(HeidenhainLimit::ValueTooLarge {
                    table: t.name.clone(),
                    column: column.clone(),
                    row,
                    value,
                    max,
                    unit,
                });
            }
        }
    }
    Ok(())
}

/// Writes the tables of `kc` beside `path` (`KC_X.COM` …), the `.CMA` that activates their
/// positioning columns (`path` with the suffix `.CMA`), then the description listing (`path`, a
/// `.TAB`), then the convention card (`card_path(path)`), each atomically, after checking `kc`
/// against `limits`. Returns the files written.
pub fn write_kinematics_comp(
    path: &Path,
    kc: &KinematicsComp,
    limits: &KcLimits,
    made_from: &[String],
) -> Result<Vec<PathBuf>, CompensateError> {
    validate_kinematics_comp(kc, limits)?;
    let name = table_file_name(path, "TAB")?;
    let cma_path = kinematics_comp_cma(path);
    let cma_name = table_file_name(&cma_path, "CMA")?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut written = Vec::new();
    for t in &kc.tables {
        let p = dir.join(&t.name);
        write_file(&p, &kc_table_text(t))?;
        written.push(p);
    }
    let assigned: Vec<(char, &str)> = kc
        .tables
        .iter()
        .map(|t| (t.axis, t.name.as_str()))
        .collect();
    write_file(&cma_path, &cma_text(&cma_name, &assigned))?;
    written.push(cma_path);
    write_file(path, &listing_text(&name, kc))?;
    written.push(path.to_path_buf());
    written.push(super::write_card(
        path,
        &name,
        &ConventionCard {
            made_from: made_from.to_vec(),
            ..kinematics_comp_card(kc)
        },
        &kc.note,
    )?);
    Ok(written)
}

/// The `.CMA` written beside a description: its name with the suffix `.CMA` (`.cma` when the
/// description's suffix is in lower case).
pub fn kinematics_comp_cma(path: &Path) -> PathBuf {
    let lower = path
        .extension()
        .is_some_and(|e| e.to_string_lossy().chars().any(|c| c.is_ascii_lowercase()));
    path.with_extension(if lower { "cma" } else { "CMA" })
}

/// The written precision: 7 decimals (0.1 nm; 1.7 nrad in degrees).
fn number(v: f64) -> String {
    let s = format!("{v:.7}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0.0000000".into()
    } else {
        s
    }
}

fn kc_table_text(t: &KcTable) -> String {
    let own = t.axis.to_string();
    let columns = ["NR", "AXISPOS", &own, "C1", "C2", "C3", "C4", "C5", "C6"];
    let rows = t
        .positions
        .iter()
        .enumerate()
        .map(|(r, p)| {
            let mut row = vec![r.to_string(), format!("{p:.6}"), number(t.positioning[r])];
            row.extend(t.columns.iter().map(|c| number(c[r])));
            row
        })
        .collect();
    table_text(&TableOut {
        name: &t.name,
        columns: &columns,
        rows,
    })
}

fn listing_text(name: &str, kc: &KinematicsComp) -> String {
    let columns = ["NR", "DOC", "KEY", "AXIS", "COORD", "COMPTAB"];
    let rows = kc
        .entries
        .iter()
        .enumerate()
        .map(|(n, e)| {
            let (coord, comptab) = match &e.value {
                KcValue::None => (String::new(), String::new()),
                KcValue::Coord(v) => (number(*v), String::new()),
                KcValue::Comptab { table, column } => (String::new(), format!("{table}:C{column}")),
            };
            vec![
                n.to_string(),
                e.doc.clone(),
                e.key.text().to_string(),
                e.axis.map_or(String::new(), |a| a.to_string()),
                coord,
                comptab,
            ]
        })
        .collect();
    table_text(&TableOut {
        name,
        columns: &columns,
        rows,
    })
}

/// Reads a KinematicsComp description (`.TAB`), the `.CMA` beside it
/// ([`kinematics_comp_cma`]) and the `.COM` tables the `.CMA` assigns, from its folder. Every
/// problem names the file, line and column.
pub fn read_kinematics_comp(path: &Path) -> Result<KinematicsComp, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let table = parse_table(&src, &text, "TAB")?;
    let col = |name: &str| {
        table
            .column(name)
            .ok_or_else(|| src.error(table.header_line, 1, format!("expected a column {name}")))
    };
    let (key, axis, coord, comptab) = (col("KEY")?, col("AXIS")?, col("COORD")?, col("COMPTAB")?);
    let doc = table.column("DOC");
    let mut entries = Vec::with_capacity(table.rows.len());
    // Each table the description uses, with the first line and column that names it.
    let mut used: Vec<(String, usize, usize)> = Vec::new();
    for row in &table.rows {
        let c = |k: usize| row.cells[k];
        let k = match c(key).text {
            "Trans" => KcKey::Trans,
            "MachAxis" => KcKey::MachAxis,
            "MachBase" => KcKey::MachBase,
            other => {
                return Err(src.error(
                    row.line,
                    c(key).column,
                    format!("expected Trans, MachAxis or MachBase, found `{other}`"),
                ));
            }
        };
        let a = entry_axis(&src, row.line, c(axis), k)?;
        let value = entry_value(&src, row.line, k, c(coord), c(comptab))?;
        if let KcValue::Comptab { table: t, .. } = &value
            && !used.iter().any(|(u, ..)| u == t)
        {
            used.push((t.clone(), row.line, c(comptab).column));
        }
        entries.push(KcEntry {
            doc: doc.map_or(String::new(), |d| c(d).text.to_string()),
            key: k,
            axis: a,
            value,
        });
    }
    // The `.CMA` beside the description assigns each table to the axis its rows follow.
    let cma = kinematics_comp_cma(path);
    let assigned = read_cma(&cma)?;
    let owner = |t: &str| {
        assigned
            .iter()
            .find(|(_, name)| name.eq_ignore_ascii_case(t))
            .map(|(axis, _)| *axis)
    };
    if let Some((t, line, column)) = used.iter().find(|(t, ..)| owner(t).is_none()) {
        return Err(src.error(
            *line,
            *column,
            format!(
                "{t} is not assigned to an axis by the active line of {}",
                cma.display()
            ),
        ));
    }
    let mut used: Vec<String> = used.into_iter().map(|(t, ..)| t).collect();
    // The tables in the order the description first uses them, then any the `.CMA` adds (a
    // table of positioning errors alone).
    for (_, name) in &assigned {
        if !used.iter().any(|u| u.eq_ignore_ascii_case(name)) {
            used.push(name.clone());
        }
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut tables = Vec::with_capacity(used.len());
    for name in used {
        let axis = owner(&name).expect("every used table is assigned");
        tables.push(read_kc_table(&dir.join(&name), axis)?);
    }
    Ok(KinematicsComp {
        entries,
        tables,
        note: String::new(),
    })
}

fn entry_axis(
    src: &Source<'_>,
    line: usize,
    f: Field<'_>,
    key: KcKey,
) -> Result<Option<char>, CompensateError> {
    let allowed: &str = match key {
        KcKey::MachBase => "",
        KcKey::MachAxis => "XYZUVWABC",
        KcKey::Trans => "XYZABC",
    };
    if key == KcKey::MachBase {
        return if f.text.is_empty() {
            Ok(None)
        } else {
            Err(src.error(
                line,
                f.column,
                format!("expected no AXIS for MachBase, found `{}`", f.text),
            ))
        };
    }
    let mut chars = f.text.chars();
    match (chars.next(), chars.next()) {
        (Some(a), None) if allowed.contains(a) => Ok(Some(a)),
        _ => Err(src.error(
            line,
            f.column,
            format!(
                "expected one of {allowed} in AXIS for {}, found `{}`",
                key.text(),
                f.text
            ),
        )),
    }
}

fn entry_value(
    src: &Source<'_>,
    line: usize,
    key: KcKey,
    coord: Field<'_>,
    comptab: Field<'_>,
) -> Result<KcValue, CompensateError> {
    match (key, coord.text.is_empty(), comptab.text.is_empty()) {
        (KcKey::Trans, false, true) => Ok(KcValue::Coord(src.number(line, coord)?)),
        (KcKey::Trans, true, false) => {
            let parsed = comptab.text.rsplit_once(":C").and_then(|(t, c)| {
                let column: usize = c.parse().ok()?;
                let is_com = t
                    .rsplit_once('.')
                    .is_some_and(|(stem, s)| !stem.is_empty() && s.eq_ignore_ascii_case("COM"));
                (is_com && (1..=6).contains(&column)).then(|| (t.to_string(), column))
            });
            match parsed {
                Some((table, column)) => Ok(KcValue::Comptab { table, column }),
                None => Err(src.error(
                    line,
                    comptab.column,
                    format!(
                        "expected `<table>.COM:C1` … `:C6` in COMPTAB, found `{}`",
                        comptab.text
                    ),
                )),
            }
        }
        (KcKey::Trans, true, true) => Err(src.error(
            line,
            coord.column,
            "expected a value in COORD or a table column in COMPTAB for Trans",
        )),
        (KcKey::Trans, false, false) => Err(src.error(
            line,
            comptab.column,
            "expected COORD or COMPTAB for Trans, not both",
        )),
        (_, true, true) => Ok(KcValue::None),
        (_, false, _) => Err(src.error(
            line,
            coord.column,
            format!("expected no COORD for {}", key.text()),
        )),
        (_, true, false) => Err(src.error(
            line,
            comptab.column,
            format!("expected no COMPTAB for {}", key.text()),
        )),
    }
}

/// Reads a KinematicsComp `.COM` table of `axis`: NR, AXISPOS, the axis' column, C1–C6.
fn read_kc_table(path: &Path, axis: char) -> Result<KcTable, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let table = parse_table(&src, &text, "COM")?;
    kc_table_from(&src, &table, axis)
}

fn kc_table_from(
    src: &Source<'_>,
    table: &TableIn<'_>,
    axis: char,
) -> Result<KcTable, CompensateError> {
    let hn = table.header_line;
    let need = |name: &str| {
        table
            .column(name)
            .ok_or_else(|| src.error(hn, 1, format!("expected a column {name}")))
    };
    let pos = need("AXISPOS")?;
    // The axis' own column (positioning) is optional: files of mtcal before it had none.
    let own = table.column(&axis.to_string());
    let mut cols = [0usize; 6];
    for (k, c) in cols.iter_mut().enumerate() {
        *c = need(&format!("C{}", k + 1))?;
    }
    let nr = table.column("NR");
    let positions = axis_positions(src, table, nr, pos)?;
    let mut columns: [Vec<f64>; 6] = Default::default();
    let mut positioning = Vec::with_capacity(table.rows.len());
    for row in &table.rows {
        positioning.push(match own {
            Some(c) => src.number(row.line, row.cells[c])?,
            None => 0.0,
        });
        for (k, &c) in cols.iter().enumerate() {
            columns[k].push(src.number(row.line, row.cells[c])?);
        }
    }
    if positions.is_empty() {
        return Err(src.error(table.end_line, 1, "expected at least one row before [END]"));
    }
    Ok(KcTable {
        name: table.name.clone(),
        axis,
        positions,
        positioning,
        columns,
    })
}

/// The convention card of a KinematicsComp description.
pub fn kinematics_comp_card(kc: &KinematicsComp) -> ConventionCard {
    let axis_mapping = kc
        .entries
        .iter()
        .filter(|e| e.key == KcKey::MachAxis)
        .filter_map(|e| e.axis)
        .map(|a| crate::AxisMap {
            mtcal: a,
            control: a.to_string(),
        })
        .collect();
    ConventionCard {
        made_from: Vec::new(),
        format: "Heidenhain iTNC 530 KinematicsComp: entries of the kinematics description \
                 (NR DOC KEY AXIS COORD COMPTAB) from the tool to the table, component errors as \
                 COMPTAB references to columns C1–C6 of one .COM table per axis, location errors \
                 as COORD values, positioning errors in the table's column named after its axis \
                 (assigned by a .CMA)"
            .into(),
        quantity: Quantity::Error,
        sign: "the entries describe the actual machine in the control's chain from the tool to \
               the table, each Trans the pose of what follows in the current frame (as the \
               manual's description places the B pivot +250.051 mm from the tool, p.670). One \
               convention for every entry: its DOC names the ISO 230-1 quantity its value is, \
               with its sign, in mtcal's values. COORD `X0C` before the axis holds +X0C and \
               `-X0C` after it −X0C (the scheme of p.684); a COMPTAB entry `-EYX` holds −EYX \
               (exactly the inverse of the axis' functional error written as Trans \
               X·Y·Z·A·B·C; to first order the negated errors), as in a chain read from the tool \
               an axis' error enters inverted. The manual labels C1–C6 by the errors (EYX …, \
               p.680) and adds EBX and B0X in one column (p.684), so its component columns may \
               carry the opposite sign to mtcal's: check one error on the machine before relying \
               on the sign. Positioning errors (EXX, ECC …) are in the column named after the \
               axis, as the manual assigns them (columns 1–18, p.686): the error, actual − \
               nominal in mtcal's axis coordinate, which the control's axis compensation \
               subtracts"
            .into(),
        squareness: format!(
            "{SQUARENESS_ISO}; written as COORD rotations before the linear axis and their \
             negation after it"
        ),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping,
        units: "COORD, C1–C3 and a linear axis' own column in mm, COORD rotations, C4–C6 and a \
                rotary axis' own column in degrees (7 decimals); AXISPOS in mm (linear) or \
                degrees (rotary) of mtcal's axis positions"
            .into(),
        control_will: vec![
            "use the entries only once they are inserted into the machine's kinematics \
             description with KinematicsComp enabled: the nominal Trans and MachAxis entries \
             are the control's own and are not written; each axis' entries stand where mtcal's \
             model defines its error: a linear axis' components move with its carriage (before \
             a tool-side axis' MachAxis, after a workpiece-side one's), a rotary axis' are on \
             the side that does not turn (before a table axis, after a head axis), the \
             location errors around the MachAxis"
                .into(),
            "take the positioning errors from the column named after each axis once the .CMA \
             written beside the description is active (one line assigning KC_<axis>.COM to \
             each axis, nonlinear axis compensation on); do not also activate the X.COM … set \
             of heidenhain-com, which holds the same positioning errors"
                .into(),
            "correct the tool centre point through its kinematics model, at a rate set by \
             MP4070 (p.671)"
                .into(),
            "refuse more than 100 COMPTAB entries including the MachAxis entries and more than \
             50 COORD entries (p.686)"
                .into(),
            "interpolate the COMPTAB tables between their rows; the layout of these .COM tables \
             (AXISPOS, C1–C6) and the COMPTAB reference `TABLE.COM:Cn` are assumptions, the \
             manual's pages on them were not available: check them in KinematicsDesign"
                .into(),
            "need every error in machine X/Y/Z at the zero pose; set-up offsets (tool length, \
             workpiece position) are not in the description"
                .into(),
        ],
    }
}
