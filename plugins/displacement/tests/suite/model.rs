//! The measurement model on hand-computed cases: a planted tool displacement and tilt.

use mtcal_displacement::{DisplacementSetup, load};
use mtcal_instrument::{At, Setup, SetupContext, SetupFormat};
use mtcal_kinematics::{Machine, Rigid};
use nalgebra::{Matrix3, Vector3};

fn machine() -> Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../machines/mcv754-zfyx.urdf"
    );
    mtcal_machine::load_machine(path, Default::default())
        .expect("shipped machine")
        .machine
}

fn setup(machine: &Machine, text: &str) -> DisplacementSetup {
    let t: toml::Table = toml::from_str(text).expect("toml");
    load(&t, &SetupContext { machine }).expect("loads")
}

const SETUP: &str = r#"
position = [100.0, -50.0, 200.0]
[sensors]
ax = "X"
by = "-Y"
cv = [0.0, 3.0, 4.0]
dm = { direction = "X", at = [0.0, 0.0, 50.0], sigma_um = 0.3 }
em = { direction = "-Y", at = [0.0, 0.0, 80.0] }
free = {}
"#;

fn predict(s: &DisplacementSetup, pose: &Rigid, nuis: &[f64]) -> Vec<f64> {
    let q = [0.0; 3];
    let mut out = vec![f64::NAN; s.channels().len()];
    s.predict(
        &At {
            q: &q,
            t: 0.0,
            w_t_t: pose,
            label: 0,
        },
        nuis,
        &mut out,
    );
    out
}

/// Rotation about +X by `a` then about +Y by `b` (both rad): `R = R_y(b)·R_x(a)`.
fn tilt(a: f64, b: f64) -> Matrix3<f64> {
    let (sa, ca) = a.sin_cos();
    let (sb, cb) = b.sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca);
    let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
    ry * rx
}

#[test]
fn channels_and_offsets_are_in_sorted_sensor_order() {
    let m = machine();
    let s = setup(&m, SETUP);
    let names: Vec<&str> = s.channels().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["d_ax", "d_by", "d_cv", "d_dm", "d_em", "d_free"]);
    let nuis: Vec<&str> = s.nuisance().iter().map(|n| n.name.as_str()).collect();
    assert_eq!(
        nuis,
        [
            "ax_offset",
            "by_offset",
            "cv_offset",
            "dm_offset",
            "em_offset",
            "free_offset"
        ]
    );
    assert!(s.nuisance().iter().all(|n| n.free));
    // The per-sensor σ overrides the set-up's default 0.5 µm.
    let sigma: Vec<f64> = s.channels().iter().map(|c| c.sigma * 1e6).collect();
    for (got, want) in sigma.iter().zip([0.5, 0.5, 0.5, 0.3, 0.5, 0.5]) {
        assert!((got - want).abs() < 1e-12, "{sigma:?}");
    }
    // Written out of order, the sensors still come sorted (a table that keeps file order
    // must not change the channel order).
    let other = setup(&m, "[sensors]\nzz = \"Z\"\naa = {}\nmm = \"-X\"\n");
    let names: Vec<&str> = other.channels().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["d_aa", "d_mm", "d_zz"]);
}

#[test]
fn a_planted_displacement_and_tilt_reads_along_each_sensor() {
    let m = machine();
    let s = setup(&m, SETUP);
    let position = Vector3::new(0.1, -0.05, 0.2);
    let d = Vector3::new(3e-6, -2e-6, 5e-6);
    // 20 µrad about X, −30 µrad about Y.
    let (a, b) = (20e-6, -30e-6);
    let pose = Rigid::new(tilt(a, b), position + d);
    let offsets = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let r = predict(&s, &pose, &offsets);
    // Letters read the displacement along their (signed) axis; the vector its projection.
    assert!((r[0] - 3e-6).abs() < 1e-15, "ax {}", r[0]);
    assert!((r[1] - 2e-6).abs() < 1e-15, "by {}", r[1]);
    assert!(
        (r[2] - (3.0 * -2e-6 + 4.0 * 5e-6) / 5.0).abs() < 1e-15,
        "cv {}",
        r[2]
    );
    // 50 mm up the tool axis the tilt adds R·(0, 0, L) − (0, 0, L): along X that is
    // L·cos(a)·sin(b), along Y −L·sin(a) (R = R_y(b)·R_x(a)).
    let l = 0.05;
    let want = 3e-6 + l * a.cos() * b.sin();
    assert!((r[3] - want).abs() < 1e-15, "dm {} vs {want}", r[3]);
    assert!(
        (r[3] - (3e-6 - 1.5e-6)).abs() < 1e-12,
        "−30 µrad over 50 mm is −1.5 µm: {}",
        r[3]
    );
    let l = 0.08;
    let want = -(-2e-6 - l * a.sin());
    assert!((r[4] - want).abs() < 1e-15, "em {} vs {want}", r[4]);
    assert!((r[4] - (2e-6 + 1.6e-6)).abs() < 1e-12, "em {}", r[4]);
    // The sensor without a direction reads nothing of the pose.
    assert_eq!(r[5], 0.0);
}

