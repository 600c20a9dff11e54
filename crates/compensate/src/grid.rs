//! 3-D grids of tool-point error vectors over the X/Y/Z strokes, CSV, trilinear interpolation.

use crate::text::{Source, csv_fields, data_lines};
use crate::{
    CompensateError, MAX_NODES, MM, UM, bracket, check_inputs, default_hold, linear_axis, nodes_mm,
    read_file, write_file,
};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use mtcal_machine::card::{ConventionCard, Quantity, ROTARY_RIGHT_HAND};
use std::fmt::Write as _;
use std::path::Path;

const HEADER: [&str; 6] = ["X", "Y", "Z", "dx_um", "dy_um", "dz_um"];
const HEADER_ORIENTATION: [&str; 3] = ["da_urad", "db_urad", "dc_urad"];

/// What grid to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct GridSpec {
    /// Node spacing along X, Y, Z (mm); nodes from the lower limit, plus the upper limit.
    pub spacing_mm: [f64; 3],
    /// Positions (SI, canonical axis order) of the axes the grid does not span: rotary axes
    /// and any linear axis other than X, Y, Z. The X, Y, Z entries are ignored.
    pub hold_q: Vec<f64>,
    /// Whether to add the orientation error columns.
    pub orientation: bool,
}

impl GridSpec {
    /// `spacing_mm` on X, Y, Z; other axes as [`default_hold`] (rotary axes at 0);
    /// orientation columns when the machine has a rotary axis.
    pub fn new(machine: &Machine, spacing_mm: [f64; 3]) -> Self {
        GridSpec {
            spacing_mm,
            hold_q: default_hold(machine),
            orientation: machine.axes().iter().any(|a| a.kind() == AxisKind::Rotary),
        }
    }
}

/// Errors of the tool relative to the workpiece at the nodes of an X/Y/Z grid. Node
/// `(i, j, k)` is entry `(i·ny + j)·nz + k` (X slowest, Z fastest).
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorGrid {
    pub x_mm: Vec<f64>,
    pub y_mm: Vec<f64>,
    pub z_mm: Vec<f64>,
    /// Tool-point error (µm, workpiece frame): the negated compensation.
    pub error_um: Vec<[f64; 3]>,
    /// Orientation error (µrad, rotation vector in the workpiece frame), if evaluated.
    pub error_urad: Option<Vec<[f64; 3]>>,
    /// Comment lines the writer puts above the header (machine, held axes); not read back.
    pub note: String,
}

impl ErrorGrid {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.error_um.len()
    }

    pub fn is_empty(&self) -> bool {
        self.error_um.is_empty()
    }

    /// Entry index of node `(i, j, k)`.
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.y_mm.len() + j) * self.z_mm.len() + k
    }

    /// Node `index`'s position (mm).
    pub fn position_mm(&self, index: usize) -> [f64; 3] {
        let (ny, nz) = (self.y_mm.len(), self.z_mm.len());
        [
            self.x_mm[index / (ny * nz)],
            self.y_mm[(index / nz) % ny],
            self.z_mm[index % nz],
        ]
    }

    /// Trilinear interpolation of the tool-point error (µm) at `p_mm`; clamped outside.
    pub fn error_at_um(&self, p_mm: [f64; 3]) -> [f64; 3] {
        self.trilinear(&self.error_um, p_mm)
    }

    /// The compensation (µm) at `p_mm`: `−error_at_um`.
    pub fn compensation_at_um(&self, p_mm: [f64; 3]) -> [f64; 3] {
        self.error_at_um(p_mm).map(|e| -e)
    }

    /// Trilinear interpolation of the orientation error (µrad), if the grid has it.
    pub fn error_at_urad(&self, p_mm: [f64; 3]) -> Option<[f64; 3]> {
        self.error_urad.as_ref().map(|v| self.trilinear(v, p_mm))
    }

    fn trilinear(&self, v: &[[f64; 3]], p_mm: [f64; 3]) -> [f64; 3] {
        let (i, tx) = bracket(&self.x_mm, p_mm[0]);
        let (j, ty) = bracket(&self.y_mm, p_mm[1]);
        let (k, tz) = bracket(&self.z_mm, p_mm[2]);
        let mut out = [0.0; 3];
        for (di, wx) in [(0, 1.0 - tx), (1, tx)] {
            for (dj, wy) in [(0, 1.0 - ty), (1, ty)] {
                for (dk, wz) in [(0, 1.0 - tz), (1, tz)] {
                    let w = wx * wy * wz;
                    if w == 0.0 {
                        continue;
                    }
                    let e = v[self.index(i + di, j + dj, k + dk)];
                    for (o, e) in out.iter_mut().zip(e) {
                        *o += w * e;
                    }
                }
            }
        }
        out
    }
}

