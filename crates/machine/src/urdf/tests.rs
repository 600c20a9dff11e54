use super::*;
use crate::topology::{Reading, nominal_machine, parse_code};
use proptest::prelude::*;

const LIMIT: &str = r#"<limit lower="-0.3" upper="0.3" effort="1" velocity="1"/>"#;

/// A small valid machine, one element per line so that tests can replace a line and know
/// where the error must point. Line 13 is spare for additions.
fn base_lines() -> Vec<String> {
    let z_limit = r#"<limit lower="-0.5" upper="0" effort="1" velocity="1"/>"#;
    vec![
        r#"<robot name="t">"#.into(),
        r#"<link name="frame"/>"#.into(),
        r#"<link name="y_slide"/>"#.into(),
        r#"<link name="x_slide"/>"#.into(),
        r#"<link name="workpiece"/>"#.into(),
        r#"<link name="z_slide"/>"#.into(),
        r#"<link name="tool"/>"#.into(),
        format!(
            r#"<joint name="Y" type="prismatic"><parent link="frame"/><child link="y_slide"/><axis xyz="0 -1 0"/>{LIMIT}</joint>"#
        ),
        format!(
            r#"<joint name="X" type="prismatic"><origin xyz="0 0 0.1"/><parent link="y_slide"/><child link="x_slide"/><axis xyz="-1 0 0"/>{LIMIT}</joint>"#
        ),
        r#"<joint name="wp" type="fixed"><origin xyz="0 0 0.05"/><parent link="x_slide"/><child link="workpiece"/></joint>"#.into(),
        format!(
            r#"<joint name="Z" type="prismatic"><origin xyz="0 0.4 0.8"/><parent link="frame"/><child link="z_slide"/><axis xyz="0 0 1"/>{z_limit}</joint>"#
        ),
        r#"<joint name="spindle" type="fixed"><origin xyz="0 -0.4 -0.2"/><parent link="z_slide"/><child link="tool"/></joint>"#.into(),
        String::new(),
        "</robot>".into(),
    ]
}

/// The base file with 1-based lines replaced.
fn with(edits: &[(usize, &str)]) -> String {
    let mut lines = base_lines();
    for &(n, text) in edits {
        lines[n - 1] = text.to_string();
    }
    lines.join("\n")
}

fn moving(name: &str, kind: &str, parent: &str, child: &str, extra: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>{extra}</joint>"#
    )
}

enum Expect {
    Ok(&'static str),
    /// Message substring, and (line, text at the column) unless the error is file-wide.
    Err(&'static str, Option<(usize, &'static str)>),
}

/// Loads `text` and compares with the expectation: the topology code when it loads, else
/// the message and the location of the offending element.
fn check(case: &str, text: &str, expect: Expect) {
    let result = load_urdf_str(text, Path::new("m.urdf"));
    match (expect, result) {
        (Expect::Ok(code), Ok(m)) => assert_eq!(m.topology_code(), code, "{case}"),
        (Expect::Err(part, at), Err(e)) => {
            let msg = e.to_string();
            println!("{case}: {msg}");
            assert!(msg.contains(part), "{case}: {msg:?} lacks {part:?}");
            let loc = e.location().expect("located");
            assert!(msg.starts_with(&format!("m.urdf:{}:{}: ", loc.line, loc.column)));
            if let Some((line, marker)) = at {
                let column = text.lines().nth(line - 1).unwrap().find(marker).unwrap() + 1;
                assert_eq!((loc.line, loc.column), (line, column), "{case}: {msg}");
            }
        }
        (Expect::Ok(_), Err(e)) => panic!("{case}: expected to load, got {e}"),
        (Expect::Err(part, _), Ok(_)) => panic!("{case}: expected error {part:?}, loaded"),
    }
}

