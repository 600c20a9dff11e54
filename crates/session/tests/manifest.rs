//! `session.toml`: a good session loads; every rejected manifest names file, line, column and
//! the problem; written manifests load back.

use std::path::Path;

use mtcal_session::{
    Manifest, ManifestRun, RunUse, SessionError, SetupRef, load_session, load_session_to_extend,
    write_session,
};

/// A session folder with `manifest` and empty files `a.csv`, `b.csv`, `runs/c.csv`.
fn folder(manifest: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("session.toml"), manifest).unwrap();
    std::fs::create_dir(dir.path().join("runs")).unwrap();
    for f in ["a.csv", "b.csv", "runs/c.csv"] {
        std::fs::write(dir.path().join(f), "t,X\n0,0\n").unwrap();
    }
    dir
}

fn check_err_in(dir: &Path, line: usize, column: usize, phrase: &str) {
    let e = load_session(dir).expect_err("the manifest must be rejected");
    let manifest = dir.join("session.toml");
    let at = e.location().unwrap_or_else(|| panic!("no location: {e}"));
    assert_eq!(
        (at.file.as_path(), at.line, at.column),
        (manifest.as_path(), line, column),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("{}:{line}:{column}: ", manifest.display())),
        "{text}"
    );
    assert!(text.contains(phrase), "`{phrase}` not in: {text}");
}

fn check_err(manifest: &str, line: usize, column: usize, phrase: &str) {
    let dir = folder(manifest);
    check_err_in(dir.path(), line, column, phrase);
}

const GOOD: &str = r#"machine = "machine.urdf"

[setup.ball1]
ball = [150.0, 0.0, 50.0]

[[run]]
name = "r1"
instrument = "rtest"
file = "a.csv"
setup = "ball1"
sigma_um = 0.5

[[run]]
name = "r2"
instrument = "rtest"
file = "runs/c.csv"
use = "validate"
path = "circle in XY"
[run.setup]
ball = [250.0, 0.0, 100.0]

[[run]]
name = "r3"
instrument = "ballbar"
file = "b.csv"
"#;

#[test]
fn good_session_with_shared_and_own_setups() {
    let dir = folder(GOOD);
    let s = load_session(dir.path()).unwrap();
    assert_eq!(s.dir, dir.path());
    assert_eq!(s.manifest, dir.path().join("session.toml"));
    assert_eq!(s.machine, "machine.urdf");
    assert_eq!(s.machine_path, Some(dir.path().join("machine.urdf")));
    assert_eq!(s.setups.keys().collect::<Vec<_>>(), ["ball1"]);
    let names: Vec<_> = s.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["r1", "r2", "r3"]);

    let r1 = &s.runs[0];
    assert_eq!(r1.instrument, "rtest");
    assert_eq!(r1.file, dir.path().join("a.csv"));
    assert_eq!(r1.file_as_written, "a.csv");
    assert_eq!(r1.use_, RunUse::Fit);
    assert_eq!(r1.setup, SetupRef::Shared("ball1".into()));
    assert_eq!(
        s.setup_of(r1)["ball"].as_array().unwrap()[0].as_float(),
        Some(150.0)
    );
    assert_eq!(r1.extra.len(), 1);
    assert_eq!(r1.extra["sigma_um"].as_float(), Some(0.5));
    assert_eq!((r1.location.line, r1.location.column), (6, 1));

    let r2 = &s.runs[1];
    assert_eq!(r2.use_, RunUse::Validate);
    assert_eq!(r2.file, dir.path().join("runs/c.csv"));
    let SetupRef::Own(own) = &r2.setup else {
        panic!("own set-up expected")
    };
    assert_eq!(own["ball"].as_array().unwrap()[0].as_float(), Some(250.0));
    assert_eq!(r2.extra["path"].as_str(), Some("circle in XY"));

    assert_eq!(s.runs[2].setup, SetupRef::Own(toml::Table::new()));
    assert_eq!(
        (s.runs[2].location.line, s.runs[2].location.column),
        (22, 1)
    );
    assert_eq!(s.run("r3").unwrap().instrument, "ballbar");

    // The manifest file itself may be named, and a topology code is no path.
    let text = GOOD.replace("machine.urdf", "wCAFYXZt");
    std::fs::write(dir.path().join("other.toml"), text).unwrap();
    let s = load_session(&dir.path().join("other.toml")).unwrap();
    assert_eq!(s.manifest, dir.path().join("other.toml"));
    assert_eq!(
        (s.machine.as_str(), s.machine_path.as_ref()),
        ("wCAFYXZt", None)
    );
}

