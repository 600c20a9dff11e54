//! `mtcal compensate` writes compensation files that mtcal-compensate reads back: a
//! bidirectional LinuxCNC pitch table and a 3-D error grid; a bad format writes nothing.

use mtcal_testkit::cli::{
    THREE_AXIS_MACHINE, THREE_AXIS_TRUTH, assert_refused, assert_success, on_three_axis_example,
    run_in_repo,
};
use std::path::Path;
use std::process::Output;

/// `mtcal compensate MACHINE --params TRUTH OPTIONS --out OUT` on the three-axis example:
/// `options` as typed on the command line.
fn compensate(options: &str, out: &Path) -> Output {
    let mut args: Vec<&str> = options.split_whitespace().collect();
    args.extend(["--out", out.to_str().unwrap()]);
    run_in_repo(
        env!("CARGO_BIN_EXE_mtcal"),
        &on_three_axis_example("compensate", &args),
    )
}

/// `compensate` with `options` must be refused, saying `says`, and write nothing.
fn assert_compensate_refuses(dir: &Path, options: &str, says: &str) {
    let bad = dir.join("bad.csv");
    assert_refused(&compensate(options, &bad), says, &bad);
}

#[test]
fn pitch_tables_and_grids_are_written_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let comp = dir.path().join("x.comp");
    let grid = dir.path().join("grid.csv");
    let out = compensate(
        "--axis X --format linuxcnc --reversal-um -1.5 --spacing-mm 50 --hold Y=0,Z=-250",
        &comp,
    );
    assert_success(&out);
    let table = mtcal_compensate::read_linuxcnc_comp(&comp, 'X').unwrap();
    assert_eq!(table.len(), 16);
    let reverse = table.reverse_um.as_ref().unwrap();
    for (f, r) in table.forward_um.iter().zip(reverse) {
        assert!((r - f + 1.5).abs() < 1e-6, "reverse {r} forward {f}");
    }
    let out = compensate("--spacing-mm 100", &grid);
    assert_success(&out);
    let g = mtcal_compensate::read_grid_csv(&grid).unwrap();
    assert!(g.len() > 100 && g.error_um.iter().any(|e| e[0].abs() > 0.5));

    assert_compensate_refuses(dir.path(), "--axis X --format okuma", "--format `okuma`");
}

/// Every control format: `compensate` writes the file, names every file beside it, prints the
/// convention card, and `check-compensation` reads the file back within the control's limits.
/// A limit smaller than the file needs is refused by the check.
#[test]
fn control_files_are_written_with_their_card_and_pass_their_check() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "--format fanuc --spacing-mm 50",
            "pitch.txt",
            "pitch.txt.values.csv",
        ),
        (
            "--format fanuc --axis Y --increment is-c",
            "y.txt",
            "y.txt.values.csv",
        ),
        ("--format siemens-eec --spacing-mm 50", "eec.ini", ""),
        ("--format siemens-cec --spacing-mm 100", "cec.ini", ""),
        (
            "--format heidenhain-com --spacing-mm 100",
            "CONFIG.CMA",
            "X.COM",
        ),
        (
            "--format heidenhain-kinematicscomp --spacing-mm 100",
            "KC.TAB",
            "KC_X.COM",
        ),
    ];
    for (options, file, beside) in cases {
        let out_path = dir.path().join(file);
        let out = compensate(options, &out_path);
        assert_success(&out);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            stdout.starts_with(&format!("wrote {}", out_path.display())),
            "{stdout}"
        );
        for key in [
            "format",
            "values are",
            "sign",
            "squareness",
            "axis mapping",
            "units",
        ] {
            assert!(
                stdout.contains(&format!("\n  {key} ")),
                "{options}: no {key}\n{stdout}"
            );
        }
        if !beside.is_empty() {
            let beside = dir.path().join(beside);
            assert!(
                stdout.contains(&format!("wrote {}", beside.display())),
                "{stdout}"
            );
            assert!(beside.exists());
        }
        let mut args = vec![
            "check-compensation",
            THREE_AXIS_MACHINE,
            out_path.to_str().unwrap(),
        ];
        args.extend(
            options
                .split_whitespace()
                .filter(|o| !o.starts_with("--spacing")),
        );
        args.retain(|a| a.parse::<f64>().is_err());
        let checked = run_in_repo(env!("CARGO_BIN_EXE_mtcal"), &args);
        assert_success(&checked);
        let said = String::from_utf8_lossy(&checked.stdout);
        assert!(
            said.contains("reads back and is within the control's limits"),
            "{said}"
        );
    }
    let eec = dir.path().join("eec.ini");
    let args = [
        "check-compensation",
        THREE_AXIS_MACHINE,
        eec.to_str().unwrap(),
        "--format",
        "siemens-eec",
        "--max-points",
        "4",
    ];
    let refused = run_in_repo(env!("CARGO_BIN_EXE_mtcal"), &args);
    assert_eq!(refused.status.code(), Some(2));
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(
        said.contains("MD38000") && said.contains("allows 4"),
        "{said}"
    );
}

