//! Measuring paths: ISO 230-4 circles in a coordinate plane and five-axis rotary-axis tests.
//! The keys are documented in the crate docs.

use crate::setup::BallbarConfig;
use mtcal_instrument::config::{self, Number, expected, required};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::ik::{IkError, follow_point};
use mtcal_kinematics::rigid::log_so3;
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::de::IgnoredAny;
use serde::{Deserialize, Deserializer};

/// A coordinate plane of the workpiece frame, with its in-plane basis `(e1, e2)` and normal
/// `e1 × e2`: XY (normal +Z), YZ (normal +X), ZX (normal +Y). Angles are measured from `e1`
/// towards `e2`, so counter-clockwise is positive about the normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
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

impl TryFrom<String> for Plane {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        Plane::parse(&value)
            .ok_or_else(|| format!("expected \"XY\", \"YZ\" or \"ZX\", found \"{value}\""))
    }
}

/// Which way the bar points in a rotary-axis test.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(try_from = "toml::Value")]
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

impl TryFrom<toml::Value> for Bar {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        if let toml::Value::String(s) = &value {
            return match s.as_str() {
                "radial" => Ok(Bar::Radial),
                "tangential" => Ok(Bar::Tangential),
                "axial" => Ok(Bar::Axial),
                other => Err(format!(
                    "expected \"radial\", \"tangential\", \"axial\" or [x, y, z], found \"{other}\""
                )),
            };
        }
        let v = config::vec3(&value)
            .map(Vector3::from)
            .ok_or_else(|| expected("three numbers [x, y, z]", &value))?;
        let n = v.norm();
        if n < 1e-9 {
            return Err("the bar direction is the zero vector".into());
        }
        Ok(Bar::Vector(v / n))
    }
}

/// Default number of samples of a path.
pub const DEFAULT_SAMPLES: usize = 361;

/// The key that says how the rest of a path table is read.
#[derive(Debug, Deserialize)]
struct Tagged {
    kind: Option<PathKind>,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "String")]
enum PathKind {
    Circle,
    Rotary,
}

impl TryFrom<String> for PathKind {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        match value.as_str() {
            "circle" => Ok(PathKind::Circle),
            "rotary" => Ok(PathKind::Rotary),
            other => Err(format!(
                "unknown path kind \"{other}\"; the ball-bar knows \"circle\" and \"rotary\""
            )),
        }
    }
}

/// A circle path table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CircleKeys {
    /// Read by [`Tagged`].
    #[serde(rename = "kind")]
    _kind: Option<IgnoredAny>,
    plane: Option<Plane>,
    direction: Option<Turn>,
    start_deg: Option<Number>,
    sweep_deg: Option<Number>,
    overshoot_deg: Option<Number>,
    samples: Option<Number>,
    #[serde(default, deserialize_with = "hold_table")]
    hold: Option<toml::Table>,
}

/// A rotary-axis path table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RotaryKeys {
    /// Read by [`Tagged`].
    #[serde(rename = "kind")]
    _kind: Option<IgnoredAny>,
    #[serde(default, deserialize_with = "sweep_table")]
    sweep: Option<toml::Table>,
    bar: Option<Bar>,
    samples: Option<Number>,
    #[serde(default, deserialize_with = "hold_table")]
    hold: Option<toml::Table>,
}

fn hold_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(
        d,
        "a table of rotary axis positions in degrees, e.g. { A = 0.0 }",
    )
    .map(Some)
}

/// What a `sweep` that is not a table, or names more or fewer than one axis, is told.
const SWEEP_EXPECTED: &str = "one rotary axis and its range in degrees, e.g. { C = [0.0, 360.0] }";

fn sweep_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, SWEEP_EXPECTED).map(Some)
}

/// The direction a circle is run in.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "String")]
enum Turn {
    Ccw,
    Cw,
}

impl TryFrom<String> for Turn {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        match value.as_str() {
            "ccw" => Ok(Turn::Ccw),
            "cw" => Ok(Turn::Cw),
            other => Err(format!("expected \"ccw\" or \"cw\", found \"{other}\"")),
        }
    }
}

