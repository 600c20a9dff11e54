//! Measuring paths: runs along one axis (linear, straightness, angular) with ISO 230-2
//! bidirectional cycles, and diagonal / step-diagonal runs between two corners (ISO 230-6).
//! The keys are documented in the crate docs.

use crate::setup::{LaserSetup, Mode};
use mtcal_instrument::config::{self, Number, expected, required};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::{AxisKind, Machine};
use serde::{Deserialize, Deserializer};

/// Every key of a path along one axis.
pub const AXIS_PATH_KEYS: &[&str] = &[
    "axis",
    "targets",
    "from",
    "to",
    "step",
    "points",
    "cycles",
    "bidirectional",
    "overrun",
    "hold",
];
/// Every key of a diagonal or step-diagonal path.
pub const DIAGONAL_PATH_KEYS: &[&str] =
    &["from", "to", "points", "cycles", "bidirectional", "hold"];
/// Targets of a path when neither `targets`, `step` nor `points` is given.
pub const DEFAULT_POINTS: usize = 11;
/// How far (rad) the nominal travel of the tool point may be from the set-up's `direction`.
pub const ALIGN_TOL: f64 = 1e-6;

const LIMIT_TOL: f64 = 1e-9;

/// A path along one axis as written ([`AXIS_PATH_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisPathKeys {
    axis: Option<String>,
    targets: Option<Targets>,
    from: Option<Number>,
    to: Option<Number>,
    step: Option<Number>,
    points: Option<Number>,
    cycles: Option<Number>,
    bidirectional: Option<bool>,
    overrun: Option<Number>,
    #[serde(default, deserialize_with = "positions_table")]
    hold: Option<toml::Table>,
}

/// A diagonal or step-diagonal path as written ([`DIAGONAL_PATH_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DiagonalPathKeys {
    #[serde(default, deserialize_with = "positions_table")]
    from: Option<toml::Table>,
    #[serde(default, deserialize_with = "positions_table")]
    to: Option<toml::Table>,
    points: Option<Number>,
    cycles: Option<Number>,
    bidirectional: Option<bool>,
    #[serde(default, deserialize_with = "positions_table")]
    hold: Option<toml::Table>,
}

/// Axis positions by letter (`{ X = 10.0, C = 90.0 }`); each is read once its letter is known
/// to name an axis ([`positions`]).
fn positions_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of axis positions like { X = 0.0, Z = -200.0 }").map(Some)
}

/// The targets of a path along one axis, mm.
#[derive(Debug, Deserialize)]
#[serde(try_from = "toml::Value")]
struct Targets(Vec<f64>);

impl TryFrom<toml::Value> for Targets {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        let list = value
            .as_array()
            .ok_or_else(|| expected("a list of positions (mm)", &value))?;
        list.iter()
            .map(|x| config::number(x).ok_or_else(|| expected("numbers (mm)", x)))
            .collect::<Result<_, _>>()
            .map(Targets)
    }
}

fn to_si(machine: &Machine, axis: usize, v: f64) -> f64 {
    machine.axes()[axis].kind().from_file(v)
}

fn axis_of(machine: &Machine, letter: &str, key: &str) -> Result<usize, SetupError> {
    let mut chars = letter.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) => machine.axis_index(c),
        _ => None,
    }
    .ok_or_else(|| {
        SetupError::new(
            key,
            format!(
                "`{letter}` is not an axis of machine `{}` (axes: {})",
                machine.name(),
                machine.letters()
            ),
        )
    })
}

/// Axis positions by letter (`{ X = 10.0, C = 90.0 }`, mm / degrees) of key `key`, written
/// into `q` (SI). Returns which axes were named.
fn positions(
    machine: &Machine,
    positions: Option<&toml::Table>,
    key: &str,
    q: &mut [f64],
) -> Result<Vec<bool>, SetupError> {
    let mut named = vec![false; machine.n_axes()];
    for (letter, v) in positions.into_iter().flatten() {
        let k = format!("{key}.{letter}");
        let axis = axis_of(machine, letter, &k)?;
        let x = config::number(v).ok_or_else(|| {
            SetupError::new(
                &k,
                format!("expected a position (mm, or degrees for a rotary axis), found {v}"),
            )
        })?;
        q[axis] = to_si(machine, axis, x);
        named[axis] = true;
    }
    Ok(named)
}

fn count(
    value: Option<Number>,
    key: &str,
    default: usize,
    min: usize,
) -> Result<usize, SetupError> {
    match value.map(f64::from) {
        None => Ok(default),
        Some(x) if x.fract() == 0.0 && x >= min as f64 && x <= 1e6 => Ok(x as usize),
        Some(x) => Err(SetupError::new(
            key,
            format!("expected a whole number from {min} to 1000000, found {x}"),
        )),
    }
}

