//! The planner simulates its candidates in memory (`mtcal_simulate::simulate_session`,
//! `mtcal_identify::Study::from_parts`): planning needs no temporary folder and writes no file
//! until the plan is written.

use std::path::Path;
use std::process::Command;

/// Set in the child process that plans.
const CHILD: &str = "MTCAL_PLAN_TEST_CHILD";

#[test]
fn planning_needs_no_temporary_folder() {
    let planning =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/five-axis/planning.toml");
    if std::env::var_os(CHILD).is_some() {
        let planned = mtcal_plan::plan(&planning).unwrap_or_else(|e| panic!("{e}"));
        assert!(!planned.runs.is_empty());
        return;
    }
    // The same test in a child process whose temporary folder does not exist: creating
    // anything in it fails (the planner used to write every candidate design there).
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("missing");
    let before = std::fs::read_dir(planning.parent().unwrap())
        .unwrap()
        .count();
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "planning_needs_no_temporary_folder",
            "--nocapture",
        ])
        .env(CHILD, "1")
        .env("TMPDIR", &missing)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!missing.exists());
    let after = std::fs::read_dir(planning.parent().unwrap())
        .unwrap()
        .count();
    assert_eq!(before, after, "nothing written beside the planning file");
}
