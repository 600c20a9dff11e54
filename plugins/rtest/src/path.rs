//! Measuring paths: rotary axes swept, linear axes following the ball.

use crate::setup::RTest;
use mtcal_instrument::config::{self, Number, expected};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::{AxisKind, Machine, ik};
use nalgebra::Vector3;
use serde::{Deserialize, Deserializer};

/// Samples of a path when the table does not say.
pub const DEFAULT_SAMPLES: usize = 73;

/// Every key a path table may have.
pub const PATH_KEYS: &[&str] = &["kind", "sweep", "hold", "samples", "back"];

/// The half-range of the A sweep of the `xyzac` preset, degrees (narrowed to A's limits).
pub const XYZAC_TILT_DEG: f64 = 30.0;
/// The range the `yza` and `zxb` presets clip the tilting axis' limits to, degrees.
pub const TILT_RANGE_DEG: (f64, f64) = (-30.0, 90.0);

/// A path table as written ([`PATH_KEYS`], in that order). `sweep` and `hold` are keyed by
/// axis letters: their entries are read once the letter is known to name a rotary axis.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PathKeys {
    kind: Option<Kind>,
    #[serde(default, deserialize_with = "sweep_table")]
    sweep: Option<toml::Table>,
    #[serde(default, deserialize_with = "hold_table")]
    hold: Option<toml::Table>,
    samples: Option<Number>,
    back: Option<bool>,
}

fn sweep_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table like { C = [0.0, 360.0] }").map(Some)
}

fn hold_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table like { A = -30.0 }").map(Some)
}

/// A named path: a preset or the general `rotary` sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum Kind {
    /// C from 0 to 360°, the other rotary axis held.
    Xyc,
    /// A over its limits clipped to [−30°, 90°], the other rotary axis held.
    Yza,
    /// B over its limits clipped to [−30°, 90°], the other rotary axis held.
    Zxb,
    /// A from −θ to +θ (θ = 30° or less, within A's limits) and C from 0 to 360° together.
    Xyzac,
    /// The axes and ranges of `sweep`.
    Rotary,
}

impl Kind {
    pub fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "xyc" => Kind::Xyc,
            "yza" => Kind::Yza,
            "zxb" => Kind::Zxb,
            "xyzac" => Kind::Xyzac,
            "rotary" => Kind::Rotary,
            _ => return None,
        })
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Xyc => "xyc",
            Kind::Yza => "yza",
            Kind::Zxb => "zxb",
            Kind::Xyzac => "xyzac",
            Kind::Rotary => "rotary",
        }
    }
}

impl TryFrom<String> for Kind {
    type Error = String;
    fn try_from(value: String) -> Result<Self, String> {
        Kind::parse(&value).ok_or_else(|| {
            format!(
                "unknown path `{value}`; expected \"xyc\", \"yza\", \"zxb\", \"xyzac\" or \
                 \"rotary\""
            )
        })
    }
}

/// A path table resolved against a machine: which rotary axes sweep where, which are held.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Swept axes: (axis index, from, to), rad.
    pub sweep: Vec<(usize, f64, f64)>,
    /// Held rotary axes: (axis index, position), rad.
    pub hold: Vec<(usize, f64)>,
    pub samples: usize,
    /// Go and come back.
    pub back: bool,
}

fn rotary_axes(machine: &Machine) -> Vec<usize> {
    (0..machine.n_axes())
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Rotary)
        .collect()
}

fn rotary_letters(machine: &Machine) -> String {
    let letters: Vec<String> = rotary_axes(machine)
        .iter()
        .map(|&i| machine.axes()[i].letter().to_string())
        .collect();
    if letters.is_empty() {
        "none".into()
    } else {
        letters.join(", ")
    }
}

/// Whether R-test paths can run on `machine`: three linear axes and one or two rotary axes.
pub fn check_machine(machine: &Machine) -> Result<(), SetupError> {
    let rotary = rotary_axes(machine).len();
    let linear = machine.n_axes() - rotary;
    if linear != 3 || !(1..=2).contains(&rotary) {
        return Err(SetupError::new(
            "kind",
            format!(
                "machine `{}` has axes {}; R-test paths need three linear axes and one or two \
                 rotary axes",
                machine.name(),
                machine.letters()
            ),
        ));
    }
    Ok(())
}

