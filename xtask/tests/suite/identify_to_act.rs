//! From the identification to what acts on it in one flow (issue 37): every command that takes
//! `--params` takes the JSON of `identify --json` too, and gives the same files as with the
//! parameter file `identify --params-out` writes of the same identification; what went in and
//! what was left out (parameters the session could not determine, combinations, discoveries)
//! is said on the screen, and nothing the identification gave no number gets one.

use mtcal_testkit::repo;
use std::path::Path;
use std::process::{Command, Output};

fn mtcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .current_dir(repo())
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `identify SESSION --json D/id.json --params-out D/id.toml`.
fn identify(session: &str, dir: &Path) {
    let (json, toml) = (dir.join("id.json"), dir.join("id.toml"));
    ok(&mtcal(&[
        "identify",
        session,
        "--quiet",
        "--json",
        json.to_str().unwrap(),
        "--params-out",
        toml.to_str().unwrap(),
    ]));
}

/// The command `args` (with `{params}` and `{out}` in it) run with the JSON and with the TOML:
/// the same files and the same screen after the JSON's account of what went in.
fn same_either_way(dir: &Path, args: &[&str], outputs: &[&str]) -> String {
    let mut screens = Vec::new();
    for (params, tag) in [("id.json", "json"), ("id.toml", "toml")] {
        let out_dir = dir.join(tag);
        std::fs::create_dir_all(&out_dir).unwrap();
        let params = dir.join(params);
        let args: Vec<String> = args
            .iter()
            .map(|a| {
                a.replace("{params}", params.to_str().unwrap())
                    .replace("{out}", out_dir.to_str().unwrap())
            })
            .collect();
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        // The files' own names aside (`map` prints the parameter file's).
        let screen = ok(&mtcal(&refs))
            .replace(out_dir.to_str().unwrap(), "OUT")
            .replace(params.to_str().unwrap(), "PARAMS");
        screens.push(screen);
    }
    for f in outputs {
        let a = std::fs::read(dir.join("json").join(f)).unwrap();
        let b = std::fs::read(dir.join("toml").join(f)).unwrap();
        assert!(a == b, "{f} differs with the JSON and with the TOML");
    }
    let (json, toml) = (&screens[0], &screens[1]);
    assert!(
        json.starts_with("parameters from the identification ") && json.ends_with(toml.as_str()),
        "{json}\n---\n{toml}"
    );
    json[..json.len() - toml.len()].to_string()
}

#[test]
fn every_command_reads_the_identify_json_as_the_parameter_file_it_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    identify("examples/three-axis/session", d);
    let m = "examples/three-axis/session/machine.urdf";
    std::fs::write(
        d.join("p.nc"),
        "G21 G90\nN10 G0 X-100 Y-50 Z-100\nN20 G1 X100 F500\nY50\nM30\n",
    )
    .unwrap();
    std::fs::write(d.join("cl.csv"), "x,y,z\n0,0,300\n100,50,280\n").unwrap();
    let nc = d.join("p.nc");
    let cl = d.join("cl.csv");
    let account = same_either_way(
        d,
        &[
            "compensate",
            m,
            "--params",
            "{params}",
            "--out",
            "{out}/x.csv",
            "--axis",
            "X",
        ],
        &["x.csv"],
    );
    // The three-axis session determines its whole model: all of it went in, nothing left out.
    assert!(account.contains(": 33 identified"), "{account}");
    assert!(!account.contains("left at zero"), "{account}");
    same_either_way(
        d,
        &[
            "compensate",
            m,
            "--params",
            "{params}",
            "--out",
            "{out}/grid.csv",
        ],
        &["grid.csv"],
    );
    same_either_way(
        d,
        &[
            "correct",
            m,
            "--params",
            "{params}",
            "--program",
            nc.to_str().unwrap(),
            "--out",
            "{out}/c.nc",
        ],
        &["c.nc"],
    );
    same_either_way(d, &["zero-point", m, "--params", "{params}"], &[]);
    same_either_way(
        d,
        &[
            "cl-error",
            m,
            "--params",
            "{params}",
            "--cl",
            cl.to_str().unwrap(),
            "--out",
            "{out}/e.csv",
        ],
        &["e.csv"],
    );
    same_either_way(
        d,
        &["map", m, "--params", "{params}", "--grid", "3x3x3"],
        &[],
    );
}

