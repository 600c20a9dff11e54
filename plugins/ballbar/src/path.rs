//! Measuring paths: ISO 230-4 circles in a coordinate plane and five-axis rotary-axis tests.
//! The keys are documented in the crate docs.

use crate::setup::BallbarConfig;
use mtcal_instrument::{PathSpec, SetupError, read};
use mtcal_kinematics::ik::follow_point;
use mtcal_kinematics::rigid::log_so3;
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// A coordinate plane of the workpiece frame, with its in-plane basis `(e1, e2)` and normal
/// `e1 × e2`: XY (normal +Z), YZ (normal +X), ZX (normal +Y). Angles are measured from `e1`
/// towards `e2`, so counter-clockwise is positive about the normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    XY,
    YZ,
    ZX,
}

impl Plane {
    pub const ALL: [Plane; 3] = [Plane::XY, Plane::YZ, Plane::ZX];

    /// Indices of `e1`, `e2` and the normal among x, y, z.
    pub fn indices(self) -> [usize; 3] {
        match self {
            Plane::XY => [0, 1, 2],
            Plane::YZ => [1, 2, 0],
            Plane::ZX => [2, 0, 1],
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Plane::XY => "XY",
            Plane::YZ => "YZ",
            Plane::ZX => "ZX",
        }
    }

    pub fn parse(s: &str) -> Option<Plane> {
        Plane::ALL.into_iter().find(|p| p.name() == s)
    }

    /// The point at angle `phi` on the unit circle of this plane.
    pub fn unit(self, phi: f64) -> Vector3<f64> {
        let [i, j, _] = self.indices();
        let mut v = Vector3::zeros();
        v[i] = phi.cos();
        v[j] = phi.sin();
        v
    }
}

/// Which way the bar points in a rotary-axis test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bar {
    /// Away from the rotary axis line, through the pivot.
    Radial,
    /// `axial × radial`: the direction the pivot would move as the axis turns positively.
    Tangential,
    /// Along the rotary axis (its positive direction of rotation, workpiece frame).
    Axial,
    /// An explicit direction in the workpiece frame (normalised).
    Vector(Vector3<f64>),
}

/// Default number of samples of a path.
pub const DEFAULT_SAMPLES: usize = 361;

const CIRCLE_KEYS: &[&str] = &[
    "kind",
    "plane",
    "direction",
    "start_deg",
    "sweep_deg",
    "overshoot_deg",
    "samples",
    "hold",
];
const ROTARY_KEYS: &[&str] = &["kind", "sweep", "bar", "samples", "hold"];

/// Commanded positions (SI, one `Vec` per sample) of a path; see the crate docs for the keys.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let config = BallbarConfig::from_table(spec.setup)?;
    let kind = read::string(spec.path, "kind")?.ok_or_else(|| {
        SetupError::new("kind", "missing: the path kind, \"circle\" or \"rotary\"")
    })?;
    match kind {
        "circle" => circle_path(spec.machine, &config, spec.path),
        "rotary" => rotary_path(spec.machine, &config, spec.path),
        other => Err(SetupError::new(
            "kind",
            format!("unknown path kind \"{other}\"; the ball-bar knows \"circle\" and \"rotary\""),
        )),
    }
}

/// The commanded angles (rad) of a circle path, in order: from `start − overshoot` to
/// `start + sweep + overshoot`, negated about `start` for clockwise.
pub fn circle_angles(
    start_deg: f64,
    sweep_deg: f64,
    overshoot_deg: f64,
    ccw: bool,
    samples: usize,
) -> Vec<f64> {
    let total = sweep_deg + 2.0 * overshoot_deg;
    let sign = if ccw { 1.0 } else { -1.0 };
    (0..samples)
        .map(|i| {
            let s = -overshoot_deg + total * i as f64 / (samples - 1) as f64;
            (start_deg + sign * s).to_radians()
        })
        .collect()
}

