//! A representative set-up and path on a given machine, for the conformance harness and tests.

use crate::path::{self, linear_axes};
use mtcal_instrument::{Fixture, PathSpec};
use mtcal_kinematics::{AxisKind, Machine};

/// Reflector offsets the fixtures cycle through, mm, tool frame.
const REFLECTORS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 120.0],
    [60.0, -40.0, 100.0],
    [-80.0, 50.0, 60.0],
];
/// Rotary axes are held here every fourth seed (clamped to their limits), degrees, so that a
/// turned nominal tool is exercised too.
const TILT_DEG: f64 = 15.0;

/// A set-up and poses on `machine`: a station beside and below a corner of the volume the
/// tool point sweeps (which corner cycles with the seed), a reflector offset cycling through
/// four (none, along the tool, two lateral), a small grid (even seeds) or the edges and
/// diagonals (odd seeds). `None` if the machine lacks a linear X, Y or Z axis with limits.
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let axes = linear_axes(machine).ok()?;
    let tilted = seed % 4 == 3;
    let mut hold = toml::Table::new();
    let mut q_mid = vec![0.0; machine.n_axes()];
    for (i, a) in machine.axes().iter().enumerate() {
        if a.kind() != AxisKind::Rotary {
            continue;
        }
        let want = if tilted { TILT_DEG.to_radians() } else { 0.0 };
        let v = a.limits().map_or(want, |(lo, hi)| want.clamp(lo, hi));
        let deg = (v.to_degrees() * 1e3).round() / 1e3;
        q_mid[i] = deg.to_radians();
        hold.insert(a.letter().to_string(), deg.into());
    }
    // The box the tool point sweeps at the path's share of the strokes (nominal machine).
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for c in 0..8usize {
        let mut q = q_mid.clone();
        for (k, &(i, a, b)) in axes.iter().enumerate() {
            let (m, h) = (0.5 * (a + b), 0.5 * path::DEFAULT_FRACTION * (b - a));
            q[i] = if c >> k & 1 == 1 { m + h } else { m - h };
        }
        let t = machine.tool_in_workpiece(&q).t * 1e3;
        for k in 0..3 {
            lo[k] = lo[k].min(t[k]);
            hi[k] = hi[k].max(t[k]);
        }
    }
    let sx = if seed % 2 == 0 { 1.0 } else { -1.0 };
    let sy = if (seed / 2) % 2 == 0 { 1.0 } else { -1.0 };
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let half = [0, 1, 2].map(|k| 0.5 * (hi[k] - lo[k]));
    let station = [
        centre[0] + sx * (half[0] + 100.0 + 10.0 * (seed % 3) as f64),
        centre[1] + sy * (half[1] + 80.0),
        centre[2] - half[2] - 150.0 - 25.0 * (seed % 2) as f64,
    ]
    .map(|v| (v * 10.0).round() / 10.0);
    let reflector = REFLECTORS[(seed % REFLECTORS.len() as u64) as usize];
    let v3 = |v: [f64; 3]| toml::Value::Array(v.iter().map(|&x| x.into()).collect());
    let mut setup = toml::Table::new();
    setup.insert("station".into(), v3(station));
    if reflector != [0.0; 3] || seed % 3 == 0 {
        setup.insert("reflector".into(), v3(reflector));
    }
    if seed % 3 == 1 {
        setup.insert("sigma_um".into(), 0.2.into());
        setup.insert("sigma_um_per_m".into(), 0.0.into());
    }
    if seed % 5 == 4 {
        setup.insert("station_free".into(), false.into());
    } else if seed % 5 == 2 {
        setup.insert("station_u_mm".into(), 5.0.into());
    }
    if seed % 7 == 6 {
        setup.insert("dead_path_free".into(), false.into());
    }
    let mut p = toml::Table::new();
    if seed % 2 == 0 {
        p.insert("kind".into(), "grid".into());
        p.insert(
            "counts".into(),
            toml::Value::Array(vec![3.into(), 3.into(), 2.into()]),
        );
    } else {
        p.insert("kind".into(), "lines".into());
        p.insert("samples".into(), 3.into());
    }
    if !hold.is_empty() {
        p.insert("hold".into(), toml::Value::Table(hold));
    }
    let loaded = crate::setup::load(&setup, &mtcal_instrument::SetupContext { machine }).ok()?;
    let poses = path::path(&PathSpec {
        path: &p,
        setup: &loaded,
        machine,
    })
    .ok()?;
    Some(Fixture {
        setup,
        poses,
        labels: Vec::new(),
    })
}
