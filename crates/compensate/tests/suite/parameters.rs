//! Error-parameter files (ISG CSV, Etalon Exchange): export → reload → the model a controller
//! builds from the file gives the same pose errors as the identified model at the nodes.

use crate::common;

use common::{TOL_UM, load};
use mtcal_compensate::*;
use mtcal_kinematics::model::Role;
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_testkit::random::SplitMix64;

/// Machine errors uniform in ±5 µm / µrad per coefficient; set-up offsets zero (the files
/// leave them out, they belong to the set-up).
fn random_machine_coeffs(model: &MachineModel, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    let mut c: Vec<f64> = (0..model.n_coeffs()).map(|_| 5e-6 * rng.signed()).collect();
    for p in model.errors().params() {
        if matches!(p.role, Role::ToolOffset(_) | Role::WorkpieceOffset(_)) {
            c[p.offset] = 0.0;
        }
    }
    c
}

/// Per axis, the node positions (SI) the file tabulates.
fn axis_nodes(params: &ErrorParameters, model: &MachineModel) -> Vec<Vec<f64>> {
    model
        .machine()
        .axes()
        .iter()
        .map(|ax| {
            let table = params.params.iter().find_map(|p| match &p.value {
                ParameterValue::Table { args, .. } if p.name.axis() == Some(ax.letter()) => {
                    Some(args.clone())
                }
                _ => None,
            });
            let args = table.expect("every axis has a component table");
            let si = match ax.kind() {
                AxisKind::Linear => 1e-3,
                AxisKind::Rotary => 1f64.to_radians(),
            };
            args.iter().map(|a| a * si).collect()
        })
        .collect()
}

fn check_round_trip(name: &str, seed: u64, format: ParameterFormat) {
    let model = load(name);
    let coeffs = random_machine_coeffs(&model, seed);
    let params = error_parameters(&model, &coeffs, 25.0, 15.0).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("errors.txt");
    write_error_parameters(&path, model.machine(), &params, format, &[]).unwrap();
    let back = read_error_parameters(&path, format).unwrap();

    // Same names in the same order, values within the print precision.
    assert_eq!(back.params.len(), params.params.len());
    for (a, b) in params.params.iter().zip(&back.params) {
        assert_eq!(a.name, b.name);
        match (&a.value, &b.value) {
            (ParameterValue::Constant(x), ParameterValue::Constant(y)) => {
                assert!((x - y).abs() < 1e-9, "{}: {x} vs {y}", a.name)
            }
            (
                ParameterValue::Table { args, values },
                ParameterValue::Table {
                    args: args2,
                    values: values2,
                },
            ) => {
                assert_eq!(args.len(), args2.len());
                for (x, y) in args.iter().zip(args2) {
                    assert!((x - y).abs() < 1e-6);
                }
                for (x, y) in values.iter().zip(values2) {
                    assert!((x - y).abs() < 1e-9, "{}: {x} vs {y}", a.name);
                }
            }
            _ => panic!("{}: kind changed", a.name),
        }
    }

    // The controller's model (tables interpolated linearly) against the identified one, at
    // 3000 random grid points whose coordinates are table nodes.
    let (reloaded, reloaded_coeffs) = back.model(model.machine()).unwrap();
    let nodes = axis_nodes(&back, &model);
    let mut rng = SplitMix64(seed ^ 0xABCD);
    let mut ws = model.workspace();
    let mut ws2 = reloaded.workspace();
    let (mut worst_um, mut worst_urad, mut largest_um) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..3000 {
        let q: Vec<f64> = nodes
            .iter()
            .map(|n| n[((rng.signed() + 1.0) * 0.5 * n.len() as f64) as usize % n.len()])
            .collect();
        let e = model.pose_error(&q, &coeffs, &mut ws);
        let r = reloaded.pose_error(&q, &reloaded_coeffs, &mut ws2);
        worst_um = worst_um.max((e.translation - r.translation).norm() * 1e6);
        worst_urad = worst_urad.max((e.rotation - r.rotation).norm() * 1e6);
        largest_um = largest_um.max(e.translation.norm() * 1e6);
    }
    eprintln!(
        "{name} {format:?}: largest error {largest_um:.2} µm, round trip {worst_um:.2e} µm, \
         {worst_urad:.2e} µrad"
    );
    assert!(
        largest_um > 5.0,
        "errors too small to test: {largest_um} µm"
    );
    // Far inside the 0.1 µm: the files print 1 pm.
    assert!(TOL_UM > 1e-4 && worst_um < 1e-4, "{worst_um} µm");
    assert!(worst_urad < 1e-4, "{worst_urad} µrad");
}

#[test]
fn isg_csv_round_trips_three_and_five_axis() {
    check_round_trip("mcv754-zfyx.urdf", 1, ParameterFormat::IsgCsv);
    check_round_trip("mcu630-cafyxz.urdf", 2, ParameterFormat::IsgCsv);
}

#[test]
fn etalon_round_trips_three_and_five_axis() {
    check_round_trip("mcv754-zfyx.urdf", 3, ParameterFormat::Etalon);
    check_round_trip("mcu630-cafyxz.urdf", 4, ParameterFormat::Etalon);
}

