//! Measuring paths: the machine held still at one position for the whole run.

use crate::setup::DisplacementSetup;
use mtcal_instrument::config::{self, Number, expected};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::{AxisKind, Machine};
use serde::{Deserialize, Deserializer};

/// Samples of a path when the table does not say.
pub const DEFAULT_SAMPLES: usize = 100;

/// Every key a path table may have.
pub const PATH_KEYS: &[&str] = &["samples", "at"];

/// How far (mm) a nominal touched point the set-up assumes may lie from where the machine's
/// nominal geometry puts it at the held axis positions. Beyond it the readings would carry a
/// constant that is a set-up mistake, not a machine error.
pub const POSITION_TOL_MM: f64 = 1e-3;

/// Axis limits are checked with this tolerance (m or rad), as the conformance harness does.
const LIMIT_TOL: f64 = 1e-9;

/// A path table as written ([`PATH_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PathKeys {
    samples: Option<Number>,
    #[serde(default, deserialize_with = "at_table")]
    at: Option<toml::Table>,
}

/// Axis positions by letter; each is read once its letter is known to name an axis.
fn at_table<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    config::table(d, "a table of axis positions like { X = 0.0, Z = -200.0 }").map(Some)
}

fn show(machine: &Machine, axis: usize, v: f64) -> String {
    match machine.axes()[axis].kind() {
        AxisKind::Linear => format!("{:.4} mm", v * 1e3),
        AxisKind::Rotary => format!("{:.4}°", v.to_degrees()),
    }
}

/// The held axis positions (SI, canonical axis order) of a path table's `at`: every axis
/// named there at its value (mm for linear axes, degrees for rotary ones), every other at 0.
/// Unknown letters, non-numbers and positions outside the axis limits are errors naming
/// `at.<letter>` (or `at` for an unnamed axis whose 0 lies outside its limits).
pub fn held_position(machine: &Machine, path: &toml::Table) -> Result<Vec<f64>, SetupError> {
    let keys: PathKeys = config::read(path)?;
    held(machine, keys.at.as_ref())
}

/// [`held_position`] of the `at` table as written.
fn held(machine: &Machine, at: Option<&toml::Table>) -> Result<Vec<f64>, SetupError> {
    let mut q = vec![0.0; machine.n_axes()];
    let mut named = vec![false; machine.n_axes()];
    for (letter, v) in at.into_iter().flatten() {
        let key = format!("at.{letter}");
        let mut chars = letter.chars();
        let axis = match (chars.next(), chars.next()) {
            (Some(c), None) => machine.axis_index(c),
            _ => None,
        }
        .ok_or_else(|| {
            SetupError::new(
                &key,
                format!(
                    "`{letter}` is not an axis of machine `{}` (axes: {})",
                    machine.name(),
                    machine.letters()
                ),
            )
        })?;
        let x = config::number(v).ok_or_else(|| {
            SetupError::new(
                &key,
                expected(
                    "a position (mm for linear axes, degrees for rotary ones)",
                    v,
                ),
            )
        })?;
        q[axis] = machine.axes()[axis].kind().from_file(x);
        named[axis] = true;
    }
    for (i, axis) in machine.axes().iter().enumerate() {
        let Some((lo, hi)) = axis.limits() else {
            continue;
        };
        if q[i] < lo - LIMIT_TOL || q[i] > hi + LIMIT_TOL {
            let key = if named[i] {
                format!("at.{}", axis.letter())
            } else {
                "at".to_string()
            };
            return Err(SetupError::new(
                key,
                format!(
                    "axis {} = {}{} is outside its limits [{}, {}]",
                    axis.letter(),
                    show(machine, i, q[i]),
                    if named[i] { "" } else { " (not named, so 0)" },
                    show(machine, i, lo),
                    show(machine, i, hi)
                ),
            ));
        }
    }
    Ok(q)
}

/// Checks a set-up against the machine's nominal geometry at the held axis positions `q`: the
/// set-up's `position` must be the nominal tool point, and every directed sensor's `at` offset
/// must not be turned by the nominal tool orientation (the model takes the nominal tool frame
/// aligned with the workpiece frame; crate docs). Both within [`POSITION_TOL_MM`].
pub fn check_setup(
    machine: &Machine,
    setup: &DisplacementSetup,
    q: &[f64],
) -> Result<(), SetupError> {
    let nominal = machine.tool_in_workpiece(q);
    let tool_mm = nominal.t * 1e3;
    let off_mm = (nominal.t - setup.position_m()).norm() * 1e3;
    if off_mm > POSITION_TOL_MM {
        return Err(SetupError::new(
            "position",
            format!(
                "the set-up puts the tool point at {:?} mm, but at the held axis positions the \
                 machine's nominal tool point is [{}, {}, {}] mm ({off_mm:.4} mm away, more than \
                 {POSITION_TOL_MM} mm); set `position` to it",
                setup.position_mm(),
                tool_mm.x,
                tool_mm.y,
                tool_mm.z
            ),
        ));
    }
    for s in setup.sensors() {
        if s.direction().is_none() {
            continue;
        }
        let a = s.at_m();
        let turned_mm = (nominal.r * a - a).norm() * 1e3;
        if turned_mm > POSITION_TOL_MM {
            return Err(SetupError::new(
                format!("sensors.{}.at", s.name()),
                format!(
                    "at the held axis positions the nominal tool orientation turns this offset \
                     by {turned_mm:.4} mm; the model takes the nominal tool frame aligned with the \
                     workpiece frame, so hold the rotary axes where it is (or give `at` along \
                     the axis the tool is turned about)"
                ),
            ));
        }
    }
    Ok(())
}

/// The number of samples of a path table (default [`DEFAULT_SAMPLES`], at least 1).
fn samples(samples: Option<Number>) -> Result<usize, SetupError> {
    match samples.map(f64::from) {
        None => Ok(DEFAULT_SAMPLES),
        Some(x) if x.fract() == 0.0 && (1.0..=1e7).contains(&x) => Ok(x as usize),
        Some(x) => Err(SetupError::new(
            "samples",
            format!("expected a whole number from 1 to 10000000, found {x}"),
        )),
    }
}

/// The plugin's path function: `samples` copies of the held position of `at` (path keys in
/// the crate docs), after checking the set-up (which must load) against the machine there.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let setup: &DisplacementSetup = spec.own_setup()?;
    let keys: PathKeys = config::read(spec.path)?;
    let n = samples(keys.samples)?;
    let q = held(spec.machine, keys.at.as_ref())?;
    check_setup(spec.machine, setup, &q)?;
    Ok(vec![q; n])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<PathKeys>(), Some(PATH_KEYS));
    }
}