#[test]
fn written_manifest_loads_back_the_same() {
    let dir = folder(GOOD);
    let s = load_session(dir.path()).unwrap();
    let out = tempfile::tempdir().unwrap();
    for f in ["a.csv", "b.csv"] {
        std::fs::copy(dir.path().join(f), out.path().join(f)).unwrap();
    }
    std::fs::create_dir(out.path().join("runs")).unwrap();
    std::fs::copy(dir.path().join("runs/c.csv"), out.path().join("runs/c.csv")).unwrap();
    let path = write_session(out.path(), &s.to_manifest()).unwrap();
    assert_eq!(path, out.path().join("session.toml"));
    let back = load_session(out.path()).unwrap();
    assert_eq!(back.to_manifest(), s.to_manifest());
    let names: Vec<_> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 4, "no temporary file left: {names:?}");
}

fn one_run(name: &str, file: &str) -> ManifestRun {
    ManifestRun {
        name: name.into(),
        instrument: "rtest".into(),
        file: file.into(),
        use_: RunUse::Fit,
        setup: SetupRef::Own(toml::Table::new()),
        extra: toml::Table::new(),
    }
}

#[test]
fn write_refuses_a_manifest_that_would_not_load() {
    let out = tempfile::tempdir().unwrap();
    let refused = |m: Manifest, phrase: &str| {
        let e = write_session(out.path(), &m).unwrap_err();
        assert!(matches!(e, SessionError::NotWritten { .. }), "{e}");
        assert!(e.to_string().contains(phrase), "`{phrase}` not in: {e}");
        assert!(!out.path().join("session.toml").exists());
    };
    let m = |runs| Manifest {
        machine: "CAFYXZ".into(),
        setups: Default::default(),
        runs,
        identify: Default::default(),
    };
    refused(
        m(vec![one_run("a", "a.csv"), one_run("a", "b.csv")]),
        "is used twice",
    );
    refused(
        m(vec![one_run("a", "../a.csv")]),
        "outside the session folder",
    );
    refused(m(vec![]), "`run` is empty");
    let mut r = one_run("a", "a.csv");
    r.setup = SetupRef::Shared("nowhere".into());
    refused(m(vec![r]), "names no [setup.nowhere] table");
    let mut r = one_run("a", "a.csv");
    r.extra.insert("file".into(), "x".into());
    refused(m(vec![r]), "`extra` holds `file`");
}

#[test]
fn toml_syntax_error() {
    check_err(
        "machine = \"m.urdf\"\n[[run]\nname = 1\n",
        2,
        7,
        "this is not valid TOML",
    );
    check_err("machine = \n", 1, 11, "this is not valid TOML");
}

#[test]
fn missing_machine() {
    check_err(
        "[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\n",
        1,
        1,
        "missing `machine`",
    );
    check_err(
        "machine = 3\n",
        1,
        11,
        "`machine` must be a string, found an integer",
    );
}

#[test]
fn no_runs() {
    check_err(
        "machine = \"CAFYXZ\"\n",
        1,
        1,
        "no [[run]]: a session needs at least one run",
    );
    check_err("machine = \"CAFYXZ\"\nrun = []\n", 2, 7, "`run` is empty");
}

