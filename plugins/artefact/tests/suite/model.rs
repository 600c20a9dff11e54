//! The artefact model against hand-worked cases: what a plate error, a placement deviation and
//! a machine error do to the readings, the label grammar, the datum, reading preparation.

use mtcal_artefact::{ArtefactSetup, load};
use mtcal_instrument::{At, RunData, Setup, SetupContext, SetupFormat};
use mtcal_kinematics::{Machine, Rigid};
use nalgebra::Vector3;

fn machine() -> Machine {
    let loaded = mtcal_machine::load_machine(
        &format!(
            "{}/../../machines/mcv754-zfyx.urdf",
            env!("CARGO_MANIFEST_DIR")
        ),
        mtcal_machine::topology::Reading::default(),
    )
    .expect("shipped machine");
    loaded.machine
}

fn setup(text: &str, m: &Machine) -> ArtefactSetup {
    let t: toml::Table = toml::from_str(text).expect("toml");
    load(&t, &SetupContext { machine: m }).expect("loads")
}

const PLATE: &str = r#"
sigma_um = 0.5
[features]
a = [0.0, 0.0]
b = [100.0, 0.0]
c = [0.0, 50.0]
[placements]
p1 = { origin = [10.0, 20.0, -300.0] }
p2 = { origin = [-30.0, 0.0, -300.0], rotation_deg = 90.0 }
p3 = { origin = [0.0, 0.0, -300.0], flipped = true }
"#;

/// The reading at (placement j, feature k) with the actual tool point moved by `err` (m) from
/// the nominal one at the nominal probing position.
fn read(
    s: &ArtefactSetup,
    m: &Machine,
    j: usize,
    k: usize,
    nuis: &[f64],
    err: Vector3<f64>,
) -> Vec<f64> {
    let p = s.nominal_xyz(j, k);
    let mut q = vec![0.0; m.n_axes()];
    for (c, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        q[m.axis_index(l).unwrap()] = p[c];
    }
    let nominal = m.tool_in_workpiece(&q);
    let pose = Rigid::new(nominal.r, nominal.t + err);
    let mut out = vec![f64::NAN; s.channels().len()];
    s.predict(
        &At {
            q: &q,
            t: 0.0,
            w_t_t: &pose,
            label: s.label(j, k),
        },
        nuis,
        &mut out,
    );
    out
}

#[test]
fn nominal_reads_zero_and_a_machine_error_reads_its_opposite() {
    let m = machine();
    let s = setup(PLATE, &m);
    assert_eq!(s.channels().len(), 2);
    let nuis = vec![0.0; s.nuisance().len()];
    for j in 0..3 {
        for k in 0..3 {
            let r = read(&s, &m, j, k, &nuis, Vector3::zeros());
            assert!(r.iter().all(|v| v.abs() < 1e-15), "{j} {k}: {r:?}");
            // The tool really 3 µm further along +X, 1 µm along −Y: it reaches the feature
            // 3 µm earlier in X, so the reported centre is 3 µm short.
            let r = read(&s, &m, j, k, &nuis, Vector3::new(3e-6, -1e-6, 0.0));
            assert!(
                (r[0] + 3e-6).abs() < 1e-15 && (r[1] - 1e-6).abs() < 1e-15,
                "{r:?}"
            );
        }
    }
}

#[test]
fn a_plate_error_turns_and_mirrors_with_its_placement() {
    let m = machine();
    let s = setup(PLATE, &m);
    let mut nuis = vec![0.0; s.nuisance().len()];
    // Feature b's error along the plate's X and Y.
    let names: Vec<&str> = s.nuisance().iter().map(|n| n.name.as_str()).collect();
    let ix = names.iter().position(|n| *n == "b_ex").unwrap();
    let iy = names.iter().position(|n| *n == "b_ey").unwrap();
    nuis[ix] = 5e-6;
    nuis[iy] = 2e-6;
    let b = 1;
    let r1 = read(&s, &m, 0, b, &nuis, Vector3::zeros());
    let r2 = read(&s, &m, 1, b, &nuis, Vector3::zeros());
    let r3 = read(&s, &m, 2, b, &nuis, Vector3::zeros());
    let close = |a: &[f64], e: [f64; 2]| (a[0] - e[0]).abs() < 1e-15 && (a[1] - e[1]).abs() < 1e-15;
    assert!(close(&r1, [5e-6, 2e-6]), "{r1:?}");
    assert!(close(&r2, [-2e-6, 5e-6]), "turned by 90°: {r2:?}");
    assert!(close(&r3, [5e-6, -2e-6]), "flipped: {r3:?}");
    // Other features do not move.
    let r = read(&s, &m, 0, 0, &nuis, Vector3::zeros());
    assert!(r.iter().all(|v| v.abs() < 1e-15));
}

