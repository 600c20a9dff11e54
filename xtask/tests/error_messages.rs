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
