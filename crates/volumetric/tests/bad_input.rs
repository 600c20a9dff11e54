//! Sessions that are no volumetric thermal test, or a broken one, are refused with a message
//! that names the file (and line) or the run at fault: never a panic, never a number.

use std::fmt::Write as _;
use std::path::Path;

use mtcal_volumetric::{Options, evaluate, read_session};

const BALLS: [&str; 3] = ["b1", "b2", "b3"];

/// A session of three balls on a CAFYXZ trunnion, `cycles` cycles 10 min apart, one run per
/// ball; `edit` may change the manifest and the run files (name → text) before they are
/// written.
fn session(dir: &Path, cycles: usize, edit: impl FnOnce(&mut String, &mut Vec<(String, String)>)) {
    let mut manifest = String::from("machine = \"CAFYXZ\"\n");
    let mut files = Vec::new();
    for (j, ball) in BALLS.iter().enumerate() {
        let _ = write!(
            manifest,
            "\n[setup.{ball}]\nball = [{}.0, 0.0, 50.0]\n",
            100 * (j + 1)
        );
        let mut csv = String::from("t,X,Y,Z,A,C,dx,dy,dz\n");
        for c in 0..cycles {
            let t = 600.0 * c as f64 + 15.0 * j as f64;
            let _ = writeln!(
                csv,
                "{t},{}.0,0.0,-200.0,0.0,0.0,{},{},{}",
                100 * (j + 1),
                0.1 * c as f64,
                -0.2 * c as f64 + 0.05 * j as f64,
                1.5 * c as f64
            );
        }
        files.push((format!("{ball}.csv"), csv));
    }
    for ball in BALLS {
        let _ = write!(
            manifest,
            "\n[[run]]\nname = \"{ball}\"\ninstrument = \"rtest\"\nfile = \"{ball}.csv\"\nsetup = \"{ball}\"\n"
        );
    }
    edit(&mut manifest, &mut files);
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("session.toml"), manifest).unwrap();
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
}

/// The error of reading and evaluating the session at `dir`.
fn refused(dir: &Path) -> String {
    let result = read_session(dir).and_then(|v| evaluate(&v, &Options::default()));
    match result {
        Ok(e) => panic!("accepted: {}", e.summary()),
        Err(e) => e.to_string(),
    }
}

fn file<'a>(files: &'a mut [(String, String)], name: &str) -> &'a mut String {
    &mut files.iter_mut().find(|(n, _)| n == name).unwrap().1
}

#[test]
fn a_good_session_of_this_shape_is_evaluated() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |_, _| {});
    let e = evaluate(&read_session(tmp.path()).unwrap(), &Options::default()).unwrap();
    assert_eq!(e.instants.len(), 4);
    assert_eq!(e.visits.points.len(), 3);
    assert!(!e.to_json().contains("NaN"));
}

#[test]
fn a_session_without_rtest_runs_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |manifest, files| {
        *manifest = "machine = \"CAFYXZ\"\n\n[[run]]\nname = \"c1\"\ninstrument = \"ballbar\"\n\
                     file = \"c1.csv\"\n[run.setup]\npivot = [0.0, 0.0, 0.0]\nlength = 100.0\n"
            .into();
        files.push((
            "c1.csv".into(),
            "t,X,Y,Z,A,C,dr\n0,100,0,0,0,0,0.5\n".into(),
        ));
    });
    let e = refused(tmp.path());
    assert!(e.contains("session.toml: no rtest run"), "{e}");
    assert!(e.contains("`c1` (ballbar)"), "{e}");
}

#[test]
fn a_point_visited_once_is_named_at_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |_, files| {
        file(files, "b2.csv").push_str("2000,200.0,0.0,-200.0,0.0,90.0,0.1,0.2,0.3\n");
    });
    let e = refused(tmp.path());
    assert!(e.contains("b2.csv:6"), "{e}");
    assert!(e.contains("point `b2@C90` is visited once"), "{e}");
}

#[test]
fn times_that_go_back_in_a_run_are_refused_at_their_line() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |_, files| {
        let text = file(files, "b3.csv");
        *text = text.replacen("1230,", "500,", 1);
    });
    let e = refused(tmp.path());
    assert!(e.contains("b3.csv:4:"), "{e}");
}

#[test]
fn two_visits_of_a_point_at_one_time_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |manifest, files| {
        manifest.push_str(
            "\n[[run]]\nname = \"b1-again\"\ninstrument = \"rtest\"\nfile = \"b1-again.csv\"\n\
             setup = \"b1\"\n",
        );
        files.push((
            "b1-again.csv".into(),
            "t,X,Y,Z,A,C,dx,dy,dz\n600,100.0,0.0,-200.0,0.0,0.0,0,0,0\n".into(),
        ));
    });
    let e = refused(tmp.path());
    assert!(e.contains("point `b1`"), "{e}");
    assert!(
        e.contains("visited at t = 600 s after a visit at t = 600 s"),
        "{e}"
    );
}

#[test]
fn a_run_without_readings_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |manifest, files| {
        manifest.push_str(
            "\n[[run]]\nname = \"b1-c5\"\ninstrument = \"rtest\"\nfile = \"b1-c5.csv\"\n\
             setup = \"b1\"\nuse = \"validate\"\n",
        );
        files.push((
            "b1-c5.csv".into(),
            "t,X,Y,Z,A,C\n2400,100.0,0.0,-200.0,0.0,0.0\n".into(),
        ));
    });
    let e = refused(tmp.path());
    assert!(e.contains("b1-c5.csv: run `b1-c5` has no readings"), "{e}");
}

#[test]
fn a_missing_reading_or_a_nan_is_refused_at_its_line() {
    let cases = [
        ("b1.csv", ",0.2,", ",,", "b1.csv:4:7: column \"dx\""),
        ("b2.csv", ",0.1,", ",NaN,", "b2.csv:3:7: column \"dx\""),
    ];
    for (name, from, to, want) in cases {
        let tmp = tempfile::tempdir().unwrap();
        session(tmp.path(), 4, |_, files| {
            let text = file(files, name);
            *text = text.replacen(from, to, 1);
        });
        let e = refused(tmp.path());
        assert!(e.contains(want), "{e}");
    }
}

#[test]
fn too_few_cycles_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 2, |_, _| {});
    let e = refused(tmp.path());
    assert!(e.contains("2 complete cycles"), "{e}");
    assert!(e.contains("at least 3"), "{e}");
}

#[test]
fn a_nest_on_the_table_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |manifest, _| {
        *manifest = manifest.replacen(
            "[setup.b2]\n",
            "[setup.b2]\nmount = \"ball-in-spindle\"\n",
            1,
        );
    });
    let e = refused(tmp.path());
    assert!(e.contains("session.toml:"), "{e}");
    assert!(e.contains("run `b2`: mount = \"ball-in-spindle\""), "{e}");
}

#[test]
fn an_unknown_machine_is_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    session(tmp.path(), 4, |manifest, _| {
        *manifest = manifest.replacen("\"CAFYXZ\"", "\"no-such-machine.urdf\"", 1);
    });
    let e = refused(tmp.path());
    assert!(
        e.contains("session.toml: cannot load the machine `no-such-machine.urdf`"),
        "{e}"
    );
}