/// Commanded positions (SI, one `Vec` per sample) of a path; see the crate docs for the keys.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let setup = spec.own_setup::<crate::BallbarSetup>()?.config();
    let tagged: Tagged = config::read_part(spec.path)?;
    let kind = required(
        tagged.kind,
        "kind",
        "the path kind, \"circle\" or \"rotary\"",
    )?;
    match kind {
        PathKind::Circle => circle_path(spec.machine, setup, &config::read(spec.path)?),
        PathKind::Rotary => rotary_path(spec.machine, setup, &config::read(spec.path)?),
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
    keys: &CircleKeys,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let plane = required(keys.plane, "plane", "\"XY\", \"YZ\" or \"ZX\"")?;
    let ccw = matches!(keys.direction.unwrap_or(Turn::Ccw), Turn::Ccw);
    let start = keys.start_deg.map_or(0.0, f64::from);
    let sweep = keys.sweep_deg.map_or(360.0, f64::from);
    if sweep <= 0.0 {
        return Err(SetupError::new(
            "sweep_deg",
            format!("the swept angle must be positive (degrees), found {sweep}"),
        ));
    }
    let overshoot = keys.overshoot_deg.map_or(0.0, f64::from);
    if overshoot < 0.0 {
        return Err(SetupError::new(
            "overshoot_deg",
            format!("the overshoot arcs cannot be negative (degrees), found {overshoot}"),
        ));
    }
    let samples = samples(keys.samples)?;
    let base = held_rotaries(machine, keys.hold.as_ref(), None)?;
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
    keys: &RotaryKeys,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let (axis, from, to) = swept_axis(machine, keys.sweep.as_ref())?;
    let bar = required(
        keys.bar,
        "bar",
        "\"radial\", \"tangential\", \"axial\" or a direction [x, y, z]",
    )?;
    let samples = samples(keys.samples)?;
    let mut base = held_rotaries(machine, keys.hold.as_ref(), Some(axis))?;
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

/// Why the tool cannot be placed at a point.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlaceError {
    #[error(transparent)]
    Ik(#[from] IkError),
    #[error("machine `{machine}` (axes {axes}) has no linear axes to move the ball")]
    NoLinearAxes { machine: String, axes: String },
    #[error("{0}")]
    Solve(&'static str),
    #[error(
        "machine `{machine}` (axes {axes}) has too few linear axes: its linear axes cannot reach \
         the ball position (missed by {miss_mm:.3} mm)"
    )]
    Unreachable {
        machine: String,
        axes: String,
        miss_mm: f64,
    },
}

/// Sets the linear axes of `q` so that the nominal tool point is at `tip` (workpiece frame, m),
/// rotary axes as they are: [`follow_point`] on machines with three linear axes, otherwise a
/// least-squares solve over the linear axes that must reach `tip` exactly.
pub fn place_tool(machine: &Machine, q: &mut [f64], tip: &Vector3<f64>) -> Result<(), PlaceError> {
    let linear: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
        .collect();
    if linear.len() == 3 {
        return Ok(follow_point(machine, q, tip)?);
    }
    if linear.is_empty() {
        return Err(PlaceError::NoLinearAxes {
            machine: machine.name().to_string(),
            axes: machine.letters(),
        });
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
        .map_err(PlaceError::Solve)?;
    let miss = (&jac * &x - &rhs).norm();
    if miss > 1e-9 {
        return Err(PlaceError::Unreachable {
            machine: machine.name().to_string(),
            axes: machine.letters(),
            miss_mm: miss * 1e3,
        });
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

fn samples(samples: Option<Number>) -> Result<usize, SetupError> {
    let Some(Number(n)) = samples else {
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
    hold: Option<&toml::Table>,
    swept: Option<usize>,
) -> Result<Vec<f64>, SetupError> {
    let mut q = vec![0.0; machine.n_axes()];
    let Some(hold) = hold else {
        return Ok(q);
    };
    for (key, v) in hold {
        let i = rotary_index(machine, key, "hold")?;
        if Some(i) == swept {
            return Err(SetupError::new(
                "hold",
                format!("axis {key} is the swept axis; it cannot also be held"),
            ));
        }
        q[i] = config::number(v)
            .ok_or_else(|| {
                SetupError::new("hold", format!("{key}: {}", expected("a finite number", v)))
            })?
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

fn swept_axis(
    machine: &Machine,
    sweep: Option<&toml::Table>,
) -> Result<(usize, f64, f64), SetupError> {
    let bad = |why: String| SetupError::new("sweep", why);
    let sweep = required(sweep, "sweep", SWEEP_EXPECTED)?;
    if sweep.len() != 1 {
        let written = toml::Value::Table(sweep.clone());
        return Err(bad(expected(SWEEP_EXPECTED, &written)));
    }
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