fn circle_path(
    machine: &Machine,
    config: &BallbarConfig,
    table: &toml::Table,
) -> Result<Vec<Vec<f64>>, SetupError> {
    read::only_keys(table, CIRCLE_KEYS)?;
    let plane_name = read::string(table, "plane")?
        .ok_or_else(|| SetupError::new("plane", "missing: \"XY\", \"YZ\" or \"ZX\""))?;
    let plane = Plane::parse(plane_name).ok_or_else(|| {
        SetupError::new(
            "plane",
            format!("expected \"XY\", \"YZ\" or \"ZX\", found \"{plane_name}\""),
        )
    })?;
    let ccw = match read::string(table, "direction")?.unwrap_or("ccw") {
        "ccw" => true,
        "cw" => false,
        other => {
            return Err(SetupError::new(
                "direction",
                format!("expected \"ccw\" or \"cw\", found \"{other}\""),
            ));
        }
    };
    let start = read::number(table, "start_deg")?.unwrap_or(0.0);
    let sweep = read::number(table, "sweep_deg")?.unwrap_or(360.0);
    if sweep <= 0.0 {
        return Err(SetupError::new(
            "sweep_deg",
            format!("the swept angle must be positive (degrees), found {sweep}"),
        ));
    }
    let overshoot = read::number(table, "overshoot_deg")?.unwrap_or(0.0);
    if overshoot < 0.0 {
        return Err(SetupError::new(
            "overshoot_deg",
            format!("the overshoot arcs cannot be negative (degrees), found {overshoot}"),
        ));
    }
    let samples = samples(table)?;
    let base = held_rotaries(machine, table, None)?;
    let pivot = config.pivot();
    let length = config.length();
    let mut out = Vec::with_capacity(samples);
    for (i, phi) in circle_angles(start, sweep, overshoot, ccw, samples)
        .into_iter()
        .enumerate()
    {
        let mut q = base.clone();
        let tip = pivot + plane.unit(phi) * length;
        place_tool(machine, &mut q, &tip).map_err(|why| {
            SetupError::new(
                "plane",
                format!("a circle in the {} plane: {why}", plane.name()),
            )
        })?;
        check_limits(machine, &q, i)?;
        out.push(q);
    }
    Ok(out)
}

fn rotary_path(
    machine: &Machine,
    config: &BallbarConfig,
    table: &toml::Table,
) -> Result<Vec<Vec<f64>>, SetupError> {
    read::only_keys(table, ROTARY_KEYS)?;
    let (axis, from, to) = swept_axis(machine, table)?;
    let bar = bar(table)?;
    let samples = samples(table)?;
    let mut base = held_rotaries(machine, table, Some(axis))?;
    base[axis] = from;
    let pivot = config.pivot();
    let u = bar_direction(machine, &base, axis, &pivot, bar)?;
    let ball = pivot + u * config.length();
    let mut out = Vec::with_capacity(samples);
    for i in 0..samples {
        let mut q = base.clone();
        q[axis] = from + (to - from) * i as f64 / (samples - 1) as f64;
        place_tool(machine, &mut q, &ball)
            .map_err(|why| SetupError::new("sweep", format!("sample {i}: {why}")))?;
        check_limits(machine, &q, i)?;
        out.push(q);
    }
    Ok(out)
}

/// The bar's unit direction (workpiece frame) for a rotary test of `axis` at the start pose
/// `q` (linear axes placed so that the tool point is at the pivot).
fn bar_direction(
    machine: &Machine,
    q: &[f64],
    axis: usize,
    pivot: &Vector3<f64>,
    bar: Bar,
) -> Result<Vector3<f64>, SetupError> {
    if let Bar::Vector(v) = bar {
        return Ok(v);
    }
    let mut q = q.to_vec();
    place_tool(machine, &mut q, pivot)
        .map_err(|why| SetupError::new("bar", format!("placing the tool at the pivot: {why}")))?;
    let (a, c) = axis_line(machine, &q, axis);
    if bar == Bar::Axial {
        return Ok(a);
    }
    let d = pivot - c;
    let radial = d - a * a.dot(&d);
    if radial.norm() < 1e-6 {
        return Err(SetupError::new(
            "bar",
            format!(
                "the pivot lies on the line of axis {}, so \"radial\" and \"tangential\" are \
                 undefined; move the pivot off the axis or give the bar as a vector [x, y, z]",
                machine.axes()[axis].letter()
            ),
        ));
    }
    let radial = radial.normalize();
    Ok(if bar == Bar::Radial {
        radial
    } else {
        a.cross(&radial)
    })
}