#[test]
fn a_placement_rotation_moves_features_by_their_lever() {
    let m = machine();
    let s = setup(PLATE, &m);
    let mut nuis = vec![0.0; s.nuisance().len()];
    let i = s.nuisance().iter().position(|n| n.name == "p2_rz").unwrap();
    nuis[i] = 1e-4;
    // Feature b at plate (100, 0) mm, turned by 90° sits at (0, 100) from the origin; a further
    // turn of 100 µrad moves it by 100 µrad × 100 mm = 10 µm along −X (exactly: sin, cos − 1).
    let r = read(&s, &m, 1, 1, &nuis, Vector3::zeros());
    assert!((r[0] + 0.1 * 1e-4_f64.sin()).abs() < 1e-15, "{r:?}");
    assert!((r[1] - 0.1 * (1e-4_f64.cos() - 1.0)).abs() < 1e-16, "{r:?}");
}

#[test]
fn labels_name_placement_and_feature() {
    let m = machine();
    let s = setup(PLATE, &m);
    assert_eq!(s.label_columns(), ["feature"]);
    assert_eq!(s.resolve_label(&["p2/c"]), Ok(s.label(1, 2)));
    assert!(
        s.resolve_label(&["c"])
            .unwrap_err()
            .message
            .contains("placements")
    );
    assert!(
        s.resolve_label(&["p9/c"])
            .unwrap_err()
            .message
            .contains("p9")
    );
    assert!(
        s.resolve_label(&["p1/zz"])
            .unwrap_err()
            .message
            .contains("a, b, c")
    );
    let one = setup(
        "[features]\nh1 = [0.0, 0.0, 0.0]\nh2 = [10.0, 0.0, 1.0]\n",
        &m,
    );
    assert_eq!(one.channels().len(), 3);
    assert_eq!(one.resolve_label(&["h2"]), Ok(1));
    assert_eq!(one.resolve_label(&["p1/h2"]), Ok(1));
    assert_eq!(one.label_text(0, 1), "h2");
    assert_eq!(s.label_text(2, 0), "p3/a");
}

#[test]
fn the_datum_fixes_the_plate_frame_only_without_a_prior() {
    let m = machine();
    let s = setup(PLATE, &m);
    // a (first) held in x and y; b is farthest from a, along X: its y held.
    assert_eq!(s.datum_held(), vec![(0, 0), (0, 1), (1, 1)]);
    let held: Vec<&str> = s
        .nuisance()
        .iter()
        .filter(|n| !n.free)
        .map(|n| n.name.as_str())
        .collect();
    assert_eq!(held, ["a_ex", "a_ey", "b_ey"]);
    let cal = setup(&format!("feature_sigma_um = 0.3\n{PLATE}"), &m);
    assert!(cal.nuisance().iter().all(|n| n.free));
    let pr = cal
        .nuisance()
        .iter()
        .find(|n| n.name == "c_ey")
        .unwrap()
        .prior_sigma;
    assert_eq!(pr, Some(0.3e-6));
    let perfect = setup(&format!("feature_errors = false\n{PLATE}"), &m);
    assert_eq!(perfect.nuisance().len(), 9);
}

#[test]
fn recorded_centres_become_deviations_from_the_probed_position() {
    let m = machine();
    let s = setup(PLATE, &m);
    let n = m.n_axes();
    let mut q = vec![0.0; 2 * n];
    let (ix, iy) = (m.axis_index('X').unwrap(), m.axis_index('Y').unwrap());
    q[ix] = 0.1;
    q[iy] = -0.05;
    q[n + ix] = 0.2;
    let mut readings = vec![0.100003, -0.050001, 0.2, 0.0];
    let run = RunData {
        q: &q,
        t: &[0.0, 1.0],
        context: &[],
    };
    s.prepare_readings(&run, &mut readings).unwrap();
    assert!((readings[0] - 3e-6).abs() < 1e-15 && (readings[1] + 1e-6).abs() < 1e-15);
    assert!(readings[2].abs() < 1e-15 && readings[3].abs() < 1e-15);
}

#[test]
fn malformed_set_ups_are_rejected_naming_the_key() {
    let m = machine();
    let bad = |text: &str, key: &str| {
        let t: toml::Table = toml::from_str(text).unwrap();
        let e = load(&t, &SetupContext { machine: &m }).unwrap_err();
        assert!(e.key.starts_with(key), "{text}: {e}");
    };
    bad(
        "origin = [0.0, 0.0, 0.0]\n[features]\na = [0.0, 0.0]\n[placements]\np = {}\n",
        "origin",
    );
    bad(
        "[features]\na = [0.0, 0.0]\nb = [1.0, 2.0, 3.0]\n",
        "features.b",
    );
    bad("[features]\n\"a/b\" = [0.0, 0.0]\n", "features.a/b");
    bad(
        "[features]\na = [0.0, 0.0]\n[placements]\np = { turn = 3 }\n",
        "placements.p.turn",
    );
    bad("sigma_um = -1.0\n[features]\na = [0.0, 0.0]\n", "sigma_um");
    bad("[features]\n", "features");
}

