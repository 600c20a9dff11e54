//! Unit tests: the kinematics against hand-computed points, the squareness convention, and
//! FORMATS.md's worked examples for the R-test.

use nalgebra::Vector3;

use crate::instruments::{GeometricOnly, Instrument, Mount, SetupOffsets};
use crate::machine::{Machine, apply, translation_of};
use crate::truth::Truth;
use crate::{paths, shipped_machine};

/// A three-axis machine: X carries the table (axis -1 0 0), Y and Z the spindle; the tool
/// point 0.5 m above the frame, the workpiece 0.1 m above it, a fixed joint between Y and Z
/// turned by 90° about z (so Z's frame is rotated).
pub(crate) const SIMPLE: &str = r#"<?xml version="1.0"?>
<robot name="simple">
  <link name="frame"/><link name="table"/><link name="workpiece"/>
  <link name="col"/><link name="bracket"/><link name="ram"/><link name="tool"/>
  <joint name="X" type="prismatic">
    <origin xyz="0 0 0.05" rpy="0 0 0"/><parent link="frame"/><child link="table"/>
    <axis xyz="-1 0 0"/><limit lower="-0.4" upper="0.4" effort="1" velocity="1"/>
  </joint>
  <joint name="wp" type="fixed">
    <origin xyz="0 0 0.05" rpy="0 0 0"/><parent link="table"/><child link="workpiece"/>
  </joint>
  <joint name="Y" type="prismatic">
    <origin xyz="0 0.3 0.6" rpy="0 0 0"/><parent link="frame"/><child link="col"/>
    <axis xyz="0 1 0"/><limit lower="-0.3" upper="0.3" effort="1" velocity="1"/>
  </joint>
  <joint name="turn" type="fixed">
    <origin xyz="0 0 0" rpy="0 0 1.5707963267948966"/><parent link="col"/><child link="bracket"/>
  </joint>
  <joint name="Z" type="prismatic">
    <origin xyz="-0.3 0 0" rpy="0 0 0"/><parent link="bracket"/><child link="ram"/>
    <axis xyz="0 0 1"/><limit lower="-0.5" upper="0" effort="1" velocity="1"/>
  </joint>
  <joint name="tp" type="fixed">
    <origin xyz="0 0 -0.1" rpy="0 0 0"/><parent link="ram"/><child link="tool"/>
  </joint>
</robot>"#;

fn close(a: Vector3<f64>, b: Vector3<f64>, tol: f64) -> bool {
    (a - b).norm() < tol
}

#[test]
fn nominal_kinematics_of_a_simple_machine() {
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    assert_eq!(m.letters(), "XYZ");
    // Tool branch at zero: (0, 0.3, 0.6) then the bracket turn, then (-0.3, 0, 0) in the turned
    // frame = (0, -0.3, 0) in the machine frame, then 0.1 down: (0, 0, 0.5).
    // Workpiece at (0, 0, 0.1). So the tool is at (0, 0, 0.4) in the workpiece frame.
    let t0 = translation_of(&m.tool_in_workpiece(&[0.0, 0.0, 0.0], None));
    assert!(close(t0, Vector3::new(0.0, 0.0, 0.4), 1e-15), "{t0}");
    // +X moves the table to -x: the tool moves +x relative to the workpiece (CNC convention);
    // +Y the column +y; Z (axis z in the turned frame) along +z.
    let t = translation_of(&m.tool_in_workpiece(&[0.1, -0.2, -0.25], None));
    assert!(close(t, Vector3::new(0.1, -0.2, 0.15), 1e-15), "{t}");
    // The zero-pose orientation of Z's frame includes the fixed turn: machine +X is the
    // joint frame's -y.
    let z = &m.joints[2];
    assert!(close(z.zero_rotation * Vector3::y(), -Vector3::x(), 1e-15));
    assert_eq!(z.own_direction(), 2);
    // Inverse: the tool point on a target.
    let target = Vector3::new(0.12, 0.05, 0.2);
    let q = m
        .follow_point(&[0.0; 3], &Vector3::zeros(), &target)
        .unwrap();
    assert!(close(
        translation_of(&m.tool_in_workpiece(&q, None)),
        target,
        1e-15
    ));
}

