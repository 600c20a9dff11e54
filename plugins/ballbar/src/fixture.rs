//! A representative set-up and path on a given machine, for the conformance harness and tests.

use crate::path;
use mtcal_instrument::{Fixture, PathSpec};
use mtcal_kinematics::{AxisKind, Machine};
use std::f64::consts::{FRAC_PI_2, TAU};

/// Bar lengths tried, longest first, mm.
const LENGTHS_MM: [f64; 4] = [150.0, 100.0, 75.0, 50.0];
/// Pivot offsets from the middle of the workspace tried in turn, mm.
const OFFSETS_MM: [[f64; 3]; 7] = [
    [0.0, 0.0, 0.0],
    [100.0, 0.0, 0.0],
    [0.0, 100.0, 0.0],
    [-100.0, 0.0, 0.0],
    [0.0, -100.0, 0.0],
    [0.0, 0.0, 100.0],
    [0.0, 0.0, -100.0],
];

/// A set-up and poses on `machine`: a circle in the plane `XY`, `YZ`, `ZX` cycling with `seed`
/// (direction and set-up flags varying too), on machines with rotary axes every fourth seed a
/// rotary-axis test; `None` if no bar fits.
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let rotary: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Rotary)
        .collect();
    if !rotary.is_empty() && seed % 4 == 3 {
        if let Some(f) = rotary_fixture(machine, seed, &rotary) {
            return Some(f);
        }
    }
    circle_fixture(machine, seed)
}

fn setup_table(pivot_mm: [f64; 3], length_mm: f64, seed: u64) -> toml::Table {
    let mut t = toml::Table::new();
    let pivot = pivot_mm.iter().map(|&v| toml::Value::Float(v)).collect();
    t.insert("pivot".into(), toml::Value::Array(pivot));
    t.insert("length".into(), toml::Value::Float(length_mm));
    t.insert(
        "sigma_um".into(),
        toml::Value::Float(0.5 + (seed % 3) as f64),
    );
    if seed % 2 == 1 {
        t.insert("length_free".into(), toml::Value::Boolean(true));
        t.insert("length_u_um".into(), toml::Value::Float(2.0));
    }
    if seed % 5 == 4 {
        t.insert("pivot_free".into(), toml::Value::Boolean(false));
    }
    t
}

/// The tool point (mm, rounded to 0.1 mm) with the linear axes mid-stroke and rotary axes at 0.
fn middle_mm(machine: &Machine) -> [f64; 3] {
    let q: Vec<f64> = machine
        .axes()
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => 0.5 * (lo + hi),
            _ => 0.0,
        })
        .collect();
    let p = machine.tool_in_workpiece(&q).t * 1e3;
    [p.x, p.y, p.z].map(|v| (v * 10.0).round() / 10.0)
}

fn candidates(machine: &Machine) -> impl Iterator<Item = ([f64; 3], f64)> {
    let mid = middle_mm(machine);
    OFFSETS_MM.into_iter().flat_map(move |off| {
        let pivot = [mid[0] + off[0], mid[1] + off[1], mid[2] + off[2]];
        LENGTHS_MM.into_iter().map(move |l| (pivot, l))
    })
}

fn try_path(
    machine: &Machine,
    setup: &toml::Table,
    path_table: &toml::Table,
) -> Option<Vec<Vec<f64>>> {
    let loaded = crate::BallbarSetup::new(crate::BallbarConfig::from_table(setup).ok()?);
    path::path(&PathSpec {
        path: path_table,
        setup: &loaded,
        machine,
    })
    .ok()
}

fn circle_fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let first = (seed % 3) as usize;
    let direction = if (seed / 3) % 2 == 0 { "ccw" } else { "cw" };
    for k in 0..3 {
        let plane = ["XY", "YZ", "ZX"][(first + k) % 3];
        let mut p = toml::Table::new();
        p.insert("kind".into(), "circle".into());
        p.insert("plane".into(), plane.into());
        p.insert("direction".into(), direction.into());
        p.insert(
            "start_deg".into(),
            toml::Value::Float((seed % 7) as f64 * 15.0),
        );
        p.insert("samples".into(), toml::Value::Integer(37));
        for (pivot, length) in candidates(machine) {
            let setup = setup_table(pivot, length, seed);
            if let Some(poses) = try_path(machine, &setup, &p) {
                return Some(Fixture {
                    setup,
                    poses,
                    labels: Vec::new(),
                });
            }
        }
    }
    None
}

fn rotary_fixture(machine: &Machine, seed: u64, rotary: &[usize]) -> Option<Fixture> {
    let axis = rotary[(seed / 4) as usize % rotary.len()];
    let letter = machine.axes()[axis].letter().to_string();
    let (from, to) = match machine.axes()[axis].limits() {
        None => (0.0, TAU),
        Some((lo, hi)) => (lo.max(-FRAC_PI_2), hi.min(FRAC_PI_2)),
    };
    let bars = ["radial", "tangential", "axial"];
    for shrink in [1.0, 0.5, 0.25] {
        for k in 0..bars.len() {
            let bar = bars[(seed as usize / 4 + k) % bars.len()];
            let mut p = toml::Table::new();
            p.insert("kind".into(), "rotary".into());
            let range = [from * shrink, to * shrink].map(|v| toml::Value::Float(v.to_degrees()));
            let mut sweep = toml::Table::new();
            sweep.insert(letter.clone(), toml::Value::Array(range.to_vec()));
            p.insert("sweep".into(), toml::Value::Table(sweep));
            p.insert("bar".into(), bar.into());
            p.insert("samples".into(), toml::Value::Integer(25));
            for (pivot, length) in candidates(machine) {
                let setup = setup_table(pivot, length, seed);
                if let Some(poses) = try_path(machine, &setup, &p) {
                    return Some(Fixture {
                        setup,
                        poses,
                        labels: Vec::new(),
                    });
                }
            }
        }
    }
    None
}
