use super::*;
use mtcal_kinematics::{BranchSpec, JointSpec, MachineSpec};
use nalgebra::{Isometry3, Vector3};
use std::f64::consts::PI;

fn joint(letter: char, axis: [f64; 3], limits: Option<(f64, f64)>) -> JointSpec {
    let kind = if matches!(letter, 'A' | 'B' | 'C') {
        AxisKind::Rotary
    } else {
        AxisKind::Linear
    };
    JointSpec {
        letter,
        kind,
        origin: Isometry3::identity(),
        axis: Vector3::from(axis),
        limits,
    }
}

fn machine(workpiece: Vec<JointSpec>, tool: Vec<JointSpec>) -> Machine {
    let branch = |joints| BranchSpec {
        joints,
        end: Isometry3::identity(),
    };
    Machine::try_new(&MachineSpec {
        name: "test".into(),
        workpiece: branch(workpiece),
        tool: branch(tool),
    })
    .unwrap()
}

/// CAFYXZ: a C table on an A trunnion; Y, X, Z on the tool side. X -350..350 mm,
/// Y -250..250 mm, Z -400..100 mm, A -120..30 deg, C unlimited.
pub(crate) fn five_axis() -> Machine {
    machine(
        vec![
            joint(
                'A',
                [-1., 0., 0.],
                Some((-120f64.to_radians(), 30f64.to_radians())),
            ),
            joint('C', [0., 0., -1.], None),
        ],
        vec![
            joint('Y', [0., 1., 0.], Some((-0.25, 0.25))),
            joint('X', [1., 0., 0.], Some((-0.35, 0.35))),
            joint('Z', [0., 0., 1.], Some((-0.4, 0.1))),
        ],
    )
}

/// ZFYX: X and Y table, Z column.
pub(crate) fn three_axis() -> Machine {
    machine(
        vec![
            joint('Y', [0., -1., 0.], Some((-0.2, 0.2))),
            joint('X', [-1., 0., 0.], Some((-0.3, 0.3))),
        ],
        vec![joint('Z', [0., 0., 1.], Some((-0.25, 0.25)))],
    )
}

fn file() -> &'static Path {
    Path::new("m.errors.toml")
}

/// The parameter names of a successful parse, space-separated, or the error message
/// without the file name: "line:column: message".
fn outcome(m: &Machine, input: &str) -> String {
    match parse_config(input, file(), m) {
        Ok(list) => list
            .iter()
            .map(|c| c.name.to_string())
            .collect::<Vec<_>>()
            .join(" "),
        Err(e) => e
            .to_string()
            .strip_prefix("m.errors.toml:")
            .unwrap_or("?")
            .to_string(),
    }
}

/// `expect` is a full name list, `count=N`, or the start of an error "line:column: message".
fn check(m: &Machine, input: &str, expect: &str) {
    let got = outcome(m, input);
    let ok = match expect.strip_prefix("count=") {
        Some(n) => got.split(' ').count().to_string() == n && !got.contains(':'),
        None => got.starts_with(expect),
    };
    assert!(ok, "input:\n{input}\nexpected: {expect}\ngot:      {got}");
}

fn basis_of(list: &[ParamConfig], name: &str) -> Basis {
    let name: ParamName = name.parse().unwrap();
    let c = list.iter().find(|c| c.name == name).unwrap();
    c.basis.clone().unwrap()
}

