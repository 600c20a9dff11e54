//! `mtcal identify --acceptance FILE` on the bundled examples, checked against values this test
//! computes itself from the run files: the ISO 230-2 values of the three-axis example's laser
//! runs and the ISO 230-4 G of the five-axis example's XY circles, each with the expanded
//! uncertainty of docs/ACCEPTANCE.md, and the verdicts of the ISO 14253-1 rule on tolerances
//! placed at known distances from them (inside by more than U, within U, beyond by more than
//! U). Also: parameters the data cannot separate cannot be decided, the screen block and the
//! report's table say what the JSON says, and without `--acceptance` the JSON and the screen are
//! byte for byte what they were.

use mtcal_testkit::repo;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// The laser set-ups' reading noise: they declare none, so the plugin's default `sigma_um`.
const LASER_SIGMA_UM: f64 = 0.5;
/// The ball-bar set-up's: its default `sigma_um`.
const BALLBAR_SIGMA_UM: f64 = 1.0;

/// Runs `mtcal identify SESSION --quiet --json J [--acceptance A] [--report R]` in the
/// repository; its standard output and JSON text.
fn identify(
    session: &str,
    acceptance: Option<&Path>,
    report: Option<&Path>,
    json: &Path,
) -> (String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_mtcal"));
    cmd.args(["identify", session, "--quiet", "--json"])
        .arg(json);
    if let Some(a) = acceptance {
        cmd.arg("--acceptance").arg(a);
    }
    if let Some(r) = report {
        cmd.arg("--report").arg(r);
    }
    let out = cmd.current_dir(repo()).output().expect("mtcal runs");
    let json_text = std::fs::read_to_string(json).expect("the JSON is written");
    // Exit 0 when every tolerance passes (and the fit holds), 1 when one fails or cannot be
    // decided (tests/exit_codes.rs): the outputs are written either way.
    let verdict = serde_json::from_str::<Value>(&json_text).unwrap()["acceptance"]["verdict"]
        .as_str()
        .map(str::to_string);
    let expected = match verdict.as_deref() {
        None | Some("pass") => 0,
        _ => 1,
    };
    assert_eq!(
        out.status.code(),
        Some(expected),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (String::from_utf8(out.stdout).expect("UTF-8"), json_text)
}

/// A run file's columns by name.
fn columns(path: &Path) -> BTreeMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut out: BTreeMap<String, Vec<f64>> =
        header.iter().map(|h| (h.clone(), Vec::new())).collect();
    for line in lines.filter(|l| !l.trim().is_empty()) {
        for (h, v) in header.iter().zip(line.split(',')) {
            out.get_mut(h).unwrap().push(v.trim().parse().unwrap());
        }
    }
    out
}

/// The ISO 14253-1 rule on `|value|` (two-sided) or `value` (upper): pass, fail, cannot decide.
fn rule(value: f64, u: f64, limit: f64) -> &'static str {
    if value <= limit - u {
        "pass"
    } else if value > limit + u {
        "fail"
    } else {
        "cannot decide"
    }
}

// ---------------------------------------------------------------------------------------------
// ISO 230-2 from a laser run file

/// The approaches of one target in one direction: mean, standard deviation (n − 1), count.
#[derive(Clone, Copy, Debug)]
struct Cell {
    mean: f64,
    s: f64,
    n: f64,
}

impl Cell {
    fn of(x: &[f64]) -> Cell {
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let s = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        Cell { mean, s, n }
    }
    /// The scatter the budget uses: the repeatability, never below the reading noise.
    fn sigma(&self) -> f64 {
        self.s.max(LASER_SIGMA_UM)
    }
    /// Variance of the mean.
    fn var_mean(&self) -> f64 {
        self.sigma().powi(2) / self.n
    }
    /// Variance of the standard deviation.
    fn var_s(&self) -> f64 {
        self.sigma().powi(2) / (2.0 * (self.n - 1.0))
    }
}