/// The line of rotary axis `axis` in the workpiece frame at positions `q`: its unit direction
/// (the sense in which a positive command turns the tool relative to the workpiece) and the
/// point of the line nearest the workpiece origin. Exact: turning one axis moves the tool
/// relative to the workpiece by a rotation about that line.
pub fn axis_line(machine: &Machine, q: &[f64], axis: usize) -> (Vector3<f64>, Vector3<f64>) {
    let t0 = machine.tool_in_workpiece(q);
    let mut q1 = q.to_vec();
    q1[axis] += 1.0;
    let t1 = machine.tool_in_workpiece(&q1);
    // Tool-fixed points at q move to m·x at q1: m = Rot(a, 1 rad) about the line.
    let m = t1.compose(&t0.inverse());
    let a = log_so3(&m.r).normalize();
    let lhs = Matrix3::identity() - m.r + a * a.transpose();
    let c = lhs.lu().solve(&m.t).unwrap_or_else(Vector3::zeros);
    (a, c)
}

/// Sets the linear axes of `q` so that the nominal tool point is at `tip` (workpiece frame, m),
/// rotary axes as they are: [`follow_point`] on machines with three linear axes, otherwise a
/// least-squares solve over the linear axes that must reach `tip` exactly.
pub fn place_tool(machine: &Machine, q: &mut [f64], tip: &Vector3<f64>) -> Result<(), String> {
    let linear: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
        .collect();
    if linear.len() == 3 {
        return follow_point(machine, q, tip).map_err(|e| e.to_string());
    }
    if linear.is_empty() {
        return Err(format!(
            "machine `{}` (axes {}) has no linear axes to move the ball",
            machine.name(),
            machine.letters()
        ));
    }
    for &i in &linear {
        q[i] = 0.0;
    }
    let p0 = machine.tool_in_workpiece(q).t;
    let mut jac = DMatrix::zeros(3, linear.len());
    for (c, &i) in linear.iter().enumerate() {
        q[i] = 1.0;
        jac.set_column(c, &(machine.tool_in_workpiece(q).t - p0));
        q[i] = 0.0;
    }
    let rhs = DVector::from_column_slice((tip - p0).as_slice());
    let x = jac
        .clone()
        .svd(true, true)
        .solve(&rhs, 1e-12)
        .map_err(|e| e.to_string())?;
    let miss = (&jac * &x - &rhs).norm();
    if miss > 1e-9 {
        return Err(format!(
            "machine `{}` (axes {}) has too few linear axes: its linear axes cannot reach the \
             ball position (missed by {:.3} mm)",
            machine.name(),
            machine.letters(),
            miss * 1e3
        ));
    }
    for (c, &i) in linear.iter().enumerate() {
        q[i] = x[c];
    }
    Ok(())
}

fn check_limits(machine: &Machine, q: &[f64], sample: usize) -> Result<(), SetupError> {
    for (axis, &v) in machine.axes().iter().zip(q) {
        let Some((lo, hi)) = axis.limits() else {
            continue;
        };
        if v >= lo - 1e-9 && v <= hi + 1e-9 {
            continue;
        }
        let (scale, unit) = match axis.kind() {
            AxisKind::Linear => (1e3, "mm"),
            AxisKind::Rotary => (180.0 / std::f64::consts::PI, "deg"),
        };
        return Err(SetupError::new(
            "path",
            format!(
                "sample {sample}: axis {} would be at {:.3} {unit}, outside its limits \
                 [{:.3}, {:.3}] {unit}; move the pivot, shorten the bar or shorten the sweep",
                axis.letter(),
                v * scale,
                lo * scale,
                hi * scale
            ),
        ));
    }
    Ok(())
}

fn samples(table: &toml::Table) -> Result<usize, SetupError> {
    let Some(n) = read::number(table, "samples")? else {
        return Ok(DEFAULT_SAMPLES);
    };
    if n.fract() != 0.0 || !(2.0..=1e7).contains(&n) {
        return Err(SetupError::new(
            "samples",
            format!("expected a whole number of samples, from 2 to 10 000 000, found {n}"),
        ));
    }
    Ok(n as usize)
}

