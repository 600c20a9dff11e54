//! Output paths and inputs that are not what they seem (issue 36), through the command line:
//! a device node, a FIFO or a symbolic link where the JSON goes is written through, never
//! renamed over (run as root, a rename onto `/dev/null` would replace the device for every
//! program on the machine); a URDF nested 100,000 deep is refused at once, not a stack
//! overflow. The corpus (`tests/bad-input/outputs-*`) holds the paths refused before anything is
//! written.

#![cfg(unix)]

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn session() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/bad-input/good-laser")
}

fn mtcal(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// `identify --json <path>` on the clean laser session.
fn identify_json(dir: &Path, json: &str) -> Output {
    let s = session();
    mtcal(
        dir,
        &["identify", "--quiet", "--json", json, s.to_str().unwrap()],
    )
}

fn made(cmd: &str, args: &[&str]) -> bool {
    Command::new(cmd)
        .args(args)
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn the_json_onto_a_fifo_is_written_through_and_the_fifo_stays() {
    let tmp = tempfile::tempdir().unwrap();
    let fifo = tmp.path().join("out.json");
    assert!(made("mkfifo", &[fifo.to_str().unwrap()]), "mkfifo");
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let out = identify_json(tmp.path(), "out.json");
    assert!(out.status.success(), "{out:?}");
    let got = reader.join().unwrap();
    let json: serde_json::Value = serde_json::from_slice(&got).unwrap();
    assert_eq!(json["schema"], "mtcal.identify/1");
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the FIFO was replaced: {kind:?}");
    // Nothing else left in the folder (no temporary beside the FIFO).
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

/// A character device (the null device's numbers) made in a temporary folder: written
/// through, kept. Making a device node takes root — as CI runs; elsewhere the test says so.
#[test]
fn the_json_onto_a_device_node_keeps_the_node() {
    let tmp = tempfile::tempdir().unwrap();
    let node = tmp.path().join("null");
    if !made("mknod", &[node.to_str().unwrap(), "c", "1", "3"]) {
        eprintln!("skipped: making a device node needs root (CI runs as root)");
        return;
    }
    let out = identify_json(tmp.path(), "null");
    assert!(out.status.success(), "{out:?}");
    let kind = std::fs::symlink_metadata(&node).unwrap().file_type();
    assert!(kind.is_char_device(), "the device was replaced: {kind:?}");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn the_json_onto_a_symbolic_link_writes_its_target() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("results")).unwrap();
    std::fs::write(tmp.path().join("results/id.json"), "old").unwrap();
    std::os::unix::fs::symlink("results/id.json", tmp.path().join("latest.json")).unwrap();
    let out = identify_json(tmp.path(), "latest.json");
    assert!(out.status.success(), "{out:?}");
    let link = tmp.path().join("latest.json");
    assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
    let text = std::fs::read_to_string(tmp.path().join("results/id.json")).unwrap();
    assert!(text.contains("mtcal.identify/1"), "{text}");
}

/// 100,000 unknown elements nested inside `<robot>`: exit 2 within a second with the place,
/// no abort (the readers after the XML parser recurse).
#[test]
fn a_urdf_nested_a_hundred_thousand_deep_is_refused_at_once() {
    let tmp = tempfile::tempdir().unwrap();
    let urdf = std::fs::read_to_string(session().join("m.urdf")).unwrap();
    let open = urdf.find("<robot").unwrap();
    let body = open + urdf[open..].find('>').unwrap() + 1;
    let n = 100_000;
    let deep = format!(
        "{}\n{}{}\n{}",
        &urdf[..body],
        "<x>".repeat(n),
        "</x>".repeat(n),
        &urdf[body..]
    );
    std::fs::write(tmp.path().join("deep.urdf"), deep).unwrap();
    let start = Instant::now();
    let out = mtcal(tmp.path(), &["describe", "deep.urdf"]);
    let took = start.elapsed();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("deep.urdf:") && err.contains("nested 65 deep"),
        "{err}"
    );
    assert!(took < Duration::from_secs(1), "took {took:?}");
}

/// A set-up that no run uses (a run's `setup` misspelt, say) is said, not silently kept.
#[test]
fn a_set_up_no_run_uses_is_warned_about() {
    let tmp = tempfile::tempdir().unwrap();
    for f in ["laser-x.csv", "m.errors.toml", "m.urdf", "session.toml"] {
        std::fs::copy(session().join(f), tmp.path().join(f)).unwrap();
    }
    let manifest = tmp.path().join("session.toml");
    let mut text = std::fs::read_to_string(&manifest).unwrap();
    text.push_str(
        "\n[setup.spare]\nmode = \"linear\"\ndirection = \"Y\"\norigin = [0.0, 0.0, 390.0]\n",
    );
    std::fs::write(&manifest, text).unwrap();
    let out = mtcal(tmp.path(), &["identify", "--quiet", "."]);
    assert!(out.status.success(), "{out:?}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("warning: ./session.toml: set-up `spare` is used by no run"),
        "{stdout}"
    );
}
