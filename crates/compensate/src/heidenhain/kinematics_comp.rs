//! KinematicsComp (iTNC 530): the identified ISO 230-1 errors as entries of the kinematics
//! description, component errors as COMPTAB references to columns C1–C6 of one `.COM` table
//! per axis, location errors as COORD values. Conventions in the module documentation of
//! `heidenhain`.

use super::HeidenhainLimit;
use super::table::{TableIn, TableOut, axis_positions, parse_table, table_text};
use crate::parameters::{ParameterValue, error_parameters};
use crate::text::{Field, Source};
use crate::{CompensateError, MM, read_file, write_file};
use mtcal_kinematics::model::default_stroke;
use mtcal_kinematics::rigid::{Rigid, axis_rotation, exp_so3};
use mtcal_kinematics::{AxisKind, Direction, MachineModel, ParamName, Side};
use mtcal_machine::card::{ConventionCard, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;
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

/// The KinematicsComp description of `model` with coefficients `coeffs` (SI): each axis' six
/// component errors as the chain transformation placed just before its `MachAxis` (columns
/// C1–C6 of `KC_<axis>.COM`, rows at the nodes [`error_parameters`] uses: `spacing_mm` apart
/// over a linear stroke, `spacing_deg` over a rotary axis' range), its location errors as COORD
/// entries around it. Needs joint frames parallel to the machine frame at the zero pose (the
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

/// The transformation just before axis `i`'s `MachAxis` (chain from the tool to the table,
/// each entry the next element's pose in the current frame) that makes the chain the model's:
/// the inverse of the axis' functional error `E = (exp(ε), δ)`, moved across the axis' motion
/// where the model has it on the other side (workpiece-side linear axes, tool-side rotary
/// axes).
fn chain_factor(model: &MachineModel, i: usize, q: f64, c: &[f64; 6], l: &Rigid) -> Rigid {
    let ax = &model.machine().axes()[i];
    let e_inv = Rigid::new(
        exp_so3(&Vector3::new(c[3], c[4], c[5])),
        Vector3::new(c[0], c[1], c[2]),
    )
    .inverse();
    let a = ax.direction();
    let across = match (ax.kind(), ax.side()) {
        (AxisKind::Linear, Side::Tool) | (AxisKind::Rotary, Side::Workpiece) => return e_inv,
        (AxisKind::Linear, Side::Workpiece) => Rigid::translation(l.r * a * q),
        (AxisKind::Rotary, Side::Tool) => l
            .compose(&Rigid::rotation(axis_rotation(a, -q)))
            .compose(&l.inverse()),
    };
    across.compose(&e_inv).compose(&across.inverse())
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
    let si = match ax.kind() {
        AxisKind::Linear => 1.0 / MM,
        AxisKind::Rotary => 1f64.to_radians(),
    };
    let mut columns: [Vec<f64>; 6] = Default::default();
    for (p, c) in errors.positions.iter().zip(&errors.components) {
        let f = chain_factor(model, i, p * si, c, &l);
        let abc = euler_xyz(&f.r);
        for k in 0..3 {
            columns[k].push(f.t[k] * MM);
            columns[3 + k].push(abc[k].to_degrees());
        }
    }
    for (k, &t) in TRANS_AXES.iter().enumerate() {
        entries.push(KcEntry {
            doc: ParamName::component(Direction::ALL[k], ax.letter()).to_string(),
            key: KcKey::Trans,
            axis: Some(t),
            value: KcValue::Comptab {
                table: name.clone(),
                column: k + 1,
            },
        });
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
    tables.push(KcTable {
        name,
        axis: letter,
        positions: errors.positions.clone(),
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
    for (k, c) in t.columns.iter().enumerate() {
        let (max, unit) = if k < 3 {
            (limits.max_abs_mm, "mm")
        } else {
            (limits.max_abs_deg, "degrees")
        };
        for (row, &value) in c.iter().enumerate() {
            if !value.is_finite() || value.abs() > max {
                return Err(HeidenhainLimit::ValueTooLarge {
                    table: t.name.clone(),
                    column: format!("C{}", k + 1),
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

/// Writes the tables of `kc` beside `path` (`KC_X.COM` …), then the description listing
/// (`path`, a `.TAB`), then the convention card (`card_path(path)`), each atomically, after
/// checking `kc` against `limits`. Returns the files written.
pub fn write_kinematics_comp(
    path: &Path,
    kc: &KinematicsComp,
    limits: &KcLimits,
    made_from: &[String],
) -> Result<Vec<PathBuf>, CompensateError> {
    validate_kinematics_comp(kc, limits)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_uppercase())
        .unwrap_or_default();
    if !(name.ends_with(".TAB") && name.len() > 4 && name.is_ascii() && !name.contains(' ')) {
        return Err(HeidenhainLimit::Shape {
            table: path.display().to_string(),
            what: "the description needs an ASCII file name without blanks ending in .TAB".into(),
        }
        .into());
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut written = Vec::new();
    for t in &kc.tables {
        let p = dir.join(&t.name);
        write_file(&p, &kc_table_text(t))?;
        written.push(p);
    }
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
    let columns = ["NR", "AXISPOS", "C1", "C2", "C3", "C4", "C5", "C6"];
    let rows = t
        .positions
        .iter()
        .enumerate()
        .map(|(r, p)| {
            let mut row = vec![r.to_string(), format!("{p:.6}")];
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

/// Reads a KinematicsComp description (`.TAB`) and the `.COM` tables its COMPTAB entries name,
/// from its folder. Every problem names the file, line and column.
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
    // Tables by name: the line that first uses each (the tables' order).
    let mut used: BTreeMap<String, usize> = BTreeMap::new();
    let mut pending: Vec<(String, usize, Field<'_>)> = Vec::new();
    let mut owner: BTreeMap<String, char> = BTreeMap::new();
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
        if let KcValue::Comptab { table: t, .. } = &value {
            used.entry(t.clone()).or_insert(row.line);
            pending.push((t.clone(), row.line, c(comptab)));
        }
        if k == KcKey::MachAxis {
            let letter = a.expect("MachAxis has an axis");
            for (t, line, f) in pending.drain(..) {
                match owner.get(&t) {
                    Some(&other) if other != letter => {
                        return Err(src.error(
                            line,
                            f.column,
                            format!(
                                "{t} is used before MachAxis {letter} here and before MachAxis \
                                 {other} elsewhere: a table belongs to one axis"
                            ),
                        ));
                    }
                    _ => {
                        owner.insert(t, letter);
                    }
                }
            }
        }
        entries.push(KcEntry {
            doc: doc.map_or(String::new(), |d| c(d).text.to_string()),
            key: k,
            axis: a,
            value,
        });
    }
    if let Some((t, line, f)) = pending.first() {
        return Err(src.error(
            *line,
            f.column,
            format!("{t} is used after the last MachAxis: its entries must come before an axis"),
        ));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut tables = Vec::with_capacity(owner.len());
    for (name, axis) in owner {
        tables.push(read_kc_table(&dir.join(&name), axis)?);
    }
    // Order the tables as the description first uses them.
    tables.sort_by_key(|t| used.get(&t.name).copied());
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

/// Reads a KinematicsComp `.COM` table of `axis`: NR, AXISPOS, C1–C6.
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
    let mut cols = [0usize; 6];
    for (k, c) in cols.iter_mut().enumerate() {
        *c = need(&format!("C{}", k + 1))?;
    }
    let nr = table.column("NR");
    let positions = axis_positions(src, table, nr, pos)?;
    let mut columns: [Vec<f64>; 6] = Default::default();
    for row in &table.rows {
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
                 as COORD values"
            .into(),
        quantity: Quantity::Error,
        sign: "the entries describe the actual machine in the control's chain from the tool to \
               the table, each Trans the pose of what follows in the current frame (as the \
               manual's description places the B pivot +250.051 mm from the tool, p.670); \
               location errors keep their ISO 230-1 value before the axis and are negated after \
               it (p.684); the six COMPTAB columns of an axis are the transformation placed \
               before its MachAxis, which is the inverse of mtcal's functional error (C1 ≈ −EXX, \
               C2 ≈ −EYX …), for workpiece-side linear and tool-side rotary axes carried across \
               the axis' motion (adding the Abbe terms of its angular errors)"
            .into(),
        squareness: format!(
            "{SQUARENESS_ISO}; written as COORD rotations before the linear axis and their \
             negation after it"
        ),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping,
        units: "COORD and C1–C3 in mm, COORD rotations and C4–C6 in degrees (7 decimals); \
                AXISPOS in mm (linear) or degrees (rotary) of mtcal's axis positions"
            .into(),
        control_will: vec![
            "use the entries only once they are inserted into the machine's kinematics \
             description with KinematicsComp enabled: the nominal Trans and MachAxis entries \
             are the control's own and are not written, each axis' error entries go directly \
             before its MachAxis"
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
