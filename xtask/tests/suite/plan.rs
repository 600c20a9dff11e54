//! `mtcal plan`: the shipped planning file gives a plan, programs and a report; a bad
//! planning file is located by line and column, exits with 2 and writes nothing.

fn run(args: &[&str]) -> std::process::Output {
    mtcal_testkit::cli::run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

#[test]
fn the_example_is_planned() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let o = run(&[
        "plan",
        "examples/five-axis/planning.toml",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("GIVEN UP"), "{stdout}");
    for f in ["plan.toml", "machine.urdf", "report.json", "report.txt"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let programs = std::fs::read_dir(out.join("programs")).unwrap().count();
    assert!(programs >= 4, "{programs} programs");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["schema"], "mtcal.plan/1");
}

#[test]
fn a_bad_planning_file_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "machine = \"machines/mcu630-cafyxz.urdf\"\nwanted = \"all\"\nclearance_mm = \"big\"\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = run(&[
        "plan",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("bad.toml:3:"), "{stderr}");
    assert!(!out.exists());
}