/// The ISO 230-2 sequence of target indices (`None` = an overrun sample below the first
/// target, `Some(usize::MAX)` above the last) for `m` targets.
fn cycle_order(m: usize, cycles: usize, bidirectional: bool, overrun: bool) -> Vec<Option<usize>> {
    let mut seq = Vec::new();
    for _ in 0..cycles {
        if overrun {
            seq.push(None);
        }
        seq.extend((0..m).map(Some));
        if bidirectional {
            if overrun {
                seq.push(Some(usize::MAX));
            }
            seq.extend((0..m).rev().map(Some));
        }
    }
    if overrun && bidirectional {
        seq.push(None);
    }
    seq
}

fn check_limits(machine: &Machine, poses: &[Vec<f64>], key: &str) -> Result<(), SetupError> {
    for (k, q) in poses.iter().enumerate() {
        if !machine.within_limits(q, LIMIT_TOL) {
            let shown: Vec<String> = machine
                .axes()
                .iter()
                .zip(q)
                .map(|(a, &v)| match a.kind() {
                    AxisKind::Linear => format!("{} = {:.4} mm", a.letter(), v * 1e3),
                    AxisKind::Rotary => format!("{} = {:.4}°", a.letter(), v.to_degrees()),
                })
                .collect();
            return Err(SetupError::new(
                key,
                format!(
                    "sample {k} ({}) is outside the axis limits of machine `{}`",
                    shown.join(", "),
                    machine.name()
                ),
            ));
        }
    }
    Ok(())
}

/// The nominal travel of the tool point from the first to the last distinct pose must lie
/// along the set-up's beam `direction` (either sense).
fn check_direction(
    machine: &Machine,
    setup: &LaserSetup,
    a: &[f64],
    b: &[f64],
) -> Result<(), SetupError> {
    let d = machine.tool_in_workpiece(b).t - machine.tool_in_workpiece(a).t;
    let norm = d.norm();
    if norm == 0.0 {
        return Err(SetupError::new(
            "from",
            "the path does not move the tool point",
        ));
    }
    let u = d / norm;
    let n = setup.beam();
    let off = u.cross(&n).norm();
    if off > ALIGN_TOL {
        return Err(SetupError::new(
            "direction",
            format!(
                "the path moves the tool point along [{}, {}, {}] (workpiece frame), {off:.2e} \
                 rad away from the set-up's beam direction; write that direction",
                u.x, u.y, u.z
            ),
        ));
    }
    Ok(())
}

fn axis_path(spec: &PathSpec<'_>, setup: &LaserSetup) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let keys: AxisPathKeys = config::read(spec.path)?;
    let letter = match &keys.axis {
        Some(s) => s.to_string(),
        None => match setup.direction().value().as_str() {
            Some(d) => d.trim_start_matches(['+', '-']).to_string(),
            None => {
                return Err(SetupError::new(
                    "axis",
                    "missing: the axis that moves (the set-up's direction is not an axis letter)",
                ));
            }
        },
    };
    let axis = axis_of(machine, &letter, "axis")?;
    if machine.axes()[axis].kind() != AxisKind::Linear {
        return Err(SetupError::new(
            "axis",
            format!("`{letter}` is not a linear axis"),
        ));
    }
    let mut base = vec![0.0; machine.n_axes()];
    let held = positions(machine, keys.hold.as_ref(), "hold", &mut base)?;
    if held[axis] {
        return Err(SetupError::new(
            format!("hold.{letter}"),
            "the moving axis cannot be held",
        ));
    }
    let limits = machine.axes()[axis].limits();
    // Targets, mm along the axis, ascending.
    let mut targets: Vec<f64> = if let Some(Targets(targets)) = &keys.targets {
        let range = [
            ("from", keys.from.is_some()),
            ("to", keys.to.is_some()),
            ("step", keys.step.is_some()),
            ("points", keys.points.is_some()),
        ];
        if let Some((key, _)) = range.iter().find(|(_, given)| *given) {
            return Err(SetupError::new(
                *key,
                "give either `targets` or a range, not both",
            ));
        }
        targets.clone()
    } else {
        let (lo, hi) = limits.map_or((-0.1, 0.1), |(l, h)| (l, h));
        let from = keys.from.map_or(lo * 1e3, f64::from);
        let to = keys.to.map_or(hi * 1e3, f64::from);
        if from == to {
            return Err(SetupError::new(
                "to",
                "`from` and `to` are the same position",
            ));
        }
        let points = match keys.step.map(f64::from) {
            Some(step) => {
                if keys.points.is_some() {
                    return Err(SetupError::new("points", "give either `step` or `points`"));
                }
                if step <= 0.0 {
                    return Err(SetupError::new(
                        "step",
                        format!("must be > 0 mm, found {step}"),
                    ));
                }
                let n = ((to - from).abs() / step + 1e-9).floor() as usize + 1;
                if n < 2 {
                    return Err(SetupError::new("step", "the step is longer than the range"));
                }
                return finish_axis(spec, setup, &keys, axis, &base, {
                    let sgn = (to - from).signum();
                    (0..n).map(|i| from + sgn * step * i as f64).collect()
                });
            }
            None => count(keys.points, "points", DEFAULT_POINTS, 2)?,
        };
        (0..points)
            .map(|i| from + (to - from) * i as f64 / (points - 1) as f64)
            .collect()
    };
    targets.sort_by(f64::total_cmp);
    finish_axis(spec, setup, &keys, axis, &base, targets)
}

