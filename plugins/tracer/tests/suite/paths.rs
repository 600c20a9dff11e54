//! Measuring paths: shape, order, limits, and the checks that reject a bad plan.

use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::Machine;
use mtcal_machine::topology::Reading;
use std::path::Path;

fn machine(name: &str) -> Machine {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../machines/{name}.urdf"));
    mtcal_machine::load_machine(p.to_str().unwrap(), Reading::default())
        .unwrap()
        .machine
}

fn table(text: &str) -> toml::Table {
    toml::from_str(text).unwrap()
}

fn run(m: &Machine, setup: &str, path: &str) -> Result<Vec<Vec<f64>>, SetupError> {
    let loaded = mtcal_tracer::load(
        &table(setup),
        &mtcal_instrument::SetupContext { machine: m },
    )?;
    mtcal_tracer::path(&PathSpec {
        path: &table(path),
        setup: &loaded,
        machine: m,
    })
}

const STATION: &str = "station = [420.0, 320.0, 0.0]";

#[test]
fn a_grid_spans_the_share_of_the_strokes_in_serpentine_order() {
    let m = machine("mcv754-zfyx");
    let q = run(
        &m,
        STATION,
        "kind = \"grid\"\ncounts = [4, 3, 2]\nfraction = 0.5",
    )
    .unwrap();
    assert_eq!(q.len(), 24);
    let (x, y, z) = (
        m.axis_index('X').unwrap(),
        m.axis_index('Y').unwrap(),
        m.axis_index('Z').unwrap(),
    );
    for k in 1..q.len() {
        // Neighbours differ in exactly one axis: the machine never jumps across the volume.
        let moved = [x, y, z]
            .iter()
            .filter(|&&i| (q[k][i] - q[k - 1][i]).abs() > 1e-12)
            .count();
        assert_eq!(moved, 1, "samples {} and {k}", k - 1);
    }
    for (i, stroke) in [(x, 0.75), (y, 0.54), (z, 0.54)] {
        let lo = q.iter().map(|p| p[i]).fold(f64::INFINITY, f64::min);
        let hi = q.iter().map(|p| p[i]).fold(f64::NEG_INFINITY, f64::max);
        assert!(
            ((hi - lo) - 0.5 * stroke).abs() < 1e-12,
            "axis {i}: {lo}..{hi}"
        );
    }
    assert!(q.iter().all(|p| m.within_limits(p, 0.0)));
}

#[test]
fn lines_are_the_edges_and_body_diagonals_of_the_box() {
    let m = machine("mcv754-zfyx");
    let q = run(&m, STATION, "kind = \"lines\"\nsamples = 5").unwrap();
    assert_eq!(q.len(), 16 * 5);
    // The last four lines are diagonals: every axis moves at every step.
    for line in 12..16 {
        for k in line * 5 + 1..line * 5 + 5 {
            assert!(
                (0..3).all(|i| (q[k][i] - q[k - 1][i]).abs() > 1e-6),
                "line {line}"
            );
        }
    }
}

#[test]
fn the_path_does_not_depend_on_the_station_or_the_reflector() {
    let m = machine("mcu630-cafyxz");
    let a = run(&m, STATION, "counts = [3, 3, 3]").unwrap();
    let b = run(
        &m,
        "station = [-500.0, 100.0, -200.0]\nreflector = [50.0, 0.0, 100.0]",
        "counts = [3, 3, 3]",
    )
    .unwrap();
    assert_eq!(a, b);
    // Rotary axes are held at 0 unless `hold` names them.
    let c = m.axis_index('C').unwrap();
    assert!(a.iter().all(|p| p[c] == 0.0));
    let held = run(&m, STATION, "counts = [2, 2, 2]\nhold = { C = 90.0 }").unwrap();
    assert!(
        held.iter()
            .all(|p| (p[c] - 90f64.to_radians()).abs() < 1e-15)
    );
}

#[test]
fn bad_plans_are_rejected_naming_the_key() {
    let m = machine("mcv754-zfyx");
    let key = |setup: &str, path: &str| run(&m, setup, path).unwrap_err().key;
    // The reflector passes within 50 mm of a station in the middle of the volume.
    assert_eq!(
        key("station = [0.0, 0.0, 370.0]", "counts = [3, 3, 3]"),
        "station"
    );
    assert_eq!(key(STATION, "kind = \"spiral\""), "kind");
    assert_eq!(key(STATION, "kind = \"grid\"\nsamples = 4"), "samples");
    assert_eq!(
        key(STATION, "kind = \"lines\"\ncounts = [2, 2, 2]"),
        "counts"
    );
    assert_eq!(key(STATION, "kind = \"lines\"\nsamples = 1"), "samples");
    assert_eq!(key(STATION, "counts = [2, 0, 2]"), "counts[1]");
    assert_eq!(key(STATION, "fraction = 1.5"), "fraction");
    assert_eq!(key(STATION, "hold = { X = 0.0 }"), "hold.X");
    assert_eq!(key(STATION, "hold = { Q = 0.0 }"), "hold.Q");
    assert_eq!(key(STATION, "speed = 3"), "speed");
    assert_eq!(
        key("reflector = [0.0, 0.0, 0.0]", "counts = [2, 2, 2]"),
        "station"
    );
}