/// The five-axis example cannot separate the A axis' EZ0A from the balls' heights: the JSON
/// gives it no number, the compensation leaves it at zero and says so, and so does the
/// parameter file's header.
#[test]
fn what_the_session_could_not_determine_is_left_out_and_said() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    identify("examples/five-axis/session", d);
    let m = "examples/five-axis/session/machine.urdf";
    let account = same_either_way(
        d,
        &[
            "compensate",
            m,
            "--params",
            "{params}",
            "--out",
            "{out}/grid.csv",
        ],
        &["grid.csv"],
    );
    assert!(account.contains("left at zero"), "{account}");
    assert!(account.contains("EZ0A"), "{account}");
    assert!(
        account.contains("not separated, left out: moving EZ0A"),
        "{account}"
    );
    let toml = std::fs::read_to_string(d.join("id.toml")).unwrap();
    assert!(
        toml.starts_with("# parameters from the identification"),
        "{toml}"
    );
    assert!(toml.contains("EZ0A = 0"), "{toml}");
    // The card in the file says it too (the same from the JSON and from the parameter file
    // its header came with: the files are byte-identical above).
    let grid = std::fs::read_to_string(d.join("json").join("grid.csv")).unwrap();
    let made_from: Vec<&str> = grid
        .lines()
        .skip_while(|l| !l.contains("made from"))
        .take_while(|l| l.starts_with('#'))
        .collect();
    assert!(
        made_from.first().is_some_and(|l| l
            .contains("made from               parameters from the identification: 10 identified")),
        "{grid}"
    );
    assert!(
        made_from
            .iter()
            .any(|l| l.contains("not separated, left out: moving EZ0A")),
        "{made_from:?}"
    );
    // EZ0A among the parameters left at zero (a list folded over several lines).
    let block = made_from.join("\n");
    let (zero, separated) = (
        block.find("left at zero").unwrap(),
        block.find("not separated").unwrap(),
    );
    assert!(block[zero..separated].contains("EZ0A"), "{block}");
}

/// A fit stopped before it converged gives no parameters to act on.
#[test]
fn an_unconverged_identification_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("id.json");
    let out = mtcal(&[
        "identify",
        "examples/five-axis/session",
        "--quiet",
        "--max-iterations",
        "1",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let grid = tmp.path().join("grid.csv");
    let out = mtcal(&[
        "compensate",
        "examples/five-axis/session/machine.urdf",
        "--params",
        json.to_str().unwrap(),
        "--out",
        grid.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("did not converge"), "{err}");
    assert!(!grid.exists());
}

/// The reversal of a pitch table file read back: `(position_mm, reverse − forward µm)` per
/// node of a LinuxCNC table (`nominal forward reverse`, mm).
fn reversal_columns(path: &Path) -> Vec<(f64, f64)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            (v[0], (v[2] - v[1]) * 1e3)
        })
        .collect()
}

