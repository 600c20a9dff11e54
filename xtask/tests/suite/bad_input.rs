//! The bad-input corpus (`tests/bad-input/<case>/`): one folder per case with its input files and
//! a `case.toml`:
//!
//! ```toml
//! # what is wrong
//! args = ["identify", "--quiet", "--json", "out.json", "."]   # paths relative to the folder
//! exit = 2
//! stderr = "error: ./laser-x.csv:4:5: column \"d\": …"      # the exact message
//! ```
//!
//! Each case runs in a copy of its folder. A bad case (`exit = 2`) must print exactly `stderr`
//! (or every fragment of `contains = [...]`), nothing on standard output, no panic, and leave
//! the folder as it was: no file created (outputs named by `args` included), none changed or
//! removed. A good case (`exit = 0`, e.g. a byte-order mark or CRLF line ends, which the formats
//! accept) names the case it must equal, `same_as = "<case>"`: both run with the same
//! arguments, and standard output and the files listed in `outputs` must be byte-identical.
//! Every failing case is reported, not just the first.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The number of bad cases the corpus must hold at least.
const MIN_BAD_CASES: usize = 40;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/bad-input")
}

/// Every file under `dir`, by relative path, with its contents; every folder too (a folder
/// created and left empty is a change), as its path with a trailing `/` and no contents.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                let rel = p.strip_prefix(root).unwrap().join("");
                out.insert(rel, Vec::new());
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn copy_case(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for (rel, bytes) in snapshot(from) {
        let p = to.join(&rel);
        if rel.to_string_lossy().ends_with('/') {
            std::fs::create_dir_all(p).unwrap();
            continue;
        }
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
}

struct Case {
    name: String,
    args: Vec<String>,
    exit: i32,
    stderr: Option<String>,
    contains: Vec<String>,
    same_as: Option<String>,
    outputs: Vec<String>,
}

fn strings(v: Option<&toml::Value>) -> Vec<String> {
    v.and_then(toml::Value::as_array)
        .map(|a| {
            a.iter()
                .map(|s| s.as_str().expect("a string").to_string())
                .collect()
        })
        .unwrap_or_default()
}

fn load_case(dir: &Path) -> Case {
    let name = dir.file_name().unwrap().to_string_lossy().to_string();
    let text = std::fs::read_to_string(dir.join("case.toml"))
        .unwrap_or_else(|e| panic!("{name}/case.toml: {e}"));
    let t: toml::Table = text
        .parse()
        .unwrap_or_else(|e| panic!("{name}/case.toml: {e}"));
    for key in t.keys() {
        assert!(
            ["args", "exit", "stderr", "contains", "same_as", "outputs"].contains(&key.as_str()),
            "{name}/case.toml: unknown key `{key}`"
        );
    }
    let str_of = |k: &str| t.get(k).and_then(|v| v.as_str()).map(str::to_string);
    Case {
        args: strings(t.get("args")),
        exit: t
            .get("exit")
            .and_then(toml::Value::as_integer)
            .unwrap_or_else(|| panic!("{name}/case.toml: no `exit`")) as i32,
        stderr: str_of("stderr"),
        contains: strings(t.get("contains")),
        same_as: str_of("same_as"),
        outputs: strings(t.get("outputs")),
        name,
    }
}

/// Runs `case`'s arguments in a fresh copy of folder `dir` inside `tmp`.
fn run_in_copy(tmp: &Path, dir: &Path, label: &str, args: &[String]) -> (PathBuf, Output) {
    let work = tmp.join(label);
    copy_case(dir, &work);
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .current_dir(&work)
        .output()
        .unwrap();
    (work, out)
}

/// What is wrong with one case's run; empty if nothing.
fn check(case: &Case, dir: &Path, tmp: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    let before = snapshot(dir);
    if before.len() < 2 {
        problems.push("the folder holds no input files besides case.toml".to_string());
    }
    let (work, out) = run_in_copy(tmp, dir, &case.name, &case.args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    if out.status.code() != Some(case.exit) {
        problems.push(format!(
            "exit code {:?}, expected {}; stderr: {stderr}",
            out.status.code(),
            case.exit
        ));
    }
    if stderr.contains("panicked") || stderr.contains("RUST_BACKTRACE") {
        problems.push(format!("it panicked: {stderr}"));
    }
    if let Some(expected) = &case.stderr
        && stderr.trim_end() != expected.trim_end()
    {
        problems.push(format!(
            "stderr differs:\n      expected: {expected}\n      found:    {}",
            stderr.trim_end()
        ));
    }
    for fragment in &case.contains {
        if !stderr.contains(fragment.as_str()) {
            problems.push(format!("stderr lacks `{fragment}`: {stderr}"));
        }
    }
    let mut after = snapshot(&work);
    for o in &case.outputs {
        if after.remove(Path::new(o)).is_none() && case.exit == 0 {
            problems.push(format!("output {o} was not written"));
        }
    }
    if case.exit != 0 && !stdout.is_empty() {
        problems.push(format!("printed on standard output: {stdout}"));
    }
    for (rel, bytes) in &after {
        match before.get(rel) {
            None => problems.push(format!("wrote {}", rel.display())),
            Some(b) if b != bytes => problems.push(format!("changed {}", rel.display())),
            Some(_) => {}
        }
    }
    for rel in before.keys() {
        if !after.contains_key(rel) {
            problems.push(format!("removed {}", rel.display()));
        }
    }
    if let Some(reference) = &case.same_as {
        let (ref_work, ref_out) = run_in_copy(
            tmp,
            &corpus().join(reference),
            &format!("{}.reference", case.name),
            &case.args,
        );
        if ref_out.stdout != out.stdout {
            problems.push(format!(
                "standard output differs from {reference}'s:\n{stdout}\n---\n{}",
                String::from_utf8_lossy(&ref_out.stdout)
            ));
        }
        for o in &case.outputs {
            let (a, b) = (std::fs::read(work.join(o)), std::fs::read(ref_work.join(o)));
            if a.is_err() || a.ok() != b.ok() {
                problems.push(format!("{o} differs from {reference}'s"));
            }
        }
    }
    problems
}

#[test]
fn every_bad_input_is_rejected_with_its_exact_error_and_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(corpus())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    let mut failures = Vec::new();
    let mut bad = 0;
    for dir in &dirs {
        let case = load_case(dir);
        if case.exit == 2 {
            bad += 1;
            if case.stderr.is_none() && case.contains.is_empty() {
                failures.push(format!("{}: a bad case names no error", case.name));
            }
        }
        let problems = check(&case, dir, tmp.path());
        for p in problems {
            failures.push(format!("{}: {p}", case.name));
        }
    }
    assert!(
        bad >= MIN_BAD_CASES,
        "the corpus has {bad} bad cases, expected at least {MIN_BAD_CASES}"
    );
    assert!(
        failures.is_empty(),
        "{} problem(s) in {} cases:\n{}",
        failures.len(),
        dirs.len(),
        failures.join("\n")
    );
}
