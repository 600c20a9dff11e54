//! Path presets on the shipped CAFYXZ machine (MCU 630) and their errors.

use mtcal_instrument::{PathSpec, program::nc_program};
use mtcal_kinematics::Machine;
use nalgebra::Vector3;

fn machine(name: &str) -> Machine {
    let path = format!("{}/../../machines/{name}.urdf", env!("CARGO_MANIFEST_DIR"));
    mtcal_machine::load_machine(&path, Default::default())
        .expect("shipped machine")
        .machine
}

fn run(
    m: &Machine,
    setup: &str,
    path: &str,
) -> Result<Vec<Vec<f64>>, mtcal_instrument::SetupError> {
    let setup: toml::Table = toml::from_str(setup).expect("toml");
    let path: toml::Table = toml::from_str(path).expect("toml");
    let loaded = mtcal_rtest::load_setup(&setup, &mtcal_instrument::SetupContext { machine: m })?;
    mtcal_rtest::path(&PathSpec {
        path: &path,
        setup: &*loaded,
        machine: m,
    })
}

const BALL: &str = "ball = [100.0, 0.0, 200.0]";

fn deg(m: &Machine, q: &[f64], letter: char) -> f64 {
    q[m.axis_index(letter).unwrap()].to_degrees()
}

#[test]
fn presets_keep_the_tool_point_on_the_ball() {
    let m = machine("mcu630-cafyxz");
    let ball = Vector3::new(0.1, 0.0, 0.2);
    for kind in ["xyc", "yza", "xyzac"] {
        let poses =
            run(&m, BALL, &format!("kind = \"{kind}\"")).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(poses.len(), mtcal_rtest::DEFAULT_SAMPLES, "{kind}");
        for q in &poses {
            assert!(m.within_limits(q, 1e-12), "{kind}: {q:?}");
            let tip = m.tool_in_workpiece(q).t;
            assert!(
                (tip - ball).norm() < 1e-12,
                "{kind}: {}",
                (tip - ball).norm()
            );
        }
        let (first, last) = (&poses[0], &poses[poses.len() - 1]);
        match kind {
            "xyc" => {
                assert_eq!((deg(&m, first, 'C'), deg(&m, last, 'C')), (0.0, 360.0));
                assert!(poses.iter().all(|q| deg(&m, q, 'A') == 0.0));
            }
            "yza" => {
                assert!((deg(&m, first, 'A') + 30.0).abs() < 1e-9);
                assert!((deg(&m, last, 'A') - 90.0).abs() < 1e-9);
                assert!(poses.iter().all(|q| deg(&m, q, 'C') == 0.0));
            }
            _ => {
                assert!((deg(&m, first, 'A') + 30.0).abs() < 1e-9);
                assert!((deg(&m, last, 'A') - 30.0).abs() < 1e-9);
                assert!((deg(&m, last, 'C') - 360.0).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn sweep_hold_samples_and_back() {
    let m = machine("mcu630-cafyxz");
    let poses = run(
        &m,
        BALL,
        "kind = \"xyc\"\nsweep = { C = [90.0, -90.0] }\nhold = { A = 25.0 }\nsamples = 5\nback = true",
    )
    .unwrap();
    let c: Vec<f64> = poses.iter().map(|q| deg(&m, q, 'C')).collect();
    let expect = [90.0, 45.0, 0.0, -45.0, -90.0, -45.0, 0.0, 45.0, 90.0];
    assert_eq!(c.len(), expect.len());
    for (a, b) in c.iter().zip(expect) {
        assert!((a - b).abs() < 1e-9, "{c:?}");
    }
    assert!(poses.iter().all(|q| (deg(&m, q, 'A') - 25.0).abs() < 1e-12));
    // The general form with two axes swept together.
    let poses = run(
        &m,
        BALL,
        "sweep = { A = [0, 20], C = [0, 90] }\nsamples = 3",
    )
    .unwrap();
    assert!((deg(&m, &poses[1], 'A') - 10.0).abs() < 1e-9);
    assert!((deg(&m, &poses[1], 'C') - 45.0).abs() < 1e-9);
}

#[test]
fn positions_outside_the_limits_are_rejected_naming_axis_and_sample() {
    let m = machine("mcu630-cafyxz");
    // X stroke is ±350 mm: a ball 400 mm from the C axis cannot be followed.
    let e = run(&m, "ball = [400.0, 0.0, 200.0]", "kind = \"xyc\"").unwrap_err();
    assert_eq!(e.key, "ball", "{e}");
    assert!(e.message.contains("sample 1 of 73"), "{e}");
    assert!(e.message.contains("axis X"), "{e}");
    // A is limited to −30…120°.
    let e = run(&m, BALL, "sweep = { A = [-40.0, 0.0] }").unwrap_err();
    assert_eq!(e.key, "sweep", "{e}");
    assert!(e.message.contains("axis A"), "{e}");
    let e = run(&m, BALL, "kind = \"xyc\"\nhold = { A = -45.0 }").unwrap_err();
    assert_eq!(e.key, "hold", "{e}");
}

#[test]
fn path_table_errors_name_the_key() {
    let m = machine("mcu630-cafyxz");
    for (path, key) in [
        ("kind = \"zxb\"", "kind"),
        ("kind = \"spiral\"", "kind"),
        ("kind = \"rotary\"", "sweep"),
        ("sweep = { B = [0, 90] }", "sweep.B"),
        ("sweep = { X = [0, 90] }", "sweep.X"),
        ("sweep = { C = [0] }", "sweep.C"),
        ("sweep = { C = [0, 0] }", "sweep.C"),
        ("kind = \"xyc\"\nhold = { C = 10 }", "hold.C"),
        ("kind = \"xyc\"\nsamples = 1", "samples"),
        ("kind = \"xyc\"\nsamples = 2.5", "samples"),
        ("kind = \"xyc\"\nback = \"yes\"", "back"),
        ("kind = \"xyc\"\nfeed = 500", "feed"),
    ] {
        let e = run(&m, BALL, path).expect_err(path);
        assert_eq!(e.key, key, "{path}: {e}");
    }
    // The set-up must load too.
    let e = run(&m, "ball = [0, 0]", "kind = \"xyc\"").unwrap_err();
    assert_eq!(e.key, "ball");
}

#[test]
fn machines_without_a_rotary_axis_have_no_paths_and_no_fixture() {
    let m = machine("mcv754-zfyx");
    let e = run(&m, BALL, "sweep = { C = [0, 360] }").unwrap_err();
    assert_eq!(e.key, "kind", "{e}");
    assert!(e.message.contains("rotary"), "{e}");
    assert!(mtcal_rtest::fixture(&m, 0).is_none());
}

#[test]
fn the_nc_program_has_one_move_per_pose() {
    let m = machine("mcu630-cafyxz");
    let poses = run(&m, BALL, "kind = \"xyc\"\nsamples = 13").unwrap();
    let text = nc_program(&m, &poses, 500.0, "R-test XYC, ball (100, 0, 200)");
    let moves: Vec<&str> = text.lines().filter(|l| l.starts_with('N')).collect();
    assert_eq!(moves.len(), 13);
    assert!(moves[3].contains(" C90.0000 "), "{}", moves[3]);
    assert!(
        text.starts_with("%\n(R-test XYC, ball [100, 0, 200])\n"),
        "{text}"
    );
}
