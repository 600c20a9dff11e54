//! `mtcal map --orientations`: the linear grid repeated at every combination of rotary
//! positions (source 004's orientation grid for five-axis machines). Its statistics must be
//! those of the separate maps put together: the largest error is the largest of the maps at
//! each orientation, the point count their sum.

fn run(args: &[&str]) -> std::process::Output {
    mtcal_testkit::cli::run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

/// The number after `label` on its line of the summary.
fn value(text: &str, label: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(label))
        .unwrap_or_else(|| panic!("no `{label}` in\n{text}"));
    line.trim_start()[label.len()..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

fn points(text: &str) -> usize {
    let line = text
        .lines()
        .find(|l| l.starts_with("volumetric map:"))
        .unwrap();
    line.split_whitespace().nth(2).unwrap().parse().unwrap()
}

const MACHINE: &str = "machines/mcu630-cafyxz.urdf";
const PARAMS: &str = "examples/five-axis/truth.params.toml";

#[test]
fn an_orientation_grid_is_the_union_of_the_maps_at_each_orientation() {
    let out = run(&[
        "map",
        MACHINE,
        "--params",
        PARAMS,
        "--grid",
        "5x5x5",
        "--orientations",
        "A=0..90/3,C=0..270/4",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let all = String::from_utf8_lossy(&out.stdout).to_string();
    assert_eq!(points(&all), 3 * 4 * 125);
    let mut largest: f64 = 0.0;
    let mut count = 0;
    for a in [0.0, 45.0, 90.0] {
        for c in [0.0, 90.0, 180.0, 270.0] {
            let at = format!("A={a},C={c}");
            let out = run(&[
                "map", MACHINE, "--params", PARAMS, "--grid", "5x5x5", "--at", &at,
            ]);
            assert!(out.status.success());
            let one = String::from_utf8_lossy(&out.stdout).to_string();
            largest = largest.max(value(&one, "max |Δ|"));
            count += points(&one);
        }
    }
    assert_eq!(count, points(&all));
    assert!((value(&all, "max |Δ|") - largest).abs() < 0.01, "{all}");
    // The orientations matter on this machine: the grid's max differs from A = C = 0's.
    let out = run(&["map", MACHINE, "--params", PARAMS, "--grid", "5x5x5"]);
    let zero = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(value(&all, "max |Δ|") > value(&zero, "max |Δ|") + 1.0);
}

#[test]
fn bad_orientation_grids_are_refused() {
    for (spec, want) in [
        ("A=0..90", "expected LETTER=FROM..TO/COUNT"),
        ("A=0..x/3", "expected LETTER=FROM..TO/COUNT"),
        ("A=0..90/0", "expected LETTER=FROM..TO/COUNT"),
        ("B=0..90/3", "no rotary axis B"),
    ] {
        let out = run(&[
            "map",
            MACHINE,
            "--params",
            PARAMS,
            "--grid",
            "3x3x3",
            "--orientations",
            spec,
        ]);
        assert_eq!(out.status.code(), Some(2), "{spec}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(want), "{spec}: {err}");
    }
}