#[test]
fn squareness_moves_the_tool_against_x() {
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    let mut truth = Truth::zero(&m);
    let e = 20e-6;
    truth.set(&m, "EC0Y", e).unwrap();
    let y = 0.25;
    let dev = |q: &[f64]| {
        translation_of(&m.tool_in_workpiece(q, Some(&truth)))
            - translation_of(&m.tool_in_workpiece(q, None))
    };
    // ARCHITECTURE.md: EC0Y > 0, moving Y by y moves the tool by −EC0Y·y along X.
    let d = dev(&[0.0, y, 0.0]);
    assert!((d.x + e * y).abs() < 1e-15, "{d}");
    // Second order: the tilted motion is shorter along Y by EC0Y²·y/2.
    assert!(
        (d.y + e * e * y / 2.0).abs() < 1e-15 && d.z.abs() < 1e-15,
        "{d}"
    );
    // The same convention whichever branch carries the axis: X is a table axis here; EB0Z
    // tilts Z (spindle side, in a rotated frame) about +Y: moving Z by z moves the tool by
    // +EB0Z·z along X (a rotation about +Y takes +z towards +x).
    let mut truth = Truth::zero(&m);
    truth.set(&m, "EB0Z", e).unwrap();
    let d = translation_of(&m.tool_in_workpiece(&[0.0, 0.0, -0.2], Some(&truth)))
        - translation_of(&m.tool_in_workpiece(&[0.0, 0.0, -0.2], None));
    assert!((d.x - e * -0.2).abs() < 1e-15, "{d}");
}

#[test]
fn a_component_error_moves_the_tool_the_same_way_on_either_branch() {
    // EXX = +5 µm puts the tool 5 µm further along +X relative to the workpiece whether X
    // moves the table (here) or the spindle; EYY likewise for the spindle-side Y.
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    let mut truth = Truth::zero(&m);
    // P1 coefficient: value u·c at normalised position u = 0.5 (X = 0.2 of ±0.4).
    truth.axes[0].component[0][1] = 10e-6;
    truth.axes[1].component[1][1] = 10e-6;
    let q = [0.2, 0.15, -0.1];
    let d = translation_of(&m.tool_in_workpiece(&q, Some(&truth)))
        - translation_of(&m.tool_in_workpiece(&q, None));
    assert!(close(d, Vector3::new(5e-6, 5e-6, 0.0), 1e-15), "{d}");
}

