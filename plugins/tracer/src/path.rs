//! Measuring paths: a 3-D grid or a set of lines (edges and body diagonals) over the linear
//! axes' strokes, the same commanded path whatever the station.

use crate::setup::TracerSetup;
use mtcal_instrument::config::{self, Number, expected};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::{AxisKind, Machine};
use serde::{Deserialize, Deserializer};

/// Every key a path table may have.
pub const PATH_KEYS: &[&str] = &["kind", "counts", "samples", "fraction", "hold"];
/// Default share of each linear axis' stroke the path spans (centred).
pub const DEFAULT_FRACTION: f64 = 0.8;
/// Default grid points per axis.
pub const DEFAULT_COUNTS: [usize; 3] = [4, 4, 4];
/// Default samples per line of a `lines` path.
pub const DEFAULT_LINE_SAMPLES: usize = 11;
/// The reflector must stay at least this far (mm) from the station at every sample: closer, a
/// tracker cannot follow it (and the line of sight is undefined at the station).
pub const MIN_DISTANCE_MM: f64 = 50.0;

/// Axis limits are checked with this tolerance (m or rad), as the conformance harness does.
const LIMIT_TOL: f64 = 1e-9;

/// A path table as written ([`PATH_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PathKeys {
    kind: Option<Kind>,
    counts: Option<Counts>,
    samples: Option<LineSamples>,
    fraction: Option<Number>,
    #[serde(default, deserialize_with = "hold_table")]
    hold: Option<toml::Table>,
}

fn hold_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of axis positions like { A = 0.0 }").map(Some)
}

/// The shape of a path.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "String")]
enum Kind {
    Grid,
    Lines,
}

impl TryFrom<String> for Kind {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        match value.as_str() {
            "grid" => Ok(Kind::Grid),
            "lines" => Ok(Kind::Lines),
            other => Err(format!(
                "unknown path kind `{other}`; expected \"grid\" or \"lines\""
            )),
        }
    }
}

/// Samples per line of a `lines` path.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "toml::Value")]
struct LineSamples(usize);

impl TryFrom<toml::Value> for LineSamples {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        count(&value, 2).map(LineSamples)
    }
}

/// Grid points per axis `[nx, ny, nz]` as written; each is read by [`count`] where an error
/// can name its place (`counts[1]`).
#[derive(Debug, Deserialize)]
#[serde(try_from = "toml::Value")]
struct Counts([toml::Value; 3]);

impl TryFrom<toml::Value> for Counts {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        match value.as_array().map(Vec::as_slice) {
            Some([x, y, z]) => Ok(Counts([x.clone(), y.clone(), z.clone()])),
            _ => Err(expected("three whole numbers [nx, ny, nz]", &value)),
        }
    }
}

/// The indices of the linear axes X, Y, Z of `machine` and their strokes (m), or an error
/// naming `kind` if it lacks one or one has no limits.
pub fn linear_axes(machine: &Machine) -> Result<[(usize, f64, f64); 3], SetupError> {
    let mut out = [(0, 0.0, 0.0); 3];
    for (k, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let i = machine
            .axis_index(letter)
            .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
            .ok_or_else(|| {
                SetupError::new(
                    "kind",
                    format!(
                        "a tracer path needs the linear axes X, Y and Z; machine `{}` has {}",
                        machine.name(),
                        machine.letters()
                    ),
                )
            })?;
        let (lo, hi) = machine.axes()[i].limits().ok_or_else(|| {
            SetupError::new(
                "kind",
                format!("axis {letter} has no limits: the path spans a share of its stroke"),
            )
        })?;
        out[k] = (i, lo, hi);
    }
    Ok(out)
}

/// A whole number from `min` to 10000, written as an integer.
fn count(v: &toml::Value, min: usize) -> Result<usize, String> {
    match v {
        toml::Value::Integer(i) if *i >= min as i64 && *i <= 10_000 => Ok(*i as usize),
        _ => Err(expected(&format!("a whole number from {min} to 10000"), v)),
    }
}

/// The held positions of the other axes (`hold = { A = 0.0 }`, degrees for rotary, mm for
/// linear axes other than X, Y, Z); unnamed ones at 0.
fn held(
    machine: &Machine,
    hold: Option<&toml::Table>,
    xyz: &[usize; 3],
) -> Result<Vec<f64>, SetupError> {
    let mut q = vec![0.0; machine.n_axes()];
    for (letter, v) in hold.into_iter().flatten() {
        let key = format!("hold.{letter}");
        let mut chars = letter.chars();
        let i = match (chars.next(), chars.next()) {
            (Some(c), None) => machine.axis_index(c),
            _ => None,
        }
        .filter(|i| !xyz.contains(i))
        .ok_or_else(|| {
            SetupError::new(
                &key,
                format!(
                    "`{letter}` is not an axis of machine `{}` that the path holds \
                     (axes: {}; X, Y and Z are moved by the path)",
                    machine.name(),
                    machine.letters()
                ),
            )
        })?;
        let x = config::number(v)
            .ok_or_else(|| SetupError::new(&key, expected("a position (degrees or mm)", v)))?;
        q[i] = machine.axes()[i].kind().from_file(x);
    }
    Ok(q)
}

