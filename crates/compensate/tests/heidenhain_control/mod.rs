//! How a Heidenhain control reads and applies the files mtcal writes, written from the manuals,
//! not from the crate: shared by the format's tests (`heidenhain.rs`) and the chain from the
//! recordings to the control (`end_to_end.rs`), each of which uses part of it.
#![allow(dead_code)]

use mtcal_kinematics::{AxisKind, MachineModel, Side};
use nalgebra::{Matrix4, Rotation3, Unit, Vector3};
use std::collections::BTreeMap;
use std::path::Path;

/// A table as the control holds it: positions and one value column per axis letter.
pub struct ControlTable {
    pub positions_mm: Vec<f64>,
    pub columns: BTreeMap<char, Vec<f64>>,
}

/// Header and rows of a Heidenhain table whose cells are all filled: `BEGIN`, names, rows,
/// `[END]`.
pub fn tokens(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    assert!(lines.next().unwrap().starts_with("BEGIN "));
    let header = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(String::from)
        .collect();
    let rows = lines
        .take_while(|l| l.trim() != "[END]")
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect();
    (header, rows)
}

/// The active line of a `.CMA`: input axis → table file.
pub fn control_cma(text: &str) -> Vec<(char, String)> {
    let (header, rows) = tokens(text);
    let active = header.iter().position(|h| h == "ACTIVE").unwrap();
    let row = rows
        .iter()
        .find(|r| r[active] == "*")
        .expect("an active line");
    header
        .iter()
        .enumerate()
        .filter(|(_, h)| h.len() == 1)
        .map(|(k, h)| (h.chars().next().unwrap(), row[k].clone()))
        .collect()
}

pub fn control_com(text: &str) -> ControlTable {
    let (header, rows) = tokens(text);
    let pos = header.iter().position(|h| h == "AXISPOS").unwrap();
    let mut columns = BTreeMap::new();
    for (k, h) in header.iter().enumerate() {
        if h.len() == 1 {
            let v = rows.iter().map(|r| r[k].parse().unwrap()).collect();
            columns.insert(h.chars().next().unwrap(), v);
        }
    }
    ControlTable {
        positions_mm: rows.iter().map(|r| r[pos].parse().unwrap()).collect(),
        columns,
    }
}

/// Linear interpolation between rows, end values outside.
pub fn interpolate(x: &[f64], y: &[f64], at: f64) -> f64 {
    if at <= x[0] {
        return y[0];
    }
    if at >= x[x.len() - 1] {
        return y[y.len() - 1];
    }
    let k = x.windows(2).position(|w| at <= w[1]).unwrap();
    let t = (at - x[k]) / (x[k + 1] - x[k]);
    y[k] + t * (y[k + 1] - y[k])
}

/// Reads the written `.CMA` and its tables the control's way.
pub fn control_tables(cma: &Path) -> Vec<(char, ControlTable)> {
    let dir = cma.parent().unwrap();
    control_cma(&std::fs::read_to_string(cma).unwrap())
        .into_iter()
        .map(|(axis, file)| {
            let text = std::fs::read_to_string(dir.join(file)).unwrap();
            (axis, control_com(&text))
        })
        .collect()
}

/// One entry of the description as the control reads it.
pub enum Entry {
    Trans {
        axis: char,
        value: Value,
        /// The axis the entry goes with, as the card tells the user: the last letter of its
        /// DOC (`-EYX`, `X0C`, `-X0C`).
        owner: char,
    },
    MachAxis(char),
    MachBase,
}

pub enum Value {
    Coord(f64),
    Comptab { table: String, column: usize },
}

/// The description's entries: `NR DOC KEY [AXIS [COORD|COMPTAB]]` (empty cells are blank).
pub fn control_description(text: &str) -> Vec<Entry> {
    let (_, rows) = tokens(text);
    rows.iter()
        .map(|r| match r[2].as_str() {
            "MachBase" => Entry::MachBase,
            "MachAxis" => Entry::MachAxis(r[3].chars().next().unwrap()),
            "Trans" => {
                let v = &r[4];
                let value = match v.split_once(":C") {
                    Some((t, c)) => Value::Comptab {
                        table: t.to_string(),
                        column: c.parse().unwrap(),
                    },
                    None => Value::Coord(v.parse().unwrap()),
                };
                Entry::Trans {
                    axis: r[3].chars().next().unwrap(),
                    value,
                    owner: r[1].chars().last().unwrap(),
                }
            }
            other => panic!("unknown KEY {other}"),
        })
        .collect()
}