/// Values (µm) and their U (k = 2) of one laser run along `axis`, computed from its file: a
/// sample's direction is that of the move that brought the axis there; targets are the
/// positions approached at least twice from both sides (the overrun points are not).
fn iso230_2_from_file(file: &str, axis: &str) -> BTreeMap<&'static str, (f64, f64)> {
    let cols = columns(&repo().join(file));
    let (x, d) = (&cols[axis], &cols["d"]);
    let mut cells: BTreeMap<(i64, bool), Vec<f64>> = BTreeMap::new();
    for k in 1..x.len() {
        if x[k] == x[k - 1] {
            continue;
        }
        let key = ((x[k] * 1e4).round() as i64, x[k] > x[k - 1]);
        cells.entry(key).or_default().push(d[k]);
    }
    let mut targets: Vec<(Cell, Cell)> = Vec::new();
    let mut positions: Vec<i64> = cells.keys().map(|k| k.0).collect();
    positions.dedup();
    for p in positions {
        if let (Some(up), Some(down)) = (cells.get(&(p, true)), cells.get(&(p, false)))
            && up.len() >= 2
            && down.len() >= 2
        {
            targets.push((Cell::of(up), Cell::of(down)));
        }
    }
    assert!(targets.len() >= 5, "{file}: {} targets", targets.len());
    let all: Vec<Cell> = targets.iter().flat_map(|(u, d)| [*u, *d]).collect();
    let arg = |cells: &[Cell], f: &dyn Fn(&Cell) -> f64, largest: bool| {
        let mut best = 0;
        for (i, c) in cells.iter().enumerate() {
            let better = if largest {
                f(c) > f(&cells[best])
            } else {
                f(c) < f(&cells[best])
            };
            if better {
                best = i;
            }
        }
        best
    };
    let mut out = BTreeMap::new();
    // E over both directions, and E↑, E↓: the range of the means.
    let range = |cells: &[Cell]| {
        let (hi, lo) = (
            arg(cells, &|c| c.mean, true),
            arg(cells, &|c| c.mean, false),
        );
        let value = cells[hi].mean - cells[lo].mean;
        (
            value,
            2.0 * (cells[hi].var_mean() + cells[lo].var_mean()).sqrt(),
        )
    };
    out.insert("E", range(&all));
    let ups: Vec<Cell> = targets.iter().map(|t| t.0).collect();
    let downs: Vec<Cell> = targets.iter().map(|t| t.1).collect();
    out.insert("E↑", range(&ups));
    out.insert("E↓", range(&downs));
    // M: the range of the bidirectional means (x̄↑ + x̄↓)/2.
    let mid: Vec<f64> = targets
        .iter()
        .map(|(u, d)| 0.5 * (u.mean + d.mean))
        .collect();
    let var_mid = |i: usize| 0.25 * (targets[i].0.var_mean() + targets[i].1.var_mean());
    let (hi, lo) = (
        (0..mid.len())
            .max_by(|&a, &b| mid[a].total_cmp(&mid[b]))
            .unwrap(),
        (0..mid.len())
            .min_by(|&a, &b| mid[a].total_cmp(&mid[b]))
            .unwrap(),
    );
    out.insert(
        "M",
        (mid[hi] - mid[lo], 2.0 * (var_mid(hi) + var_mid(lo)).sqrt()),
    );
    // A: max(x̄ + 2s) − min(x̄ − 2s); each end moves with its mean and twice its s.
    let (top, bottom) = (
        arg(&all, &|c| c.mean + 2.0 * c.s, true),
        arg(&all, &|c| c.mean - 2.0 * c.s, false),
    );
    let a = all[top].mean + 2.0 * all[top].s - (all[bottom].mean - 2.0 * all[bottom].s);
    let end = |c: &Cell| c.var_mean() + 4.0 * c.var_s();
    let var_a = if top == bottom {
        16.0 * all[top].var_s()
    } else {
        end(&all[top]) + end(&all[bottom])
    };
    out.insert("A", (a, 2.0 * var_a.sqrt()));
    // R: the largest R_i = max(2s↑ + 2s↓ + |B_i|, 4s↑, 4s↓), by the branch that gave it.
    let r_of = |(u, d): &(Cell, Cell)| {
        let b = (u.mean - d.mean).abs();
        (2.0 * u.s + 2.0 * d.s + b).max(4.0 * u.s).max(4.0 * d.s)
    };
    let i = (0..targets.len())
        .max_by(|&a, &b| r_of(&targets[a]).total_cmp(&r_of(&targets[b])))
        .unwrap();
    let (u, d) = targets[i];
    let r = r_of(&targets[i]);
    let var_r = if r == 2.0 * u.s + 2.0 * d.s + (u.mean - d.mean).abs() {
        end(&u) + end(&d)
    } else if r == 4.0 * u.s {
        16.0 * u.var_s()
    } else {
        16.0 * d.var_s()
    };
    out.insert("R", (r, 2.0 * var_r.sqrt()));
    // B: the largest |x̄↑ − x̄↓|.
    let i = (0..targets.len())
        .max_by(|&a, &b| {
            let b_of = |k: usize| (targets[k].0.mean - targets[k].1.mean).abs();
            b_of(a).total_cmp(&b_of(b))
        })
        .unwrap();
    let (u, d) = targets[i];
    out.insert(
        "B",
        (
            (u.mean - d.mean).abs(),
            2.0 * (u.var_mean() + d.var_mean()).sqrt(),
        ),
    );
    out
}

