//! Numerical edge cases (issue 7) through the command line: a session of one sample, readings
//! that are all exactly zero, an exactly and a nearly rank-deficient parameter set, a prior of
//! 10⁶ µm, and a five-axis machine at its singular pose (A = 0, where C turns about the tool
//! axis) for `correct` and `cl-error`. Each command either succeeds with no NaN or infinity in
//! anything it writes or prints — unidentifiable parameters named, never given a number — or
//! fails with exit code 2 and a message that says why.

use mtcal_testkit::cli::run_in_repo;
use mtcal_testkit::repo;
use std::path::{Path, PathBuf};
use std::process::Output;

fn mtcal(args: &[&str]) -> Output {
    run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// No NaN or infinity in `text` (as Rust, serde_json or a person would write them).
fn assert_finite_text(what: &str, text: &str) {
    for word in text.split(|c: char| !(c.is_alphanumeric() || c == '_')) {
        let w = word.to_ascii_lowercase();
        assert!(
            w != "nan" && w != "inf" && w != "infinity",
            "{what} contains `{word}`:\n{text}"
        );
    }
}

/// No `null` in the identify JSON (serde_json writes NaN and ±∞ as `null`; without `--search`
/// the JSON has no other nulls), and no NaN or infinity as text.
fn assert_finite_json(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    fn walk(v: &serde_json::Value, at: &str) {
        match v {
            serde_json::Value::Null => panic!("null (a NaN or an infinity) at {at}"),
            serde_json::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, &format!("{at}[{i}]"));
                }
            }
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    walk(x, &format!("{at}.{k}"));
                }
            }
            _ => {}
        }
    }
    walk(&v, "");
    assert_finite_text(&path.display().to_string(), &text);
}

/// Names of the identified parameters and of every parameter in an unidentifiable combination.
fn identified_and_not(json: &Path) -> (Vec<String>, Vec<String>) {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let names = |key: &str, field: &str| -> Vec<String> {
        v[key]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| match &p[field] {
                serde_json::Value::String(s) => vec![s.clone()],
                serde_json::Value::Array(a) => {
                    a.iter().map(|s| s.as_str().unwrap().to_string()).collect()
                }
                _ => vec![],
            })
            .collect()
    };
    (
        names("parameters", "name"),
        names("unidentifiable", "parameters"),
    )
}

