//! The command line as its tests run it: in the repository root, on the shipped examples, its
//! failures checked the one way (exit code 2, a message, nothing written).

use std::path::Path;
use std::process::{Command, Output};

/// The three-axis example's machine and truth, relative to the repository root.
pub const THREE_AXIS_MACHINE: &str = "examples/three-axis/machine/zfyx.urdf";
pub const THREE_AXIS_TRUTH: &str = "examples/three-axis/truth.params.toml";

/// Runs `program` (a test's `env!("CARGO_BIN_EXE_mtcal")`) with `args` in the repository root,
/// so that `args` may name the shipped files by relative paths.
pub fn run_in_repo(program: &str, args: &[&str]) -> Output {
    Command::new(program)
        .args(args)
        .current_dir(crate::repo())
        .output()
        .expect("the program runs")
}

/// `[command, THREE_AXIS_MACHINE, "--params", THREE_AXIS_TRUTH, rest…]`: a command's arguments
/// on the three-axis example's machine and truth.
pub fn on_three_axis_example<'a>(command: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![command, THREE_AXIS_MACHINE, "--params", THREE_AXIS_TRUTH];
    args.extend_from_slice(rest);
    args
}

/// Fails the test, showing the program's standard error, unless it succeeded.
#[track_caller]
pub fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Fails the test unless the program refused its input as the command line does: exit code 2,
/// standard error containing `says`, and `not_written` not written.
#[track_caller]
pub fn assert_refused(out: &Output, says: &str, not_written: &Path) {
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(says), "{err}");
    assert!(!not_written.exists(), "{} written", not_written.display());
}