/// The rotary axis named by `key` (`sweep.C`), or an error naming that key.
fn rotary_axis(machine: &Machine, letter: &str, key: &str) -> Result<usize, SetupError> {
    let mut chars = letter.chars();
    let found = match (chars.next(), chars.next()) {
        (Some(c), None) => machine
            .axis_index(c)
            .filter(|&i| machine.axes()[i].kind() == AxisKind::Rotary),
        _ => None,
    };
    found.ok_or_else(|| {
        SetupError::new(
            key,
            format!(
                "`{letter}` is not a rotary axis of machine `{}` (rotary axes: {})",
                machine.name(),
                rotary_letters(machine)
            ),
        )
    })
}

fn parse_sweep(
    machine: &Machine,
    sweep: &toml::Table,
) -> Result<Vec<(usize, f64, f64)>, SetupError> {
    if sweep.is_empty() || sweep.len() > 2 {
        return Err(SetupError::new(
            "sweep",
            format!("expected one or two rotary axes, found {}", sweep.len()),
        ));
    }
    let mut out = Vec::new();
    for (letter, v) in sweep {
        let key = format!("sweep.{letter}");
        let axis = rotary_axis(machine, letter, &key)?;
        let ends = match v.as_array().map(Vec::as_slice) {
            Some([from, to]) => config::number(from).zip(config::number(to)),
            _ => None,
        };
        let (from, to) =
            ends.ok_or_else(|| SetupError::new(&key, expected("[from, to] in degrees", v)))?;
        if from == to {
            return Err(SetupError::new(
                &key,
                "from and to are equal: nothing is swept",
            ));
        }
        out.push((axis, from.to_radians(), to.to_radians()));
    }
    Ok(out)
}

/// The preset's swept axis range clipped to `range` (degrees) and the axis' limits.
fn clipped(machine: &Machine, axis: usize, range: (f64, f64)) -> Result<(f64, f64), SetupError> {
    let (lo, hi) = (range.0.to_radians(), range.1.to_radians());
    let (from, to) = match machine.axes()[axis].limits() {
        None => (lo, hi),
        Some((l, h)) => (l.max(lo), h.min(hi)),
    };
    if from >= to {
        return Err(SetupError::new(
            "kind",
            format!(
                "axis {}'s limits leave nothing of [{}°, {}°] to sweep",
                machine.axes()[axis].letter(),
                range.0,
                range.1
            ),
        ));
    }
    Ok((from, to))
}

fn preset_axis(machine: &Machine, kind: Kind, letter: char) -> Result<usize, SetupError> {
    machine
        .axis_index(letter)
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Rotary)
        .ok_or_else(|| {
            SetupError::new(
                "kind",
                format!(
                    "the `{}` path sweeps {letter}; machine `{}` has rotary axes {} (use kind = \
                     \"rotary\" with a `sweep` table)",
                    kind.as_str(),
                    machine.name(),
                    rotary_letters(machine)
                ),
            )
        })
}

/// Resolves a path table against a machine (keys in the crate documentation).
pub fn plan(machine: &Machine, path: &toml::Table) -> Result<Plan, SetupError> {
    let keys: PathKeys = config::read(path)?;
    check_machine(machine)?;
    let kind = keys.kind.unwrap_or(Kind::Rotary);
    let samples = match keys.samples.map(f64::from) {
        None => DEFAULT_SAMPLES,
        Some(x) if x.fract() == 0.0 && (2.0..=1e6).contains(&x) => x as usize,
        Some(x) => {
            return Err(SetupError::new(
                "samples",
                format!("expected a whole number from 2 to 1000000, found {x}"),
            ));
        }
    };
    let back = keys.back.unwrap_or(false);
    let sweep = match &keys.sweep {
        Some(t) => parse_sweep(machine, t)?,
        None => match kind {
            Kind::Rotary => {
                return Err(SetupError::new(
                    "sweep",
                    "missing: the swept rotary axes and ranges, e.g. sweep = { C = [0.0, 360.0] }",
                ));
            }
            Kind::Xyc => {
                let c = preset_axis(machine, kind, 'C')?;
                vec![(c, 0.0, 360f64.to_radians())]
            }
            Kind::Yza | Kind::Zxb => {
                let letter = if kind == Kind::Yza { 'A' } else { 'B' };
                let axis = preset_axis(machine, kind, letter)?;
                let (from, to) = clipped(machine, axis, TILT_RANGE_DEG)?;
                vec![(axis, from, to)]
            }
            Kind::Xyzac => {
                let a = preset_axis(machine, kind, 'A')?;
                let c = preset_axis(machine, kind, 'C')?;
                let tilt = XYZAC_TILT_DEG.to_radians();
                let theta = match machine.axes()[a].limits() {
                    None => tilt,
                    Some((lo, hi)) => tilt.min(-lo).min(hi),
                };
                if theta <= 0.0 {
                    return Err(SetupError::new(
                        "kind",
                        "the `xyzac` path tilts A symmetrically about 0, but A's limits do not \
                         include both sides of 0",
                    ));
                }
                vec![(a, -theta, theta), (c, 0.0, 360f64.to_radians())]
            }
        },
    };
    let mut hold = Vec::new();
    for (letter, v) in keys.hold.iter().flatten() {
        let key = format!("hold.{letter}");
        let axis = rotary_axis(machine, letter, &key)?;
        if sweep.iter().any(|s| s.0 == axis) {
            return Err(SetupError::new(
                &key,
                "this axis is swept; it cannot be held too",
            ));
        }
        let x = config::number(v)
            .ok_or_else(|| SetupError::new(&key, expected("a position in degrees", v)))?;
        hold.push((axis, x.to_radians()));
    }
    for axis in rotary_axes(machine) {
        if !sweep.iter().any(|s| s.0 == axis) && !hold.iter().any(|h| h.0 == axis) {
            hold.push((axis, 0.0));
        }
    }
    Ok(Plan {
        sweep,
        hold,
        samples,
        back,
    })
}

