//! Real ISO 230-2 positioning runs (`../shared/data/ecmc-iso230-2`, eight cases from the EPICS
//! ecmc motion test tools: 5 bidirectional cycles at 5 or 9 targets) through mtcal's laser
//! plugin and the identification pipeline.
//!
//! Each case's `*_ISO230.dat` (the producer's input table, parsed here: a third-party
//! `KEY=VALUE` format, `TGT_DATA[i]`, `REF_DATA_FWD[i,j]`, `REF_DATA_BWD[i,j]`, mm) becomes a
//! session with one `laser` linear run along X of the topology machine `ZFYX`: `t`, `X` =
//! the target, `Y = Z = 0`, `d` = reference − target in µm, samples in ISO 230-2 cycle order
//! (targets ascending, then descending, five times). mtcal decides the approach direction
//! from that motion, never from the labels: **the `.dat` block `REF_DATA_FWD` is taken as
//! the positive approach (↑)**: it is the block the producer's extraction tool names for the
//! forward (positive) motion; its report generator swapped the blocks (README caveat 2).
//!
//! Expected values come from the standard's formulas, checked three ways:
//! - against the README's table of the ISO 230-2:2014 bidirectional R and E per case (a second
//!   opinion computed with the standard's formulas), to the digits printed there;
//! - against the producer's report (`*.md`): B, B̄, M, A and the unidirectional R↑/R↓, E↑/E↓,
//!   A↑/A↓ agree with it to its printed precision **once its direction swap is undone** (its
//!   "fwd" values are mtcal's ↓, its B̄ has the opposite sign);
//! - mtcal does not repeat the report's errors: where the README says the report's R
//!   (max(R↑, R↓), leaving out 2s↑ + 2s↓ + |B_i|) or E is wrong, mtcal's value differs from
//!   the report's by more than its printed precision.
//!
//! The data files are never copied into the repository (licences: GPL / none). Without
//! `../shared` (or `MTCAL_SHARED_DATA`) the test says it was skipped.

use crate::common;

use common::honesty::honest;
use mtcal_identify::identify_session;
use mtcal_identify::search::{SearchOptions, search};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn data_dir() -> Option<PathBuf> {
    mtcal_testkit::shared_data("ecmc-iso230-2")
}

/// One `.dat` file: targets (mm) and reference readings per target and cycle (mm).
struct Dat {
    targets: Vec<f64>,
    fwd: Vec<Vec<f64>>,
    bwd: Vec<Vec<f64>>,
}

fn parse_dat(path: &Path) -> Dat {
    let text = std::fs::read_to_string(path).unwrap();
    let mut targets = BTreeMap::new();
    let mut fwd = BTreeMap::new();
    let mut bwd = BTreeMap::new();
    let mut unit = "mm".to_string();
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with('#') || line.starts_with("TEST_DATA=") {
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let index = |k: &str| -> Vec<usize> {
            let inner = k.split_once('[').unwrap().1.trim_end_matches(']');
            inner
                .split(',')
                .map(|s| s.trim().parse().unwrap())
                .collect()
        };
        let number = || -> f64 {
            value
                .trim()
                .parse()
                .unwrap_or_else(|e| panic!("{}: `{line}`: {e}", path.display()))
        };
        if key == "UNIT" {
            unit = value.trim().to_string();
        } else if key.starts_with("TGT_DATA[") {
            targets.insert(index(key)[0], number());
        } else if key.starts_with("REF_DATA_FWD[") {
            let ij = index(key);
            fwd.insert((ij[0], ij[1]), number());
        } else if key.starts_with("REF_DATA_BWD[") {
            let ij = index(key);
            bwd.insert((ij[0], ij[1]), number());
        }
    }
    assert_eq!(unit, "mm", "{}", path.display());
    let m = targets.len();
    let cycles = fwd.keys().map(|&(_, j)| j).max().unwrap();
    let block = |b: &BTreeMap<(usize, usize), f64>| -> Vec<Vec<f64>> {
        (1..=m)
            .map(|i| (1..=cycles).map(|j| b[&(i, j)]).collect())
            .collect()
    };
    Dat {
        targets: targets.values().copied().collect(),
        fwd: block(&fwd),
        bwd: block(&bwd),
    }
}

