//! `mtcal compensate` writes compensation files that mtcal-compensate reads back: a
//! bidirectional LinuxCNC pitch table and a 3-D error grid; a bad format writes nothing.

use std::path::Path;
use std::process::Command;

fn run(args: &[&str]) -> std::process::Output {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .current_dir(repo)
        .output()
        .unwrap()
}

#[test]
fn pitch_tables_and_grids_are_written_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let comp = dir.path().join("x.comp");
    let grid = dir.path().join("grid.csv");
    let machine = "examples/three-axis/machine/zfyx.urdf";
    let params = "examples/three-axis/truth.params.toml";
    let out = run(&[
        "compensate",
        machine,
        "--params",
        params,
        "--axis",
        "X",
        "--format",
        "linuxcnc",
        "--reversal-um",
        "-1.5",
        "--spacing-mm",
        "50",
        "--hold",
        "Y=0,Z=-250",
        "--out",
        comp.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = mtcal_compensate::read_linuxcnc_comp(&comp, 'X').unwrap();
    assert_eq!(table.len(), 16);
    let reverse = table.reverse_um.as_ref().unwrap();
    for (f, r) in table.forward_um.iter().zip(reverse) {
        assert!((r - f + 1.5).abs() < 1e-6, "reverse {r} forward {f}");
    }
    let out = run(&[
        "compensate",
        machine,
        "--params",
        params,
        "--spacing-mm",
        "100",
        "--out",
        grid.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let g = mtcal_compensate::read_grid_csv(&grid).unwrap();
    assert!(g.len() > 100 && g.error_um.iter().any(|e| e[0].abs() > 0.5));

    let bad = dir.path().join("bad.csv");
    let out = run(&[
        "compensate",
        machine,
        "--params",
        params,
        "--axis",
        "X",
        "--format",
        "fanuc",
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--format `fanuc`"));
    assert!(!bad.exists());
}

/// `--format isg` / `etalon`: the machine's error parameters, which the library reads back into
/// the model a controller builds; at table nodes it matches the identified model to 0.1 µm.
#[test]
fn error_parameter_files_reproduce_the_model() {
    use mtcal_compensate::{ParameterFormat, read_error_parameters};
    let dir = tempfile::tempdir().unwrap();
    let machine = "examples/three-axis/machine/zfyx.urdf";
    let params = "examples/three-axis/truth.params.toml";
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let loaded = mtcal_machine::load_machine(
        repo.join(machine).to_str().unwrap(),
        mtcal_machine::topology::Reading::FromWorkpiece,
    )
    .unwrap();
    let model = mtcal_kinematics::MachineModel::new(loaded.machine, &loaded.config).unwrap();
    let coeffs = mtcal_machine::params::load_params(&repo.join(params), model.errors()).unwrap();
    for (format, kind) in [
        ("isg", ParameterFormat::IsgCsv),
        ("etalon", ParameterFormat::Etalon),
    ] {
        let path = dir.path().join(format!("errors.{format}"));
        let out = run(&[
            "compensate",
            machine,
            "--params",
            params,
            "--format",
            format,
            "--spacing-mm",
            "30",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
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
    let bad = dir.path().join("bad.csv");
    let out = run(&[
        "compensate",
        machine,
        "--params",
        params,
        "--format",
        "isg",
        "--axis",
        "X",
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("drop --axis X"));
    assert!(!bad.exists());
}

/// `--joint-offset-mm` moves a LinuxCNC table's nodes into joint coordinates, compensations
/// unchanged.
#[test]
fn joint_offset_shifts_the_nodes_only() {
    let dir = tempfile::tempdir().unwrap();
    let machine = "examples/three-axis/machine/zfyx.urdf";
    let params = "examples/three-axis/truth.params.toml";
    let write = |name: &str, offset: &str| {
        let path = dir.path().join(name);
        let out = run(&[
            "compensate",
            machine,
            "--params",
            params,
            "--axis",
            "Y",
            "--format",
            "linuxcnc",
            "--joint-offset-mm",
            offset,
            "--out",
            path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        mtcal_compensate::read_linuxcnc_comp(&path, 'Y').unwrap()
    };
    let plain = write("y0.comp", "0");
    let shifted = write("y1.comp", "-125.5");
    assert_eq!(plain.forward_um, shifted.forward_um);
    for (a, b) in plain.positions_mm.iter().zip(&shifted.positions_mm) {
        assert!((b - (a - 125.5)).abs() < 1e-9);
    }
}
