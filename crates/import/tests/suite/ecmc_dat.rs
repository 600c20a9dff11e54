//! `ecmc-dat` imports: a synthetic table round-trips into a session `identify` fits, and the
//! real tables of `../shared/data/ecmc-iso230-2` give the ISO 230-2 values the standard's
//! formulas give (the README's table of R and E).
//!
//! The real files are read from `../shared` only, never copied (GPL-3 / no licence). Without
//! them the real-data test says it was skipped; in CI (`MTCAL_REQUIRE_SHARED_DATA`, set by
//! `.ci/run`) it fails instead.

use crate::common;

use common::{identify, import_new, read_back};
use mtcal_import::Format;
use mtcal_laser::{TARGET_TOL, approach_table, iso230_2};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A table in the ecmc layout: targets −100 … 100 mm, deviation = 20 µm/m slope, a reversal
/// of 4 µm (FWD reads +2, BWD −2) and a small per-cycle scatter.
fn synthetic_dat() -> (String, Vec<f64>) {
    let targets = [-100.0, -50.0, 0.0, 50.0, 100.0];
    let mut text =
        String::from("TEST_DATA=# synthetic table written by mtcal's tests\n# comment\n");
    text.push_str("UNIT=mm\nCYCLES=3\nPOSITIONS=5\nDEC=6\n");
    for (i, t) in targets.iter().enumerate() {
        writeln!(text, "TGT_DATA[{}]={t}", i + 1).unwrap();
    }
    let dev_um = |t: f64, j: usize, s: f64| 0.02 * t + s * 2.0 + 0.1 * j as f64;
    for (block, s) in [("FWD", 1.0), ("BWD", -1.0)] {
        for j in 1..=3 {
            for (i, &t) in targets.iter().enumerate() {
                let reading_mm = t + dev_um(t, j, s) * 1e-3;
                writeln!(text, "REF_DATA_{block}[{},{j}]={reading_mm:.7}", i + 1).unwrap();
            }
        }
    }
    text.push_str("  \n");
    (text, targets.to_vec())
}

#[test]
fn a_synthetic_table_round_trips_into_a_session_identify_fits() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, targets) = synthetic_dat();
    let file = tmp.path().join("x_ISO230.dat");
    std::fs::write(&file, text).unwrap();
    let session = tmp.path().join("session");
    let imported = import_new(Format::EcmcDat, &file, &session, Some('X'));
    assert_eq!(
        (imported.recording.targets, imported.recording.cycles),
        (5, 3)
    );
    let (travel, d) = read_back(&imported);
    // The standard test cycle: up through the targets (FWD), down (BWD), three times.
    assert_eq!(travel.len(), 30);
    assert_eq!(&travel[..5], &targets[..]);
    assert_eq!(
        travel[5..10].iter().rev().copied().collect::<Vec<_>>(),
        targets
    );
    assert!(
        (d[0] - (0.02 * -100.0 + 2.0 + 0.1)).abs() < 1e-6,
        "{}",
        d[0]
    );
    assert!((d[5] - (0.02 * 100.0 - 2.0 + 0.1)).abs() < 1e-6, "{}", d[5]);
    let (rms_um, metrics) = identify(&session);
    let metric = |name: &str| metrics.iter().find(|(n, _)| n == name).unwrap().1;
    // B = x̄↑ − x̄↓ = 4 µm at every target, from the motion, whatever the labels.
    assert!((metric("B (ISO 230-2)") - 4.0).abs() < 1e-6);
    // The model (slope, reversal through the set-up's zero) leaves the reversal and the
    // cycle drift: a few µm, not the 2 µm/… of a unit error.
    assert!(rms_um < 3.0, "fit rms {rms_um} µm");
}

fn data_dir() -> Option<PathBuf> {
    mtcal_testkit::shared_data("ecmc-iso230-2")
}

/// The README's table: case label → (R, E) printed with the ISO formula (mm).
fn readme_table(dir: &Path) -> BTreeMap<String, (String, String)> {
    let text = std::fs::read_to_string(dir.join("README.md")).unwrap();
    let rows = text
        .lines()
        .map(str::trim)
        .skip_while(|l| !l.starts_with("| case | R (ISO formula)"))
        .skip(2)
        .take_while(|l| l.starts_with('|'));
    rows.map(|l| {
        let c: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
        let num = |s: &str| s.trim_end_matches(" mm").trim().to_string();
        (c[0].to_string(), (num(c[1]), num(c[3])))
    })
    .collect()
}

/// The README's case label of a `.dat` file.
fn label(dat: &Path) -> String {
    let folder = dat.parent().unwrap().file_name().unwrap().to_string_lossy();
    let file = dat.file_name().unwrap().to_string_lossy();
    if folder != "ess-target-week42-xyz" {
        return folder.to_string();
    }
    let axis = file.trim_start_matches("target_").chars().next().unwrap();
    let sensor = if file.contains("ILD50") {
        "ILD50"
    } else {
        "ILD2300 below"
    };
    format!("week42 {axis} ({sensor})")
}