/// A backlash the search found (the warm five-axis example: 3 µm of lost motion in X) goes
/// into the bidirectional table of its axis with ISO 230-2's sign — the axis lags behind the
/// command, so `B = x̄↑ − x̄↓` is minus the backlash: reverse = forward − backlash at every node
/// — and the card says where it came from; a file that has no table of that axis (SINUMERIK
/// EEC) says it does not hold it; a reversal whose interval reaches zero is left out, and so
/// is one the user's `--reversal-um` replaces.
#[test]
fn a_found_reversal_goes_into_the_bidirectional_table_of_its_axis() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let json = d.join("id.json");
    ok(&mtcal(&[
        "identify",
        "examples/five-axis-warm/session",
        "--search",
        "--quiet",
        "--json",
        json.to_str().unwrap(),
    ]));
    let text = std::fs::read_to_string(&json).unwrap();
    let id: serde_json::Value = serde_json::from_str(&text).unwrap();
    let found = id["discoveries"]
        .as_array()
        .unwrap()
        .iter()
        .find(|x| x["effect"] == "reversal" && x["axis"] == "X")
        .expect("the search finds X's lost motion");
    let param = |name: &str| {
        found["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .map(|p| p["value"].as_f64().unwrap())
    };
    let backlash_um = param("backlash_um").unwrap();
    assert!((backlash_um - 3.0).abs() < 1.0, "{backlash_um}");
    let change_um = param("backlash_change_um").unwrap_or(0.0);
    let m = "examples/five-axis-warm/session/machine.urdf";
    let comp = |params: &Path, extra: &[&str], out: &Path| {
        let mut args = vec![
            "compensate",
            m,
            "--params",
            params.to_str().unwrap(),
            "--format",
            "linuxcnc",
            "--axis",
            "X",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        ok(&mtcal(&args))
    };
    let table = d.join("x.comp");
    let screen = comp(&json, &[], &table);
    assert!(
        screen.contains("in the reverse table of axis X"),
        "{screen}"
    );
    // Over the span the discovery gives it over (the stroke without one), its ends' values
    // beyond.
    let (lo, hi) = found["spans"]
        .as_array()
        .and_then(|spans| spans.iter().find(|s| s["axis"] == "X"))
        .map_or((-350.0, 350.0), |s| {
            (s["from"].as_f64().unwrap(), s["to"].as_f64().unwrap())
        });
    let rows = reversal_columns(&table);
    assert!(rows.len() > 2);
    for (x, b_um) in &rows {
        let u = ((2.0 * x - lo - hi) / (hi - lo)).clamp(-1.0, 1.0);
        let want = -(backlash_um + change_um * u);
        assert!(
            (b_um - want).abs() < 2e-3,
            "at {x} mm: reverse − forward {b_um} µm, the found reversal {want} µm"
        );
    }
    let card = std::fs::read_to_string(d.join("x.comp.card.txt")).unwrap();
    assert!(card.contains("reversal X"), "{card}");
    // The SINUMERIK EEC tables have no direction: named, not held.
    let eec = d.join("eec.ini");
    let screen = ok(&mtcal(&[
        "compensate",
        m,
        "--params",
        json.to_str().unwrap(),
        "--format",
        "siemens-eec",
        "--out",
        eec.to_str().unwrap(),
    ]));
    assert!(
        screen.contains("not in this file (no bidirectional table of axis X"),
        "{screen}"
    );
    // The user's value replaces it.
    let given = d.join("given.comp");
    let screen = comp(&json, &["--reversal-um", "-1.5"], &given);
    assert!(screen.contains("not used, --reversal-um given"), "{screen}");
    assert!(
        reversal_columns(&given)
            .iter()
            .all(|(_, b)| (b + 1.5).abs() < 2e-3)
    );
    // Its interval widened to reach zero: left out, the table one-way.
    let mut wide = id.clone();
    for x in wide["discoveries"].as_array_mut().unwrap() {
        if x["effect"] == "reversal" {
            for p in x["parameters"].as_array_mut().unwrap() {
                p["u95"] = serde_json::json!(10.0);
            }
        }
    }
    let wide_json = d.join("wide.json");
    std::fs::write(&wide_json, serde_json::to_string(&wide).unwrap()).unwrap();
    let one_way = d.join("one-way.comp");
    let screen = comp(&wide_json, &[], &one_way);
    assert!(
        screen.contains("left out, the identification did not determine it"),
        "{screen}"
    );
    assert!(reversal_columns(&one_way).iter().all(|(_, b)| *b == 0.0));
}

/// `--split-combinations`: a combination of machine parameters the identification could not
/// separate (here one put into the five-axis example's JSON: ECX.P0 − EBY.P0 = 2 µrad, neither
/// identified) gets its minimum-norm split, +1 and −1 µrad, in the file and said as a choice
/// on the screen and the card; without the flag both stay zero; a parameter file refuses it.
#[test]
fn a_combination_is_split_by_minimum_norm_only_on_request() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    identify("examples/five-axis/session", d);
    let path = d.join("id.json");
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let given: Vec<&str> = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(!given.contains(&"ECX.P0") && !given.contains(&"EBY.P0"));
    // The example's JSON has no combinations of its own (the key is then left out).
    let combinations = json
        .as_object_mut()
        .unwrap()
        .entry("combinations")
        .or_insert_with(|| serde_json::json!([]));
    combinations
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({
            "expression": "ECX.P0 − EBY.P0", "name": "ECX.P0",
            "terms": [{"name": "EBY.P0", "coefficient": -1.0}],
            "value": 2.0, "unit": "urad", "u95": 0.3, "kind": "machine"
        }));
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    let m = "examples/five-axis/session/machine.urdf";
    let constant_urad = |file: &Path, name: &str| {
        let params = mtcal_compensate::read_error_parameters(
            file,
            mtcal_compensate::ParameterFormat::IsgCsv,
        )
        .unwrap();
        let p = params
            .params
            .iter()
            .find(|p| p.name.to_string() == name)
            .unwrap();
        let mtcal_compensate::ParameterValue::Table { values, .. } = &p.value else {
            panic!("{name} is a table")
        };
        values.iter().sum::<f64>() / values.len() as f64 * 1e6
    };
    let mut screens = Vec::new();
    for split in [false, true] {
        let out = d.join(format!("isg-{split}.csv"));
        let mut args = vec![
            "compensate",
            m,
            "--params",
            path.to_str().unwrap(),
            "--format",
            "isg",
            "--out",
            out.to_str().unwrap(),
        ];
        if split {
            args.push("--split-combinations");
        }
        screens.push(ok(&mtcal(&args)));
        let (ecx, eby) = (constant_urad(&out, "ECX"), constant_urad(&out, "EBY"));
        let want = if split { (1.0, -1.0) } else { (0.0, 0.0) };
        assert!(
            (ecx - want.0).abs() < 1e-6 && (eby - want.1).abs() < 1e-6,
            "split {split}: ECX {ecx}, EBY {eby}"
        );
        let card = std::fs::read_to_string(&out).unwrap();
        assert_eq!(card.contains("split by minimum norm on request"), split);
    }
    assert!(
        screens[1].contains(
            "split by minimum norm on request (a choice, not an identification): ECX.P0 = 1.000, \
             EBY.P0 = -1.000 (urad) of ECX.P0 − EBY.P0 = 2.000 ± 0.300 urad"
        ),
        "{}",
        screens[1]
    );
    assert!(!screens[0].contains("split by minimum norm"));
    // A parameter file holds numbers only: nothing to split.
    let refused = mtcal(&[
        "compensate",
        m,
        "--params",
        d.join("id.toml").to_str().unwrap(),
        "--format",
        "isg",
        "--out",
        d.join("x.csv").to_str().unwrap(),
        "--split-combinations",
    ]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("needs the identify JSON"));
}
