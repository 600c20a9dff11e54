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