/// Axis positions with every axis at 0 except the rotary axes named in `hold` (degrees).
fn held_rotaries(
    machine: &Machine,
    table: &toml::Table,
    swept: Option<usize>,
) -> Result<Vec<f64>, SetupError> {
    let mut q = vec![0.0; machine.n_axes()];
    let Some(hold) = table.get("hold") else {
        return Ok(q);
    };
    let hold = hold.as_table().ok_or_else(|| {
        SetupError::new(
            "hold",
            format!("expected a table of rotary axis positions in degrees, e.g. {{ A = 0.0 }}, found {hold}"),
        )
    })?;
    for key in hold.keys() {
        let i = rotary_index(machine, key, "hold")?;
        if Some(i) == swept {
            return Err(SetupError::new(
                "hold",
                format!("axis {key} is the swept axis; it cannot also be held"),
            ));
        }
        q[i] = read::number(hold, key)
            .map_err(|e| SetupError::new("hold", format!("{key}: {}", e.message)))?
            .unwrap_or(0.0)
            .to_radians();
    }
    Ok(q)
}

fn rotary_index(machine: &Machine, letter: &str, key: &str) -> Result<usize, SetupError> {
    let mut chars = letter.chars();
    let found = match (chars.next(), chars.next()) {
        (Some(c), None) => machine.axis_index(c),
        _ => None,
    };
    match found {
        Some(i) if machine.axes()[i].kind() == AxisKind::Rotary => Ok(i),
        Some(_) => Err(SetupError::new(
            key,
            format!("axis {letter} is linear; linear axes follow the ball, name rotary axes only"),
        )),
        None => Err(SetupError::new(
            key,
            format!(
                "machine `{}` has no axis `{letter}` (it has {})",
                machine.name(),
                machine.letters()
            ),
        )),
    }
}

fn swept_axis(machine: &Machine, table: &toml::Table) -> Result<(usize, f64, f64), SetupError> {
    let bad = |why: String| SetupError::new("sweep", why);
    let sweep = table.get("sweep").ok_or_else(|| {
        bad("missing: one rotary axis and its range in degrees, e.g. { C = [0.0, 360.0] }".into())
    })?;
    let sweep = sweep
        .as_table()
        .filter(|t| t.len() == 1)
        .ok_or_else(|| bad(format!("expected one rotary axis and its range in degrees, e.g. {{ C = [0.0, 360.0] }}, found {sweep}")))?;
    let (letter, range) = sweep.iter().next().expect("one entry");
    let axis = rotary_index(machine, letter, "sweep")?;
    let range = range
        .as_array()
        .filter(|a| a.len() == 2)
        .and_then(|a| {
            let f = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
            Some((f(&a[0])?, f(&a[1])?))
        })
        .filter(|(a, b)| a.is_finite() && b.is_finite() && a != b)
        .ok_or_else(|| {
            bad(format!(
                "axis {letter}: expected [from, to] in degrees with from ≠ to, found {range}"
            ))
        })?;
    Ok((axis, range.0.to_radians(), range.1.to_radians()))
}

fn bar(table: &toml::Table) -> Result<Bar, SetupError> {
    match table.get("bar") {
        None => Err(SetupError::new(
            "bar",
            "missing: \"radial\", \"tangential\", \"axial\" or a direction [x, y, z]",
        )),
        Some(toml::Value::String(s)) => match s.as_str() {
            "radial" => Ok(Bar::Radial),
            "tangential" => Ok(Bar::Tangential),
            "axial" => Ok(Bar::Axial),
            other => Err(SetupError::new(
                "bar",
                format!(
                    "expected \"radial\", \"tangential\", \"axial\" or [x, y, z], found \"{other}\""
                ),
            )),
        },
        Some(_) => {
            let v = Vector3::from(read::vec3(table, "bar")?.expect("present"));
            let n = v.norm();
            if n < 1e-9 {
                return Err(SetupError::new(
                    "bar",
                    "the bar direction is the zero vector",
                ));
            }
            Ok(Bar::Vector(v / n))
        }
    }
}