/// Grid points along one axis: `n` points evenly over the centred `fraction` of `[lo, hi]`.
fn ticks(lo: f64, hi: f64, fraction: f64, n: usize) -> Vec<f64> {
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * fraction * (hi - lo);
    if n == 1 {
        return vec![mid];
    }
    (0..n)
        .map(|i| mid - half + 2.0 * half * i as f64 / (n - 1) as f64)
        .collect()
}

/// The plugin's path function (path keys in the crate docs). The set-up must load; every
/// sample is checked against the axis limits and against [`MIN_DISTANCE_MM`].
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let setup: &TracerSetup = spec.own_setup()?;
    let p: PathKeys = config::read(spec.path)?;
    let axes = linear_axes(machine)?;
    let xyz = [axes[0].0, axes[1].0, axes[2].0];
    let fraction = p.fraction.map_or(DEFAULT_FRACTION, f64::from);
    if !(fraction > 0.0 && fraction <= 1.0) {
        return Err(SetupError::new(
            "fraction",
            format!("expected a share of the strokes in (0, 1], found {fraction}"),
        ));
    }
    let base = held(machine, p.hold.as_ref(), &xyz)?;
    let points: Vec<[f64; 3]> = match p.kind.unwrap_or(Kind::Grid) {
        Kind::Grid => {
            if p.samples.is_some() {
                return Err(SetupError::new(
                    "samples",
                    "a grid path takes `counts = [nx, ny, nz]`, not `samples`",
                ));
            }
            let counts = match &p.counts {
                None => DEFAULT_COUNTS,
                Some(Counts(written)) => {
                    let mut c = [0; 3];
                    for (k, v) in written.iter().enumerate() {
                        c[k] =
                            count(v, 1).map_err(|m| SetupError::new(format!("counts[{k}]"), m))?;
                    }
                    c
                }
            };
            let t: Vec<Vec<f64>> = (0..3)
                .map(|k| ticks(axes[k].1, axes[k].2, fraction, counts[k]))
                .collect();
            // Serpentine order: Y reverses on alternate Z layers, X on alternate rows, so the
            // machine never jumps across the volume.
            let mut out = Vec::with_capacity(counts.iter().product());
            let mut row = 0usize;
            for (iz, &z) in t[2].iter().enumerate() {
                let ys: Vec<f64> = if iz % 2 == 0 {
                    t[1].clone()
                } else {
                    t[1].iter().rev().copied().collect()
                };
                for y in ys {
                    if row % 2 == 0 {
                        out.extend(t[0].iter().map(|&x| [x, y, z]));
                    } else {
                        out.extend(t[0].iter().rev().map(|&x| [x, y, z]));
                    }
                    row += 1;
                }
            }
            out
        }
        Kind::Lines => {
            if p.counts.is_some() {
                return Err(SetupError::new(
                    "counts",
                    "a lines path takes `samples` (per line), not `counts`",
                ));
            }
            let n = p.samples.map_or(DEFAULT_LINE_SAMPLES, |LineSamples(n)| n);
            let lo: Vec<f64> = (0..3)
                .map(|k| ticks(axes[k].1, axes[k].2, fraction, 2)[0])
                .collect();
            let hi: Vec<f64> = (0..3)
                .map(|k| ticks(axes[k].1, axes[k].2, fraction, 2)[1])
                .collect();
            let corner = |c: usize| [0, 1, 2].map(|k| if c >> k & 1 == 1 { hi[k] } else { lo[k] });
            // The 12 edges of the box (corner pairs differing in one bit) and its 4 body
            // diagonals (corner c to its opposite 7 − c, c < 4).
            let mut lines: Vec<(usize, usize)> = Vec::new();
            for k in 0..3 {
                for c in 0..8usize {
                    if c >> k & 1 == 0 {
                        lines.push((c, c | 1 << k));
                    }
                }
            }
            lines.extend((0..4).map(|c| (c, 7 - c)));
            let mut out = Vec::with_capacity(lines.len() * n);
            for (a, b) in lines {
                let (pa, pb) = (corner(a), corner(b));
                for i in 0..n {
                    let s = i as f64 / (n - 1) as f64;
                    out.push([0, 1, 2].map(|k| pa[k] + s * (pb[k] - pa[k])));
                }
            }
            out
        }
    };
    let mut poses = Vec::with_capacity(points.len());
    for (k, pt) in points.iter().enumerate() {
        let mut q = base.clone();
        for (j, &i) in xyz.iter().enumerate() {
            q[i] = pt[j];
        }
        if !machine.within_limits(&q, LIMIT_TOL) {
            let key = if p.hold.is_some() { "hold" } else { "kind" };
            return Err(SetupError::new(
                key,
                format!(
                    "sample {k} {q:?} lies outside the axis limits of {} (held axes at 0 \
                     unless `hold` names them)",
                    machine.letters()
                ),
            ));
        }
        let distance_mm = (setup.nominal_reflector(&q) - setup.config().station()).norm() * 1e3;
        if distance_mm < MIN_DISTANCE_MM {
            return Err(SetupError::new(
                "station",
                format!(
                    "at sample {k} the reflector comes within {distance_mm:.1} mm of the station \
                     (at least {MIN_DISTANCE_MM} mm needed): move the station out of the path"
                ),
            ));
        }
        poses.push(q);
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<PathKeys>(), Some(PATH_KEYS));
    }
}