/// The error grid of `spec`: exact pose errors ([`MachineModel::pose_error`]) at every node.
/// The machine needs linear axes X, Y and Z.
pub fn error_grid(
    model: &MachineModel,
    coeffs: &[f64],
    spec: &GridSpec,
) -> Result<ErrorGrid, CompensateError> {
    check_inputs(model, coeffs, &spec.hold_q)?;
    let machine = model.machine();
    let not_xyz = || CompensateError::NotXyz {
        letters: machine.letters(),
    };
    let mut idx = [0; 3];
    let mut nodes: [Vec<f64>; 3] = Default::default();
    for (d, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let (i, lo, hi) = match linear_axis(machine, letter) {
            Ok(v) => v,
            Err(_) => return Err(not_xyz()),
        };
        idx[d] = i;
        nodes[d] = nodes_mm(lo, hi, spec.spacing_mm[d], &format!("grid along {letter}"))?;
    }
    let total = nodes.iter().map(Vec::len).product::<usize>();
    if total > MAX_NODES {
        let what = "3-D error grid".to_string();
        let (nodes, max) = (total, MAX_NODES);
        return Err(CompensateError::TooManyNodes { what, nodes, max });
    }
    let [x_mm, y_mm, z_mm] = nodes;
    let mut grid = ErrorGrid {
        error_um: Vec::with_capacity(total),
        error_urad: spec.orientation.then(|| Vec::with_capacity(total)),
        note: grid_note(machine, &spec.hold_q, &idx),
        x_mm,
        y_mm,
        z_mm,
    };
    fill(model, coeffs, &spec.hold_q, idx, &mut grid);
    Ok(grid)
}

/// Evaluates every node into `grid`'s (empty, preallocated) outputs.
fn fill(
    model: &MachineModel,
    coeffs: &[f64],
    hold_q: &[f64],
    idx: [usize; 3],
    grid: &mut ErrorGrid,
) {
    let mut q = hold_q.to_vec();
    let mut ws = model.workspace();
    for &x in &grid.x_mm {
        q[idx[0]] = x / MM;
        for &y in &grid.y_mm {
            q[idx[1]] = y / MM;
            for &z in &grid.z_mm {
                q[idx[2]] = z / MM;
                let e = model.pose_error(&q, coeffs, &mut ws);
                grid.error_um.push((e.translation * UM).into());
                if let Some(r) = grid.error_urad.as_mut() {
                    r.push((e.rotation * UM).into());
                }
            }
        }
    }
}

/// `machine: …` and `held: A = … deg` comment text (axes other than X, Y, Z).
fn grid_note(machine: &Machine, hold_q: &[f64], xyz: &[usize; 3]) -> String {
    let held: Vec<String> = machine
        .axes()
        .iter()
        .zip(hold_q)
        .enumerate()
        .filter(|(k, _)| !xyz.contains(k))
        .map(|(_, (a, &v))| {
            let letter = a.letter();
            if letter.is_rotary() {
                format!("{} = {:.6} deg", letter.as_char(), v.to_degrees())
            } else {
                format!("{} = {:.6} mm", letter.as_char(), v * MM)
            }
        })
        .collect();
    let held = if held.is_empty() {
        "none".to_string()
    } else {
        held.join(", ")
    };
    format!("machine: {}\nheld: {held}", machine.name())
}

/// Writes `grid` as CSV (see the crate doc), atomically.
pub fn write_grid_csv(path: &Path, grid: &ErrorGrid) -> Result<(), CompensateError> {
    let mut text = String::from(
        "# mtcal error grid: X,Y,Z axis positions (mm); dx_um..dz_um tool-point ERROR (um) of \
         the tool relative to the workpiece, workpiece frame; da_urad..dc_urad orientation error \
         (urad); compensation = -error; X slowest, Z fastest\n",
    );
    for l in grid.note.lines() {
        let _ = writeln!(text, "# {l}");
    }
    let mut header = HEADER.join(",");
    if grid.error_urad.is_some() {
        header = format!("{header},{}", HEADER_ORIENTATION.join(","));
    }
    let _ = writeln!(text, "{header}");
    for (n, e) in grid.error_um.iter().enumerate() {
        let [x, y, z] = grid.position_mm(n);
        let _ = write!(
            text,
            "{x:.6},{y:.6},{z:.6},{:.6},{:.6},{:.6}",
            e[0], e[1], e[2]
        );
        if let Some(r) = &grid.error_urad {
            let r = r[n];
            let _ = write!(text, ",{:.6},{:.6},{:.6}", r[0], r[1], r[2]);
        }
        text.push('\n');
    }
    write_file(path, &text)
}