/// Units and signs, checked on values known by hand: EXX = +10 µm/m · x (a scale error of
/// 10 ppm) is written as 0.002 mm at x = 200 mm; a squareness EC0Y of +20 µrad as 0.00002
/// rad; the header says errors, not compensations.
#[test]
fn units_and_signs_are_the_documented_ones() {
    let model = load("mcv754-zfyx.urdf");
    let mut coeffs = vec![0.0; model.n_coeffs()];
    let exx = model
        .errors()
        .find(&"EXX".parse().unwrap())
        .unwrap()
        .clone();
    let Role::Component { basis, .. } = &exx.role else {
        panic!("EXX is a component")
    };
    // Fit a straight line of 10 µm/m through the EXX basis (it holds degree 1 and up).
    let line: Vec<(f64, f64)> = (0..11)
        .map(|i| {
            let x = -0.3 + 0.06 * i as f64;
            (x, 10e-6 * x)
        })
        .collect();
    let c = basis.fit(&line).unwrap();
    coeffs[exx.offset..exx.offset + exx.len].copy_from_slice(&c);
    let ec0y = model.errors().find(&"EC0Y".parse().unwrap()).unwrap();
    coeffs[ec0y.offset] = 20e-6;
    let params = error_parameters(&model, &coeffs, 50.0, 15.0).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("errors.csv");
    write_error_parameters(
        &path,
        model.machine(),
        &params,
        ParameterFormat::IsgCsv,
        &[],
    )
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("ERRORS (not compensations)"));
    let data: Vec<&str> = text.lines().filter(|l| !l.starts_with("//")).collect();
    let x_block = data
        .iter()
        .skip_while(|l| !l.starts_with("X EXX"))
        .nth(1)
        .unwrap();
    let first: Vec<f64> = x_block
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let (x_mm, exx_mm) = (first[0], first[1]);
    assert!(
        (exx_mm - 10e-6 * x_mm).abs() < 1e-9,
        "{x_mm} mm -> {exx_mm} mm"
    );
    let names = data.iter().find(|l| l.contains("C0Y")).unwrap();
    let col = names.split_whitespace().position(|n| n == "C0Y").unwrap();
    let values = data
        .iter()
        .skip_while(|l| !l.contains("C0Y"))
        .nth(1)
        .unwrap();
    let v: f64 = values.split_whitespace().nth(col).unwrap().parse().unwrap();
    assert!((v - 20e-6).abs() < 1e-15, "{v}");
}

fn parse_error(format: ParameterFormat, text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.txt");
    std::fs::write(&path, text).unwrap();
    let e = read_error_parameters(&path, format)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.txt"), "{e}");
    e
}

#[test]
fn bad_files_name_line_column_and_what_was_expected() {
    use ParameterFormat::*;
    let cases: &[(ParameterFormat, &str, &str)] = &[
        (
            IsgCsv,
            "X EXX\n0 0.1\nten 0.2\n",
            ":3:1: expected a finite number",
        ),
        (
            IsgCsv,
            "X EXX EQX\n0 0.1 0\n",
            ":1:7: expected an ISO 230-1 error parameter",
        ),
        (
            IsgCsv,
            "X EXY\n0 0.1\n",
            ":1:3: expected a component error of axis X",
        ),
        (
            IsgCsv,
            "X EXX\n0 0.1\n0 0.2\n",
            ":3:1: arguments must ascend",
        ),
        (IsgCsv, "X EXX EYX\n0 0.1\n", ":2:"),
        (IsgCsv, "C0Y B0Z\n0.1\n", ":2:4: expected 2 fields"),
        (IsgCsv, "C0Y\n0.1\n0.2\n", ":3:1: expected one row"),
        (IsgCsv, "EXX\n0.1\n", ":1:1: EXX is a component error"),
        (
            IsgCsv,
            "C0Y\n0.1\n#\nC0Y\n0.2\n",
            ":4:1: C0Y is given twice (first on line 1)",
        ),
        (IsgCsv, "X EXX\n", ":2:1: expected at least one row"),
        (
            Etalon,
            "[C0Y]\nVALUE = abc\n",
            ":2:9: expected a finite number",
        ),
        (
            Etalon,
            "VALUE = 1\n",
            ":1:1: expected `[NAME]` before a value",
        ),
        (
            Etalon,
            "[EXX]\nVALUE = 1\n",
            ":2:1: EXX is a component error",
        ),
        (
            Etalon,
            "[C0Y]\nGridpoints = {\n",
            ":2:1: C0Y is a location error",
        ),
        (
            Etalon,
            "[EXX]\nGridpoints = {\n0 1\n",
            ":4:1: expected `}` closing",
        ),
        (
            Etalon,
            "[EXX]\nGridpoints = {\n0 1 2\n}\n",
            ":3:5: expected 2 fields",
        ),
        (Etalon, "[EXX\n", ":1:5: expected `]`"),
        (
            Etalon,
            "[C0Y]\n[B0Z]\nVALUE = 1\n",
            ":2:1: block [C0Y] from line 1 has no VALUE",
        ),
        (
            Etalon,
            "[C0Y]\nVALUES = 1\n",
            ":2:1: expected VALUE or Gridpoints",
        ),
        (
            Etalon,
            "[PXA]\nVALUE = 1\n",
            ":1:2: expected an ISO 230-1 error parameter",
        ),
    ];
    for (format, text, want) in cases {
        let e = parse_error(*format, text);
        assert!(
            e.contains(want),
            "{format:?} {text:?}: got `{e}`, want `{want}`"
        );
    }
}

/// A file written for another machine does not silently become a model of this one.
#[test]
fn parameters_of_an_axis_the_machine_lacks_are_refused() {
    let five = load("mcu630-cafyxz.urdf");
    let three = load("mcv754-zfyx.urdf");
    let coeffs = random_machine_coeffs(&five, 9);
    let params = error_parameters(&five, &coeffs, 50.0, 30.0).unwrap();
    let e = params.model(three.machine()).unwrap_err().to_string();
    assert!(e.contains("no axis"), "{e}");
}