/// The first ```toml block of this module's documentation.
fn doc_example() -> String {
    let src = include_str!("mod.rs");
    let start = src.find("//! ```toml\n").unwrap() + "//! ```toml\n".len();
    let end = start + src[start..].find("//! ```\n").unwrap();
    src[start..end]
        .lines()
        .map(|l| l.strip_prefix("//!").unwrap_or(l).trim_start_matches(' '))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn selections() {
    let five = five_axis();
    let three = three_axis();
    check(&five, "", "count=41");
    check(
        &five,
        "components = \"all\"\nlocations = \"iso\"",
        "count=41",
    );
    check(&three, "", "count=21");
    check(&three, "components = \"none\"", "EC0Y EB0Z EA0Z");
    check(
        &five,
        "components = [\"EXX\", \"ECC\"]\nlocations = [\"EXOC\"]\nsetup = [\"TOOL_DZ\"]",
        "EXX ECC EX0C TOOL_DZ",
    );
    check(&five, "exclude = [\"EAC\", \"EBC\"]", "count=39");
    check(
        &three,
        "components = \"none\"\nlocations = \"none\"\nsetup = [\"WP_DX\", \"WP_DC\"]",
        "WP_DX WP_DC",
    );
    // The 41 errors of the five-axis machine: 30 components, 3 squareness, 8 locations.
    let names = outcome(&five, "");
    for n in [
        "EXX", "ECC", "EAA", "EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A",
    ] {
        assert!(names.split(' ').any(|x| x == n), "{n} missing from {names}");
    }
    for n in ["EX0C", "EY0C", "EA0C", "EB0C"] {
        assert!(names.split(' ').any(|x| x == n), "{n} missing from {names}");
    }
}

#[test]
fn empty_file_is_the_default_model() {
    for m in [five_axis(), three_axis()] {
        let parsed = parse_config("", file(), &m).unwrap();
        assert_eq!(parsed, default_config(&m));
        let explicit = "[basis.linear]\nkind = \"legendre\"\ndegree = 3\n\
                        [basis.rotary]\nkind = \"fourier\"\nharmonics = 2\n";
        assert_eq!(parse_config(explicit, file(), &m).unwrap(), parsed);
    }
    assert_eq!(default_config(&five_axis()).len(), 41);
    assert_eq!(default_config(&three_axis()).len(), 21);
}

#[test]
fn doc_example_parses() {
    let m = five_axis();
    let example = doc_example();
    let list = parse_config(&example, file(), &m).unwrap();
    // 41 - EAC - EBC + TOOL_DZ
    assert_eq!(list.len(), 40);
    assert_eq!(list.last().unwrap().name.to_string(), "TOOL_DZ");
    // spacing 50 mm over 700 mm: 15 knots, the first pinned (positioning).
    match basis_of(&list, "EXX") {
        Basis::Table {
            knots,
            pin_first,
            pin_last,
        } => {
            assert_eq!(knots.len(), 15);
            assert!((knots[0] + 0.35).abs() < 1e-15 && (knots[14] - 0.35).abs() < 1e-15);
            assert!((knots[1] - knots[0] - 0.05).abs() < 1e-15);
            assert!(pin_first && !pin_last);
        }
        other => panic!("EXX: {other:?}"),
    }
}

#[test]
fn bases_and_units() {
    let m = five_axis();
    let text = "[basis.linear]\ndegree = 5\n\
                [component.EYX]\nstroke_mm = [0.0, 700.0]\n\
                [component.EZX]\nkind = \"bspline\"\ncontrol_points = 8\n\
                [component.EXC]\nkind = \"table\"\nknots_deg = [-180, 0, 90, 180]\n\
                [component.ECA]\nkind = \"legendre\"\nmin_degree = 0\nstroke_deg = [-90, 0]\n\
                [component.EXY]\nkind = \"table\"\nspacing_mm = 300\npin_first = false\n\
                [component.ECC]\nmin_harmonic = 0\nharmonics = 3\n";
    let list = parse_config(text, file(), &m).unwrap();
    let check = |name: &str, expect: Basis| assert_eq!(basis_of(&list, name), expect);
    check("EXX", Basis::legendre(-0.35, 0.35, 1, 5).unwrap());
    check("EYX", Basis::legendre(0.0, 0.7, 2, 5).unwrap());
    check("EAX", Basis::legendre(-0.35, 0.35, 0, 5).unwrap());
    check("EZX", Basis::bspline(-0.35, 0.35, 8, true, true).unwrap());
    let deg = |v: f64| v.to_radians();
    let knots = vec![deg(-180.0), 0.0, deg(90.0), deg(180.0)];
    check("EXC", Basis::table(knots, true, false).unwrap());
    // Another kind starts afresh: the linear default's degree 5 does not apply.
    check("ECA", Basis::legendre(deg(-90.0), 0.0, 0, 3).unwrap());
    // 500 mm at a 300 mm spacing: one interval; straightness pins the last knot only now.
    check("EXY", Basis::table(vec![-0.25, 0.25], false, true).unwrap());
    check("ECC", Basis::fourier(0, 3).unwrap());
    check("EXA", Basis::fourier(1, 2).unwrap());
}

/// Error cases: TOML input, then `=> line:column: start of the message`, separated by
/// `----` lines. A case whose input starts with `# three-axis` runs on the 3-axis machine.
const ERROR_CASES: &str = r#"
components = "all"
foo = 1
=> 2:1: unknown key `foo` at the top level
----
components =
=> 1:13: this is not valid TOML
----
components = 3
=> 1:14: `components` must be "all", "none" or a list
----
components = "full"
=> 1:14: components = "full" is not understood
----
components = ["EXX", "EQX"]
=> 1:22: `EQX` is not an error parameter name
----
components = ["EXX", 3]
=> 1:22: entries of `components` must be parameter names
----
components = ["EXX", "EXX"]
=> 1:22: EXX is listed twice
----
components = ["EX0C"]
=> 1:15: EX0C is a location error; list it under `locations`
----
locations = ["EXX"]
=> 1:14: EXX is a component error; list it under `components`
----
setup = ["EX0C"]
=> 1:10: EX0C is a location error
----
components = ["EXU"]
=> 1:15: EXU: the machine has no axis U (it has XYZAC)
----
locations = ["EX0Y"]
=> 1:14: EX0Y: a linear axis has no translational location error
----
locations = ["EB0Y"]
=> 1:14: EB0Y: a rotation of a linear axis about its own direction
----
exclude = ["EXU"]
=> 1:12: cannot exclude EXU
----
components = "none"
exclude = ["EXX"]
=> 2:12: cannot exclude EXX
----
schema = "mtcal.errors/9"
=> 1:10: schema "mtcal.errors/9" is not supported
----
[basis.linear]
kind = "spline"
=> 2:8: unknown basis kind "spline"
----
[basis.linear]
kind = "fourier"
=> 2:8: a Fourier series is periodic in the angle and needs a rotary axis
----
[basis.linear]
degree = 30
=> 2:10: `degree` must be an integer from 0 to 20, got 30
----
[basis.linear]
degree = -1
=> 2:10: `degree` must be an integer from 0 to 20, got -1
----
[basis.linear]
degree = 2.5
=> 2:10: `degree` must be an integer from 0 to 20, found a float
----
[basis.linear]
degree = 1
=> 2:10: EYX: degree = 1 leaves no functions: the model leaves out the constant and the slope of a straightness error
----
[basis.linear]
degree = 0
=> 2:10: EXX: degree = 0 leaves no functions: the model leaves out the constant of a positioning error
----
[basis.rotary]
harmonics = 0
=> 2:13: EXA: harmonics = 0 leaves no functions
----
[basis.linear]
harmonics = 2
=> 2:1: `harmonics` belongs to a fourier basis, but this one is legendre
----
[basis.linear]
stroke_mm = [0, 1]
=> 2:1: `stroke_mm` can only be set for one component error
----
[basis.linear]
kind = "table"
=> 1:1: [basis.linear]: a table basis needs `knots` or `spacing_mm`
----
[basis.linear]
kind = "table"
knots = 1
=> 3:9: `knots` must be an integer from 2 to 10000, got 1
----
[basis.linear]
kind = "table"
knots = 2
=> 3:9: EYX: basis has no functions left after pinning
----
[basis.linear]
kind = "table"
spacing_mm = 0
=> 3:14: `spacing_mm` must be positive
----
[basis.linear]
kind = "table"
knots = 5
spacing_mm = 5
=> 4:1: `knots` and `spacing_mm` both set the size
----
[basis]
planar = 1
=> 2:1: unknown key `planar` in [basis]
----
basis = 1
=> 1:9: `basis` must be a table, found an integer
----
[component.EXX]
kind = "table"
spacing_mm = 900
=> 3:14: spacing_mm = 900 is longer than the stroke (700 mm)
----
[component.EXX]
stroke_mm = [700, 0]
=> 2:13: `stroke_mm` must be [lo, hi] with lo < hi, got [700, 0]
----
[component.EXX]
stroke_mm = [1, 2, 3]
=> 2:13: `stroke_mm` must be [lo, hi] with lo < hi, got 3 values
----
[component.EXX]
stroke_mm = [0, nan]
=> 2:17: `stroke_mm` must be a finite number
----
[component.EXX]
stroke_deg = [0, 1]
=> 2:1: `stroke_deg` is for rotary axes; [component.EXX] is for linear axes: use `stroke_mm`
----
[component.ECC]
stroke_deg = [0, 1]
=> 2:1: `stroke_deg` belongs to a legendre basis, but this one is fourier (the axis default
----
[component.ECC]
kind = "table"
knots_deg = [0, 90, 45]
=> 3:21: `knots_deg` must increase strictly: 45 follows 90
----
[component.ECC]
kind = "table"
knots_deg = [0, 90]
stroke_deg = [0, 90]
=> 4:14: `knots_deg` sets the stroke already
----
[component.EXX]
kind = "fourier"
=> 2:8: a Fourier series is periodic in the angle and needs a rotary axis
----
[component.EXX]
min_degree = 4
=> 2:14: EXX: min_degree = 4 is above degree = 3
----
[component.ECC]
min_harmonic = 3
=> 2:16: ECC: min_harmonic = 3 is above harmonics = 2
----
[component.EXZ]
kind = "table"
knots = 3
pin_first = 1
=> 4:13: `pin_first` must be true or false, found an integer
----
[component.EXX]
pin_first = true
=> 2:1: `pin_first` belongs to a table basis, but this one is legendre (the axis default; set `kind` to change it)
----
[component.EXX]
colour = 1
=> 2:1: unknown key `colour` in [component.EXX]; a legendre basis takes: kind, degree, min_degree, stroke_mm
----
[component.EX0C]
degree = 1
=> 1:12: EX0C is a location error with a single value
----
[component.EXU]
degree = 1
=> 1:12: EXU: the machine has no axis U
----
exclude = ["EXX"]
[component.EXX]
degree = 1
=> 2:12: EXX is not in the model
----
[component.EXX]
degree = 4
[component.EXX]
degree = 5
=> 3:12: this is not valid TOML: duplicate key
----
[component]
EXX = { degree = 4 }
EXQ = 1
=> 3:1: `EXQ` is not an error parameter name
----
[component]
EXX = 3
=> 2:7: [component.EXX] must be a table, found an integer
----
# three-axis
[component.ECC]
degree = 4
=> 2:12: ECC: the machine has no axis C (it has XYZ)
"#;

/// Splits a case table into (input, expected) pairs.
pub(crate) fn cases(table: &str) -> Vec<(String, String)> {
    table
        .split("\n----\n")
        .map(|case| {
            let (input, expect) = case.rsplit_once("=> ").expect("a case needs `=> `");
            (
                input.trim_start().to_string(),
                expect.trim_end().to_string(),
            )
        })
        .collect()
}

#[test]
fn errors_point_at_the_problem() {
    let (five, three) = (five_axis(), three_axis());
    for (input, expect) in cases(ERROR_CASES) {
        let m = if input.starts_with("# three-axis") {
            &three
        } else {
            &five
        };
        check(m, &input, &expect);
    }
}

#[test]
fn opting_out_of_exclusion_rules() {
    let m = five_axis();
    let text = "[component.EYX]\nmin_degree = 0\n[component.EZX]\nkind = \"table\"\n\
                knots = 2\npin_first = false\npin_last = false\n";
    let list = parse_config(text, file(), &m).unwrap();
    assert_eq!(
        basis_of(&list, "EYX"),
        Basis::legendre(-0.35, 0.35, 0, 3).unwrap()
    );
    assert_eq!(
        basis_of(&list, "EZX"),
        Basis::table(vec![-0.35, 0.35], false, false).unwrap()
    );
}

#[test]
fn unlimited_rotary_axis_spans_one_turn() {
    let m = five_axis();
    let text = "[component.EXC]\nkind = \"table\"\nspacing_deg = 30\n";
    let list = parse_config(text, file(), &m).unwrap();
    let Basis::Table { knots, .. } = basis_of(&list, "EXC") else {
        panic!("not a table")
    };
    assert_eq!(knots.len(), 13);
    assert!((knots[0] + PI).abs() < 1e-15 && (knots[12] - PI).abs() < 1e-15);
}

#[test]
fn columns_count_characters() {
    let p = Location::of_offset(Path::new("f"), "a = \"µµ\"\nbé = 1", 14);
    assert_eq!((p.line, p.column), (2, 3));
    assert_eq!(p.to_string(), "f:2:3");
    let end = Location::of_offset(Path::new("f"), "ab", 99);
    assert_eq!((end.line, end.column), (1, 3));
}

#[test]
fn config_path_is_beside_the_urdf() {
    assert_eq!(
        config_path_for(Path::new("dir/dmu50.urdf")),
        PathBuf::from("dir/dmu50.errors.toml")
    );
    assert_eq!(
        config_path_for(Path::new("m.v2.urdf")),
        PathBuf::from("m.v2.errors.toml")
    );
}

#[test]
fn load_reads_files_and_names_missing_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.errors.toml");
    std::fs::write(
        &path,
        "components = \"none\"\nlocations = \"none\"\nsetup = [\"TOOL_DZ\"]",
    )
    .unwrap();
    let list = load_config(&path, &five_axis()).unwrap();
    assert_eq!(list.len(), 1);
    let missing = dir.path().join("none.errors.toml");
    let err = load_config(&missing, &five_axis()).unwrap_err();
    assert!(
        err.to_string().contains("none.errors.toml: cannot read"),
        "{err}"
    );
    assert!(err.position().is_none());
}
