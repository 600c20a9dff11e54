//! Paths on the shipped machines: geometry at the nominal machine, ordering, limits, errors; and
//! the ISO 230-4 evaluation of runs on them.

use mtcal_ballbar::{BallbarConfig, fixture, path};
use mtcal_instrument::{Evaluation, PathSpec, SetupError};
use mtcal_kinematics::{AxisKind, Machine, MachineModel, ParamConfig};
use mtcal_machine::load_machine;
use mtcal_machine::topology::Reading;
use nalgebra::Vector3;

const FIVE_AXIS: [&str; 5] = [
    "headhead-xyzca",
    "mcu630-cafyxz",
    "mcv1000-5ax220-bc",
    "mixed-c-table-b-head",
    "mu6300-caxfyz",
];

fn machine(name: &str) -> Machine {
    let path = format!("{}/../../machines/{name}.urdf", env!("CARGO_MANIFEST_DIR"));
    load_machine(&path, Reading::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .machine
}

fn table(s: &str) -> toml::Table {
    toml::from_str(s).unwrap_or_else(|e| panic!("{s}: {e}"))
}

fn run(m: &Machine, setup: &toml::Table, p: &toml::Table) -> Result<Vec<Vec<f64>>, SetupError> {
    let loaded = mtcal_ballbar::BallbarSetup::new(mtcal_ballbar::BallbarConfig::from_table(setup)?);
    path(&PathSpec {
        path: p,
        setup: &loaded,
        machine: m,
    })
}

fn ball(m: &Machine, q: &[f64]) -> Vector3<f64> {
    m.tool_in_workpiece(q).t
}

/// The setup's pivot with the same length, for paths of a different kind.
fn with_setup(setup: &toml::Table) -> (Vector3<f64>, f64) {
    let c = BallbarConfig::from_table(setup).unwrap();
    (c.pivot(), c.length())
}

#[test]
fn every_path_keeps_the_bar_length_on_the_five_axis_machines() {
    for name in FIVE_AXIS {
        let m = machine(name);
        let mut rotary_seen = false;
        for seed in 0..12 {
            let f = fixture(&m, seed).unwrap_or_else(|| panic!("{name}: no fixture for {seed}"));
            let (pivot, length) = with_setup(&f.setup);
            assert!(f.poses.len() >= 25);
            for q in &f.poses {
                assert!(m.within_limits(q, 1e-9), "{name} seed {seed}: {q:?}");
                let miss = ((ball(&m, q) - pivot).norm() - length).abs();
                assert!(miss < 1e-12, "{name} seed {seed}: bar off by {miss:e} m");
            }
            let first = ball(&m, &f.poses[0]);
            let fixed = f.poses.iter().all(|q| (ball(&m, q) - first).norm() < 1e-12);
            let rotaries_move = (0..m.n_axes())
                .filter(|&i| m.axes()[i].kind() == AxisKind::Rotary)
                .any(|i| f.poses.iter().any(|q| (q[i] - f.poses[0][i]).abs() > 0.1));
            // A circle moves the ball with the rotaries held; a rotary test the other way round.
            assert_eq!(fixed, rotaries_move, "{name} seed {seed}");
            rotary_seen |= rotaries_move;
        }
        assert!(rotary_seen, "{name}: no rotary test among the fixtures");
    }
}

#[test]
fn circles_in_every_plane_and_both_directions() {
    for name in FIVE_AXIS {
        let m = machine(name);
        for (seed, plane) in ["XY", "YZ", "ZX"].into_iter().enumerate() {
            // The fixture for this seed tries this plane first: its pivot and length fit it.
            let setup = fixture(&m, seed as u64).unwrap().setup;
            let (pivot, length) = with_setup(&setup);
            let p = |dir: &str| {
                table(&format!(
                    "kind = \"circle\"\nplane = \"{plane}\"\ndirection = \"{dir}\"\nsamples = 73"
                ))
            };
            let ccw = run(&m, &setup, &p("ccw")).unwrap_or_else(|e| panic!("{name} {plane}: {e}"));
            let cw = run(&m, &setup, &p("cw")).unwrap_or_else(|e| panic!("{name} {plane}: {e}"));
            assert_eq!(ccw.len(), 73);
            for (k, (a, b)) in ccw.iter().zip(cw.iter().rev()).enumerate() {
                let d = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(d < 1e-12, "{name} {plane}: sample {k} differs by {d:e}");
            }
            // Counter-clockwise seen from the plane's normal: the ball turns positively about it.
            let normal = match plane {
                "XY" => Vector3::z(),
                "YZ" => Vector3::x(),
                _ => Vector3::y(),
            };
            let (b0, b1) = (ball(&m, &ccw[0]) - pivot, ball(&m, &ccw[1]) - pivot);
            assert!(b0.cross(&b1).dot(&normal) > 0.0, "{name} {plane}");
            // Angles start on the plane's first axis.
            assert!(b0.dot(&(Vector3::new(1.0, 1.0, 1.0) - normal)) > 0.99 * length);
            for q in ccw.iter() {
                let d = ball(&m, q) - pivot;
                assert!((d.norm() - length).abs() < 1e-12);
                assert!(
                    d.dot(&normal).abs() < 1e-12,
                    "{name} {plane}: off the plane"
                );
            }
        }
    }
}

#[test]
fn overshoot_extends_the_arc_at_both_ends() {
    let m = machine("mcv754-zfyx");
    let setup = table("pivot = [0.0, 0.0, 150.0]\nlength = 100.0");
    let p = table(
        "kind = \"circle\"\nplane = \"XY\"\nstart_deg = 90\nsweep_deg = 180\n\
         overshoot_deg = 10\nsamples = 21",
    );
    let q = run(&m, &setup, &p).unwrap();
    // 200° in 20 steps of 10°: from 80° to 280°.
    let angle = |q: &Vec<f64>| {
        let d = ball(&m, q) - Vector3::new(0.0, 0.0, 0.15);
        d.y.atan2(d.x).to_degrees().rem_euclid(360.0)
    };
    assert!((angle(&q[0]) - 80.0).abs() < 1e-9);
    assert!((angle(&q[1]) - 90.0).abs() < 1e-9);
    assert!((angle(&q[20]) - 280.0).abs() < 1e-9);
}

#[test]
fn rotary_bar_directions_on_a_c_table() {
    // MCU 630: the workpiece frame is the C table-top centre, C turns about its +z line.
    let m = machine("mcu630-cafyxz");
    let setup = table("pivot = [100.0, 0.0, 120.0]\nlength = 150.0");
    for (bar, expected) in [
        ("\"radial\"", [250.0, 0.0, 120.0]),
        ("\"tangential\"", [100.0, 150.0, 120.0]),
        ("\"axial\"", [100.0, 0.0, 270.0]),
        ("[0.0, 3.0, 4.0]", [100.0, 90.0, 240.0]),
    ] {
        let p = table(&format!(
            "kind = \"rotary\"\nsweep = {{ C = [0.0, 360.0] }}\nbar = {bar}\nsamples = 19\n\
             hold = {{ A = 0.0 }}"
        ));
        let q = run(&m, &setup, &p).unwrap_or_else(|e| panic!("{bar}: {e}"));
        let c = m.axis_index('C').unwrap();
        assert!((q[18][c] - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        for qi in &q {
            let d = ball(&m, qi) * 1e3 - Vector3::from(expected);
            assert!(d.norm() < 1e-9, "{bar}: ball off by {d:?} mm");
        }
    }
    // A pivot on the C line has no radial direction.
    let on_axis = table("pivot = [0.0, 0.0, 120.0]\nlength = 150.0");
    let p = table("kind = \"rotary\"\nsweep = { C = [0.0, 90.0] }\nbar = \"radial\"");
    let e = run(&m, &on_axis, &p).unwrap_err();
    assert_eq!(e.key, "bar");
    assert!(e.message.contains("axis C"), "{e}");
}

#[test]
fn out_of_limits_paths_name_the_axis_and_sample() {
    let m = machine("mcv754-zfyx"); // X ±375 mm, Y ±270 mm
    let setup = table("pivot = [0.0, 0.0, 150.0]\nlength = 300.0");
    let e = run(&m, &setup, &table("kind = \"circle\"\nplane = \"XY\"")).unwrap_err();
    // 300 mm fits X; Y fails first at the sample where sin φ > 0.9, i.e. φ > 64.2°.
    assert_eq!(e.key, "path");
    assert!(e.message.contains("sample 65: axis Y"), "{e}");
    let five = machine("mcu630-cafyxz"); // A from −30° to 120°
    let setup = table("pivot = [0.0, 0.0, 150.0]\nlength = 100.0");
    let p = table("kind = \"rotary\"\nsweep = { A = [0.0, 150.0] }\nbar = \"axial\"\nsamples = 16");
    let e = run(&five, &setup, &p).unwrap_err();
    assert!(e.message.contains("sample 13: axis A"), "{e}");
}

#[test]
fn bad_keys_and_machines_are_rejected() {
    let m = machine("mcu630-cafyxz");
    let setup = table("pivot = [0.0, 0.0, 150.0]\nlength = 100.0");
    let check = |p: &str, key: &str, words: &str| {
        let e = run(&m, &setup, &table(p)).unwrap_err();
        assert_eq!(e.key, key, "{p}: {e}");
        assert!(e.message.contains(words), "{p}: {e}");
    };
    check(
        "kind = \"circle\"\nplane = \"XY\"\nradius = 3",
        "radius",
        "unknown key",
    );
    check("kind = \"square\"", "kind", "circle");
    check("kind = \"circle\"\nplane = \"XZ\"", "plane", "ZX");
    check(
        "kind = \"circle\"\nplane = \"XY\"\ndirection = \"left\"",
        "direction",
        "cw",
    );
    check(
        "kind = \"circle\"\nplane = \"XY\"\nsamples = 1.5",
        "samples",
        "whole",
    );
    check(
        "kind = \"circle\"\nplane = \"XY\"\nhold = { X = 1.0 }",
        "hold",
        "linear",
    );
    check(
        "kind = \"circle\"\nplane = \"XY\"\nhold = { B = 1.0 }",
        "hold",
        "no axis `B`",
    );
    check(
        "kind = \"rotary\"\nsweep = { C = [0.0, 90.0] }",
        "bar",
        "missing",
    );
    check(
        "kind = \"rotary\"\nsweep = { C = [0.0, 90.0], A = [0, 1] }\nbar = \"axial\"",
        "sweep",
        "one rotary",
    );
    check(
        "kind = \"rotary\"\nsweep = { C = [0.0, 90.0] }\nbar = \"axial\"\nhold = { C = 1 }",
        "hold",
        "swept",
    );
    check(
        "kind = \"rotary\"\nsweep = { C = [0.0, 90.0] }\nbar = [0, 0, 0]",
        "bar",
        "zero",
    );
    // The set-up is checked too.
    let e = run(
        &m,
        &table("pivot = [0.0, 0.0, 1.0]\nlength = 100.0\npivott = 1"),
        &table("kind = \"circle\"\nplane = \"XY\""),
    )
    .unwrap_err();
    assert_eq!(e.key, "pivott");
    // A machine with two linear axes draws XY circles but no YZ circle.
    let xy = load_machine("YFX", Reading::default()).unwrap().machine;
    let z0 = xy.tool_in_workpiece(&[0.0, 0.0]).t.z * 1e3;
    let setup = table(&format!("pivot = [0.0, 0.0, {z0}]\nlength = 100.0"));
    assert!(
        run(
            &xy,
            &setup,
            &table("kind = \"circle\"\nplane = \"XY\"\nsamples = 9")
        )
        .is_ok()
    );
    let e = run(&xy, &setup, &table("kind = \"circle\"\nplane = \"YZ\"")).unwrap_err();
    assert!(e.message.contains("too few linear axes"), "{e}");
}

/// Readings of a run: bar length minus nominal, from actual tool positions.
fn readings(
    setup: &toml::Table,
    poses: &[Vec<f64>],
    model: &MachineModel,
    coeffs: &[f64],
) -> Vec<f64> {
    let (pivot, length) = with_setup(setup);
    let mut ws = model.workspace();
    poses
        .iter()
        .map(|q| (model.tool_pose(q, coeffs, &mut ws).t - pivot).norm() - length)
        .collect()
}

#[test]
fn squareness_through_the_kinematic_model() {
    // EC0Y = S on a three-axis machine: the tool is off by −S·Y along X, so to first order
    // dr = −S·Y·cos φ: a centre shift (−S·Y_centre) and the two-lobed −(L/2)·S·sin 2φ.
    let m = machine("mcv754-zfyx");
    let config = vec![ParamConfig {
        name: "EC0Y".parse().unwrap(),
        basis: None,
    }];
    let model = MachineModel::new(m.clone(), &config).unwrap();
    let s = 40e-6;
    let setup = table("pivot = [50.0, 80.0, 150.0]\nlength = 150.0");
    let poses = run(
        &m,
        &setup,
        &table("kind = \"circle\"\nplane = \"XY\"\nsamples = 361"),
    )
    .unwrap();
    let dr = readings(&setup, &poses, &model, &[s]);
    let y = m.axis_index('Y').unwrap();
    let (pivot, length) = with_setup(&setup);
    let mut angles = Vec::new();
    for (q, d) in poses.iter().zip(&dr) {
        let rel = ball(&m, q) - pivot;
        let phi = rel.y.atan2(rel.x);
        angles.push(phi);
        let expected = -s * q[y] * phi.cos();
        assert!(
            (d - expected).abs() < 1e-3 * s * 0.23,
            "{d:e} vs {expected:e}"
        );
    }
    let cd = mtcal_ballbar::circular_deviation(&angles, &dr);
    assert!((cd.g - length * s).abs() < 1e-3 * length * s, "{cd:?}");
    // The centre moved by −S·Y at the circle centre (Y = pivot y here) along X.
    assert!((cd.centre_a + s * 0.08).abs() < 1e-3 * s * 0.08, "{cd:?}");
}

#[test]
fn evaluation_reports_g_for_circles_only() {
    let m = machine("mu6300-caxfyz");
    let setup = fixture(&m, 0).unwrap().setup;
    let (pivot, _) = with_setup(&setup);
    let p = table(
        "kind = \"circle\"\nplane = \"XY\"\nsamples = 380\nstart_deg = 30.5\novershoot_deg = 9.5\n\
         direction = \"cw\"",
    );
    let poses = run(&m, &setup, &p).unwrap();
    // An ellipse of 6 µm peak to valley, a centre offset, and junk on the overshoot arcs.
    let dr: Vec<f64> = poses
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let rel = ball(&m, q) - pivot;
            let phi = rel.y.atan2(rel.x);
            let junk = if !(10..370).contains(&k) { 1e-3 } else { 0.0 };
            3e-6 * (2.0 * phi).cos() + 2e-6 * phi.cos() - 1e-6 * phi.sin() + junk
        })
        .collect();
    let q: Vec<f64> = poses.concat();
    let t: Vec<f64> = (0..poses.len()).map(|k| k as f64).collect();
    let loaded_0 =
        mtcal_ballbar::load_setup(&setup, &mtcal_instrument::SetupContext { machine: &m }).unwrap();
    let ev = Evaluation {
        machine: &m,
        setup: &*loaded_0,
        q: &q,
        readings: &dr,
        t: &t,
        labels: &[],
    };
    let metrics = mtcal_ballbar::evaluate(&ev);
    let get = |name: &str| {
        metrics
            .iter()
            .find(|x| x.name == name)
            .unwrap_or_else(|| panic!("{name} missing from {metrics:?}"))
            .value
    };
    assert!(
        (get("circular deviation G (ISO 230-4)") - 6e-6).abs() < 1e-12,
        "{metrics:?}"
    );
    assert!((get("centre offset X (least-squares circle)") - 2e-6).abs() < 1e-12);
    assert!((get("centre offset Y (least-squares circle)") + 1e-6).abs() < 1e-12);
    // Every value is about the plane; G has its uncertainty from the set-up's reading noise,
    // the others none.
    assert!(metrics.iter().all(|m| m.subject.as_deref() == Some("XY")));
    let g = &metrics[0];
    let config = mtcal_ballbar::BallbarConfig::from_table(&setup).unwrap();
    let evaluated: Vec<usize> = (10..370).collect();
    let angles: Vec<f64> = evaluated
        .iter()
        .map(|&k| {
            let rel = ball(&m, &poses[k]) - pivot;
            rel.y.atan2(rel.x)
        })
        .collect();
    let kept: Vec<f64> = evaluated.iter().map(|&k| dr[k]).collect();
    let want =
        mtcal_ballbar::circular_deviation_uncertainty(&angles, &kept, config.sigma_um * 1e-6);
    assert!(
        want > 0.0 && (g.u95.unwrap() - want).abs() < 1e-15,
        "{g:?} vs {want}"
    );
    assert!(metrics[1..].iter().all(|m| m.u95.is_none()));
    // A rotary test gets no evaluation.
    let rot = (3..40).find_map(|seed| {
        let f = fixture(&m, seed)?;
        let c = m.axis_index('C')?;
        f.poses.iter().any(|q| q[c] != f.poses[0][c]).then_some(f)
    });
    let rot = rot.expect("a rotary fixture");
    let q: Vec<f64> = rot.poses.concat();
    let zeros = vec![0.0; rot.poses.len()];
    let loaded_1 =
        mtcal_ballbar::load_setup(&rot.setup, &mtcal_instrument::SetupContext { machine: &m })
            .unwrap();
    let ev = Evaluation {
        machine: &m,
        setup: &*loaded_1,
        q: &q,
        readings: &zeros,
        t: &zeros,
        labels: &[],
    };
    assert!(mtcal_ballbar::evaluate(&ev).is_empty());
}
