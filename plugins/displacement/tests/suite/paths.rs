//! Paths: the machine held still, checked against the set-up.

use mtcal_displacement::{DEFAULT_SAMPLES, POSITION_TOL_MM, path};
use mtcal_instrument::{PathSpec, SetupError};
use mtcal_kinematics::Machine;

fn machine(name: &str) -> Machine {
    let path = format!("{}/../../machines/{name}.urdf", env!("CARGO_MANIFEST_DIR"));
    mtcal_machine::load_machine(&path, Default::default())
        .expect("shipped machine")
        .machine
}

fn table(text: &str) -> toml::Table {
    toml::from_str(text).expect("valid toml")
}

fn run(m: &Machine, setup: &str, path_text: &str) -> Result<Vec<Vec<f64>>, SetupError> {
    let loaded = mtcal_displacement::load(
        &table(setup),
        &mtcal_instrument::SetupContext { machine: m },
    )?;
    path(&PathSpec {
        path: &table(path_text),
        setup: &loaded,
        machine: m,
    })
}

/// The set-up text with `position` at the nominal tool point for axis positions `q`.
fn setup_at(m: &Machine, q: &[f64], sensors: &str) -> String {
    let p = m.tool_in_workpiece(q).t * 1e3;
    format!(
        "position = [{}, {}, {}]\n[sensors]\n{sensors}",
        p.x, p.y, p.z
    )
}

#[test]
fn a_path_holds_every_axis_where_at_says() {
    let m = machine("mcu630-cafyxz");
    let letters = m.letters();
    assert_eq!(letters, "XYZAC");
    let q = [0.1, -0.05, -0.2, 30f64.to_radians(), 0.0];
    let setup = setup_at(&m, &q, "a = \"X\"\n");
    let poses = run(
        &m,
        &setup,
        "samples = 7\nat = { X = 100.0, Y = -50, Z = -200.0, A = 30.0 }",
    )
    .expect("a valid path");
    assert_eq!(poses.len(), 7);
    for p in &poses {
        for (got, want) in p.iter().zip(q) {
            assert!((got - want).abs() < 1e-15, "{p:?}");
        }
    }
    // Without `samples` the default; without `at` every axis at 0.
    let setup = setup_at(&m, &[0.0; 5], "a = \"X\"\n");
    let poses = run(&m, &setup, "").expect("a valid path");
    assert_eq!(poses.len(), DEFAULT_SAMPLES);
    assert!(poses.iter().all(|p| p.iter().all(|&v| v == 0.0)));
}

fn expect_err(r: Result<Vec<Vec<f64>>, SetupError>, key: &str, says: &str) {
    match r {
        Ok(p) => panic!("accepted ({} poses)", p.len()),
        Err(e) => {
            assert_eq!(e.key, key, "{e}");
            assert!(e.message.contains(says), "{e}");
        }
    }
}

#[test]
fn bad_path_tables_are_rejected_naming_the_key() {
    let m = machine("mcv754-zfyx");
    let setup = setup_at(&m, &[0.0; 3], "a = \"X\"\n");
    expect_err(run(&m, &setup, "at = { Q = 1.0 }"), "at.Q", "not an axis");
    expect_err(run(&m, &setup, "at = { A = 1.0 }"), "at.A", "not an axis");
    expect_err(run(&m, &setup, "at = { XY = 1.0 }"), "at.XY", "not an axis");
    expect_err(
        run(&m, &setup, "at = { X = \"1\" }"),
        "at.X",
        "expected a position",
    );
    expect_err(
        run(&m, &setup, "at = { X = 5000.0 }"),
        "at.X",
        "outside its limits",
    );
    expect_err(
        run(&m, &setup, "at = [0, 0, 0]"),
        "at",
        "table of axis positions",
    );
    expect_err(run(&m, &setup, "samples = 0"), "samples", "whole number");
    expect_err(run(&m, &setup, "samples = 2.5"), "samples", "whole number");
    expect_err(
        run(&m, &setup, "samples = \"many\""),
        "samples",
        "finite number",
    );
    expect_err(run(&m, &setup, "kind = \"xyc\""), "kind", "unknown key");
    // The set-up must load first.
    expect_err(
        run(&m, "[sensors]\na = \"Q\"\n", ""),
        "sensors.a",
        "direction",
    );
}

#[test]
fn a_position_away_from_the_nominal_tool_point_is_rejected_with_the_value_to_write() {
    let m = machine("mcv754-zfyx");
    let q = [0.1, 0.05, -0.2];
    let p = m.tool_in_workpiece(&q).t * 1e3;
    let at = "at = { X = 100.0, Y = 50.0, Z = -200.0 }";
    // Within the tolerance it passes…
    let near = format!(
        "position = [{}, {}, {}]\n[sensors]\na = \"X\"\n",
        p.x + 0.5 * POSITION_TOL_MM,
        p.y,
        p.z
    );
    run(&m, &near, at).expect("within the tolerance");
    // …beyond it the error names `position` and says where the tool point is.
    let far = format!(
        "position = [{}, {}, {}]\n[sensors]\na = \"X\"\n",
        p.x + 0.01,
        p.y,
        p.z
    );
    expect_err(
        run(&m, &far, at),
        "position",
        &format!("[{}, {}, {}] mm", p.x, p.y, p.z),
    );
    expect_err(
        run(&m, "[sensors]\na = \"X\"\n", at),
        "position",
        "set `position`",
    );
}

#[test]
fn a_lever_turned_by_the_nominal_tool_orientation_is_rejected() {
    // On the trunnion A tilts the table about X: at A = 30° the tool is turned about X relative
    // to the workpiece, so an offset up the tool axis would no longer be where the model puts
    // it, while one along X is not turned.
    let m = machine("mcu630-cafyxz");
    let q = [0.0, 0.0, -0.2, 30f64.to_radians(), 0.0];
    let at = "at = { Z = -200.0, A = 30.0 }";
    let up = setup_at(&m, &q, "m = { direction = \"Y\", at = [0.0, 0.0, 50.0] }\n");
    expect_err(run(&m, &up, at), "sensors.m.at", "turns this offset");
    let along = setup_at(&m, &q, "m = { direction = \"Y\", at = [50.0, 0.0, 0.0] }\n");
    run(&m, &along, at).expect("an offset along the turning axis");
    // At A = 0 the same lever up the tool axis is fine.
    let q0 = [0.0, 0.0, -0.2, 0.0, 0.0];
    let up0 = setup_at(
        &m,
        &q0,
        "m = { direction = \"Y\", at = [0.0, 0.0, 50.0] }\n",
    );
    run(&m, &up0, "at = { Z = -200.0 }").expect("aligned tool frame");
}