/// The report's axis values: `NAME = value [mm]` lines (the last of each name), as written.
fn parse_report(path: &Path) -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let line = line.trim().trim_matches('*');
        let Some((name, rest)) = line.split_once(" = ") else {
            continue;
        };
        let Some(value) = rest.strip_suffix(" [mm]") else {
            continue;
        };
        if value.trim().parse::<f64>().is_ok() {
            out.insert(name.trim().to_string(), value.trim().to_string());
        }
    }
    out
}

/// One unit of the last printed digit of a number written as `s`.
fn printed_unit(s: &str) -> f64 {
    let (mantissa, exp) = match s.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().unwrap()),
        None => (s, 0),
    };
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    10f64.powi(exp - decimals)
}

/// Whether `value` (mm) agrees with the printed `s` to its last digit (one unit, allowing for
/// the producer's rounding of intermediate values).
fn agrees(value: f64, s: &str) -> bool {
    (value - s.parse::<f64>().unwrap()).abs() <= printed_unit(s) * (1.0 + 1e-9)
}

/// The README's table: case label → (R, E) as printed (ISO formula values, mm).
fn readme_table(dir: &Path) -> BTreeMap<String, (String, String, String, String)> {
    let text = std::fs::read_to_string(dir.join("README.md")).unwrap();
    let mut out = BTreeMap::new();
    let mut in_table = false;
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with("| case | R (ISO formula)") {
            in_table = true;
            continue;
        }
        if in_table {
            if !line.starts_with('|') {
                break;
            }
            let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
            if cells[0].starts_with("---") {
                continue;
            }
            let num = |s: &str| s.trim_end_matches(" mm").trim().to_string();
            out.insert(
                cells[0].to_string(),
                (num(cells[1]), num(cells[2]), num(cells[3]), num(cells[4])),
            );
        }
    }
    out
}

/// The README's case label for a `.dat` file.
fn label(folder: &str, file: &str) -> String {
    if folder == "ess-target-week42-xyz" {
        let axis = file.trim_start_matches("target_").chars().next().unwrap();
        let sensor = if file.contains("ILD50") {
            "ILD50"
        } else {
            "ILD2300 below"
        };
        format!("week42 {axis} ({sensor})")
    } else {
        folder.to_string()
    }
}