/// Describes a position of an axis in file units.
fn show(machine: &Machine, axis: usize, v: f64) -> String {
    match machine.axes()[axis].kind() {
        AxisKind::Linear => format!("{:.4} mm", v * 1e3),
        AxisKind::Rotary => format!("{:.4}°", v.to_degrees()),
    }
}

/// The commanded poses of `plan` with the linear axes following the ball at `ball_m` (m,
/// workpiece frame). Every position is checked against the axis limits: a sample outside them
/// is an error naming the axis and the sample (`sweep`/`hold` for a rotary axis, `ball` for a
/// linear one), never clipped.
pub fn poses(
    machine: &Machine,
    ball_m: &Vector3<f64>,
    plan: &Plan,
) -> Result<Vec<Vec<f64>>, SetupError> {
    let n = plan.samples;
    let mut order: Vec<usize> = (0..n).collect();
    if plan.back {
        order.extend((0..n - 1).rev());
    }
    let total = order.len();
    let mut out = Vec::with_capacity(total);
    for (k, &s) in order.iter().enumerate() {
        let f = s as f64 / (n - 1) as f64;
        let mut q = vec![0.0; machine.n_axes()];
        for &(axis, from, to) in &plan.sweep {
            q[axis] = from + f * (to - from);
        }
        for &(axis, v) in &plan.hold {
            q[axis] = v;
        }
        let where_ = |q: &[f64]| {
            let rot: Vec<String> = rotary_axes(machine)
                .iter()
                .map(|&i| {
                    format!(
                        "{} = {}",
                        machine.axes()[i].letter(),
                        show(machine, i, q[i])
                    )
                })
                .collect();
            format!("sample {} of {total} ({})", k + 1, rot.join(", "))
        };
        ik::follow_point(machine, &mut q, ball_m).map_err(|e| {
            SetupError::new(
                "ball",
                format!(
                    "{}: the linear axes cannot follow the ball: {e}",
                    where_(&q)
                ),
            )
        })?;
        for (i, axis) in machine.axes().iter().enumerate() {
            let Some((lo, hi)) = axis.limits() else {
                continue;
            };
            let tol = 1e-9;
            if q[i] < lo - tol || q[i] > hi + tol || !q[i].is_finite() {
                let key = match axis.kind() {
                    AxisKind::Linear => "ball",
                    AxisKind::Rotary if plan.sweep.iter().any(|s| s.0 == i) => "sweep",
                    AxisKind::Rotary => "hold",
                };
                return Err(SetupError::new(
                    key,
                    format!(
                        "{}: axis {} = {} is outside its limits [{}, {}]{}",
                        where_(&q),
                        axis.letter(),
                        show(machine, i, q[i]),
                        show(machine, i, lo),
                        show(machine, i, hi),
                        if key == "ball" {
                            "; move the ball or narrow the sweep"
                        } else {
                            ""
                        }
                    ),
                ));
            }
        }
        out.push(q);
    }
    Ok(out)
}

/// The plugin's path function: resolves `spec.path` on `spec.machine` and follows the ball of
/// `spec.setup`.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let setup: &RTest = spec.own_setup()?;
    let plan = plan(spec.machine, spec.path)?;
    poses(spec.machine, &setup.ball_m(), &plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<PathKeys>(), Some(PATH_KEYS));
    }
}