fn finish_axis(
    spec: &PathSpec<'_>,
    setup: &LaserSetup,
    keys: &AxisPathKeys,
    axis: usize,
    base: &[f64],
    mut targets_mm: Vec<f64>,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    targets_mm.sort_by(f64::total_cmp);
    targets_mm.dedup();
    if targets_mm.len() < 2 {
        return Err(SetupError::new(
            "targets",
            "need at least two distinct targets",
        ));
    }
    let cycles = count(keys.cycles, "cycles", 1, 1)?;
    let bidirectional = keys.bidirectional.unwrap_or(true);
    let overrun = keys.overrun.map_or(0.0, f64::from);
    if overrun < 0.0 {
        return Err(SetupError::new(
            "overrun",
            format!("must be ≥ 0 mm, found {overrun}"),
        ));
    }
    let m = targets_mm.len();
    let at = |x_mm: f64| {
        let mut q = base.to_vec();
        q[axis] = x_mm * 1e-3;
        q
    };
    let poses: Vec<Vec<f64>> = cycle_order(m, cycles, bidirectional, overrun > 0.0)
        .into_iter()
        .map(|i| match i {
            None => at(targets_mm[0] - overrun),
            Some(usize::MAX) => at(targets_mm[m - 1] + overrun),
            Some(i) => at(targets_mm[i]),
        })
        .collect();
    check_limits(
        machine,
        &poses,
        if overrun > 0.0 { "overrun" } else { "targets" },
    )?;
    check_direction(machine, setup, &at(targets_mm[0]), &at(targets_mm[m - 1]))?;
    Ok(poses)
}

fn diagonal_path(
    spec: &PathSpec<'_>,
    setup: &LaserSetup,
    steps: bool,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let keys: DiagonalPathKeys = config::read(spec.path)?;
    let mut base = vec![0.0; machine.n_axes()];
    let held = positions(machine, keys.hold.as_ref(), "hold", &mut base)?;
    let mut from = base.clone();
    let mut to = base.clone();
    let from_given = required(
        keys.from.as_ref(),
        "from",
        "the start corner, e.g. { X = -200.0, Y = -150.0, Z = -400.0 }",
    )?;
    let to_given = required(keys.to.as_ref(), "to", "the end corner")?;
    let nf = positions(machine, Some(from_given), "from", &mut from)?;
    let nt = positions(machine, Some(to_given), "to", &mut to)?;
    for i in 0..machine.n_axes() {
        let letter = machine.axes()[i].letter();
        if held[i] && (nf[i] || nt[i]) {
            return Err(SetupError::new(
                format!("hold.{letter}"),
                "an axis named in `from`/`to` cannot be held",
            ));
        }
        if nf[i] != nt[i] {
            return Err(SetupError::new(
                if nf[i] { "to" } else { "from" },
                format!("axis {letter} must be named in both `from` and `to`"),
            ));
        }
    }
    let moving: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| from[i] != to[i])
        .collect();
    if moving.len() < 2 {
        return Err(SetupError::new("to", "a diagonal moves at least two axes"));
    }
    let points = count(keys.points, "points", DEFAULT_POINTS, 2)?;
    let cycles = count(keys.cycles, "cycles", 1, 1)?;
    let bidirectional = keys.bidirectional.unwrap_or(true);
    let corner =
        |s: f64| -> Vec<f64> { from.iter().zip(&to).map(|(a, b)| a + (b - a) * s).collect() };
    let targets: Vec<Vec<f64>> = (0..points)
        .map(|i| corner(i as f64 / (points - 1) as f64))
        .collect();
    let mut poses: Vec<Vec<f64>> = Vec::new();
    let mut last: Option<usize> = None;
    for i in cycle_order(points, cycles, bidirectional, false)
        .into_iter()
        .flatten()
    {
        if steps {
            if let Some(j) = last.filter(|&j| j != i) {
                // One axis at a time, in the machine's axis order; the last step lands on the
                // target.
                let mut q = targets[j].clone();
                for &ax in &moving[..moving.len() - 1] {
                    q[ax] = targets[i][ax];
                    poses.push(q.clone());
                }
            }
        }
        poses.push(targets[i].clone());
        last = Some(i);
    }
    check_limits(machine, &poses, "to")?;
    check_direction(machine, setup, &targets[0], &targets[points - 1])?;
    Ok(poses)
}

/// The plugin's path function (path keys in the crate docs): the set-up must load, and the
/// path must move the tool point along its beam `direction`.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let setup: &LaserSetup = spec.own_setup()?;
    match setup.mode() {
        Mode::Diagonal => diagonal_path(spec, setup, false),
        Mode::StepDiagonal => diagonal_path(spec, setup, true),
        _ => axis_path(spec, setup),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<AxisPathKeys>(), Some(AXIS_PATH_KEYS));
        assert_eq!(
            config::keys_of::<DiagonalPathKeys>(),
            Some(DIAGONAL_PATH_KEYS)
        );
    }
}