/// The producer's report beside a `.dat`: `<name>.md` for `<name>.md_ISO230.dat`, else the
/// only `.md` in the folder.
fn report_for(dat: &Path) -> PathBuf {
    let name = dat.file_name().unwrap().to_string_lossy();
    let direct = dat.with_file_name(name.trim_end_matches("_ISO230.dat"));
    if direct.is_file() {
        return direct;
    }
    let mds: Vec<PathBuf> = std::fs::read_dir(dat.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    assert_eq!(mds.len(), 1, "no single report beside {}", dat.display());
    mds[0].clone()
}

/// Writes a session with one laser linear run of the `.dat` in ISO 230-2 cycle order and
/// returns the ISO 230-2 metrics of the identify report, in mm.
fn through_the_pipeline(dat: &Dat, dir: &Path) -> BTreeMap<String, f64> {
    let cycles = dat.fwd[0].len();
    let m = dat.targets.len();
    let mut csv = String::from("t,X,Y,Z,d\n");
    let mut t = 0.0;
    let mut row = |x: f64, reading: f64| {
        t += 1.0;
        csv.push_str(&format!("{t},{x},0,0,{}\n", (reading - x) * 1e3));
    };
    for j in 0..cycles {
        for i in 0..m {
            row(dat.targets[i], dat.fwd[i][j]);
        }
        for i in (0..m).rev() {
            row(dat.targets[i], dat.bwd[i][j]);
        }
    }
    std::fs::write(dir.join("x-linear.csv"), csv).unwrap();
    std::fs::write(
        dir.join("session.toml"),
        r#"machine = "ZFYX"

[identify]
parameters = ["EXX"]

[[run]]
name = "x-linear"
instrument = "laser"
file = "x-linear.csv"
[run.setup]
mode = "linear"
direction = "X"
sigma_um = 1.0
"#,
    )
    .unwrap();
    let (_, id) = identify_session(dir).unwrap_or_else(|e| panic!("{e}"));
    let run = &id.fit.runs[0];
    run.metrics
        .iter()
        .filter(|m| m.name.ends_with("(ISO 230-2)"))
        .map(|m| {
            assert_eq!(m.unit, "um");
            (
                m.name.trim_end_matches(" (ISO 230-2)").to_string(),
                m.value * 1e-3,
            )
        })
        .collect()
}

#[test]
fn real_iso230_2_runs_follow_the_standard_not_the_producers_report() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: ../shared/data/ecmc-iso230-2 not found (set MTCAL_SHARED_DATA)");
        return;
    };
    let readme = readme_table(&dir);
    assert_eq!(readme.len(), 8, "README table: {readme:?}");
    let mut dats: Vec<PathBuf> = Vec::new();
    for folder in std::fs::read_dir(&dir).unwrap() {
        let folder = folder.unwrap().path();
        if !folder.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&folder).unwrap() {
            let f = f.unwrap().path();
            if f.to_string_lossy().ends_with("_ISO230.dat") {
                dats.push(f);
            }
        }
    }
    dats.sort();
    assert_eq!(dats.len(), 8, "{dats:?}");
    let (mut r_differs, mut e_differs) = (0, 0);
    let mut spanned = 0;
    for path in &dats {
        let folder = path
            .parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let file = path.file_name().unwrap().to_string_lossy().into_owned();
        let case = label(&folder, &file);
        let (r_iso, r_rep_readme, e_iso, e_rep_readme) = readme
            .get(&case)
            .unwrap_or_else(|| panic!("no README row for {case}"));
        let dat = parse_dat(path);
        let report = parse_report(&report_for(path));
        let tmp = tempfile::tempdir().unwrap();
        // `KEEP=dir` keeps each session (as `dir/<case>`) to look at with `mtcal`.
        let dir = match std::env::var("KEEP") {
            Ok(keep) => Path::new(&keep).join(case.replace([' ', '/'], "_")),
            Err(_) => tmp.path().to_path_buf(),
        };
        std::fs::create_dir_all(&dir).unwrap();
        let got = through_the_pipeline(&dat, &dir);
        let v = |k: &str| {
            *got.get(k)
                .unwrap_or_else(|| panic!("{case}: no metric {k}: {got:?}"))
        };
        let rep = |k: &str| {
            report
                .get(k)
                .unwrap_or_else(|| panic!("{case}: report has no {k}: {report:?}"))
                .as_str()
        };
        eprintln!(
            "{case}: mtcal R = {:.6e} (README ISO {r_iso}, report {}), E = {:.6e} (README ISO \
             {e_iso}, report {}), B = {:.4e}, B̄ = {:.4e} (report {}), M = {:.4e}, A = {:.4e} mm",
            v("R"),
            rep("R"),
            v("E"),
            rep("E"),
            v("B"),
            v("B̄"),
            rep("B_avg"),
            v("M"),
            v("A")
        );
        // The standard's bidirectional values, as the README recomputed them.
        assert!(
            agrees(v("R"), r_iso),
            "{case}: R {} vs README {r_iso}",
            v("R")
        );
        assert!(
            agrees(v("E"), e_iso),
            "{case}: E {} vs README {e_iso}",
            v("E")
        );
        // The report's values the README quotes are the report's.
        assert_eq!(rep("R"), r_rep_readme, "{case}");
        assert_eq!(rep("E"), e_rep_readme, "{case}");
        // Direction-free values agree with the report.
        for k in ["B", "M", "A"] {
            assert!(
                agrees(v(k), rep(k)),
                "{case}: {k} {} vs report {}",
                v(k),
                rep(k)
            );
        }
        // Unidirectional values agree once the report's swap is undone: its "fwd" is the
        // .dat's BWD block, mtcal's ↓.
        for (ours, theirs) in [
            ("R↑", "R_bwd"),
            ("R↓", "R_fwd"),
            ("E↑", "E_bwd"),
            ("E↓", "E_fwd"),
            ("A↑", "A_bwd"),
            ("A↓", "A_fwd"),
        ] {
            assert!(
                agrees(v(ours), rep(theirs)),
                "{case}: {ours} {} vs report {theirs} {}",
                v(ours),
                rep(theirs)
            );
        }
        // …and B̄ has the opposite sign of the report's B_avg (B_i = x̄↑ − x̄↓).
        let b_avg: f64 = rep("B_avg").parse().unwrap();
        assert!(
            (v("B̄") + b_avg).abs() <= printed_unit(rep("B_avg")) * (1.0 + 1e-9),
            "{case}: B̄ {} vs report B_avg {b_avg} (swapped)",
            v("B̄")
        );
        // Where the README says the report is wrong, mtcal does not repeat it.
        let report_r_wrong = !agrees(r_iso.parse().unwrap(), rep("R"));
        let report_e_wrong = !agrees(e_iso.parse().unwrap(), rep("E"));
        if report_r_wrong {
            r_differs += 1;
            assert!(
                !agrees(v("R"), rep("R")),
                "{case}: mtcal repeats the report's R"
            );
            // The report's R is max(R↑, R↓).
            assert!(agrees(v("R↑").max(v("R↓")), rep("R")), "{case}");
        }
        if report_e_wrong {
            e_differs += 1;
            assert!(
                !agrees(v("E"), rep("E")),
                "{case}: mtcal repeats the report's E"
            );
        }
        // The physics search on the real run (a few dozen readings, its own noise far above
        // the stated micrometre): whatever it adds is a determined effect of its final fit. One
        // of these runs had a servo lag of 0.18 ± 0.51 ms kept, undetermined once the final fit
        // weighed the runs by its own residuals' noise.
        let study = mtcal_identify::Study::load(&dir).unwrap();
        let searched = search(study, &SearchOptions::default()).unwrap();
        if let Err(why) = honest(&searched) {
            panic!("{case}: {why}");
        }
        // A number about positions is given over the targets the run covers: a backlash along
        // X of ±15 mm of targets (b02-y) was "changing by 865 ± 421 µm" to the end of a stroke
        // thirty times longer.
        let (lo, hi) = dat
            .targets
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        for d in &searched.findings.discoveries {
            // ISO 230-2 reads each target with the axis standing: a lag behind the command
            // has nothing to show in these readings (one run claimed 7.8 ms from the steps
            // between targets over the time between two readings).
            assert_ne!(d.effect, "servo-lag", "{case}: {}", d.sentence);
            for span in &d.spans {
                spanned += 1;
                assert!(
                    span.axis == "X"
                        && span.unit == "mm"
                        && (span.from - lo).abs() < 1e-6
                        && (span.to - hi).abs() < 1e-6,
                    "{case}: {} over {span:?}, the targets {lo} … {hi} mm",
                    d.label
                );
            }
        }
    }
    // Measured 2026-11-30: b02-y and week42_y name a backlash along X.
    assert!(spanned >= 1, "no discovery given over a span");
    // The README lists R wrong in five cases and E wrong in all eight.
    assert_eq!(
        r_differs, 5,
        "cases where the report's R is not the standard's"
    );
    assert_eq!(
        e_differs, 8,
        "cases where the report's E is not the standard's"
    );
}
