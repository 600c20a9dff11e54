//! Measuring paths: runs along one axis (linear, straightness, angular) with ISO 230-2
//! bidirectional cycles, and diagonal / step-diagonal runs between two corners (ISO 230-6).
//! The keys are documented in the crate docs.

use crate::setup::{LaserSetup, Mode, load};
use mtcal_instrument::{PathSpec, SetupContext, SetupError, read};
use mtcal_kinematics::{AxisKind, Machine};

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

fn to_si(machine: &Machine, axis: usize, v: f64) -> f64 {
    machine.axes()[axis].kind().from_file(v)
}

fn number_value(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) if f.is_finite() => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
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

/// Axis positions by letter (`{ X = 10.0, C = 90.0 }`, mm / degrees) written into `q` (SI).
/// Returns which axes were named.
fn positions(
    machine: &Machine,
    table: &toml::Table,
    key: &str,
    q: &mut [f64],
) -> Result<Vec<bool>, SetupError> {
    let mut named = vec![false; machine.n_axes()];
    let Some(v) = table.get(key) else {
        return Ok(named);
    };
    let t = v.as_table().ok_or_else(|| {
        SetupError::new(
            key,
            format!("expected a table of axis positions like {{ X = 0.0, Z = -200.0 }}, found {v}"),
        )
    })?;
    for (letter, v) in t {
        let k = format!("{key}.{letter}");
        let axis = axis_of(machine, letter, &k)?;
        let x = number_value(v).ok_or_else(|| {
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

fn count(table: &toml::Table, key: &str, default: usize, min: usize) -> Result<usize, SetupError> {
    match read::number(table, key)? {
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
    let table = spec.path;
    read::only_keys(table, AXIS_PATH_KEYS)?;
    let letter = match read::string(table, "axis")? {
        Some(s) => s.to_string(),
        None => match spec.setup.get("direction").and_then(|v| v.as_str()) {
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
    let held = positions(machine, table, "hold", &mut base)?;
    if held[axis] {
        return Err(SetupError::new(
            format!("hold.{letter}"),
            "the moving axis cannot be held",
        ));
    }
    let limits = machine.axes()[axis].limits();
    // Targets, mm along the axis, ascending.
    let mut targets: Vec<f64> = if let Some(v) = table.get("targets") {
        for key in ["from", "to", "step", "points"] {
            if table.contains_key(key) {
                return Err(SetupError::new(
                    key,
                    "give either `targets` or a range, not both",
                ));
            }
        }
        let arr = v.as_array().ok_or_else(|| {
            SetupError::new(
                "targets",
                format!("expected a list of positions (mm), found {v}"),
            )
        })?;
        arr.iter()
            .map(|x| {
                number_value(x).ok_or_else(|| {
                    SetupError::new("targets", format!("expected numbers (mm), found {x}"))
                })
            })
            .collect::<Result<_, _>>()?
    } else {
        let (lo, hi) = limits.map_or((-0.1, 0.1), |(l, h)| (l, h));
        let from = read::number(table, "from")?.unwrap_or(lo * 1e3);
        let to = read::number(table, "to")?.unwrap_or(hi * 1e3);
        if from == to {
            return Err(SetupError::new(
                "to",
                "`from` and `to` are the same position",
            ));
        }
        let points = match read::number(table, "step")? {
            Some(step) => {
                if table.contains_key("points") {
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
                return finish_axis(spec, setup, axis, &base, {
                    let sgn = (to - from).signum();
                    (0..n).map(|i| from + sgn * step * i as f64).collect()
                });
            }
            None => count(table, "points", DEFAULT_POINTS, 2)?,
        };
        (0..points)
            .map(|i| from + (to - from) * i as f64 / (points - 1) as f64)
            .collect()
    };
    targets.sort_by(f64::total_cmp);
    finish_axis(spec, setup, axis, &base, targets)
}

fn finish_axis(
    spec: &PathSpec<'_>,
    setup: &LaserSetup,
    axis: usize,
    base: &[f64],
    mut targets_mm: Vec<f64>,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let table = spec.path;
    targets_mm.sort_by(f64::total_cmp);
    targets_mm.dedup();
    if targets_mm.len() < 2 {
        return Err(SetupError::new(
            "targets",
            "need at least two distinct targets",
        ));
    }
    let cycles = count(table, "cycles", 1, 1)?;
    let bidirectional = read::boolean(table, "bidirectional")?.unwrap_or(true);
    let overrun = read::number(table, "overrun")?.unwrap_or(0.0);
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
    let table = spec.path;
    read::only_keys(table, DIAGONAL_PATH_KEYS)?;
    let mut base = vec![0.0; machine.n_axes()];
    let held = positions(machine, table, "hold", &mut base)?;
    let mut from = base.clone();
    let mut to = base.clone();
    if !table.contains_key("from") {
        return Err(SetupError::new(
            "from",
            "missing: the start corner, e.g. { X = -200.0, Y = -150.0, Z = -400.0 }",
        ));
    }
    if !table.contains_key("to") {
        return Err(SetupError::new("to", "missing: the end corner"));
    }
    let nf = positions(machine, table, "from", &mut from)?;
    let nt = positions(machine, table, "to", &mut to)?;
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
    let points = count(table, "points", DEFAULT_POINTS, 2)?;
    let cycles = count(table, "cycles", 1, 1)?;
    let bidirectional = read::boolean(table, "bidirectional")?.unwrap_or(true);
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
    let setup = load(
        spec.setup,
        &SetupContext {
            machine: spec.machine,
        },
    )?;
    match setup.mode() {
        Mode::Diagonal => diagonal_path(spec, &setup, false),
        Mode::StepDiagonal => diagonal_path(spec, &setup, true),
        _ => axis_path(spec, &setup),
    }
}