#[test]
fn loads_valid_files_and_rejects_each_invalid_case_where_it_is() {
    use Expect::{Err as E, Ok as O};
    let stray_w = format!(
        r#"<link name="probe"/>{}"#,
        moving("W", "prismatic", "frame", "probe", LIMIT)
    );
    let cycle = concat!(
        r#"<link name="a"/><link name="b"/>"#,
        r#"<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>"#,
        r#"<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>"#
    );
    let b_head = |extra: &str| moving("B", "revolute", "z_slide", "tool", extra);
    let y_with = |extra: &str| moving("Y", "prismatic", "frame", "y_slide", extra);
    let cases: Vec<(&str, String, Expect)> = vec![
        ("valid", with(&[]), O("wXYFZt")),
        (
            "continuous head",
            with(&[(
                12,
                &moving(
                    "C",
                    "continuous",
                    "z_slide",
                    "tool",
                    r#"<axis xyz="0 0 1"/>"#,
                ),
            )]),
            O("wXYFZCt"),
        ),
        (
            "a rotary axis without <axis>, URDF's default not its letter's",
            with(&[(12, &moving("C", "continuous", "z_slide", "tool", ""))]),
            E(
                "joint `C` has no `<axis>`, and URDF's default",
                Some((12, "<joint")),
            ),
        ),
        (
            "a linear axis without <axis>, moving along X",
            with(&[(8, &y_with(LIMIT))]),
            E(
                "joint `Y` has no `<axis>`, and URDF's default",
                Some((8, "<joint")),
            ),
        ),
        (
            "two linear axes along one direction",
            with(&[(8, &y_with(&format!(r#"<axis xyz="1 0 0"/>{LIMIT}"#)))]),
            E(
                "two linear axes along one direction cannot be told apart",
                None,
            ),
        ),
        (
            "collision-only link off the branches",
            with(&[(
                13,
                r#"<link name="guard"/><joint name="g" type="fixed"><parent link="frame"/><child link="guard"/></joint>"#,
            )]),
            O("wXYFZt"),
        ),
        (
            "syntax error",
            with(&[(13, "<link name=\"a\">")]),
            E("XML syntax error", Some((14, "</robot>"))),
        ),
        (
            "not a robot",
            "<robt name=\"t\"/>".into(),
            E("a URDF file has <robot", Some((1, "<robt"))),
        ),
        (
            "missing tool",
            with(&[
                (7, r#"<link name="tip"/>"#),
                (
                    12,
                    r#"<joint name="s" type="fixed"><parent link="z_slide"/><child link="tip"/></joint>"#,
                ),
            ]),
            E("no link named `tool`", Some((1, "<robot"))),
        ),
        (
            "missing workpiece",
            with(&[
                (5, r#"<link name="part"/>"#),
                (
                    10,
                    r#"<joint name="wp" type="fixed"><parent link="x_slide"/><child link="part"/></joint>"#,
                ),
            ]),
            E("no link named `workpiece`", Some((1, "<robot"))),
        ),
        (
            "moving joint off both branches",
            with(&[(13, &stray_w)]),
            E(
                "lies on neither the tool nor the workpiece branch",
                Some((13, "<joint")),
            ),
        ),
        (
            "unknown axis letter",
            with(&[(
                9,
                &moving("joint1", "prismatic", "y_slide", "x_slide", LIMIT),
            )]),
            E("must be named after its axis letter", Some((9, "<joint"))),
        ),
        (
            "lower-case letter",
            with(&[(9, &moving("x", "prismatic", "y_slide", "x_slide", LIMIT))]),
            E("axis letters are upper case", Some((9, "<joint"))),
        ),
        (
            "duplicate axis",
            with(&[(11, &moving("X", "prismatic", "frame", "z_slide", LIMIT))]),
            E(
                "axis X is defined twice (first at line 9)",
                Some((11, "<joint")),
            ),
        ),
        (
            "duplicate joint name",
            with(&[(
                12,
                r#"<joint name="wp" type="fixed"><parent link="z_slide"/><child link="tool"/></joint>"#,
            )]),
            E(
                "joint `wp` is defined twice (first at line 10)",
                Some((12, "<joint")),
            ),
        ),
        (
            "duplicate link",
            with(&[(13, r#"<link name="tool"/>"#)]),
            E(
                "link `tool` is defined twice (first at line 7)",
                Some((13, "<link")),
            ),
        ),
        (
            "prismatic without limit",
            with(&[(8, &y_with(r#"<axis xyz="0 -1 0"/>"#))]),
            E("prismatic joint `Y` has no <limit>", Some((8, "<joint"))),
        ),
        (
            "revolute without limit",
            with(&[(12, &b_head(r#"<axis xyz="0 1 0"/>"#))]),
            E("use type=\"continuous\"", Some((12, "<joint"))),
        ),
        (
            "limit without velocity",
            with(&[(8, &y_with(r#"<limit lower="-1" upper="1" effort="1"/>"#))]),
            E("<limit> has no `velocity` attribute", Some((8, "<limit"))),
        ),
        (
            "zero axis",
            with(&[(8, &y_with(&format!(r#"<axis xyz="0 0 0"/>{LIMIT}"#)))]),
            E("zero axis vector", Some((8, "<joint"))),
        ),
        (
            "malformed axis",
            with(&[(8, &y_with(&format!(r#"<axis xyz="0 -1"/>{LIMIT}"#)))]),
            E("three finite numbers", Some((8, "<axis"))),
        ),
        (
            "non-numeric origin",
            with(&[(
                10,
                r#"<joint name="wp" type="fixed"><origin xyz="0 x 0.05"/><parent link="x_slide"/><child link="workpiece"/></joint>"#,
            )]),
            E(
                "<origin xyz=\"0 x 0.05\"> is not valid",
                Some((10, "<origin")),
            ),
        ),
        (
            "nan limit",
            with(&[(
                8,
                &y_with(r#"<limit lower="nan" upper="1" effort="1" velocity="1"/>"#),
            )]),
            E("one finite number", Some((8, "<limit"))),
        ),
        (
            "inverted limits",
            with(&[(
                8,
                &y_with(
                    r#"<axis xyz="0 -1 0"/><limit lower="0.3" upper="-0.3" effort="1" velocity="1"/>"#,
                ),
            )]),
            E(
                "limits must be finite with lower < upper",
                Some((8, "<joint")),
            ),
        ),
        (
            "kind mismatch",
            with(&[(8, &moving("A", "prismatic", "frame", "y_slide", LIMIT))]),
            E(
                "A is a rotary axis letter but the joint is prismatic",
                Some((8, "<joint")),
            ),
        ),
        (
            "link with two parents",
            with(&[(
                13,
                r#"<joint name="extra" type="fixed"><parent link="frame"/><child link="x_slide"/></joint>"#,
            )]),
            E(
                "link `x_slide` is the child of joint `X` and of joint `extra`",
                Some((13, "<joint")),
            ),
        ),
        (
            "two roots",
            with(&[(13, r#"<link name="stray"/>"#)]),
            E(
                "links `frame`, `stray` have no parent joint",
                Some((13, "<link")),
            ),
        ),
        (
            "cycle",
            with(&[(13, cycle)]),
            E(
                "cycle through links `a`, `b`",
                Some((13, "<joint name=\"ba\"")),
            ),
        ),
        (
            "unknown parent link",
            with(&[(
                10,
                r#"<joint name="wp" type="fixed"><parent link="table"/><child link="workpiece"/></joint>"#,
            )]),
            E(
                "names parent link `table`, which is not defined",
                Some((10, "<parent")),
            ),
        ),
        (
            "unknown child link",
            with(&[(
                12,
                r#"<joint name="spindle" type="fixed"><parent link="z_slide"/><child link="tol"/></joint>"#,
            )]),
            E("names child link `tol`", Some((12, "<child"))),
        ),
        (
            "missing parent element",
            with(&[(
                10,
                r#"<joint name="wp" type="fixed"><child link="workpiece"/></joint>"#,
            )]),
            E("joint `wp` has no <parent> element", Some((10, "<joint"))),
        ),
        (
            "missing type",
            with(&[(
                10,
                r#"<joint name="wp"><parent link="x_slide"/><child link="workpiece"/></joint>"#,
            )]),
            E("<joint> has no `type` attribute", Some((10, "<joint"))),
        ),
        (
            "floating joint",
            with(&[(12, &moving("spindle", "floating", "z_slide", "tool", ""))]),
            E(
                "has type `floating`, which machines cannot use",
                Some((12, "<joint")),
            ),
        ),
        (
            "planar joint",
            with(&[(12, &moving("spindle", "planar", "z_slide", "tool", ""))]),
            E("has type `planar`", Some((12, "<joint"))),
        ),
        (
            "unknown joint type",
            with(&[(12, &moving("spindle", "slider", "z_slide", "tool", ""))]),
            E("unknown type `slider`", Some((12, "<joint"))),
        ),
        (
            "tool below workpiece",
            with(&[(
                12,
                r#"<joint name="spindle" type="fixed"><parent link="workpiece"/><child link="tool"/></joint>"#,
            )]),
            E(
                "link `tool` hangs below link `workpiece`",
                Some((7, "<link")),
            ),
        ),
        (
            "shared moving joint",
            with(&[(
                12,
                r#"<joint name="spindle" type="fixed"><parent link="x_slide"/><child link="tool"/></joint>"#,
            )]),
            E(
                "moving joint `Y` carries both the tool and the workpiece",
                Some((8, "<joint")),
            ),
        ),
    ];
    for (case, text, expect) in cases {
        check(case, &text, expect);
    }
}

#[test]
fn unreadable_file_names_the_file() {
    let e = load_urdf_file(Path::new("/nonexistent/m.urdf")).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("/nonexistent/m.urdf: cannot read"),
        "{e}"
    );
    assert!(e.location().is_none());
}

#[test]
fn fixed_joints_collapse_into_origins_and_ends() {
    // A fixed stem from the root (frame → bed) must reach both branches.
    let text = with(&[
        (
            2,
            r#"<link name="frame"/><link name="bed"/><joint name="stem" type="fixed"><origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/><parent link="frame"/><child link="bed"/></joint>"#,
        ),
        (
            8,
            &format!(
                r#"<joint name="Y" type="prismatic"><parent link="bed"/><child link="y_slide"/><axis xyz="0 -1 0"/>{LIMIT}</joint>"#
            ),
        ),
        (
            11,
            r#"<joint name="Z" type="prismatic"><origin xyz="0 0.4 0.8"/><parent link="bed"/><child link="z_slide"/><axis xyz="0 0 1"/><limit lower="-0.5" upper="0" effort="1" velocity="1"/></joint>"#,
        ),
    ]);
    let m = load_urdf_str(&text, Path::new("m.urdf")).unwrap();
    let q = [0.1, 0.2, -0.3];
    // Relative to the workpiece the stem cancels: tool − workpiece = Z origin + spindle
    // − X origin − wp + (X, Y, Z) motions.
    let p = m.tool_in_workpiece(&q).t;
    let expected = Vector3::new(0.1, 0.2, -0.3) + Vector3::new(0.0, 0.0, 0.6 - 0.15);
    assert!((p - expected).norm() < 1e-12, "{p}");
    // In the frame, the stem's 90° yaw turns the branches: the tool sits at stem ∘ (Z, spindle).
    let t = m.branch_pose(Side::Tool, &q).t;
    let in_bed = Vector3::new(0.0, 0.4 - 0.4, 0.8 - 0.3 - 0.2);
    let expected = Vector3::new(1.0 - in_bed.y, 2.0 + in_bed.x, 3.0 + in_bed.z);
    assert!((t - expected).norm() < 1e-12, "{t}");
}

fn random_q(m: &Machine, seed: &[f64]) -> Vec<f64> {
    m.axes()
        .iter()
        .zip(seed.iter().cycle())
        .map(|(a, s)| match a.limits() {
            Some((lo, hi)) => lo + (hi - lo) * s,
            None => (s - 0.5) * 20.0,
        })
        .collect()
}

fn assert_same_machine(a: &Machine, b: &Machine, seed: &[f64]) {
    assert_eq!(a.topology_code(), b.topology_code());
    assert_eq!(a.name(), b.name());
    let q = random_q(a, seed);
    for side in [Side::Workpiece, Side::Tool] {
        let (pa, pb) = (a.branch_pose(side, &q), b.branch_pose(side, &q));
        assert!((pa.t - pb.t).norm() < 1e-12 && (pa.r - pb.r).norm() < 1e-12);
    }
    let (ta, tb) = (a.tool_in_workpiece(&q), b.tool_in_workpiece(&q));
    assert!((ta.t - tb.t).norm() < 1e-12 && (ta.r - tb.r).norm() < 1e-12);
    for (x, y) in a.axes().iter().zip(b.axes()) {
        assert_eq!(x.limits(), y.limits());
    }
}

#[test]
fn written_urdf_reads_back_and_keeps_comments_safe() {
    let code = parse_code("CAFYXZ", Reading::FromWorkpiece).unwrap();
    let m = nominal_machine(&code, "a \"quoted\" <name> & more").unwrap();
    let text = write_urdf(&m, Some("from -- topology code -"));
    assert!(
        text.contains("<!--\nfrom - - topology code - \n-->"),
        "{text}"
    );
    assert!(text.contains(r#"<joint name="C" type="continuous">"#));
    assert!(text.contains(r#"<link name="c_table">"#) && text.contains(r#"<link name="x_slide">"#));
    let back = load_urdf_str(&text, Path::new("w.urdf")).unwrap();
    assert_same_machine(&m, &back, &[0.1, 0.7, 0.3, 0.9, 0.5]);
}

#[test]
fn rpy_is_exact_near_gimbal_lock() {
    let half_pi = std::f64::consts::FRAC_PI_2;
    for pitch in [half_pi, -half_pi, half_pi - 3e-8, 3e-9 - half_pi] {
        let r = *Rotation3::from_euler_angles(0.3, pitch, -1.2).matrix();
        let [roll, p, yaw] = rpy_from_matrix(&r);
        let back = *Rotation3::from_euler_angles(roll, p, yaw).matrix();
        assert!(
            (back - r).norm() < 1e-15,
            "pitch {pitch}: {}",
            (back - r).norm()
        );
    }
}

fn rigid_strategy() -> impl Strategy<Value = Isometry3<f64>> {
    let angle = -4.0..4.0f64;
    let gimbal = prop_oneof![Just(None), Just(Some(std::f64::consts::FRAC_PI_2))];
    (
        proptest::array::uniform3(-2.0..2.0f64),
        proptest::array::uniform3(angle),
        gimbal,
    )
        .prop_map(|(t, [r, p, y], g)| {
            let rot = UnitQuaternion::from_euler_angles(r, g.unwrap_or(p), y);
            Isometry3::from_parts(Translation3::from(Vector3::from(t)), rot)
        })
}

fn joint_strategy(letter: char) -> impl Strategy<Value = JointSpec> {
    let rotary = AxisLetter::new(letter).is_some_and(|l| l.is_rotary());
    (
        rigid_strategy(),
        proptest::array::uniform3(-1.0..1.0f64),
        any::<bool>(),
    )
        .prop_map(move |(origin, axis, unlimited)| JointSpec {
            letter,
            kind: if rotary {
                AxisKind::Rotary
            } else {
                AxisKind::Linear
            },
            origin,
            axis: Vector3::from(axis) + Vector3::new(0.0, 0.0, 1.5),
            limits: if rotary && unlimited {
                None
            } else {
                Some((-0.7, 0.9))
            },
        })
}

proptest! {
    #[test]
    fn arbitrary_machines_round_trip(
        wp in proptest::collection::vec(joint_strategy('X'), 0..1),
        a in joint_strategy('A'),
        y in joint_strategy('Y'),
        c in joint_strategy('C'),
        ends in (rigid_strategy(), rigid_strategy()),
        seed in proptest::collection::vec(0.0..1.0f64, 5),
    ) {
        let mut wp_joints = wp;
        wp_joints.push(a);
        let spec = MachineSpec {
            name: "random".into(),
            workpiece: BranchSpec { joints: wp_joints, end: ends.0 },
            tool: BranchSpec { joints: vec![y, c], end: ends.1 },
        };
        let m = Machine::try_new(&spec).unwrap();
        let back = load_urdf_str(&write_urdf(&m, None), Path::new("r.urdf")).unwrap();
        assert_same_machine(&m, &back, &seed);
    }

    #[test]
    fn mangled_files_give_errors_not_panics(
        cut in 0usize..2000,
        len in 0usize..40,
        insert in "[<>/\"= XYZABCt0-9.a-z]{0,12}",
    ) {
        let text = with(&[]);
        let mut bytes: Vec<char> = text.chars().collect();
        let start = cut.min(bytes.len());
        let end = (start + len).min(bytes.len());
        bytes.splice(start..end, insert.chars());
        let mangled: String = bytes.into_iter().collect();
        let _ = load_urdf_str(&mangled, Path::new("f.urdf"));
    }
}