/// Singular values of the free nuisance columns of the readings' Jacobian over every
/// (placement, feature) sample of `s`, on the nominal machine.
fn nuisance_singular_values(s: &ArtefactSetup, m: &Machine) -> Vec<f64> {
    let nn = s.nuisance().len();
    let free: Vec<usize> = (0..nn).filter(|&i| s.nuisance()[i].free).collect();
    let nc = s.channels().len();
    let mut rows = Vec::new();
    let nuis = vec![0.0; nn];
    for j in 0..s.placements().len() {
        for k in 0..s.features().len() {
            let p = s.nominal_xyz(j, k);
            let mut q = vec![0.0; m.n_axes()];
            for (c, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                q[m.axis_index(l).unwrap()] = p[c];
            }
            let pose = m.tool_in_workpiece(&q);
            let at = At {
                q: &q,
                t: 0.0,
                w_t_t: &pose,
                label: s.label(j, k),
            };
            let mut dp = vec![0.0; nc * 6];
            let mut dn = vec![0.0; nc * nn];
            assert!(s.derivatives(&at, &nuis, &mut dp, &mut dn));
            for c in 0..nc {
                rows.push(free.iter().map(|&i| dn[c * nn + i]).collect::<Vec<f64>>());
            }
        }
    }
    let a = nalgebra::DMatrix::from_fn(rows.len(), free.len(), |r, c| rows[r][c]);
    let mut sv: Vec<f64> = a
        .svd(false, false)
        .singular_values
        .iter()
        .copied()
        .collect();
    sv.sort_by(f64::total_cmp);
    sv
}

#[test]
fn the_datum_removes_exactly_the_plates_rigid_motion() {
    let m = machine();
    // Placements and plate errors alone (no machine error): with the datum held the Jacobian
    // has full column rank; with every feature error free (a prior, however wide, switches the
    // datum off; the prior itself is not part of this Jacobian) it lacks 3 (2-D) or 6 (3-D)
    // directions: the plate's rigid motion.
    let plate3 = r#"
[features]
a = [0.0, 0.0, 0.0]
b = [100.0, 0.0, 0.0]
c = [0.0, 80.0, 0.0]
d = [60.0, 70.0, 5.0]
e = [90.0, 40.0, -3.0]
[placements]
p1 = { origin = [10.0, 20.0, -300.0] }
p2 = { origin = [-30.0, 0.0, -300.0], rotation_deg = 90.0 }
p3 = { origin = [0.0, 0.0, -300.0], flipped = true }
"#;
    for (text, rigid) in [(PLATE, 3), (plate3, 6)] {
        let with_datum = setup(text, &m);
        let sv = nuisance_singular_values(&with_datum, &m);
        assert!(
            sv[0] > 1e-6 * sv[sv.len() - 1],
            "datum: smallest singular values {:?}",
            &sv[..4]
        );
        let no_datum = setup(&format!("feature_sigma_um = 1e6\n{text}"), &m);
        let sv = nuisance_singular_values(&no_datum, &m);
        let tiny = sv.iter().filter(|&&v| v < 1e-9 * sv[sv.len() - 1]).count();
        assert_eq!(tiny, rigid, "{:?}", &sv[..8]);
    }
}

#[test]
fn the_path_visits_every_feature_of_every_placement_in_label_order() {
    let m = machine();
    let s = setup(PLATE, &m);
    let empty = toml::Table::new();
    let spec = mtcal_instrument::PathSpec {
        path: &empty,
        setup: &s,
        machine: &m,
    };
    let poses = mtcal_artefact::path(&spec).unwrap();
    let labels = mtcal_artefact::path_labels(&spec).unwrap();
    assert_eq!(poses.len(), 9);
    assert_eq!(labels.len(), 9);
    for (q, l) in poses.iter().zip(&labels) {
        let refs: Vec<&str> = l.iter().map(String::as_str).collect();
        let n = s.resolve_label(&refs).unwrap() as usize;
        let want = s.nominal_xyz(n / 3, n % 3);
        let x = q[m.axis_index('X').unwrap()];
        let y = q[m.axis_index('Y').unwrap()];
        assert!(
            (x - want.x).abs() < 1e-15 && (y - want.y).abs() < 1e-15,
            "{l:?}"
        );
    }
    assert_eq!(labels[3], ["p2/a"]);
    // A subset of placements, repeated.
    let path: toml::Table = toml::from_str("placements = [\"p3\"]\nrepeat = 2").unwrap();
    let spec = mtcal_instrument::PathSpec {
        path: &path,
        setup: &s,
        machine: &m,
    };
    let labels = mtcal_artefact::path_labels(&spec).unwrap();
    assert_eq!(labels.len(), 6);
    assert!(labels.iter().all(|l| l[0].starts_with("p3/")));
    // Out of the machine's reach: the error names the placement.
    let far = setup(
        &PLATE.replace("[10.0, 20.0, -300.0]", "[1000.0, 0.0, -300.0]"),
        &m,
    );
    let spec = mtcal_instrument::PathSpec {
        path: &empty,
        setup: &far,
        machine: &m,
    };
    let e = mtcal_artefact::path(&spec).unwrap_err();
    assert_eq!(e.key, "placements.p1", "{e}");
}
