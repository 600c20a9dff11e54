//! `mtcal identify --search` on the bundled example (its truth is the fitted 11-error set): every
//! family's candidates are scored, and no effect is added.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// Runs `mtcal args…` in `dir`; its standard output (the run must succeed).
fn mtcal<S: AsRef<OsStr>>(dir: &Path, args: impl IntoIterator<Item = S>) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_bundled_example_has_nothing_left_out() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let text = mtcal(
        repo,
        [
            "identify",
            "--quiet",
            "--search",
            "--verbose",
            "examples/five-axis/session",
        ],
    );
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

/// The whole path a user takes: simulate a session with a planted backlash of X, identify with
/// the search, read the discovery in the JSON (FORMATS.md `discoveries`, with mtcal's keys).
#[test]
fn a_planted_backlash_is_a_discovery_in_the_json() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let dir = tempfile::tempdir().unwrap();
    let plan = std::fs::read_to_string(repo.join("examples/five-axis/plan.toml"))
        .unwrap()
        .replace("../../machines", &repo.join("machines").to_string_lossy())
        .replace(
            "truth = \"truth.params.toml\"",
            &format!(
                "truth = {:?}",
                repo.join("examples/five-axis/truth.params.toml")
            ),
        )
        + "\n[[effect]]\neffect = \"reversal\"\naxis = \"X\"\nbacklash_um = 4.0\n";
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    let run = |args: &[&str]| mtcal(dir.path(), args);
    run(&["simulate", "plan.toml", "--out", "session"]);
    let text = run(&[
        "identify", "--quiet", "--search", "session", "--json", "out.json",
    ]);
    assert!(
        text.contains("+ reversal X (X): a reversal error"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out.json")).unwrap())
            .unwrap();
    let discoveries = json["discoveries"].as_array().unwrap();
    assert_eq!(discoveries.len(), 1, "{json:#}");
    let d = &discoveries[0];
    assert_eq!(d["effect"], "reversal");
    assert_eq!(d["axis"], "X");
    assert_eq!(d["driver"], "X");
    assert_eq!(d["component"], "EXX");
    let p = &d["parameters"][0];
    assert_eq!(p["name"], "backlash_um");
    let (value, u95) = (p["value"].as_f64().unwrap(), p["u95"].as_f64().unwrap());
    assert!((value - 4.0).abs() < 1.31 * u95, "{value} ± {u95}");
    for key in [
        "rms_before_um",
        "rms_after_um",
        "heldout_rms_before_um",
        "heldout_rms_after_um",
    ] {
        assert!(d[key].as_f64().is_some(), "{key} in {d:#}");
    }
    assert!(d["heldout_rms_after_um"].as_f64() < d["heldout_rms_before_um"].as_f64());
    assert!(d["explanation"].as_str().unwrap().contains("backlash"));
    // The backlash's parameter is in the parameter list too, as an effect's.
    let params = json["parameters"].as_array().unwrap();
    assert!(
        params
            .iter()
            .any(|p| p["name"] == "reversal X (X).backlash_um" && p["kind"] == "effect")
    );
    assert!(json["search"]["candidates"].as_u64().unwrap() > 100);
}

/// The bundled example of the search: a warming machine with backlash. Both are found, and the
/// validation run (never fitted) is predicted far better with them than without. The search
/// refits a step's candidates side by side: on one thread, two or eight, the same JSON, byte
/// for byte.
#[test]
fn the_warm_example_finds_the_drift_and_the_backlash() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let dir = tempfile::tempdir().unwrap();
    let searched = |threads: &str| {
        let json_path = dir.path().join(format!("out-{threads}.json"));
        mtcal(
            repo,
            [
                OsStr::new("identify"),
                OsStr::new("--quiet"),
                OsStr::new("--search"),
                OsStr::new("examples/five-axis-warm/session"),
                OsStr::new("--threads"),
                OsStr::new(threads),
                OsStr::new("--json"),
                json_path.as_os_str(),
            ],
        );
        std::fs::read_to_string(json_path).unwrap()
    };
    let text = searched("2");
    for threads in ["1", "8"] {
        assert!(
            searched(threads) == text,
            "identify --search writes the same JSON on {threads} threads as on two"
        );
    }
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    // Each discovery names the planted effect, or lists it among the explanations these data
    // cannot tell it from (on a trunnion the tool never tilts: the spindle growing along its
    // axis and a drift of Z are one column, and the search names both, claiming neither).
    let discoveries = json["discoveries"].as_array().unwrap();
    let names = |d: &serde_json::Value, effect: &str, axis: &str| {
        (d["effect"] == effect && d["axis"] == axis)
            || d["alternatives"].as_array().is_some_and(|a| {
                a.iter().any(|x| {
                    x["effect"] == effect
                        && x["label"]
                            .as_str()
                            .is_some_and(|l| l.contains(&format!(" {axis} ")))
                })
            })
    };
    assert_eq!(discoveries.len(), 2, "{json:#}");
    assert!(names(&discoveries[0], "reversal", "X"), "{json:#}");
    assert!(names(&discoveries[1], "thermal-drift", "Z"), "{json:#}");
    let last = &json["discoveries"][1];
    let (before, after) = (
        last["validation_rms_before_um"].as_f64().unwrap(),
        json["validation"][0]["rms_um"].as_f64().unwrap(),
    );
    assert!(
        after < 0.6 && before > 1.0,
        "validation {before} -> {after} µm"
    );
}

