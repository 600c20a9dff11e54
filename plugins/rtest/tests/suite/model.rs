//! The measurement model on hand-computed cases.

use mtcal_instrument::{At, Setup, SetupContext, SetupFormat};
use mtcal_kinematics::{Machine, ik};
use mtcal_rtest::{HeadKind, Mount, RTest, load, sensor_directions};
use nalgebra::Vector3;

fn mcu630() -> Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../machines/mcu630-cafyxz.urdf"
    );
    mtcal_machine::load_machine(path, Default::default())
        .expect("shipped machine")
        .machine
}

fn setup(machine: &Machine, text: &str) -> RTest {
    let t: toml::Table = toml::from_str(text).expect("toml");
    load(&t, &SetupContext { machine }).expect("loads")
}

/// Axis positions with the given rotary angles (deg) and the tool point on `ball_mm`.
fn pose_at(machine: &Machine, ball_mm: [f64; 3], a_deg: f64, c_deg: f64) -> Vec<f64> {
    let mut q = vec![0.0; machine.n_axes()];
    q[machine.axis_index('A').unwrap()] = a_deg.to_radians();
    q[machine.axis_index('C').unwrap()] = c_deg.to_radians();
    ik::follow_point(machine, &mut q, &(Vector3::from(ball_mm) * 1e-3)).expect("follows");
    assert!(machine.within_limits(&q, 0.0), "{q:?}");
    q
}

fn read(s: &RTest, machine: &Machine, q: &[f64], nuis: &[f64]) -> [f64; 3] {
    let pose = machine.tool_in_workpiece(q);
    let mut out = [f64::NAN; 3];
    s.predict(
        &At {
            q,
            t: 0.0,
            w_t_t: &pose,
            label: 0,
        },
        nuis,
        &mut out,
    );
    out
}

#[test]
fn a_head_offset_by_plus_5_um_in_x_reads_minus_5_um() {
    let m = mcu630();
    // The nest on the table, its axes the workpiece's whatever C does.
    let s = setup(
        &m,
        "ball = [100.0, 0.0, 200.0]\nmount = \"ball-in-spindle\"",
    );
    assert_eq!(s.mount(), Mount::BallInSpindle);
    assert_eq!(s.head_kind(), HeadKind::Ideal);
    assert_eq!(s.channels().len(), 3);
    let names: Vec<&str> = s.nuisance().iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["ball_x", "ball_y", "ball_z", "tool_length"]);
    for c_deg in [0.0, 90.0, 215.0] {
        let q = pose_at(&m, [100.0, 0.0, 200.0], 0.0, c_deg);
        let r = read(&s, &m, &q, &[5e-6, 0.0, 0.0, 0.0]);
        assert!((r[0] + 5e-6).abs() < 1e-15, "{r:?}");
        assert!(r[1].abs() < 1e-15 && r[2].abs() < 1e-15, "{r:?}");
    }
}

#[test]
fn a_table_ball_offset_by_plus_5_um_in_x_reads_along_the_turned_nest_axes() {
    let m = mcu630();
    let s = setup(&m, "ball = [100.0, 0.0, 200.0]");
    assert_eq!(s.mount(), Mount::BallOnTable, "the default");
    // The ball turns with the table, the nest's axes stay the machine's: the workpiece's +X
    // is the machine's +X at C = 0; mtcal's +C turns the tool about the workpiece's +Z
    // (the table clockwise seen from +Z), so at C = 90° the workpiece's +X points along the
    // machine's −Y, at C = 180° along −X, at C = 270° along +Y.
    for (c_deg, want) in [
        (0.0, [5e-6, 0.0, 0.0]),
        (90.0, [0.0, -5e-6, 0.0]),
        (180.0, [-5e-6, 0.0, 0.0]),
        (270.0, [0.0, 5e-6, 0.0]),
    ] {
        let q = pose_at(&m, [100.0, 0.0, 200.0], 0.0, c_deg);
        let r = read(&s, &m, &q, &[5e-6, 0.0, 0.0, 0.0]);
        for i in 0..3 {
            assert!((r[i] - want[i]).abs() < 1e-15, "C = {c_deg}: {r:?}");
        }
    }
}