/// The shipped trunnion with C's axis flipped to +z, as FORMATS.md's worked example reads it.
fn trunnion_c_up() -> Machine {
    let text = std::fs::read_to_string(shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let flipped = text.replacen("<axis xyz=\"0 0 -1\"/>", "<axis xyz=\"0 0 1\"/>", 1);
    assert_ne!(text, flipped);
    Machine::from_urdf_text(&flipped).unwrap()
}

fn rtest_at(machine: &Machine, truth: &Truth, mount: Mount, c_deg: f64) -> Vector3<f64> {
    let ball = [150.0, 0.0, 60.0];
    let instrument = Instrument::RTest {
        ball_mm: ball,
        mount,
        write_mount_key: true,
    };
    let q = paths::follow_ball(
        machine,
        Vector3::new(0.15, 0.0, 0.06),
        &[('C', c_deg.to_radians(), c_deg.to_radians())],
        &[],
        2,
    );
    // The worked example's ball is below the Z stroke of the shipped machine; the physics does
    // not care, so solve without the limit check.
    let q = q.unwrap_or_else(|_| {
        let mut q0 = vec![0.0; machine.n_axes()];
        q0[machine.index('C').unwrap()] = c_deg.to_radians();
        vec![
            machine
                .follow_point(&q0, &Vector3::zeros(), &Vector3::new(0.15, 0.0, 0.06))
                .unwrap(),
        ]
    });
    let r = instrument.readings(
        machine,
        truth,
        &q[..1],
        &[],
        &SetupOffsets::default(),
        &GeometricOnly,
    );
    Vector3::new(r[0][0], r[0][1], r[0][2]) * 1e6
}

#[test]
fn worked_examples_of_formats_md() {
    let m = trunnion_c_up();
    // At C = 90° the ball sits at machine (0, 150): X = 0, Y = 150 mm.
    let mut q = vec![0.0; m.n_axes()];
    q[m.index('C').unwrap()] = 90f64.to_radians();
    let q = m
        .follow_point(&q, &Vector3::zeros(), &Vector3::new(0.15, 0.0, 0.06))
        .unwrap();
    assert!((q[m.index('X').unwrap()]).abs() < 1e-12, "{q:?}");
    assert!((q[m.index('Y').unwrap()] - 0.15).abs() < 1e-12, "{q:?}");
    let ball_in_frame = apply(
        &m.branch_pose(crate::Side::Workpiece, &q, None),
        &Vector3::new(0.15, 0.0, 0.06),
    );
    assert!(close(
        ball_in_frame.xy().push(0.0),
        Vector3::new(0.0, 0.15, 0.0),
        1e-12
    ));

    // µm: the examples are first order; the second-order terms are below 1e-5 µm.
    let tol = 1e-4;
    let mut truth = Truth::zero(&m);
    truth.set(&m, "EX0C", 10e-6).unwrap();
    let table = |c| rtest_at(&m, &truth, Mount::BallOnTable, c);
    assert!(close(table(0.0), Vector3::zeros(), tol), "{}", table(0.0));
    assert!(
        close(table(90.0), Vector3::new(10.0, -10.0, 0.0), tol),
        "{}",
        table(90.0)
    );
    assert!(
        close(table(180.0), Vector3::new(20.0, 0.0, 0.0), tol),
        "{}",
        table(180.0)
    );
    let spindle = |c| rtest_at(&m, &truth, Mount::BallInSpindle, c);
    assert!(
        close(spindle(90.0), Vector3::new(10.0, 10.0, 0.0), tol),
        "{}",
        spindle(90.0)
    );
    assert!(
        close(spindle(180.0), Vector3::new(20.0, 0.0, 0.0), tol),
        "{}",
        spindle(180.0)
    );

    let mut truth = Truth::zero(&m);
    truth.set(&m, "EC0Y", 10e-6).unwrap();
    let r = rtest_at(&m, &truth, Mount::BallOnTable, 90.0);
    assert!(close(r, Vector3::new(1.5, 0.0, 0.0), tol), "{r}");
}

#[test]
fn truth_files_name_every_parameter_of_the_default_model() {
    use rand::SeedableRng;
    let m = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let truth = Truth::random(&m, &mut rand_chacha::ChaCha8Rng::seed_from_u64(3), 1.0);
    assert!(truth.outside_default_bases(&m).is_empty());
    let params = truth.params_toml(&m);
    let parsed: toml::Table = params.parse().unwrap();
    let values = parsed["values"].as_table().unwrap();
    // 3 squareness + 4 per rotary axis.
    assert_eq!(values.len(), 11, "{values:?}");
    let comps = parsed["component"].as_table().unwrap();
    assert_eq!(comps.len(), 30);
    assert_eq!(comps["EXX"]["coefficients"].as_array().unwrap().len(), 3);
    assert_eq!(comps["EYX"]["coefficients"].as_array().unwrap().len(), 2);
    assert_eq!(comps["EBX"]["coefficients"].as_array().unwrap().len(), 4);
    assert_eq!(comps["ECC"]["coefficients"].as_array().unwrap().len(), 4);
    assert!(truth.model_config(&m).contains("locations = \"iso\""));
}

#[test]
fn displacement_sensors_read_along_their_direction() {
    use crate::instruments::{DisplacementSensor, SensorDirection};
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    let q = vec![0.0, 0.2, -0.25];
    let sensor = |name: &str, direction| DisplacementSensor {
        name: name.into(),
        direction,
        at_mm: None,
    };
    let axis = |letter, negative| SensorDirection::Axis { letter, negative };
    let instrument = Instrument::Displacement {
        // The nominal tool point there: (0, 0.2, 0.15) m.
        position_mm: [0.0, 200.0, 150.0],
        sensors: vec![
            sensor("x", axis('X', false)),
            sensor("mx", axis('X', true)),
            sensor("z", axis('Z', false)),
            sensor("xy", SensorDirection::Vector([1.0, 1.0, 0.0])),
            sensor("free", SensorDirection::Unknown),
        ],
    };
    assert_eq!(
        instrument.channels(),
        ["d_x", "d_mx", "d_z", "d_xy", "d_free"]
    );
    // EC0Y > 0: Y at 200 mm puts the tool 2 µm towards −X; the fixture sits 5 µm towards +X
    // (the mandrel is relatively 5 µm further −X), and a tool 10 µm longer reaches 10 µm lower.
    let mut truth = Truth::zero(&m);
    truth.set(&m, "EC0Y", 10e-6).unwrap();
    let off = SetupOffsets {
        position: Vector3::new(5e-6, 0.0, 0.0),
        tool_length: 10e-6,
    };
    let r = instrument.readings(&m, &truth, &[q.clone(), q], &[], &off, &GeometricOnly);
    let want = [-7.0, 7.0, -10.0, -7.0 / 2f64.sqrt(), 0.0];
    for row in &r {
        for (got, want) in row.iter().zip(want) {
            // First order; EC0Y's second order is 1e-5 µm.
            assert!((got * 1e6 - want).abs() < 1e-4, "{row:?}");
        }
    }
    let toml = instrument.setup_toml(None);
    assert!(
        toml.contains(
            r#"sensors = { x = "X", mx = "-X", z = "Z", xy = [1.0, 1.0, 0.0], free = {} }"#
        ),
        "{toml}"
    );
}

#[test]
fn artefact_reads_the_axis_positions_on_the_true_centre() {
    use crate::instruments::{PlatePlacement, Probed};
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    // On SIMPLE the tool point in the workpiece frame is (X, Y, Z + 0.4 m): origin [0, 0, −250]
    // mm puts the plate's origin at (0, 0, 0.15) m. Feature f2 = [100, 50] mm, flipped
    // (100, −50), turned by 90° (50, 100): it is probed at X = 50, Y = 100 mm. With EC0Y > 0
    // the tool lands EC0Y·Y short in X, so the machine sits on the centre at X + 1 µm.
    let instrument = |probed| Instrument::Artefact {
        features: vec![
            ("f1".into(), vec![0.0, 0.0]),
            ("f2".into(), vec![100.0, 50.0]),
        ],
        placements: vec![
            PlatePlacement {
                name: "a".into(),
                origin_mm: [0.0, 0.0, -250.0],
                rotation_deg: 0.0,
                flipped: false,
            },
            PlatePlacement {
                name: "b".into(),
                origin_mm: [0.0, 0.0, -250.0],
                rotation_deg: 90.0,
                flipped: true,
            },
        ],
        probed,
    };
    let mut truth = Truth::zero(&m);
    truth.set(&m, "EC0Y", 10e-6).unwrap();
    let commanded = vec![vec![0.0, 0.0, -0.25], vec![0.05, 0.1, -0.25]];
    let labels = vec!["a/f1".to_string(), "b/f2".to_string()];
    let off = SetupOffsets::default();
    let plate = instrument(Probed::Commanded);
    assert_eq!(plate.channels(), ["x", "y"]);
    assert_eq!(plate.label_columns(), ["feature"]);
    assert_eq!(plate.file_per_si(), 1e3);
    let r = plate.readings(&m, &truth, &commanded, &labels, &off, &GeometricOnly);
    assert!(r[0][0].abs() < 1e-15 && r[0][1].abs() < 1e-15, "{r:?}");
    // First order (m); EC0Y's second order is 5e-12 m.
    assert!((r[1][0] - 0.050_001).abs() < 1e-10, "{r:?}");
    assert!((r[1][1] - 0.1).abs() < 1e-10, "{r:?}");
    assert_eq!(
        plate.recorded_poses(&m, &truth, &commanded, &labels, &off, &GeometricOnly),
        commanded
    );
    // The probing cycle's reported centre as the axis columns: the same X, Y; Z as commanded.
    let reported = instrument(Probed::Reported).recorded_poses(
        &m,
        &truth,
        &commanded,
        &labels,
        &off,
        &GeometricOnly,
    );
    assert!((reported[1][0] - 0.050_001).abs() < 1e-10, "{reported:?}");
    assert_eq!(reported[1][2], -0.25);
    let toml = plate.setup_toml(Some(0.5));
    assert!(
        toml.contains("features = { f1 = [0.0, 0.0], f2 = [100.0, 50.0] }"),
        "{toml}"
    );
    assert!(
        toml.contains("b = { origin = [0.0, 0.0, -250.0], rotation_deg = 90.0, flipped = true }"),
        "{toml}"
    );
    assert!(toml.ends_with("sigma_um = 0.5\n"), "{toml}");
}

#[test]
fn log_rotation_inverts_exp_rotation() {
    use crate::machine::{exp_rotation, log_rotation};
    for w in [
        Vector3::new(3e-6, -7e-6, 1e-5),
        Vector3::new(1e-12, 0.0, -2e-12),
        Vector3::new(0.4, -1.1, 0.9),
        Vector3::zeros(),
    ] {
        let back = log_rotation(&exp_rotation(&w));
        assert!(
            (back - w).norm() <= 1e-15 * (1.0 + w.norm()),
            "{w} -> {back}"
        );
    }
}

#[test]
fn a_step_diagonal_moves_one_axis_at_a_time_between_the_diagonals_targets() {
    let m = Machine::from_urdf_text(SIMPLE).unwrap();
    let straight = paths::diagonal(&m, 0.5, [1.0, -1.0, 1.0], 5, false, &[]).unwrap();
    let steps = paths::diagonal(&m, 0.5, [1.0, -1.0, 1.0], 5, true, &[]).unwrap();
    assert_eq!(straight.len(), 5);
    assert_eq!(steps.len(), 1 + 4 * 3);
    // The targets: every third step-diagonal sample, from X −0.2, Y +0.15, Z −0.375 (a
    // quarter of each stroke from its middle) to the opposite corner.
    for (k, q) in straight.iter().enumerate() {
        assert_eq!(&steps[3 * k], q);
    }
    let first = &straight[0];
    let want = [-0.2, 0.15, -0.375];
    assert!(
        first.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-15),
        "{first:?}"
    );
    // Between targets, X then Y then Z move, one per sample.
    for w in steps.windows(2) {
        let moved = w[0].iter().zip(&w[1]).filter(|(a, b)| a != b).count();
        assert_eq!(moved, 1, "{w:?}");
    }
    for k in 0..4 {
        let changed = |s: usize| (0..3).find(|&i| steps[s][i] != steps[s + 1][i]).unwrap();
        assert_eq!(
            [changed(3 * k), changed(3 * k + 1), changed(3 * k + 2)],
            [0, 1, 2]
        );
    }
}
