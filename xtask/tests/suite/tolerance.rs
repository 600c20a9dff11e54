//! `mtcal tolerance` on the shipped three-axis example: the report on standard output, the JSON
//! file, overrides from the command line, and errors that name the file and line.

use std::path::Path;

fn run(args: &[&str]) -> std::process::Output {
    mtcal_testkit::cli::run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

const MACHINE: &str = "examples/three-axis/machine/zfyx.urdf";
const SPEC: &str = "examples/three-axis/tolerances.toml";

#[test]
fn report_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("t.json");
    let args = [
        "tolerance",
        MACHINE,
        "--spec",
        SPEC,
        "--samples",
        "60",
        "--seed",
        "4",
        "--grid",
        "4x3x3",
        "--bootstrap",
        "10",
        "--json",
        json.to_str().unwrap(),
    ];
    let out = run(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("60 sampled machines (seed 4), grid 4 x 3 x 3 = 36 points"),
        "{text}"
    );
    assert!(text.contains("P90 ") && text.contains("% CI"), "{text}");
    assert!(text.contains("X rails vertical straightness"), "{text}");
    assert!(text.contains("XY squareness"), "{text}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["schema"], "mtcal.tolerance/1");
    assert_eq!(v["samples"], 60);
    assert_eq!(v["grid"], serde_json::json!([4, 3, 3]));
    let b = &v["baseline"];
    let p90 = b["p90_um"].as_f64().unwrap();
    let ci = b["p90_ci_um"].as_array().unwrap();
    assert!(p90 > 0.0 && ci[0].as_f64().unwrap() <= p90 && p90 <= ci[1].as_f64().unwrap());
    let sens = v["sensitivities"].as_array().unwrap();
    assert_eq!(sens.len(), 9);
    assert_eq!(sens[0]["unit"], "um");
    assert_eq!(sens[8]["unit"], "urad");
    assert_eq!(sens[0]["levels"].as_array().unwrap().len(), 5);
    // The printed P90 is the JSON's; a second run is identical (seeded).
    assert!(text.contains(&format!("P90 {p90:.2} um")), "{text}");
    let again = run(&args);
    assert_eq!(String::from_utf8(again.stdout).unwrap(), text);
}

#[test]
fn bad_input_is_an_error_naming_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(SPEC))
        .unwrap()
        .replacen("direction = \"vertical\"", "direction = \"sideways\"", 1);
    std::fs::write(&spec, &text).unwrap();
    let line = text.lines().position(|l| l.contains("sideways")).unwrap() + 1;
    let out = run(&[
        "tolerance",
        MACHINE,
        "--spec",
        spec.to_str().unwrap(),
        "--samples",
        "5",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("bad.toml:{line}:13:")), "{err}");
    assert!(
        err.contains("expected \"vertical\" or \"horizontal\""),
        "{err}"
    );

    let out = run(&["tolerance", MACHINE, "--spec", SPEC, "--grid", "11x2x11"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("three counts >= 3"));
    let out = run(&["tolerance", MACHINE, "--spec", "no/such.toml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such.toml"));
}