/// The bundled sessions are what their plans simulate, byte for byte.
#[test]
fn bundled_sessions_are_their_plans() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    for example in ["five-axis", "five-axis-warm"] {
        let dir = tempfile::tempdir().unwrap();
        let plan = format!("examples/{example}/plan.toml");
        mtcal(
            repo,
            [
                OsStr::new("simulate"),
                OsStr::new(&plan),
                OsStr::new("--out"),
                dir.path().as_os_str(),
            ],
        );
        let committed = repo.join("examples").join(example).join("session");
        let mut files = Vec::new();
        let mut stack = vec![committed.clone()];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else {
                    files.push(p);
                }
            }
        }
        assert!(files.len() > 10);
        for f in files {
            let rel = f.strip_prefix(&committed).unwrap();
            let fresh = std::fs::read_to_string(dir.path().join(rel))
                .unwrap_or_else(|e| panic!("{example}: {} not simulated: {e}", rel.display()));
            let old = std::fs::read_to_string(&f).unwrap();
            // Numbers may differ in their last digits (the kinematics' rounding changes when a
            // hot path is rearranged); everything else must be the same.
            let same = fresh.lines().count() == old.lines().count()
                && fresh.lines().zip(old.lines()).all(|(a, b)| {
                    a == b
                        || (a.split(',').count() == b.split(',').count()
                            && a.split(',').zip(b.split(',')).all(|(x, y)| {
                                match (x.parse::<f64>(), y.parse::<f64>()) {
                                    (Ok(x), Ok(y)) => (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
                                    _ => x == y,
                                }
                            }))
                });
            assert!(
                same,
                "{example}: {} differs from a fresh simulation of its plan",
                rel.display()
            );
        }
    }
}

/// `identify --search` on every bundled example: the default screen (no `--verbose`) leads with
/// how the search ended and what it found, and fits in 120 lines; the per-test p-values and
/// every trial stay behind `--verbose` (and in the JSON).
#[test]
fn the_search_summary_fits_on_two_screens() {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    for example in ["five-axis", "five-axis-warm", "three-axis"] {
        let run = |verbose: bool| {
            let session = format!("examples/{example}/session");
            let mut args = vec!["identify", "--quiet", "--search", session.as_str()];
            if verbose {
                args.push("--verbose");
            }
            mtcal(repo, args)
        };
        let text = run(false);
        let lines = text.lines().count();
        assert!(lines <= 120, "{example}: {lines} lines\n{text}");
        // The verdict or the fit before the search, then the search's outcome, come first.
        let head: Vec<&str> = text.lines().take(4).collect();
        assert!(
            head.iter().any(|l| l.starts_with("physics search: ")),
            "{example}: {head:?}"
        );
        assert!(
            !text.contains("adjusted p = "),
            "{example}: p-values on the screen"
        );
        assert!(
            !text.contains("] not kept"),
            "{example}: trials on the screen"
        );
        let verbose = run(true);
        assert!(verbose.lines().count() > lines, "{example}");
        assert!(
            verbose.contains("adjusted p = "),
            "{example}: no p-values with --verbose"
        );
    }
}
