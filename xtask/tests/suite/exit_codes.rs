//! The exit codes a script reads (`mtcal --help`, the README): 0 done and within every check
//! asked for; 1 done but a check failed or could not be decided — an acceptance that fails or
//! cannot decide, a fit that did not converge or does not explain the recordings — with the
//! outputs written; 2 bad input, nothing written. Each through the binary on the bundled
//! examples.

use mtcal_testkit::repo;
use std::path::Path;
use std::process::{Command, Output};

/// `mtcal identify SESSION --quiet --json DIR/out.json EXTRA…` in the repository.
fn identify(session: &str, dir: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .current_dir(repo())
        .args(["identify", session, "--quiet", "--json"])
        .arg(dir.join("out.json"))
        .args(extra)
        .output()
        .unwrap()
}

/// A tolerance file of `body` in `dir`; its path.
fn tolerances(dir: &Path, body: &str) -> String {
    let path = dir.join("tolerances.toml");
    std::fs::write(&path, format!("schema = \"mtcal.acceptance/1\"\n{body}")).unwrap();
    path.display().to_string()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const THREE: &str = "examples/three-axis/session";

#[test]
fn a_passing_acceptance_exits_0() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tolerances(tmp.path(), "[iso230_2.X]\nA_um = 1000\n");
    let out = identify(THREE, tmp.path(), &["--acceptance", &t]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(tmp.path().join("out.json").is_file());
}

#[test]
fn a_failing_acceptance_exits_1_with_its_outputs_written() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tolerances(tmp.path(), "[iso230_2.X]\nA_um = 0.001\n");
    let out = identify(THREE, tmp.path(), &["--acceptance", &t]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.starts_with("check failed: the acceptance (") && err.contains("): fail"),
        "{err}"
    );
    let json = std::fs::read_to_string(tmp.path().join("out.json")).unwrap();
    assert!(json.contains("\"verdict\": \"fail\""), "{json}");
}

/// E of Z is 5.6 µm with U 0.7 µm (tests/acceptance.rs): a limit of 6 µm is within U.
#[test]
fn an_acceptance_that_cannot_decide_exits_1() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tolerances(tmp.path(), "[iso230_2.Z]\nE_um = 6\n");
    let out = identify(THREE, tmp.path(), &["--acceptance", &t]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("): cannot decide"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_fit_stopped_before_it_converges_exits_1() {
    let tmp = tempfile::tempdir().unwrap();
    let out = identify(
        "examples/five-axis/session",
        tmp.path(),
        &["--max-iterations", "1"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).starts_with("check failed: the fit: NOT CONVERGED"),
        "{}",
        stderr(&out)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("NOT CONVERGED"), "{stdout}");
}

/// The warm five-axis example without the search: the model leaves the warm-up out.
#[test]
fn a_model_that_does_not_explain_the_recordings_exits_1() {
    let tmp = tempfile::tempdir().unwrap();
    let out = identify("examples/five-axis-warm/session", tmp.path(), &[]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).starts_with("check failed: the fit: THE MODEL DOES NOT EXPLAIN"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn bad_input_exits_2_with_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let out = identify("examples/no-such-session", tmp.path(), &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).starts_with("error: "), "{}", stderr(&out));
    assert!(!tmp.path().join("out.json").exists());
}
