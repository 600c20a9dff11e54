//! Every shipped machine (`machines/*.urdf`) loads into mtcal and passes ROS `check_urdf`, and so
//! does every URDF mtcal writes: FORMATS.md promises standard URDF that standard tools read.
//!
//! Without `check_urdf` (Debian/Ubuntu package `liburdfdom-tools`) the external check is skipped
//! with a message, except under CI (env `CI` set), where a missing tool fails the test so that
//! the check cannot silently disappear.

use mtcal::kinematics::Machine;
use mtcal::machine::topology::{Reading, nominal_machine, parse_code};
use mtcal::machine::urdf::{load_urdf_file, load_urdf_str, write_urdf};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The shipped machines and their explicit topology codes.
const SHIPPED: [(&str, &str); 6] = [
    ("mcv754-zfyx.urdf", "wXYFZt"),
    ("mcu630-cafyxz.urdf", "wCAFYXZt"),
    ("mu6300-caxfyz.urdf", "wCAXFYZt"),
    ("mcv1000-5ax220-bc.urdf", "wCBXYFZt"),
    ("headhead-xyzca.urdf", "wFXYZCAt"),
    ("mixed-c-table-b-head.urdf", "wCXFYZBt"),
];

fn machines_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("machines")
}

fn shipped_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(machines_dir())
        .expect("machines/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "urdf"))
        .collect();
    files.sort();
    files
}

/// `check_urdf`, or `None` (after printing why) when it is not installed outside CI.
fn check_urdf_program() -> Option<PathBuf> {
    let debian = PathBuf::from("/usr/bin/check_urdf");
    let on_path = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|dir| dir.join("check_urdf"))
            .find(|p| p.is_file())
    });
    let found = if debian.is_file() {
        Some(debian)
    } else {
        on_path
    };
    if found.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "check_urdf is not installed; install it with `apt-get install -y liburdfdom-tools`"
        );
        eprintln!("skipped: check_urdf not installed");
    }
    found
}

fn assert_check_urdf_passes(program: &Path, file: &Path) {
    let out = Command::new(program)
        .arg(file)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", program.display()));
    assert!(
        out.status.success(),
        "check_urdf rejects {}:\n{}\n{}",
        file.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn every_shipped_machine_loads_with_its_topology() {
    let files = shipped_files();
    for (name, code) in SHIPPED {
        let path = machines_dir().join(name);
        assert!(files.contains(&path), "{name} is missing from machines/");
        let m = load_urdf_file(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.topology_code(), code, "{name}");
    }
    for path in &files {
        load_urdf_file(path).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn every_shipped_machine_passes_check_urdf() {
    let Some(program) = check_urdf_program() else {
        return;
    };
    for path in shipped_files() {
        assert_check_urdf_passes(&program, &path);
    }
}

/// Writes `machine` to a temporary file, checks it with `check_urdf` and reads it back.
fn check_written(program: &Path, dir: &Path, file_name: &str, machine: &Machine) {
    let text = write_urdf(machine, Some(&format!("written by mtcal from {file_name}")));
    let path = dir.join(file_name);
    std::fs::write(&path, &text).expect("write temporary URDF");
    assert_check_urdf_passes(program, &path);
    let back = load_urdf_str(&text, &path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.topology_code(), machine.topology_code());
}

#[test]
fn written_urdfs_pass_check_urdf() {
    let Some(program) = check_urdf_program() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temporary directory");
    let codes = [
        ("ZFYX", Reading::FromTool),
        ("CAFYXZ", Reading::FromWorkpiece),
        ("CAXFYZ", Reading::FromWorkpiece),
        ("wCBXYFZt", Reading::FromWorkpiece),
        ("wFXYZCAt", Reading::FromWorkpiece),
        ("wCXFYZBt", Reading::FromWorkpiece),
        ("wWVUCFXYZABt", Reading::FromWorkpiece),
    ];
    for (code, reading) in codes {
        let parsed = parse_code(code, reading).unwrap_or_else(|e| panic!("{e}"));
        let m = nominal_machine(&parsed, code).unwrap_or_else(|e| panic!("{e}"));
        check_written(&program, dir.path(), &format!("{code}.urdf"), &m);
    }
    for path in shipped_files() {
        let m = load_urdf_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let name = path.file_name().expect("file name").to_string_lossy();
        check_written(&program, dir.path(), &format!("rewritten-{name}"), &m);
    }
}
