//! `mtcal correct` and `mtcal zero-point` on the three-axis example's truth: the corrected
//! program keeps every line that has no axis word, moves the poses by micrometres, and leaves
//! the input untouched; the zero point lowers the summed error over source 004's grid; a
//! program that cannot be read is located by line and column and nothing is written.

use std::path::Path;
use std::process::Command;

const MACHINE: &str = "examples/three-axis/machine/zfyx.urdf";
const PARAMS: &str = "examples/three-axis/truth.params.toml";
const PROGRAM: &str = "G21 G90\nN10 G0 X-100 Y-50 Z-100 (start)\nN20 G1 X100 F500\nY50\nM30\n";

fn run(args: &[&str]) -> std::process::Output {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .current_dir(repo)
        .output()
        .unwrap()
}

#[test]
fn a_program_is_corrected_and_offset_to_the_zero_point() {
    let dir = tempfile::tempdir().unwrap();
    let (input, corrected, offset) = (
        dir.path().join("p.nc"),
        dir.path().join("c.nc"),
        dir.path().join("z.nc"),
    );
    std::fs::write(&input, PROGRAM).unwrap();
    let p = |x: &Path| x.to_str().unwrap().to_string();
    let out = run(&[
        "correct",
        MACHINE,
        "--params",
        PARAMS,
        "--program",
        &p(&input),
        "--out",
        &p(&corrected),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read_to_string(&input).unwrap(), PROGRAM);
    let text = std::fs::read_to_string(&corrected).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!((lines[0], lines[4]), ("G21 G90", "M30"));
    assert!(
        lines[1].starts_with("N10 G0 X-") && lines[1].ends_with("(start)"),
        "{text}"
    );
    // Moved by micrometres, not millimetres.
    let x: f64 = lines[1].split_whitespace().nth(2).unwrap()[1..]
        .parse()
        .unwrap();
    assert!(
        (x + 100.0).abs() > 1e-4 && (x + 100.0).abs() < 0.05,
        "{text}"
    );

    let out = run(&[
        "zero-point",
        MACHINE,
        "--params",
        PARAMS,
        "--program",
        &p(&input),
        "--out",
        &p(&offset),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = String::from_utf8(out.stdout).unwrap();
    let sums: Vec<f64> = report
        .lines()
        .find(|l| l.starts_with("sum |error|"))
        .unwrap()
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(sums[1] < sums[0], "{report}");
    assert!(report.contains("of 10164 grid points"), "{report}");
    assert!(
        std::fs::read_to_string(&offset)
            .unwrap()
            .contains("(start)")
    );

    let bad = dir.path().join("bad.nc");
    let never = dir.path().join("never.nc");
    std::fs::write(&bad, "G0 X1..2\n").unwrap();
    let out = run(&[
        "correct",
        MACHINE,
        "--params",
        PARAMS,
        "--program",
        &p(&bad),
        "--out",
        &p(&never),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("{}:1:7:", bad.display())), "{err}");
    assert!(!never.exists());
}