/// A KinematicsComp table: AXISPOS and C1–C6 rows.
pub fn control_kc_table(text: &str) -> (Vec<f64>, Vec<[f64; 6]>) {
    let (header, rows) = tokens(text);
    let at = |name: &str| header.iter().position(|h| h == name).unwrap();
    let pos = rows
        .iter()
        .map(|r| r[at("AXISPOS")].parse().unwrap())
        .collect();
    let cols = rows
        .iter()
        .map(|r| std::array::from_fn(|k| r[at(&format!("C{}", k + 1))].parse().unwrap()))
        .collect();
    (pos, cols)
}

pub fn translation(v: Vector3<f64>) -> Matrix4<f64> {
    Matrix4::new_translation(&v)
}

pub fn rotation(axis: Vector3<f64>, angle: f64) -> Matrix4<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle).to_homogeneous()
}

/// `Trans <axis> value` (mm or degrees) as a 4 × 4 pose of what follows.
pub fn trans(axis: char, value: f64) -> Matrix4<f64> {
    match axis {
        'X' => translation(Vector3::x() * value * 1e-3),
        'Y' => translation(Vector3::y() * value * 1e-3),
        'Z' => translation(Vector3::z() * value * 1e-3),
        'A' => rotation(Vector3::x(), value.to_radians()),
        'B' => rotation(Vector3::y(), value.to_radians()),
        'C' => rotation(Vector3::z(), value.to_radians()),
        _ => panic!("Trans {axis}"),
    }
}

pub fn homogeneous(r: &mtcal_kinematics::rigid::Rigid) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r.r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&r.t);
    m
}

/// Pose of the tool in the table frame from the description at axis positions `q` (SI):
/// the nominal chain (the control's own entries) with the description's entries inserted
/// before and after each MachAxis, each axis standing at `q` plus its positioning error from
/// the `.CMA`'s tables (`positioning`, SI); `with_errors` false leaves both out.
pub fn chain_tool_in_table(
    model: &MachineModel,
    description: &[Entry],
    tables: &BTreeMap<String, (Vec<f64>, Vec<[f64; 6]>)>,
    positioning: &[f64],
    q: &[f64],
    with_errors: bool,
) -> Matrix4<f64> {
    let m = model.machine();
    let motion = |i: usize| {
        let ax = &m.axes()[i];
        let at = q[i] + if with_errors { positioning[i] } else { 0.0 };
        match ax.kind() {
            AxisKind::Linear => translation(ax.direction() * at),
            AxisKind::Rotary => rotation(*ax.direction(), at),
        }
    };
    let value = |axis_index: usize, v: &Value| match v {
        Value::Coord(c) => *c,
        Value::Comptab { table, column } => {
            let (pos, rows) = &tables[table];
            let ax = &m.axes()[axis_index];
            let at = match ax.kind() {
                AxisKind::Linear => q[axis_index] * 1e3,
                AxisKind::Rotary => q[axis_index].to_degrees(),
            };
            let col: Vec<f64> = rows.iter().map(|r| r[column - 1]).collect();
            interpolate(pos, &col, at)
        }
    };
    // Split the description at its MachAxis/MachBase entries: an axis' entries are those
    // before it and those right after it whose DOC names it.
    let mut t = homogeneous(m.branch(Side::Tool).end())
        .try_inverse()
        .unwrap();
    let mut k = 0;
    let tool: Vec<usize> = m
        .branch(Side::Tool)
        .joints()
        .iter()
        .rev()
        .copied()
        .collect();
    let work: Vec<usize> = m.branch(Side::Workpiece).joints().to_vec();
    let apply = |t: &mut Matrix4<f64>, k: &mut usize, i: usize, side: Side| {
        let ax = &m.axes()[i];
        let origin = homogeneous(ax.origin());
        if side == Side::Workpiece {
            *t *= origin;
        }
        let inserted = |e: &Entry| match e {
            Entry::Trans { axis, value: v, .. } => trans(*axis, value(i, v)),
            _ => unreachable!(),
        };
        while let Entry::Trans { owner, .. } = &description[*k] {
            assert_eq!(*owner, ax.letter().as_char(), "entry {k} before its axis");
            if with_errors {
                *t *= inserted(&description[*k]);
            }
            *k += 1;
        }
        let Entry::MachAxis(letter) = description[*k] else {
            panic!("expected MachAxis {}", ax.letter().as_char())
        };
        assert_eq!(letter, ax.letter().as_char(), "the chain's axis order");
        *k += 1;
        *t *= match side {
            Side::Tool => motion(i).try_inverse().unwrap(),
            Side::Workpiece => motion(i),
        };
        while let Some(Entry::Trans { owner, .. }) = description.get(*k)
            && *owner == ax.letter().as_char()
        {
            if with_errors {
                *t *= inserted(&description[*k]);
            }
            *k += 1;
        }
        if side == Side::Tool {
            *t *= origin.try_inverse().unwrap();
        }
    };
    for &i in &tool {
        apply(&mut t, &mut k, i, Side::Tool);
    }
    assert!(
        matches!(description[k], Entry::MachBase),
        "MachBase between the branches"
    );
    k += 1;
    for &i in &work {
        apply(&mut t, &mut k, i, Side::Workpiece);
    }
    assert_eq!(k, description.len(), "every entry used");
    t *= homogeneous(m.branch(Side::Workpiece).end());
    // `t` is tool_T_table; the tool's pose in the table frame is its inverse.
    t.try_inverse().unwrap()
}

