//! `mtcal correct` and `mtcal zero-point` on the three-axis example's truth: the corrected
//! program keeps every line that has no axis word, moves the poses by micrometres, and leaves
//! the input untouched; the zero point lowers the summed error over source 004's grid; a
//! program that cannot be read is located by line and column and nothing is written.

use mtcal_testkit::cli::{assert_refused, assert_success, on_three_axis_example, run_in_repo};
use std::path::Path;
use std::process::Output;

const PROGRAM: &str = "G21 G90\nN10 G0 X-100 Y-50 Z-100 (start)\nN20 G1 X100 F500\nY50\nM30\n";

/// `mtcal command` (`correct`, `zero-point`) on the three-axis example's machine and truth:
/// `program` in, `out` out.
fn on_program(command: &str, program: &Path, out: &Path) -> Output {
    let (program, out) = (program.to_str().unwrap(), out.to_str().unwrap());
    run_in_repo(
        env!("CARGO_BIN_EXE_mtcal"),
        &on_three_axis_example(command, &["--program", program, "--out", out]),
    )
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
    let out = on_program("correct", &input, &corrected);
    assert_success(&out);
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

    let out = on_program("zero-point", &input, &offset);
    assert_success(&out);
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
    let out = on_program("correct", &bad, &never);
    assert_refused(&out, &format!("{}:1:7:", bad.display()), &never);
}