/// Runs `identify` on `session` with every output; asserts success and finite outputs; returns
/// standard output and the JSON's path.
fn identify_ok(session: &Path, dir: &Path) -> (String, PathBuf) {
    let json = dir.join("id.json");
    let predict = dir.join("predict");
    let report = dir.join("report");
    let out = mtcal(&[
        "identify",
        session.to_str().unwrap(),
        "--quiet",
        "--json",
        json.to_str().unwrap(),
        "--predict",
        predict.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_finite_text("standard output", &stdout);
    assert_finite_json(&json);
    assert_finite_text(
        "the report",
        &std::fs::read_to_string(report.join("index.html")).unwrap(),
    );
    for f in std::fs::read_dir(&predict).into_iter().flatten() {
        let p = f.unwrap().path();
        assert_finite_text(
            &p.display().to_string(),
            &std::fs::read_to_string(&p).unwrap(),
        );
    }
    let (ids, unid) = identified_and_not(&json);
    for name in &unid {
        assert!(
            !ids.contains(name),
            "{name} is unidentifiable but has a value"
        );
    }
    (stdout, json)
}

const SESSION: &str = "examples/five-axis/session";

/// A copy of the five-axis example session in `dir`, `edit` applied to every run CSV's rows.
fn copy_session(dir: &Path, edit: impl Fn(&str, &[&str]) -> Option<String>) -> PathBuf {
    let to = dir.join("session");
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(repo().join(SESSION)).unwrap() {
        let p = e.unwrap().path();
        if !p.is_file() {
            continue;
        }
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        let text = std::fs::read_to_string(&p).unwrap();
        let text = if name.ends_with(".csv") {
            let mut lines = text.lines();
            let header = lines.next().unwrap();
            let cols: Vec<&str> = header.split(',').collect();
            let mut out = format!("{header}\n");
            for line in lines {
                if let Some(l) = edit(line, &cols) {
                    out.push_str(&l);
                    out.push('\n');
                }
            }
            out
        } else {
            text
        };
        std::fs::write(to.join(&name), text).unwrap();
    }
    to
}

#[test]
fn a_session_of_one_sample_names_everything_it_cannot_identify() {
    let dir = tempfile::tempdir().unwrap();
    let src = repo().join(SESSION);
    let s = dir.path().join("one");
    std::fs::create_dir(&s).unwrap();
    for f in ["machine.urdf", "machine.errors.toml"] {
        std::fs::copy(src.join(f), s.join(f)).unwrap();
    }
    let csv = std::fs::read_to_string(src.join("rtest-xyc-a0.csv")).unwrap();
    let two: Vec<&str> = csv.lines().take(2).collect();
    std::fs::write(s.join("r.csv"), two.join("\n") + "\n").unwrap();
    std::fs::write(
        s.join("session.toml"),
        "machine = \"machine.urdf\"\n[setup.ball]\nball = [100.0, 0.0, 200.0]\n\
         mount = \"ball-in-spindle\"\n\
         [[run]]\nname = \"r\"\ninstrument = \"rtest\"\nfile = \"r.csv\"\nsetup = \"ball\"\n\
         [identify]\nparameters = [\"EC0Y\", \"EY0A\", \"EX0C\", \"EY0C\", \"EA0C\"]\n",
    )
    .unwrap();
    let (stdout, json) = identify_ok(&s, dir.path());
    let (ids, unid) = identified_and_not(&json);
    // Three readings cannot fix five machine parameters and a ball position.
    for p in ["EC0Y", "EY0A", "EX0C", "EY0C", "EA0C"] {
        assert!(unid.iter().any(|u| u == p), "{p}: {stdout}");
        assert!(!ids.iter().any(|u| u == p), "{p}: {stdout}");
    }
    assert!(stdout.contains("not identifiable"), "{stdout}");
}

#[test]
fn readings_that_are_all_zero_identify_a_perfect_machine() {
    let dir = tempfile::tempdir().unwrap();
    let s = copy_session(dir.path(), |line, cols| {
        let cells: Vec<String> = line
            .split(',')
            .zip(cols)
            .map(|(v, c)| {
                if ["dx", "dy", "dz", "dr"].contains(c) {
                    "0".to_string()
                } else {
                    v.to_string()
                }
            })
            .collect();
        Some(cells.join(","))
    });
    let (stdout, json) = identify_ok(&s, dir.path());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    for p in v["parameters"].as_array().unwrap() {
        let (value, u95) = (p["value"].as_f64().unwrap(), p["u95"].as_f64().unwrap());
        assert!(value.abs() < 1e-6, "{p}");
        assert!(u95 > 0.0 && u95 < 10.0, "{p}");
    }
    assert!(v["fit"]["rms_um"].as_f64().unwrap() < 1e-6, "{stdout}");
    assert_eq!(v["solver"]["converged"], true, "{stdout}");
}

#[test]
fn an_exactly_rank_deficient_set_gives_combinations_never_numbers() {
    // The example's R-test runs see the ball height and the tool length only as a sum, and
    // EZ0A with them.
    let dir = tempfile::tempdir().unwrap();
    let (stdout, json) = identify_ok(&repo().join(SESSION), dir.path());
    let (ids, unid) = identified_and_not(&json);
    for p in ["EZ0A", "ball-low.ball_z", "ball-low.tool_length"] {
        assert!(unid.iter().any(|u| u == p), "{p}: {stdout}");
        assert!(!ids.iter().any(|u| u == p), "{p}: {stdout}");
    }
}

/// Two R-test runs at A = 0 and A = 0.01°: EY0A, EB0A and EC0A act only through the A motion,
/// which the runs barely have. The solver's rank rule is relative, so they come out as numbers
/// with intervals near a millimetre; the numbers stay finite and the report says they are
/// weakly determined (JSON `weakly_determined`).
#[test]
fn a_nearly_rank_deficient_set_is_reported_as_weakly_determined() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.toml");
    let repo = repo();
    std::fs::write(
        &plan,
        format!(
            "machine = \"{m}\"\ntruth = \"{t}\"\nseed = 7\ninterval_s = 0.25\n\
             [identify]\nparameters = [\"EY0A\", \"EZ0A\", \"EB0A\", \"EC0A\", \"EX0C\", \"EY0C\", \"EA0C\", \"EB0C\"]\n\
             [setup.ball]\nball = [100.0, 0.0, 200.0]\n\
             [[run]]\nname = \"a0\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
             path = {{ kind = \"xyc\", samples = 73 }}\n\
             [[run]]\nname = \"a-small\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
             path = {{ kind = \"xyc\", samples = 73, hold = {{ A = 0.01 }} }}\n",
            m = repo.join("machines/mcu630-cafyxz.urdf").display(),
            t = repo.join("examples/five-axis/truth.params.toml").display(),
        ),
    )
    .unwrap();
    let session = dir.path().join("session");
    let out = mtcal(&[
        "simulate",
        plan.to_str().unwrap(),
        "--out",
        session.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let (stdout, json) = identify_ok(&session, dir.path());
    assert!(stdout.contains("weakly determined"), "{stdout}");
    let page = std::fs::read_to_string(dir.path().join("report/index.html")).unwrap();
    assert!(page.contains("Parameters these data barely determine"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let weak = v["weakly_determined"]
        .as_array()
        .expect("weakly_determined");
    let names: Vec<&str> = weak
        .iter()
        .flat_map(|w| w["parameters"].as_array().unwrap())
        .map(|n| n.as_str().unwrap())
        .collect();
    for p in ["EY0A", "EB0A", "EC0A"] {
        assert!(names.contains(&p), "{p}: {stdout}");
    }
    // The well-determined ones are not flagged.
    for p in ["EA0C", "ball.ball_x"] {
        assert!(!names.contains(&p), "{p}: {stdout}");
    }
}

#[test]
fn a_prior_of_a_million_micrometres_changes_nothing_the_data_determine() {
    let dir = tempfile::tempdir().unwrap();
    let s = copy_session(dir.path(), |line, _| Some(line.to_string()));
    let manifest = s.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let edited = text.replace(
        "pivot = [0.0, 0.0, 250.0]",
        "pivot = [0.0, 0.0, 250.0]\nlength_free = true\nlength_u_um = 1e6",
    );
    assert_ne!(text, edited);
    std::fs::write(&manifest, edited).unwrap();
    let (stdout, json) = identify_ok(&s, dir.path());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let length = v["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "bar.length")
        .unwrap_or_else(|| panic!("{stdout}"));
    // The circles fix the bar length far inside its prior.
    assert!(length["u95"].as_f64().unwrap() < 1.0, "{stdout}");
}

/// A five-axis program and CL data through A = 0 on the trunnion, where C turns about the tool
/// axis: `correct` refuses the singular poses by line (exit 2, nothing written) or, matching the
/// tool point only, corrects them; `cl-error` holds C and says how many points were singular.
#[test]
fn a_singular_pose_is_refused_or_handled_never_nan() {
    let dir = tempfile::tempdir().unwrap();
    let p = |x: &Path| x.to_str().unwrap().to_string();
    let program = dir.path().join("p.nc");
    std::fs::write(
        &program,
        "G21 G90\nG0 X0 Y0 Z-300 A0 C0\nG1 X50 Y20 A10 C30 F800\nA0 C90\nM30\n",
    )
    .unwrap();
    let machine = "machines/mcu630-cafyxz.urdf";
    let params = "examples/mcu630-cafyxz.params.toml";
    let corrected = dir.path().join("c.nc");
    let out = mtcal(&[
        "correct",
        machine,
        "--params",
        params,
        "--program",
        &p(&program),
        "--out",
        &p(&corrected),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let msg = String::from_utf8_lossy(&out.stderr);
    assert!(
        msg.contains("line 2: singular") && msg.contains("nothing written"),
        "{msg}"
    );
    assert!(!corrected.exists());
    let out = mtcal(&[
        "correct",
        machine,
        "--params",
        params,
        "--program",
        &p(&program),
        "--out",
        &p(&corrected),
        "--position-only",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert_finite_text("corrected", &std::fs::read_to_string(&corrected).unwrap());

    let cl = dir.path().join("cl.csv");
    std::fs::write(
        &cl,
        "x,y,z,i,j,k\n0,0,150,0,0,1\n20,10,150,0,0,1\n40,0,150,0,0.1,1\n",
    )
    .unwrap();
    let (csv, svg) = (dir.path().join("e.csv"), dir.path().join("e.svg"));
    let out = mtcal(&[
        "cl-error",
        machine,
        "--params",
        params,
        "--cl",
        &p(&cl),
        "--out",
        &p(&csv),
        "--plot",
        &p(&svg),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("singular"), "{stdout}");
    assert_finite_text("cl-error output", &stdout);
    assert_finite_text("cl-error CSV", &std::fs::read_to_string(&csv).unwrap());
    assert_finite_text("cl-error plot", &std::fs::read_to_string(&svg).unwrap());
}

/// CL data of one point: the summary is given, but a plot needs a path; with `--plot` the
/// command fails with exit code 2 before writing either file.
#[test]
fn one_cl_point_cannot_be_plotted_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let cl = dir.path().join("cl.csv");
    std::fs::write(&cl, "x,y,z,i,j,k\n0,0,150,0,0,1\n").unwrap();
    let (csv, svg) = (dir.path().join("e.csv"), dir.path().join("e.svg"));
    let machine = "machines/mcu630-cafyxz.urdf";
    let params = "examples/mcu630-cafyxz.params.toml";
    let cl = cl.to_str().unwrap();
    let out = mtcal(&["cl-error", machine, "--params", params, "--cl", cl]);
    assert!(out.status.success(), "{}", text(&out));
    assert_finite_text("cl-error output", &String::from_utf8_lossy(&out.stdout));
    let out = mtcal(&[
        "cl-error",
        machine,
        "--params",
        params,
        "--cl",
        cl,
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("needs two finite points"),
        "{}",
        text(&out)
    );
    assert!(!csv.exists() && !svg.exists());
}
