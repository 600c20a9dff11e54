//! `mtcal identify` says what constrains each parameter and, with `--what-if`, what another
//! session's runs would do: here the three-axis example's whole campaign measured a second time
//! (with set-ups of its own), read from the text and the JSON; a session of another machine is
//! refused.

use std::path::Path;
use std::process::Command;

#[test]
fn identify_prints_the_account_and_what_another_session_would_add() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("out.json");
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args([
            "identify",
            "--quiet",
            "examples/three-axis/session",
            "--what-if",
            "examples/three-axis/session",
            "--json",
        ])
        .arg(&json)
        .current_dir(repo)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("what constrains each parameter"), "{text}");
    let what_if = text
        .split("with the runs of")
        .nth(1)
        .unwrap_or_else(|| panic!("no what-if section in:\n{text}"));
    // Every line: name, ±now → ±after; nothing gets wider.
    let mut lines = 0;
    for line in what_if.lines().skip(1).filter(|l| l.contains('→')) {
        let nums: Vec<f64> = line
            .split_whitespace()
            .filter_map(|w| w.trim_start_matches('±').parse().ok())
            .collect();
        // A second campaign narrows every interval, by at most 1/√2 (to the printed digits).
        assert!(nums.len() >= 2, "{line}");
        assert!(
            nums[1] < nums[0] && nums[1] >= nums[0] / 2f64.sqrt() * (1.0 - 1e-3),
            "{line}"
        );
        lines += 1;
    }
    assert_eq!(lines, 33, "{what_if}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let params = v["information"]["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 33);
    for p in params {
        let total: f64 = p["runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["share"].as_f64().unwrap())
            .sum();
        assert!((total - 1.0).abs() < 1e-6, "{p}");
    }
}

#[test]
fn what_if_refuses_a_session_of_another_machine() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args([
            "identify",
            "--quiet",
            "examples/three-axis/session",
            "--what-if",
            "examples/five-axis/session",
        ])
        .current_dir(repo)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("another machine"), "{err}");
}