#[test]
fn a_manifest_to_extend_may_have_no_runs_yet_but_is_checked_otherwise() {
    let dir = folder("machine = \"CAFYXZ\"\n[setup.b1]\nball = [1.0, 2.0, 3.0]\n");
    let session = load_session_to_extend(dir.path()).unwrap();
    assert!(session.runs.is_empty());
    assert_eq!(session.setups["b1"]["ball"].as_array().unwrap().len(), 3);
    assert!(
        load_session(dir.path()).is_err(),
        "a session still needs a run"
    );
    let dir = folder("machine = \"CAFYXZ\"\nrun = []\n");
    let e = load_session_to_extend(dir.path()).unwrap_err().to_string();
    assert!(e.contains("`run` is empty"), "{e}");
}

#[test]
fn run_missing_name_instrument_or_file() {
    let base =
        "machine = \"CAFYXZ\"\n\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\n";
    for (key, example) in [
        ("name", "\"rtest-xyc-a0\""),
        ("instrument", "\"rtest\""),
        ("file", "\"rtest-xyc-a0.csv\""),
    ] {
        let text: String = base
            .lines()
            .filter(|l| !l.starts_with(key))
            .map(|l| format!("{l}\n"))
            .collect();
        check_err(
            &text,
            3,
            1,
            &format!("run #1 has no `{key}`: expected e.g. `{key} = {example}`"),
        );
    }
    check_err(
        &base.replace("\"rtest\"", "\"\""),
        5,
        14,
        "`instrument` is empty",
    );
    check_err(
        &base.replace("name = \"a\"", "name = \"a/b\""),
        4,
        8,
        "run names become file names",
    );
}

#[test]
fn duplicate_run_names_point_at_the_second_and_name_the_first() {
    let text = "machine = \"CAFYXZ\"\n\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\n\n[[run]]\ninstrument = \"rtest\"\nname = \"a\"\nfile = \"b.csv\"\n";
    check_err(
        text,
        10,
        8,
        "run name \"a\" is used twice: the first run with it starts at line 3",
    );
}

#[test]
fn use_must_be_fit_or_validate() {
    let text = "machine = \"CAFYXZ\"\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\nuse = \"Fit\"\n";
    check_err(
        text,
        6,
        7,
        "`use` must be \"fit\" or \"validate\", found \"Fit\"",
    );
    check_err(
        &text.replace("\"Fit\"", "true"),
        6,
        7,
        "`use` must be \"fit\" or \"validate\", found a boolean",
    );
}

#[test]
fn shared_and_own_setup_at_once() {
    let text = "machine = \"CAFYXZ\"\n[setup.b]\nball = [0.0, 0.0, 0.0]\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\nsetup = \"b\"\n[run.setup]\nball = [1.0, 0.0, 0.0]\n";
    check_err(
        text,
        9,
        6,
        "this run has both `setup = \"<name>\"` and a `[run.setup]` table",
    );
}

#[test]
fn shared_setup_must_exist() {
    let text = "machine = \"CAFYXZ\"\n[setup.ball1]\nball = [0.0, 0.0, 0.0]\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\nsetup = \"ball2\"\n";
    check_err(
        text,
        8,
        9,
        "`setup = \"ball2\"` names no [setup.ball2] table; defined set-ups: ball1",
    );
    check_err(
        &text.replace("[setup.ball1]\nball = [0.0, 0.0, 0.0]\n", ""),
        6,
        9,
        "this session defines none",
    );
    check_err(
        "machine = \"CAFYXZ\"\nsetup.b = 3\n",
        2,
        7,
        "`setup.b` must be a table of set-up keys",
    );
}

#[test]
fn run_file_outside_the_folder() {
    let text = |f: &str| {
        format!(
            "machine = \"CAFYXZ\"\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"{f}\"\n"
        )
    };
    check_err(
        &text("/etc/passwd"),
        5,
        8,
        "`file` \"/etc/passwd\" is outside the session folder",
    );
    check_err(
        &text("../a.csv"),
        5,
        8,
        "expected a path relative to the session folder without `..`",
    );
    check_err(&text("runs/../a.csv"), 5, 8, "outside the session folder");
}

