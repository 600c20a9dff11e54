//! `mtcal identify --search` on the bundled example (its truth is the fitted 11-error set): the
//! held-out parameters are ranked, and none is claimed.

use std::path::Path;
use std::process::Command;

#[test]
fn the_bundled_example_has_nothing_left_out() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args([
            "identify",
            "--quiet",
            "--search",
            "examples/five-axis/session",
        ])
        .current_dir(repo)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let ranking = text
        .split("held-out parameters of the error model")
        .nth(1)
        .unwrap_or_else(|| panic!("no ranking in:\n{text}"));
    assert!(ranking.contains("(31 scored"), "{ranking}");
    assert!(ranking.contains("omitted-parameter"), "{ranking}");
    assert!(!ranking.contains(", significant"), "{ranking}");
    assert!(ranking.contains("none of them is significant"), "{ranking}");
}
