//! `mtcal identify --search` on the bundled example (its truth is the fitted 11-error set): every
//! family's candidates are scored, and no effect is added.

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
    let search = text
        .split("physics search: ")
        .nth(1)
        .unwrap_or_else(|| panic!("no physics search in:\n{text}"));
    assert!(search.contains("candidates scored"), "{search}");
    assert!(search.contains("discoveries: none"), "{search}");
    assert!(!search.contains("] added"), "{search}");
    // The search ends on the model as identified: the same fit before and after.
    let fit = |part: &str| {
        part.lines()
            .find(|l| l.starts_with("fit: "))
            .map(str::to_string)
            .unwrap_or_else(|| panic!("no fit line in:\n{part}"))
    };
    let (before, after) = text.split_once("after the physics search:").unwrap();
    assert_eq!(fit(before), fit(after));
}