/// The JSON's acceptance checks of `item`.
fn checks<'a>(json: &'a Value, item: &str) -> Vec<&'a Value> {
    json["acceptance"]["checks"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["item"] == item)
        .collect()
}

fn close(got: &Value, want: f64, what: &str) {
    let got = got.as_f64().unwrap_or_else(|| panic!("{what}: no number"));
    assert!(
        (got - want).abs() < 1e-9 * want.abs().max(1.0),
        "{what}: {got} vs {want}"
    );
}

#[test]
fn laser_runs_are_accepted_by_their_iso230_2_values_and_u_computed_from_the_files() {
    let x = iso230_2_from_file("examples/three-axis/session/laser-x.csv", "X");
    let z = iso230_2_from_file("examples/three-axis/session/laser-z.csv", "Z");
    // Tolerances at known places: E of X beyond its value by less than U, A inside by more
    // than U, M below it by more than U, R inside by less than U; Z's E inside by more than U,
    // its B within U, E↑ and E↓ at their mean.
    let tol = |v: &(f64, f64), f: f64| v.0 + f * v.1;
    let (eu, ed) = (z["E↑"], z["E↓"]);
    let e_uni = 0.5 * (eu.0 + ed.0);
    let file = format!(
        "schema = \"mtcal.acceptance/1\"\n\n[iso230_2.X]\nE_um = {}\nA_um = {}\nM_um = {}\n\
         R_um = {}\n\n[iso230_2.Z]\nE_um = {}\nB_um = {}\nE_uni_um = {e_uni}\n\n[parameters]\n\
         EC0Y = {{ max_abs_urad = 20 }}\nEB0Z = {{ max_abs_urad = 4 }}\nEA0Z = {{ max_abs_urad = 1 }}\n\
         EXX = {{ max_abs_um = 20 }}\nEZZ = {{ max_abs_um = 1 }}\n",
        tol(&x["E"], -0.5),
        tol(&x["A"], 1.5),
        tol(&x["M"], -1.5),
        tol(&x["R"], 0.5),
        tol(&z["E"], 1.5),
        tol(&z["B"], 0.1),
    );
    let dir = tempfile::tempdir().unwrap();
    let acc = dir.path().join("acc.toml");
    std::fs::write(&acc, &file).unwrap();
    let (screen, text) = identify(
        "examples/three-axis/session",
        Some(&acc),
        None,
        &dir.path().join("id.json"),
    );
    let json: Value = serde_json::from_str(&text).unwrap();
    let want = [
        (
            "E (ISO 230-2) X",
            x["E"],
            tol(&x["E"], -0.5),
            "cannot decide",
        ),
        ("A (ISO 230-2) X", x["A"], tol(&x["A"], 1.5), "pass"),
        ("M (ISO 230-2) X", x["M"], tol(&x["M"], -1.5), "fail"),
        (
            "R (ISO 230-2) X",
            x["R"],
            tol(&x["R"], 0.5),
            "cannot decide",
        ),
        ("E (ISO 230-2) Z", z["E"], tol(&z["E"], 1.5), "pass"),
        (
            "B (ISO 230-2) Z",
            z["B"],
            tol(&z["B"], 0.1),
            "cannot decide",
        ),
        ("E↑ (ISO 230-2) Z", eu, e_uni, rule(eu.0, eu.1, e_uni)),
        ("E↓ (ISO 230-2) Z", ed, e_uni, rule(ed.0, ed.1, e_uni)),
    ];
    for (item, (value, u), limit, verdict) in want {
        let found = checks(&json, item);
        assert_eq!(found.len(), 1, "{item}: {found:?}");
        let c = found[0];
        assert_eq!(
            c["run"],
            if item.ends_with('X') {
                "laser-x"
            } else {
                "laser-z"
            }
        );
        close(&c["value"], value, item);
        close(&c["uncertainty"], u, item);
        close(&c["tolerance"], limit, item);
        assert_eq!(c["zone"], "upper");
        assert_eq!(c["verdict"], rule(value, u, limit), "{item}");
        assert_eq!(c["verdict"], verdict, "{item}");
    }
    // Parameters against the identification's own values and 95 % intervals, two-sided.
    let parameter = |name: &str| {
        json["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} identified"))
    };
    for (name, limit, verdict) in [
        ("EC0Y", 20.0, "pass"),
        ("EB0Z", 4.0, "cannot decide"),
        ("EA0Z", 1.0, "fail"),
    ] {
        let p = parameter(name);
        let (v, u) = (p["value"].as_f64().unwrap(), p["u95"].as_f64().unwrap());
        let c = checks(&json, name)[0];
        close(&c["value"], v, name);
        close(&c["uncertainty"], u, name);
        assert_eq!(c["zone"], "two-sided");
        assert_eq!(c["verdict"], rule(v.abs(), u, limit), "{name}");
        assert_eq!(c["verdict"], verdict, "{name}");
    }
    // A component error at every point of its stroke: EXX stays far inside 20 µm at every one
    // of the JSON's samples; EZZ's largest |value| − U there is beyond 1 µm.
    let curve = |name: &str| -> Vec<[f64; 3]> {
        let c = json["component_errors"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["name"] == name)
            .unwrap();
        serde_json::from_value(c["samples"].clone()).unwrap()
    };
    assert!(curve("EXX").iter().all(|s| s[1].abs() + s[2] < 19.0));
    assert_eq!(checks(&json, "EXX over the stroke")[0]["verdict"], "pass");
    assert!(curve("EZZ").iter().any(|s| s[1].abs() - s[2] > 1.0));
    let ezz = checks(&json, "EZZ over the stroke")[0];
    assert_eq!(ezz["verdict"], "fail");
    assert!(
        ezz["note"]
            .as_str()
            .unwrap()
            .contains("101 points over the stroke"),
        "{ezz}"
    );
    assert_eq!(json["acceptance"]["verdict"], "fail");
    assert_eq!(json["acceptance"]["decision_rule"], "iso14253-1");
    // The screen: one line per check between the heading and the overall verdict.
    let n = json["acceptance"]["checks"].as_array().unwrap().len();
    assert_eq!(n, 13);
    let block: Vec<&str> = screen
        .lines()
        .skip_while(|l| !l.starts_with("acceptance against"))
        .take(n + 2)
        .collect();
    assert!(block[0].contains("acc.toml (ISO 14253-1"), "{screen}");
    // In the order of the file's keys per axis (A, E, R, M, …), then the parameters by name.
    let line = |k: usize, start: &str, end: &str| {
        assert!(
            block[k].starts_with(start) && block[k].ends_with(end),
            "line {k}: {}",
            block[k]
        )
    };
    line(1, "  A (ISO 230-2) X [laser-x]", "pass");
    line(2, "  E (ISO 230-2) X [laser-x]", "cannot decide");
    line(4, "  M (ISO 230-2) X [laser-x]", "fail");
    line(9, "  EA0Z ", "fail");
    line(13, "  EZZ over the stroke", "(101 points over the stroke)");
    assert_eq!(
        block[n + 1],
        "overall: FAIL (4 pass, 3 fail, 6 cannot decide)"
    );
}

