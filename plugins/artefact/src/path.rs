//! Measuring paths (every feature of every placement) and the conformance fixture.

use crate::setup::{ArtefactSetup, frame_of, load};
use mtcal_instrument::config::{self, Number, expected};
use mtcal_instrument::{Fixture, PathSpec, SetupContext, SetupError};
use mtcal_kinematics::{AxisKind, Machine};
use serde::Deserialize;

/// Every key a path table may have.
pub const PATH_KEYS: &[&str] = &["placements", "repeat"];

/// A path table as written ([`PATH_KEYS`], in that order).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PathKeys {
    placements: Option<PlacementNames>,
    repeat: Option<Number>,
}

/// The placements a path visits, as written (a name that is not a string names no placement).
#[derive(Debug, Deserialize)]
#[serde(try_from = "toml::Value")]
struct PlacementNames(Vec<toml::Value>);

impl TryFrom<toml::Value> for PlacementNames {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        match value {
            toml::Value::Array(names) => Ok(PlacementNames(names)),
            v => Err(expected("a list of placement names", &v)),
        }
    }
}

/// The (placement, feature) pairs of a path, in probing order: placements in the order the path
/// names them (default: every placement, name order), features in name order, the whole
/// sequence `repeat` times.
fn visits(spec: &PathSpec<'_>) -> Result<Vec<(usize, usize)>, SetupError> {
    let keys: PathKeys = config::read(spec.path)?;
    let setup: &ArtefactSetup = spec.own_setup()?;
    let order: Vec<usize> = match &keys.placements {
        None => (0..setup.placements().len()).collect(),
        Some(PlacementNames(names)) => names
            .iter()
            .map(|v| {
                let name = v.as_str().unwrap_or("");
                setup
                    .placements()
                    .iter()
                    .position(|p| p.name == name)
                    .ok_or_else(|| {
                        SetupError::new("placements", format!("no placement `{v}` in the set-up"))
                    })
            })
            .collect::<Result<_, _>>()?,
    };
    let repeat = match keys.repeat.map(f64::from) {
        None => 1,
        Some(r) if r >= 1.0 && r.fract() == 0.0 => r as usize,
        Some(r) => {
            return Err(SetupError::new(
                "repeat",
                format!("expected a whole number ≥ 1, found {r}"),
            ));
        }
    };
    let nf = setup.features().len();
    let mut out = Vec::new();
    for _ in 0..repeat {
        for &j in &order {
            out.extend((0..nf).map(|k| (j, k)));
        }
    }
    Ok(out)
}

/// Commanded positions: the machine at each feature's nominal position (axis coordinates),
/// every other axis at 0. A position outside the axis limits is an error naming the feature.
pub fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let setup: &ArtefactSetup = spec.own_setup()?;
    let visits = visits(spec)?;
    let (xyz, _) = frame_of(spec.machine).map_err(|m| SetupError::new("features", m))?;
    let n = spec.machine.n_axes();
    visits
        .into_iter()
        .map(|(j, k)| {
            let p = setup.nominal_xyz(j, k);
            let mut q = vec![0.0; n];
            for c in 0..3 {
                q[xyz[c]] = p[c];
            }
            if !spec.machine.within_limits(&q, 1e-9) {
                return Err(SetupError::new(
                    format!("placements.{}", setup.placements()[j].name),
                    format!(
                        "feature `{}` of placement `{}` sits at X Y Z = {:.3} {:.3} {:.3} mm, \
                         outside the machine's limits",
                        setup.features()[k].0,
                        setup.placements()[j].name,
                        p.x * 1e3,
                        p.y * 1e3,
                        p.z * 1e3
                    ),
                ));
            }
            Ok(q)
        })
        .collect()
}

/// The `feature` label of each sample of [`path`].
pub fn path_labels(spec: &PathSpec<'_>) -> Result<Vec<Vec<String>>, SetupError> {
    let setup: &ArtefactSetup = spec.own_setup()?;
    let visits = visits(spec)?;
    Ok(visits
        .into_iter()
        .map(|(j, k)| vec![setup.label_text(j, k)])
        .collect())
}