/// A grid row as read: line number, column of X, position, values.
struct Row {
    line: usize,
    column: usize,
    p: [f64; 3],
    v: [f64; 6],
}

/// Reads a CSV error grid (either header).
pub fn read_grid_csv(path: &Path) -> Result<ErrorGrid, CompensateError> {
    let text = read_file(path)?;
    let src = Source { file: path };
    let mut lines = data_lines(&text, true);
    let full: Vec<&str> = HEADER.iter().chain(&HEADER_ORIENTATION).copied().collect();
    let Some((hn, header)) = lines.next() else {
        return Err(src.error(1, 1, format!("expected the header `{}`", HEADER.join(","))));
    };
    let names: Vec<&str> = csv_fields(header).iter().map(|f| f.text.trim()).collect();
    let orientation = names == full;
    if !orientation && names != HEADER {
        let msg = format!(
            "expected the header `{}` or `{}`",
            HEADER.join(","),
            full.join(",")
        );
        return Err(src.error(hn, 1, msg));
    }
    let width = names.len();
    let mut rows = Vec::new();
    for (n, line) in lines {
        let fields = csv_fields(line);
        src.expect_fields(n, line, &fields, width, "the header's columns")?;
        let mut vals = [0.0; 9];
        for (v, f) in vals.iter_mut().zip(&fields) {
            *v = src.number(n, *f)?;
        }
        let (p, v) = vals.split_at(3);
        rows.push(Row {
            line: n,
            column: fields[0].column,
            p: p.try_into().expect("3 positions"),
            v: v[..6].try_into().expect("6 values"),
        });
    }
    assemble(&src, &text, rows, orientation)
}

/// Builds the grid from rows, checking they cover it in order (X slowest, Z fastest).
fn assemble(
    src: &Source<'_>,
    text: &str,
    rows: Vec<Row>,
    orientation: bool,
) -> Result<ErrorGrid, CompensateError> {
    if rows.is_empty() {
        let line = text.lines().count() + 1;
        return Err(src.error(line, 1, "expected at least one row, found none"));
    }
    let axis_nodes = |d: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| r.p[d]).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let mut grid = ErrorGrid {
        x_mm: axis_nodes(0),
        y_mm: axis_nodes(1),
        z_mm: axis_nodes(2),
        error_um: Vec::with_capacity(rows.len()),
        error_urad: orientation.then(|| Vec::with_capacity(rows.len())),
        note: String::new(),
    };
    let total = grid.x_mm.len() * grid.y_mm.len() * grid.z_mm.len();
    for (n, r) in rows.iter().enumerate() {
        let expected = (n < total).then(|| grid.position_mm(n));
        if expected != Some(r.p) {
            let msg = match expected {
                Some([x, y, z]) => format!(
                    "expected the node X = {x}, Y = {y}, Z = {z} mm here (rows cover the full \
                     grid, X slowest, Z fastest)"
                ),
                None => format!("one row too many: the grid has {total} nodes"),
            };
            return Err(src.error(r.line, r.column, msg));
        }
        grid.error_um.push([r.v[0], r.v[1], r.v[2]]);
        if let Some(o) = grid.error_urad.as_mut() {
            o.push([r.v[3], r.v[4], r.v[5]]);
        }
    }
    if rows.len() < total {
        let line = text.lines().count() + 1;
        let msg = format!(
            "the rows end after {} of the grid's {total} nodes",
            rows.len()
        );
        return Err(src.error(line, 1, msg));
    }
    Ok(grid)
}

/// The card of the 3-D error grid.
pub(crate) fn card(machine: &Machine) -> ConventionCard {
    ConventionCard {
        made_from: Vec::new(),
        format: "mtcal CSV 3-D error grid".into(),
        quantity: Quantity::Error,
        sign: "dx_um, dy_um, dz_um = actual − nominal tool point relative to the workpiece, \
               workpiece frame; the control subtracts them"
            .into(),
        squareness: "included: the grid holds the tool-point error every error causes, \
                     squareness too"
            .into(),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "positions mm, errors µm, orientation errors µrad".into(),
        control_will: vec![
            "interpolate trilinearly between the 8 nodes around a point and hold the edge values \
             outside the grid"
                .into(),
            "correct the tool point only; the rotary axes were held where the file's comment says"
                .into(),
        ],
    }
}