// ---------------------------------------------------------------------------------------------
// ISO 230-4 from a ball-bar circle file

/// The inverse of a symmetric positive definite 3 × 3 matrix by its cofactors.
fn inverse3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c = |r: usize, k: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det: f64 = (0..3).map(|k| m[0][k] * c(0, k)).sum();
    let mut inv = [[0.0; 3]; 3];
    for (r, row) in inv.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = c(k, r) / det;
        }
    }
    inv
}

/// G (µm) of an XY circle about the origin and its U from the reading noise: the residuals of
/// the least-squares circle, their range, and the variance of the difference of the two
/// extreme residuals, σ²((1 − h_hh) + (1 − h_ll) + 2 h_hl).
fn g_from_file(file: &str) -> (f64, f64) {
    let cols = columns(&repo().join(file));
    let (x, y, dr) = (&cols["X"], &cols["Y"], &cols["dr"]);
    let rows: Vec<[f64; 3]> = x
        .iter()
        .zip(y)
        .map(|(x, y)| {
            let phi = y.atan2(*x);
            assert!(
                (x.hypot(*y) - 100.0).abs() < 1e-6,
                "a circle of 100 mm about the pivot"
            );
            [1.0, phi.cos(), phi.sin()]
        })
        .collect();
    let mut ata = [[0.0; 3]; 3];
    let mut atb = [0.0; 3];
    for (r, d) in rows.iter().zip(dr) {
        for i in 0..3 {
            atb[i] += r[i] * d;
            for j in 0..3 {
                ata[i][j] += r[i] * r[j];
            }
        }
    }
    let inv = inverse3(ata);
    let fit: Vec<f64> = (0..3)
        .map(|i| (0..3).map(|j| inv[i][j] * atb[j]).sum())
        .collect();
    let e: Vec<f64> = rows
        .iter()
        .zip(dr)
        .map(|(r, d)| d - (0..3).map(|i| r[i] * fit[i]).sum::<f64>())
        .collect();
    let hi = (0..e.len()).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap();
    let lo = (0..e.len()).min_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap();
    let h = |a: usize, b: usize| -> f64 {
        (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| rows[a][i] * inv[i][j] * rows[b][j])
                    .sum::<f64>()
            })
            .sum()
    };
    let var = (1.0 - h(hi, hi)) + (1.0 - h(lo, lo)) + 2.0 * h(hi, lo);
    (e[hi] - e[lo], 2.0 * BALLBAR_SIGMA_UM * var.sqrt())
}

