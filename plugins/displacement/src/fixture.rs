//! A representative set-up and path on a given machine, for the conformance harness and tests.

use crate::path::{held_position, path};
use mtcal_instrument::{Fixture, PathSpec};
use mtcal_kinematics::rigid::log_so3;
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::Vector3;

/// Samples of a fixture's path (the machine stands still; a few suffice).
const SAMPLES: i64 = 6;
/// Where along its stroke each linear axis is held, cycling with the seed.
const STROKE_FRACTIONS: [f64; 4] = [0.5, 0.3, 0.7, 0.45];
/// Where the rotary axes are held every fourth seed, degrees (clamped to their limits), so
/// that a tilted nominal tool orientation is exercised too.
const TILT_DEG: f64 = 25.0;
/// Vectors the `tilt` sensor cycles through (not normalised: the loader does that).
const VECTORS: [[f64; 3]; 4] = [
    [0.0, 0.6, 0.9],
    [1.0, 1.0, 0.0],
    [0.2, -0.5, 1.0],
    [3.0, 0.0, -4.0],
];

/// A set-up and poses on `machine`: the axes held mid-stroke-ish (rotary axes at 0, or tilted
/// every fourth seed), `position` the nominal tool point there, and sensors varying with the
/// seed: axis letters (signed), a vector, one without a direction and one touching the mandrel
/// 50–100 mm along it. `None` only if the held position is not reachable (it always is on the
/// shipped machines).
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let path_table = path_table(machine, seed);
    let q = held_position(machine, &path_table).ok()?;
    let nominal = machine.tool_in_workpiece(&q);
    let p_mm = nominal.t * 1e3;
    // The model takes the nominal tool frame aligned with the workpiece frame: a lever that
    // tilted axes would turn must lie along the axis they turn the tool about.
    let turn = log_so3(&nominal.r);
    let lever_dir = if turn.norm() < 1e-12 {
        Vector3::z()
    } else {
        turn.normalize()
    };
    let mut setup = toml::Table::new();
    setup.insert(
        "position".into(),
        toml::Value::Array(vec![p_mm.x.into(), p_mm.y.into(), p_mm.z.into()]),
    );
    if seed % 3 != 0 {
        setup.insert("sigma_um".into(), (0.25 * (1 + seed % 4) as f64).into());
    }
    if seed % 5 == 4 {
        setup.insert("offset_free".into(), false.into());
    }
    setup.insert(
        "sensors".into(),
        toml::Value::Table(sensors(seed, lever_dir)),
    );
    let loaded = crate::setup::load(&setup, &mtcal_instrument::SetupContext { machine }).ok()?;
    let poses = path(&PathSpec {
        path: &path_table,
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

/// The `path` table: `samples` and `at` with every axis named.
fn path_table(machine: &Machine, seed: u64) -> toml::Table {
    let frac = STROKE_FRACTIONS[(seed % STROKE_FRACTIONS.len() as u64) as usize];
    let tilted = seed % 4 == 3;
    let mut at = toml::Table::new();
    for axis in machine.axes() {
        let value = match (axis.kind(), axis.limits()) {
            // Rounded to 0.1 mm, as a user would write it.
            (AxisKind::Linear, Some((lo, hi))) => ((lo + frac * (hi - lo)) * 1e4).round() / 10.0,
            (AxisKind::Linear, None) => 0.0,
            (AxisKind::Rotary, limits) => {
                let want = if tilted { TILT_DEG.to_radians() } else { 0.0 };
                let v = limits.map_or(want, |(lo, hi)| want.clamp(lo, hi));
                (v.to_degrees() * 1e3).round() / 1e3
            }
        };
        at.insert(axis.letter().to_string(), value.into());
    }
    let mut t = toml::Table::new();
    t.insert("samples".into(), SAMPLES.into());
    t.insert("at".into(), toml::Value::Table(at));
    t
}

/// The sensors of a fixture; `lever_dir` is the direction (tool frame) the `mandrel` sensor's
/// `at` offset lies along.
fn sensors(seed: u64, lever_dir: Vector3<f64>) -> toml::Table {
    let mut s = toml::Table::new();
    s.insert("x1".into(), if seed % 2 == 0 { "X" } else { "-X" }.into());
    if seed % 3 != 1 {
        s.insert("y1".into(), if seed % 3 == 0 { "+Y" } else { "Y" }.into());
    }
    let z = if seed % 2 == 1 {
        "-Z".into()
    } else {
        let mut t = toml::Table::new();
        t.insert("direction".into(), "Z".into());
        t.insert("sigma_um".into(), 0.3.into());
        toml::Value::Table(t)
    };
    s.insert("z1".into(), z);
    let v = VECTORS[(seed % VECTORS.len() as u64) as usize];
    // Every fourth seed writes the vector with integers, which the loader must accept.
    let tilt = if seed % 4 == 1 {
        toml::Value::Array(v.iter().map(|&x| toml::Value::Integer(x as i64)).collect())
    } else {
        toml::Value::Array(v.iter().map(|&x| x.into()).collect())
    };
    s.insert("tilt".into(), tilt);
    let mut own = toml::Table::new();
    if seed % 2 == 1 {
        own.insert("sigma_um".into(), 0.8.into());
    }
    s.insert("ch5".into(), toml::Value::Table(own));
    let lever_mm = 50.0 + 25.0 * (seed % 3) as f64;
    let at = lever_dir * lever_mm;
    let mut mandrel = toml::Table::new();
    mandrel.insert(
        "direction".into(),
        if seed % 2 == 0 {
            "X".into()
        } else {
            toml::Value::Array(vec![0.0.into(), 1.0.into(), 0.5.into()])
        },
    );
    if seed % 3 == 2 {
        mandrel.insert("sigma_um".into(), 0.4.into());
    }
    mandrel.insert(
        "at".into(),
        toml::Value::Array(vec![at.x.into(), at.y.into(), at.z.into()]),
    );
    s.insert("mandrel".into(), toml::Value::Table(mandrel));
    s
}