/// A representative plate on `machine`: a grid of features (2-D or 3-D with the seed) centred
/// in the X/Y strokes at mid Z, one to three placements (turned by 90°, by 30°, flipped, moved).
/// `None` on a machine without linear X, Y, Z axes along the workpiece axes.
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let (xyz, _) = frame_of(machine).ok()?;
    let mut mid = [0.0; 3];
    let mut half = [0.0; 3];
    for c in 0..3 {
        let a = &machine.axes()[xyz[c]];
        let (lo, hi) = match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some(l)) => l,
            _ => (-0.2, 0.2),
        };
        mid[c] = 0.5 * (lo + hi) * 1e3;
        half[c] = 0.5 * (hi - lo) * 1e3;
    }
    // Plate half-size: a fifth of the smaller XY half-stroke, so every turn fits.
    let s = 0.2 * half[0].min(half[1]);
    let dim3 = seed % 2 == 1;
    let mut features = toml::Table::new();
    let grid = [-1.0, 0.0, 1.0];
    for (i, gx) in grid.iter().enumerate() {
        for (k, gy) in grid.iter().enumerate() {
            // A slightly irregular grid, as a real plate's calibration would give.
            let x = (gx * s + 0.37 * (i as f64) + 0.11 * seed as f64).round_ties_even();
            let y = gy * s - 0.29 * (k as f64);
            let v = if dim3 {
                vec![x.into(), y.into(), (0.5 * (i + k) as f64).into()]
            } else {
                vec![x.into(), y.into()]
            };
            features.insert(format!("h{}{}", i, k), toml::Value::Array(v));
        }
    }
    let mut setup = toml::Table::new();
    setup.insert("features".into(), toml::Value::Table(features));
    let origin = |dx: f64, dy: f64| {
        toml::Value::Array(vec![
            (mid[0] + dx).into(),
            (mid[1] + dy).into(),
            (mid[2] + 0.1 * half[2]).into(),
        ])
    };
    match seed % 3 {
        0 => {
            setup.insert("origin".into(), origin(0.0, 0.0));
            if seed % 2 == 0 {
                setup.insert("rotation_deg".into(), 15.0.into());
            }
        }
        _ => {
            let mut pl = toml::Table::new();
            let mut p = |name: &str, dx: f64, rot: f64, flipped: bool| {
                let mut t = toml::Table::new();
                t.insert("origin".into(), origin(dx, -0.5 * dx));
                t.insert("rotation_deg".into(), rot.into());
                if flipped {
                    t.insert("flipped".into(), true.into());
                }
                pl.insert(name.into(), toml::Value::Table(t));
            };
            p("a", 0.0, 0.0, false);
            p("b", 0.5 * s, 90.0, seed % 2 == 0);
            if seed % 3 == 2 {
                p("c", -0.5 * s, 30.0, true);
            }
            setup.insert("placements".into(), toml::Value::Table(pl));
        }
    }
    if seed % 4 == 1 {
        setup.insert("sigma_um".into(), 0.5.into());
    }
    if seed % 4 == 2 {
        setup.insert("feature_sigma_um".into(), 0.8.into());
    }
    if seed % 5 == 3 {
        setup.insert("feature_errors".into(), false.into());
    }
    let path_table = toml::Table::new();
    let loaded = load(&setup, &SetupContext { machine }).ok()?;
    let spec = PathSpec {
        path: &path_table,
        setup: &loaded,
        machine,
    };
    let poses = path(&spec).ok()?;
    let labels = path_labels(&spec).ok()?;
    Some(Fixture {
        setup,
        poses,
        labels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_typed_tables_know_the_documented_keys() {
        assert_eq!(config::keys_of::<PathKeys>(), Some(PATH_KEYS));
    }
}