#[test]
fn circles_are_accepted_by_g_and_u_computed_from_the_files_and_nothing_else_changes() {
    let ccw = g_from_file("examples/five-axis/session/ballbar-xy-ccw.csv");
    let cw = g_from_file("examples/five-axis/session/ballbar-xy-cw.csv");
    // XY inside by more than the clockwise circle's U; the other planes far beyond 1 µm.
    let xy = cw.0 + 1.2 * cw.1;
    let file = format!(
        "[iso230_4]\nG_um = 1\n\n[iso230_4.XY]\nG_um = {xy}\n\n[parameters]\n\
         EC0Y = {{ max_abs_urad = 20 }}\nEZ0A = {{ max_abs_um = 20 }}\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let acc = dir.path().join("acc.toml");
    std::fs::write(&acc, &file).unwrap();
    let report = dir.path().join("report");
    let session = "examples/five-axis/session";
    let (plain_screen, plain) = identify(session, None, None, &dir.path().join("plain.json"));
    let (screen, text) = identify(
        session,
        Some(&acc),
        Some(&report),
        &dir.path().join("acc.json"),
    );
    let json: Value = serde_json::from_str(&text).unwrap();
    let g = checks(&json, "G (ISO 230-4) XY");
    assert_eq!(g.len(), 2);
    for (c, (value, u), run) in [(g[0], ccw, "ballbar-xy-ccw"), (g[1], cw, "ballbar-xy-cw")] {
        assert_eq!(c["run"], run);
        close(&c["value"], value, run);
        close(&c["uncertainty"], u, run);
        close(&c["tolerance"], xy, run);
        assert_eq!(c["verdict"], rule(value, u, xy), "{run}");
    }
    assert_eq!(g[1]["verdict"], "pass");
    for item in ["G (ISO 230-4) YZ", "G (ISO 230-4) ZX"] {
        let c = checks(&json, item)[0];
        let (v, u) = (
            c["value"].as_f64().unwrap(),
            c["uncertainty"].as_f64().unwrap(),
        );
        assert!(u > 2.0 && u < 3.0, "{item}: U = {u}");
        assert_eq!(c["tolerance"], 1.0);
        assert_eq!(c["verdict"], rule(v, u, 1.0));
        assert_eq!(c["verdict"], "fail");
    }
    // A parameter the runs cannot separate: no value, cannot decide, and why.
    let ez0a = checks(&json, "EZ0A")[0];
    assert_eq!(ez0a["verdict"], "cannot decide");
    assert!(ez0a.get("value").is_none());
    let why = ez0a["note"].as_str().unwrap();
    assert!(why.starts_with("not determined by these runs: "), "{why}");
    assert!(why.contains("ball-low.ball_z"), "{why}");
    assert_eq!(checks(&json, "EC0Y")[0]["verdict"], "pass");
    assert_eq!(json["acceptance"]["verdict"], "fail");

    // Without --acceptance the JSON is what it was: with it, only `acceptance` is added, last.
    let head = plain
        .strip_suffix("\n}\n")
        .expect("the JSON ends its object");
    assert!(
        text.starts_with(head),
        "the JSON before `acceptance` changed"
    );
    assert!(text[head.len()..].starts_with(",\n  \"acceptance\": {"));
    // The screen likewise, but for its block.
    let start = screen.find("\nacceptance against").expect("the block");
    let end = start + screen[start..].find("\noverall: ").unwrap();
    let end = end + 1 + screen[end + 1..].find('\n').unwrap() + 1;
    let without_files = |s: &str| -> String {
        s.lines()
            .filter(|l| !l.starts_with("wrote "))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    assert_eq!(
        without_files(&format!("{}{}", &screen[..start], &screen[end..])),
        without_files(&plain_screen)
    );

    // The report's table: a row per check, in order, with the JSON's verdicts.
    let page = std::fs::read_to_string(report.join("index.html")).unwrap();
    let s = page
        .find("<section id=\"acceptance\">")
        .expect("the acceptance section");
    let section = &page[s..s + page[s..].find("</section>").unwrap()];
    let verdicts: Vec<&str> = section
        .split("<tr data-verdict=\"")
        .skip(1)
        .map(|r| &r[..r.find('"').unwrap()])
        .collect();
    let from_json: Vec<&str> = json["acceptance"]["checks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["verdict"].as_str().unwrap())
        .collect();
    assert_eq!(verdicts, from_json);
    assert!(section.contains("data-verdict=\"fail\""), "{section}");
}