/// A KinematicsComp set as the control holds it: the description, its COMPTAB tables and the
/// tables the `.CMA` beside it activates (their columns named after axes: positioning).
pub struct KcControl {
    pub description: Vec<Entry>,
    pub tables: BTreeMap<String, (Vec<f64>, Vec<[f64; 6]>)>,
    pub assigned: Vec<(char, ControlTable)>,
}

impl KcControl {
    /// Reads the description `tab` (`NAME.TAB`), its tables and `NAME.CMA` from their folder.
    pub fn read(tab: &Path) -> Self {
        let dir = tab.parent().unwrap();
        let description = control_description(&std::fs::read_to_string(tab).unwrap());
        let mut tables = BTreeMap::new();
        for e in &description {
            if let Entry::Trans {
                value: Value::Comptab { table, .. },
                ..
            } = e
            {
                let text = std::fs::read_to_string(dir.join(table)).unwrap();
                tables.insert(table.clone(), control_kc_table(&text));
            }
        }
        let stem = tab.file_stem().unwrap().to_string_lossy();
        let assigned = control_tables(&dir.join(format!("{stem}.CMA")));
        KcControl {
            description,
            tables,
            assigned,
        }
    }

    /// Each axis' positioning error (SI) at `q`: the columns named after it, summed over the
    /// active tables at their input axes' positions, as the nonlinear compensation adds them.
    pub fn positioning(&self, model: &MachineModel, q: &[f64]) -> Vec<f64> {
        let m = model.machine();
        let file_unit = |i: usize| match m.axes()[i].kind() {
            AxisKind::Linear => 1e3,
            AxisKind::Rotary => 1f64.to_degrees(),
        };
        let mut v = vec![0.0; m.n_axes()];
        for (input, t) in &self.assigned {
            let k = m.axis_index(*input).unwrap();
            for (axis, column) in &t.columns {
                let j = m.axis_index(*axis).unwrap();
                v[j] += interpolate(&t.positions_mm, column, q[k] * file_unit(k)) / file_unit(j);
            }
        }
        v
    }

    /// The tool's pose in the table frame the control's description gives at axis positions
    /// `q` (SI): the machine as the control believes it stands.
    pub fn tool_in_table(&self, model: &MachineModel, q: &[f64]) -> Matrix4<f64> {
        let v = self.positioning(model, q);
        chain_tool_in_table(model, &self.description, &self.tables, &v, q, true)
    }
}