#[test]
fn offsets_add_and_a_sensor_without_direction_reads_only_its_offset() {
    let m = machine();
    let s = setup(&m, SETUP);
    let nominal = Rigid::new(Matrix3::identity(), Vector3::new(0.1, -0.05, 0.2));
    let offsets = [1e-6, 2e-6, 3e-6, 4e-6, 5e-6, -7e-6];
    let r0 = predict(&s, &nominal, &offsets);
    for (got, want) in r0.iter().zip(offsets) {
        assert!((got - want).abs() < 1e-15, "{r0:?}");
    }
    // Far off and turned, the direction-less sensor still reads its offset exactly.
    let moved = Rigid::new(tilt(0.01, -0.02), Vector3::new(0.3, 0.1, -0.4));
    let r1 = predict(&s, &moved, &offsets);
    assert_eq!(r1[5], -7e-6);
    assert!(r1[..5].iter().zip(&r0).all(|(a, b)| a != b), "{r1:?}");

    let flags: Vec<bool> = (0..6).map(|c| s.reads_pose(c)).collect();
    assert_eq!(flags, [true, true, true, true, true, false]);

    let mut d_pose = vec![f64::NAN; 6 * 6];
    let mut d_nuis = vec![f64::NAN; 6 * 6];
    let q = [0.0; 3];
    let at = At {
        q: &q,
        t: 0.0,
        w_t_t: &moved,
        label: 0,
    };
    assert!(s.derivatives(&at, &offsets, &mut d_pose, &mut d_nuis));
    assert!(
        d_pose[5 * 6..].iter().all(|&v| v == 0.0),
        "{:?}",
        &d_pose[30..]
    );
    for c in 0..6 {
        for k in 0..6 {
            assert_eq!(d_nuis[c * 6 + k], if c == k { 1.0 } else { 0.0 });
        }
    }
    // A sensor touching the tool point has no lever: no orientation column.
    assert!(d_pose[3..6].iter().all(|&v| v == 0.0));
}

#[test]
fn only_sensors_with_a_lever_make_the_set_up_touch_the_orientation() {
    let m = machine();
    let t = setup(&m, "[sensors]\na = \"X\"\nb = {}\n").touches();
    assert!(t.position && !t.orientation);
    let t = setup(&m, "[sensors]\nb = {}\n").touches();
    assert!(!t.position && !t.orientation);
    let t = setup(
        &m,
        "[sensors]\na = { direction = \"Z\", at = [0, 0, 40] }\n",
    )
    .touches();
    assert!(t.position && t.orientation);
}

#[test]
fn the_set_up_round_trips_in_canonical_form() {
    let m = machine();
    let s = setup(
        &m,
        "[sensors]\na = \"+X\"\nb = [1, 1, 0]\nc = {}\nd = { direction = \"-Z\" }\n",
    );
    let t = s.to_toml();
    // Every top-level key is written, defaults included.
    assert_eq!(
        t["position"],
        toml::Value::Array(vec![0.0.into(), 0.0.into(), 0.0.into()])
    );
    assert_eq!(t["sigma_um"], toml::Value::Float(0.5));
    assert_eq!(t["offset_free"], toml::Value::Boolean(true));
    let sensors = t["sensors"].as_table().expect("a table");
    assert_eq!(sensors["a"], toml::Value::from("X"));
    // The vector is written as given (not normalised) so that reloading normalises it again
    // to the same bits.
    assert_eq!(
        sensors["b"],
        toml::Value::Array(vec![1.0.into(), 1.0.into(), 0.0.into()])
    );
    assert_eq!(sensors["c"], toml::Value::Table(toml::Table::new()));
    assert_eq!(sensors["d"], toml::Value::from("-Z"));
    let again = load(&t, &SetupContext { machine: &m }).expect("reloads");
    assert_eq!(again, s);
    let n = s.sensors()[1].unit_direction();
    assert!((n - Vector3::new(1.0, 1.0, 0.0) / 2f64.sqrt()).norm() < 1e-16);
}
