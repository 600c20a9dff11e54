//! `mtcal cl-error` on the three-axis example's truth: CL data (tool tip, mm) becomes axis
//! positions and a predicted error per point, summarised and written as CSV; a file that cannot
//! be read is located by file, line and column and nothing is written.

use mtcal_testkit::cli::{assert_refused, assert_success, on_three_axis_example, run_in_repo};
use std::path::Path;
use std::process::Output;

/// Tool tips in the workpiece frame (on this machine Z = z − 640 mm), axis +Z.
const CL: &str =
    "# three points\nx,y,z,i,j,k\n0,0,300,0,0,1\n\n100,50,280,0,0,1\n-200,-100,350,0,0,2\n";

/// `mtcal cl-error` on the three-axis example's machine and truth, CL data `cl`, then `rest`.
fn cl_error(cl: &Path, rest: &[&str]) -> Output {
    let cl = cl.to_str().unwrap();
    let mut args = vec!["--cl", cl];
    args.extend_from_slice(rest);
    run_in_repo(
        env!("CARGO_BIN_EXE_mtcal"),
        &on_three_axis_example("cl-error", &args),
    )
}

#[test]
fn cl_data_gives_a_summary_and_a_csv_and_bad_files_are_located() {
    let dir = tempfile::tempdir().unwrap();
    let (input, csv) = (dir.path().join("path.csv"), dir.path().join("errors.csv"));
    let svg = dir.path().join("errors.svg");
    std::fs::write(&input, CL).unwrap();
    let p = |x: &Path| x.to_str().unwrap().to_string();
    let out = cl_error(&input, &["--out", &p(&csv), "--plot", &p(&svg)]);
    assert_success(&out);
    assert_eq!(std::fs::read_to_string(&input).unwrap(), CL);
    let report = String::from_utf8(out.stdout).unwrap();
    assert!(report.contains(": 3 points\n"), "{report}");
    let summary = report
        .lines()
        .find(|l| l.starts_with("|error|     max "))
        .unwrap_or_else(|| panic!("{report}"));
    let numbers: Vec<f64> = summary
        .split([' ', ','])
        .filter_map(|w| w.parse().ok())
        .collect();
    // max, line, RMS, P90, tilt
    let (max, line, rms, p90) = (numbers[0], numbers[1], numbers[2], numbers[3]);
    assert!(max > 0.1 && max < 100.0, "{summary}");
    assert!(rms <= max && p90 <= max, "{summary}");
    assert!([3.0, 5.0, 6.0].contains(&line), "{summary}");

    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(
        rows[0],
        "x,y,z,X_mm,Y_mm,Z_mm,dx_um,dy_um,dz_um,e_um,tilt_urad"
    );
    assert_eq!(rows.len(), 4, "{text}");
    let cells: Vec<Vec<f64>> = rows[1..]
        .iter()
        .map(|r| r.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    let tips = [
        [0.0, 0.0, 300.0],
        [100.0, 50.0, 280.0],
        [-200.0, -100.0, 350.0],
    ];
    let mut largest: f64 = 0.0;
    for (c, tip) in cells.iter().zip(tips) {
        assert_eq!(c.len(), 11);
        assert_eq!(&c[..3], &tip);
        // Tool point over the table: X = x, Y = y, Z = z − 640 mm.
        assert!((c[3] - tip[0]).abs() < 1e-6 && (c[4] - tip[1]).abs() < 1e-6);
        assert!((c[5] - (tip[2] - 640.0)).abs() < 1e-6, "{c:?}");
        let e = (c[6] * c[6] + c[7] * c[7] + c[8] * c[8]).sqrt();
        assert!((e - c[9]).abs() < 1e-3, "{c:?}");
        largest = largest.max(c[9]);
    }
    assert!((largest - max).abs() < 2e-3, "{summary} vs {text}");
    // The plot: one line (a three-axis path has no tool-axis tilt) with one vertex per point.
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg"), "{plot}");
    // The data line is the one in the model colour (the axes are polylines too).
    let lines: Vec<&str> = plot
        .match_indices("<polyline")
        .map(|(k, _)| &plot[k..])
        .filter(|l| l[..l.find('>').unwrap()].contains("stroke=\"#1F77B4\""))
        .collect();
    assert_eq!(lines.len(), 1, "{plot}");
    let points = lines[0]
        .split("points=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap();
    assert_eq!(points.split_whitespace().count(), 3, "{points}");

    for (bad, at) in [
        ("x,y,z\n0,0,300\n1,5;2\n", ":3:4:"),
        ("x,y,z,i,j,k\n0,0,300,0,0,0\n", ":2:9:"),
        ("x,y,z\n0,0,NaN\n", ":2:5:"),
    ] {
        let file = dir.path().join("bad.csv");
        let never = dir.path().join("never.csv");
        std::fs::write(&file, bad).unwrap();
        let out = cl_error(&file, &["--out", &p(&never)]);
        assert_refused(&out, &format!("{}{at} expected", file.display()), &never);
    }

    // A point outside the axis limits is reported by line, nothing written.
    let file = dir.path().join("far.csv");
    let never = dir.path().join("never.csv");
    std::fs::write(&file, "x,y,z\n0,0,300\n0,0,0\n").unwrap();
    let out = cl_error(&file, &["--out", &p(&never)]);
    assert_refused(&out, "line 3: axis Z", &never);
}