/// `--format isg` / `etalon`: the machine's error parameters, which the library reads back into
/// the model a controller builds; at table nodes it matches the identified model to 0.1 µm.
#[test]
fn error_parameter_files_reproduce_the_model() {
    use mtcal_compensate::{ParameterFormat, read_error_parameters};
    let dir = tempfile::tempdir().unwrap();
    let repo = mtcal_testkit::repo();
    let loaded = mtcal_machine::load_machine(
        repo.join(THREE_AXIS_MACHINE).to_str().unwrap(),
        mtcal_machine::topology::Reading::FromWorkpiece,
    )
    .unwrap();
    let model = mtcal_kinematics::MachineModel::new(loaded.machine, &loaded.config).unwrap();
    let coeffs =
        mtcal_machine::params::load_params(&repo.join(THREE_AXIS_TRUTH), model.errors()).unwrap();
    for (format, kind) in [
        ("isg", ParameterFormat::IsgCsv),
        ("etalon", ParameterFormat::Etalon),
    ] {
        let path = dir.path().join(format!("errors.{format}"));
        let out = compensate(&format!("--format {format} --spacing-mm 30"), &path);
        assert_success(&out);
        assert!(String::from_utf8_lossy(&out.stdout).contains("component-error tables"));
        let back = read_error_parameters(&path, kind).unwrap();
        let (reloaded, c2) = back.model(model.machine()).unwrap();
        // X, Y, Z at table nodes (every 30 mm from the lower limit).
        let m = model.machine();
        let nodes = |letter: char| {
            let (lo, hi) = m.axes()[m.axis_index(letter).unwrap()].limits().unwrap();
            (0..)
                .map(move |i| lo + 0.03 * i as f64)
                .take_while(move |&v| v <= hi + 1e-12)
        };
        let (mut ws, mut ws2) = (model.workspace(), reloaded.workspace());
        let mut checked = 0;
        for x in nodes('X').step_by(3) {
            for y in nodes('Y').step_by(3) {
                for z in nodes('Z').step_by(3) {
                    let mut q = vec![0.0; m.n_axes()];
                    for (letter, v) in [('X', x), ('Y', y), ('Z', z)] {
                        q[m.axis_index(letter).unwrap()] = v;
                    }
                    // The file leaves out set-up offsets; the truth file has none.
                    let a = model.pose_error(&q, &coeffs, &mut ws).translation * 1e6;
                    let b = reloaded.pose_error(&q, &c2, &mut ws2).translation * 1e6;
                    assert!((a - b).norm() < 0.1, "{format} at {q:?}: {a} vs {b}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 50, "{checked}");
    }
    // --axis with a whole-machine format is refused, and nothing is written.
    assert_compensate_refuses(dir.path(), "--format isg --axis X", "drop --axis X");
}

/// `--joint-offset-mm` moves a LinuxCNC table's nodes into joint coordinates, compensations
/// unchanged.
#[test]
fn joint_offset_shifts_the_nodes_only() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, offset: &str| {
        let path = dir.path().join(name);
        let options = format!("--axis Y --format linuxcnc --joint-offset-mm {offset}");
        let out = compensate(&options, &path);
        assert_success(&out);
        mtcal_compensate::read_linuxcnc_comp(&path, 'Y').unwrap()
    };
    let plain = write("y0.comp", "0");
    let shifted = write("y1.comp", "-125.5");
    assert_eq!(plain.forward_um, shifted.forward_um);
    for (a, b) in plain.positions_mm.iter().zip(&shifted.positions_mm) {
        assert!((b - (a - 125.5)).abs() < 1e-9);
    }
}

/// `--format` names come from the library's registry: `--help` lists each with what it
/// writes, an unknown name is refused with every registered one (sorted), and a
/// `--control-option` the format does not take, or one that is no KEY=VALUE, is refused by
/// name, writing nothing.
#[test]
fn formats_and_their_options_come_from_the_registry() {
    let help = run_in_repo(env!("CARGO_BIN_EXE_mtcal"), &["compensate", "--help"]);
    assert_success(&help);
    let text = String::from_utf8_lossy(&help.stdout);
    let names: Vec<&str> = mtcal_compensate::control_formats()
        .iter()
        .map(|f| f.name())
        .collect();
    for name in &names {
        assert!(
            text.contains(&format!("- {name}: ")),
            "{name} not in\n{text}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let (last, rest) = names.split_last().unwrap();
    let expected = format!("--format `okuma`: expected {} or {last}", rest.join(", "));
    assert_compensate_refuses(dir.path(), "--format okuma", &expected);
    assert_compensate_refuses(
        dir.path(),
        "--format fanuc --control-option colour=blue",
        "--format fanuc takes no control option `colour` (it takes none)",
    );
    assert_compensate_refuses(
        dir.path(),
        "--format fanuc --control-option colour",
        "--control-option `colour`: expected KEY=VALUE",
    );
}