#[cfg(unix)]
#[test]
fn run_file_escaping_through_a_symlink() {
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(outside.path().join("x.csv"), "t,X\n0,0\n").unwrap();
    let dir = folder(
        "machine = \"CAFYXZ\"\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"link/x.csv\"\n",
    );
    std::os::unix::fs::symlink(outside.path(), dir.path().join("link")).unwrap();
    check_err_in(
        dir.path(),
        5,
        8,
        "run \"a\": file \"link/x.csv\" leads outside the session folder through a symbolic link",
    );
    // A link that stays inside is fine.
    std::fs::remove_file(dir.path().join("link")).unwrap();
    std::os::unix::fs::symlink(dir.path().join("runs"), dir.path().join("link")).unwrap();
    std::fs::write(dir.path().join("runs/x.csv"), "t,X\n0,0\n").unwrap();
    assert!(load_session(dir.path()).is_ok());
}

#[test]
fn run_file_must_exist() {
    let text = "machine = \"CAFYXZ\"\n[[run]]\nname = \"r7\"\ninstrument = \"rtest\"\nfile = \"missing.csv\"\n";
    check_err(
        text,
        5,
        8,
        "run \"r7\": its file \"missing.csv\" does not exist",
    );
    check_err(
        &text.replace("missing.csv", "runs"),
        5,
        8,
        "\"runs\" is not a file",
    );
}

#[test]
fn unknown_top_level_key_lists_the_allowed_ones() {
    let text = "machine = \"CAFYXZ\"\nmachin = \"x\"\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\n";
    check_err(
        text,
        2,
        1,
        "unknown top-level key `machin`; a session manifest has only: machine, setup, run",
    );
    check_err(
        &text.replace("machin = \"x\"", "[runs]\nx = 1"),
        2,
        2,
        "unknown top-level key `runs`",
    );
}

#[test]
fn missing_manifest_is_a_read_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_session(dir.path()).unwrap_err();
    assert!(matches!(e, SessionError::Read { .. }), "{e}");
    assert!(e.to_string().contains("session.toml: cannot read"), "{e}");
}

#[test]
fn bom_is_accepted_and_not_utf8_is_located() {
    let dir = folder(&format!("\u{feff}{GOOD}"));
    assert_eq!(load_session(dir.path()).unwrap().runs.len(), 3);
    let dir = folder("");
    std::fs::write(dir.path().join("session.toml"), b"machine = \"CA\xffF\"\n").unwrap();
    check_err_in(dir.path(), 1, 14, "not UTF-8");
}

#[test]
fn identify_options_load_and_write_back() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.csv"), "t,X\n0,1\n").unwrap();
    let text = "machine = \"CAFYXZ\"\n[identify]\nparameters = [\"EC0Y\"]\n\n[[run]]\nname = \"a\"\ninstrument = \"rtest\"\nfile = \"a.csv\"\n";
    std::fs::write(dir.path().join("session.toml"), text).unwrap();
    let s = mtcal_session::load_session(dir.path()).unwrap();
    assert_eq!(s.identify["parameters"].as_array().unwrap().len(), 1);
    mtcal_session::write_session(dir.path(), &s.to_manifest()).unwrap();
    let again = mtcal_session::load_session(dir.path()).unwrap();
    assert_eq!(again.identify, s.identify);
    std::fs::write(
        dir.path().join("session.toml"),
        text.replace("[identify]\nparameters = [\"EC0Y\"]\n", "identify = 3\n"),
    )
    .unwrap();
    let e = mtcal_session::load_session(dir.path()).unwrap_err();
    assert!(e.to_string().contains("`identify` must be a table"), "{e}");
}