/// Whether `value` (mm) agrees with the printed `s` to one unit of its last digit.
fn agrees(value: f64, s: &str) -> bool {
    let (mantissa, exp) = match s.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().unwrap()),
        None => (s, 0),
    };
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    let unit = 10f64.powi(exp - decimals);
    (value - s.parse::<f64>().unwrap()).abs() <= unit * (1.0 + 1e-9)
}

fn dat_files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .flat_map(|folder| {
            std::fs::read_dir(folder)
                .unwrap()
                .map(|e| e.unwrap().path())
        })
        .filter(|p| p.to_string_lossy().ends_with("_ISO230.dat"))
        .collect();
    out.sort();
    out
}

#[test]
fn real_tables_import_to_the_iso_230_2_values_of_the_standard() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: ../shared/data/ecmc-iso230-2 not found (set MTCAL_SHARED_DATA)");
        return;
    };
    let readme = readme_table(&dir);
    let dats = dat_files(&dir);
    assert_eq!((readme.len(), dats.len()), (8, 8), "{readme:?} {dats:?}");
    let tmp = tempfile::tempdir().unwrap();
    for (k, dat) in dats.iter().enumerate() {
        let case = label(dat);
        let (r_iso, e_iso) = &readme[&case];
        let session = tmp.path().join(format!("s{k}"));
        let imported = import_new(Format::EcmcDat, dat, &session, Some('X'));
        let (travel, d_um) = read_back(&imported);
        let table = approach_table(&travel, &d_um, TARGET_TOL);
        assert_eq!(table.targets.len(), imported.recording.targets, "{case}");
        let iso = iso230_2(&table).unwrap_or_else(|e| panic!("{case}: {e}"));
        let (r_mm, e_mm) = (iso.r * 1e-3, iso.e * 1e-3);
        eprintln!("{case}: R = {r_mm:.6e} (README {r_iso}), E = {e_mm:.6e} (README {e_iso}) mm");
        assert!(agrees(r_mm, r_iso), "{case}: R {r_mm} vs README {r_iso}");
        assert!(agrees(e_mm, e_iso), "{case}: E {e_mm} vs README {e_iso}");
        if k == 0 {
            // The session fits, and the plugin's own evaluation says the same.
            let (_, metrics) = identify(&session);
            let r = metrics
                .iter()
                .find(|(n, _)| n == "R (ISO 230-2)")
                .unwrap()
                .1;
            assert!(
                (r - iso.r).abs() < 1e-9,
                "{case}: evaluate R {r} vs {}",
                iso.r
            );
        }
    }
}

/// A second import into an existing session adds its run and manifest entry beside the first:
/// the session keeps both, names the machine once, refuses a second `--machine`, and fits both
/// axes' runs.
#[test]
fn a_second_import_appends_to_the_session() {
    let tmp = tempfile::tempdir().unwrap();
    let (text, _) = synthetic_dat();
    let x_file = tmp.path().join("x_ISO230.dat");
    std::fs::write(&x_file, &text).unwrap();
    let y_file = tmp.path().join("y_ISO230.dat");
    std::fs::write(&y_file, &text).unwrap();
    let session = tmp.path().join("session");
    let first = import_new(Format::EcmcDat, &x_file, &session, Some('X'));
    assert!(first.created);
    let options = |machine| mtcal_import::ImportOptions {
        format: Format::EcmcDat,
        file: &y_file,
        session: &session,
        machine,
        axis: Some('Y'),
        name: None,
        hold: Some("X=0,Z=-200"),
    };
    let machine = common::three_axis_machine();
    let refused = mtcal_import::import(&options(Some(machine.to_str().unwrap())));
    assert!(refused.is_err(), "a second --machine must be refused");
    let second = mtcal_import::import(&options(None)).unwrap_or_else(|e| panic!("{e}"));
    assert!(!second.created);
    assert_eq!(second.manifest, first.manifest);
    let manifest = std::fs::read_to_string(&first.manifest).unwrap();
    assert_eq!(manifest.matches("[[run]]").count(), 2, "{manifest}");
    assert_eq!(manifest.matches("machine =").count(), 1, "{manifest}");
    let (_, id) = mtcal_identify::identify_session(&session).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = id.fit.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, [first.run_name.as_str(), second.run_name.as_str()]);
    for run in &id.fit.runs {
        let b = run
            .metrics
            .iter()
            .find(|m| m.name == "B (ISO 230-2)")
            .unwrap();
        assert!(
            (b.value - 4.0).abs() < 1e-6,
            "{}: B = {}",
            run.name,
            b.value
        );
    }
}
