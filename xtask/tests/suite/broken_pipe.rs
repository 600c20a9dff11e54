//! `mtcal … | head` must not panic: when the reader closes standard output, every command stops
//! quietly with success (`println!` would panic with "failed printing to stdout").

use std::process::{Command, Stdio};

/// Runs `mtcal args` with its standard output a pipe whose reading end is closed at once.
fn with_closed_stdout(args: &[&str]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .current_dir(mtcal_testkit::repo())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the reading end before the program gets to write.
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn every_printing_command_survives_a_closed_pipe() {
    let commands: [&[&str]; 5] = [
        &["plugins"],
        &["describe", "machines/mcu630-cafyxz.urdf"],
        &["topology", "CAFYXZ"],
        &[
            "map",
            "machines/mcu630-cafyxz.urdf",
            "--params",
            "examples/five-axis/truth.params.toml",
        ],
        &["identify", "--quiet", "examples/five-axis/session"],
    ];
    for args in commands {
        let out = with_closed_stdout(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "mtcal {args:?}: {stderr}");
        assert!(
            out.status.success(),
            "mtcal {args:?}: {:?} {stderr}",
            out.status
        );
    }
}
