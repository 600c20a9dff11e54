//! What the command line says when it fails: one line naming the file and what went wrong, each
//! cause said once, exit code 2, nothing on standard output.

use std::process::Command;

fn fail(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{args:?}");
    assert!(out.stdout.is_empty(), "{args:?}");
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn a_missing_file_is_named_once_with_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-session");
    let plan = dir.path().join("no-such-plan.toml");
    let out = dir.path().join("out");
    let cases: [(Vec<&str>, &std::path::Path); 2] = [
        (vec!["identify", missing.to_str().unwrap()], &missing),
        (
            vec![
                "simulate",
                "--out",
                out.to_str().unwrap(),
                plan.to_str().unwrap(),
            ],
            &plan,
        ),
    ];
    for (args, path) in cases {
        let err = fail(&args);
        assert!(err.starts_with("error: "), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        let path = path.display().to_string();
        assert_eq!(err.matches(&path).count(), 1, "{err}");
        // The operating system's reason, once (it was printed twice: message and cause).
        assert_eq!(err.matches("(os error 2)").count(), 1, "{err}");
    }
}

/// A session of one run, written by hand into `dir`: the manifest's set-up and the run file.
fn session(dir: &std::path::Path, instrument: &str, setup: &str, csv: &str) -> String {
    std::fs::write(
        dir.join("session.toml"),
        format!(
            "machine = \"ZFYX\"\n[[run]]\nname = \"r\"\ninstrument = \"{instrument}\"\n\
             file = \"r.csv\"\n[run.setup]\n{setup}"
        ),
    )
    .unwrap();
    std::fs::write(dir.join("r.csv"), csv).unwrap();
    dir.to_str().unwrap().to_string()
}

#[test]
fn an_unknown_artefact_feature_is_located_by_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(
        dir.path(),
        "artefact",
        "features = { h1 = [0.0, 0.0], h2 = [50.0, 0.0] }\norigin = [0.0, 0.0, 300.0]\n",
        "t,X,Y,Z,feature,x,y\n0,0,0,300,h1,0,0\n1,50,0,300,h9,50,0\n",
    );
    let err = fail(&["identify", "--quiet", &s]);
    let csv = dir.path().join("r.csv").display().to_string();
    assert!(err.contains(&format!("{csv}:3:5")), "{err}");
    assert!(err.contains("h9") && err.contains("feature"), "{err}");
}

#[test]
fn a_raw_laser_run_without_its_air_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(
        dir.path(),
        "laser",
        "mode = \"linear\"\ndirection = \"X\"\nwavelength_compensated = false\n",
        "t,X,Y,Z,d\n0,0,0,300,0\n1,50,0,300,1.5\n2,100,0,300,2.0\n",
    );
    let err = fail(&["identify", "--quiet", &s]);
    let csv = dir.path().join("r.csv").display().to_string();
    assert!(err.contains(&csv), "{err}");
    assert!(err.contains("T_air"), "{err}");
}