#[test]
fn a_10_um_longer_tool_reads_plus_10_um_in_z_of_the_spindle_nest_at_any_tilt() {
    let m = mcu630();
    let s = setup(&m, "ball = [100.0, 0.0, 200.0]\nmount = \"ball-on-table\"");
    // The nest centre sits 10 µm further down the tool axis, the ball 10 µm above it along
    // the nest's own z, whatever A and C are.
    for (a_deg, c_deg) in [(0.0, 0.0), (30.0, 0.0), (-20.0, 125.0)] {
        let q = pose_at(&m, [100.0, 0.0, 200.0], a_deg, c_deg);
        let r = read(&s, &m, &q, &[0.0, 0.0, 0.0, 10e-6]);
        assert!(r[0].abs() < 1e-15 && r[1].abs() < 1e-15, "{r:?}");
        assert!((r[2] - 10e-6).abs() < 1e-15, "{r:?}");
    }
}

#[test]
fn a_10_um_longer_tool_at_a_30_deg_reads_along_the_tilted_tool_axis() {
    let m = mcu630();
    let s = setup(
        &m,
        "ball = [100.0, 0.0, 200.0]\nmount = \"ball-in-spindle\"",
    );
    let q = pose_at(&m, [100.0, 0.0, 200.0], 30.0, 0.0);
    // Positive A turns the tool relative to the workpiece positively about +X: the tool axis
    // in the workpiece frame is (0, −sin 30°, cos 30°), and the ball of a longer tool sits
    // 10 µm further down it.
    let z = m.tool_in_workpiece(&q).r.column(2).into_owned();
    assert!(
        (z - Vector3::new(0.0, -0.5, 0.75f64.sqrt())).norm() < 1e-12,
        "{z}"
    );
    let r = read(&s, &m, &q, &[0.0, 0.0, 0.0, 10e-6]);
    assert!(r[0].abs() < 1e-15, "{r:?}");
    assert!((r[1] - 5e-6).abs() < 1e-15, "dy = {}", r[1]);
    assert!(
        (r[2] + 10e-6 * 0.75f64.sqrt()).abs() < 1e-15,
        "dz = {}",
        r[2]
    );
}

#[test]
fn the_three_sensor_head_without_geometry_errors_reads_as_the_ideal_head() {
    let m = mcu630();
    for (mount, elevation) in Mount::ALL
        .into_iter()
        .flat_map(|m| [(m, ""), (m, "sensor_elevation_deg = 50.0\n")])
    {
        let mount = mount.as_str();
        let ideal = setup(
            &m,
            &format!("ball = [100.0, 0.0, 200.0]\nmount = \"{mount}\""),
        );
        let three = setup(
            &m,
            &format!(
                "ball = [100.0, 0.0, 200.0]\nmount = \"{mount}\"\nhead = \"three-sensor\"\n\
                 {elevation}"
            ),
        );
        assert_eq!(three.nuisance().len(), 4 + 9);
        assert!(three.nuisance()[4..].iter().all(|n| !n.free));
        let q = pose_at(&m, [100.0, 0.0, 200.0], 20.0, 70.0);
        let nuis = [3e-6, -7e-6, 11e-6, 20e-6];
        let mut nuis3 = nuis.to_vec();
        nuis3.extend([0.0; 9]);
        let a = read(&ideal, &m, &q, &nuis);
        let b = read(&three, &m, &q, &nuis3);
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-18, "{a:?} vs {b:?}");
        }
        // …and a 1000 ppm gain error on one sensor shows up along that sensor's contribution.
        nuis3[4] = 1e-3;
        let c = read(&three, &m, &q, &nuis3);
        assert!((Vector3::from(c) - Vector3::from(b)).norm() > 1e-11);
    }
}

#[test]
fn the_default_sensor_directions_are_orthonormal_and_point_at_the_ball() {
    let e = mtcal_rtest::default_sensor_elevation_deg();
    let table = sensor_directions(e, Mount::BallInSpindle);
    let spindle = sensor_directions(e, Mount::BallOnTable);
    for i in 0..3 {
        assert!((table[i].norm() - 1.0).abs() < 1e-15);
        // The nest on the table: below the equator, pointing up at the centre.
        assert!(table[i].z > 0.0);
        // The nest in the spindle: above it, pointing down; the same mirrored in z.
        assert!(spindle[i].z < 0.0);
        assert_eq!(spindle[i].xy(), table[i].xy());
        assert_eq!(spindle[i].z, -table[i].z);
        for j in 0..i {
            assert!(table[i].dot(&table[j]).abs() < 1e-15);
            assert!(spindle[i].dot(&spindle[j]).abs() < 1e-15);
        }
    }
}

#[test]
fn a_spindle_nest_sensor_pointing_down_reads_a_ball_below_it_as_positive() {
    // Sensor 1 of the spindle nest at elevation 35.26° reads mᵢ = nᵢ·d: a ball centre that
    // moves down (−z in the nest frame) moves away from a sensor above it, so with the tool
    // 10 µm longer (the nest 10 µm lower, d = +10 µm ẑ) every sensor sees the ball come closer.
    let n = sensor_directions(
        mtcal_rtest::default_sensor_elevation_deg(),
        Mount::BallOnTable,
    );
    let d = Vector3::new(0.0, 0.0, 10e-6);
    for ni in n {
        assert!(ni.dot(&d) < 0.0);
    }
}

#[test]
fn set_up_errors_name_the_key() {
    let m = mcu630();
    let ctx = SetupContext { machine: &m };
    let cases = [
        ("head = \"ideal\"", "ball"),
        ("ball = [1, 2]", "ball"),
        ("ball = [0, 0, 0]\nhead = \"two-sensor\"", "head"),
        ("ball = [0, 0, 0]\nsigma_um = 0.0", "sigma_um"),
        (
            "ball = [0, 0, 0]\nball_diameter_mm = 22.0",
            "ball_diameter_mm",
        ),
        (
            "ball = [0, 0, 0]\nhead = \"three-sensor\"\nsensor_elevation_deg = 90",
            "sensor_elevation_deg",
        ),
        (
            "ball = [0, 0, 0]\nhead = \"three-sensor\"\nsensor_gain_u_ppm = 10",
            "sensor_gain_u_ppm",
        ),
        ("ball = [0, 0, 0]\nball_fre = true", "ball_fre"),
        ("ball = [0, 0, 0]\nmount = \"sideways\"", "mount"),
        ("ball = [0, 0, 0]\nmount = 1", "mount"),
        ("ball = [0, 0, 0]\ntool_length_free = 1", "tool_length_free"),
    ];
    for (text, key) in cases {
        let t: toml::Table = toml::from_str(text).expect("toml");
        let e = load(&t, &ctx).expect_err(text);
        assert_eq!(e.key, key, "{text}: {e}");
    }
}

#[test]
fn an_unknown_mount_names_the_key_and_both_values() {
    let m = mcu630();
    let t: toml::Table = toml::from_str("ball = [0, 0, 0]\nmount = \"sideways\"").expect("toml");
    let e = load(&t, &SetupContext { machine: &m }).expect_err("sideways");
    assert_eq!(e.key, "mount");
    assert_eq!(
        e.message,
        "unknown mount `sideways`; expected \"ball-on-table\" or \"ball-in-spindle\""
    );
}

#[test]
fn to_toml_writes_the_mount_default_or_given() {
    let m = mcu630();
    for (text, want) in [
        ("ball = [1, 2, 3]", "ball-on-table"),
        (
            "ball = [1, 2, 3]\nmount = \"ball-on-table\"",
            "ball-on-table",
        ),
        (
            "ball = [1, 2, 3]\nmount = \"ball-in-spindle\"",
            "ball-in-spindle",
        ),
    ] {
        let s = setup(&m, text);
        assert_eq!(s.to_toml()["mount"].as_str(), Some(want), "{text}");
        let again = setup(&m, &toml::to_string(&s.to_toml()).expect("toml"));
        assert_eq!(again, s);
    }
}

#[test]
fn to_toml_writes_every_key_with_its_value() {
    let m = mcu630();
    let s = setup(
        &m,
        "ball = [100, 0, 200]\nhead = \"three-sensor\"\nsensor_geometry_free = true\nsensor_gain_u_ppm = 300",
    );
    let t = s.to_toml();
    assert_eq!(t["ball"].as_array().unwrap()[0].as_float(), Some(100.0));
    assert_eq!(t["sigma_um"].as_float(), Some(0.5));
    assert_eq!(t["ball_diameter_mm"].as_float(), Some(22.0));
    assert_eq!(t["sensor_geometry_free"].as_bool(), Some(true));
    assert!(!t.contains_key("sensor_angle_u_urad"));
    let gain = &s.nuisance()[4];
    assert_eq!(gain.name, "sensor1_gain");
    assert_eq!(gain.prior_sigma, Some(300e-6));
    assert!(gain.free);
}
