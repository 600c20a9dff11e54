//! `mtcal volumetric` on sessions of the independent simulator: the verdict leads the screen,
//! the JSON (`mtcal.volumetric/1`) and the page are written together, `--require-uniform`
//! exits 1 on drive heat with the outputs written, bad input exits 2 and writes nothing.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use mtcal_indsim::{Campaign, Machine, Realism, Truth, VolumetricLoad, VolumetricSpec};

/// A five-cycle volumetric test on the shipped trunnion under `load`, into `dir`.
fn simulate(dir: &Path, load: VolumetricLoad) -> PathBuf {
    let machine = Machine::from_urdf_file(&mtcal_indsim::shipped_machine("mcu630-cafyxz.urdf"))
        .expect("the shipped trunnion");
    let mut spec = VolumetricSpec::short(load, 5);
    spec.stream = None;
    Campaign::volumetric_trunnion(dir, &Truth::zero(&machine), &spec, &Realism::realistic(3))
        .expect("the simulator writes the session");
    dir.to_path_buf()
}

fn mtcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .output()
        .expect("mtcal runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn the_verdict_leads_the_screen_and_the_json_and_page_are_written() {
    let tmp = tempfile::tempdir().unwrap();
    let session = simulate(&tmp.path().join("spindle"), VolumetricLoad::Spindle);
    let json = tmp.path().join("out/v.json");
    let page = tmp.path().join("out/v.html");
    let out = mtcal(&[
        "volumetric",
        session.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--report",
        page.to_str().unwrap(),
        "--phase",
        "0.3,1",
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}{}", text(&out.stderr));
    assert!(stdout.starts_with("UNIFORM — "), "{stdout}");
    assert!(stdout.lines().count() <= 40, "a screen:\n{stdout}");
    assert!(
        stdout.contains(&format!("wrote {}", json.display())),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!("wrote {}", page.display())),
        "{stdout}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("the JSON parses");
    assert_eq!(v["schema"], "mtcal.volumetric/1");
    assert_eq!(v["verdict"]["overall"], "uniform");
    assert_eq!(v["instants"].as_array().unwrap().len(), 5);
    assert_eq!(v["points"].as_array().unwrap().len(), 15);
    assert_eq!(v["phases"].as_array().unwrap().len(), 2);
    assert_eq!(v["phases"][0]["requested_h"], 0.3);
    assert_eq!(v["time_base"]["method"], "interpolated");
    assert!(v["noise"]["sigma_um"][2].as_f64().unwrap() > 0.0);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("data-verdict=\"uniform\""));
    // Two phases' vector plots and three time plots.
    assert_eq!(html.matches("<svg ").count(), 5);
    let names: Vec<_> = std::fs::read_dir(tmp.path().join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "no temporary file left: {names:?}");
}

#[test]
fn require_uniform_exits_1_on_drive_heat_with_the_outputs_written() {
    let tmp = tempfile::tempdir().unwrap();
    let session = simulate(&tmp.path().join("drive"), VolumetricLoad::YDrive);
    let json = tmp.path().join("v.json");
    let out = mtcal(&[
        "volumetric",
        session.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--require-uniform",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert!(text(&out.stdout).starts_with("NOT UNIFORM — "));
    assert!(
        text(&out.stderr)
            .contains("check failed: --require-uniform: the deformation is not uniform"),
        "{}",
        text(&out.stderr)
    );
    assert!(json.is_file(), "the outputs are written");
    // Without the check the same session is done: exit 0.
    let out = mtcal(&["volumetric", session.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
}

#[test]
fn bad_input_exits_2_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let session = tmp.path().join("ballbar-only");
    std::fs::create_dir_all(&session).unwrap();
    std::fs::write(
        session.join("session.toml"),
        "machine = \"CAFYXZ\"\n\n[[run]]\nname = \"c1\"\ninstrument = \"ballbar\"\nfile = \"c1.csv\"\n",
    )
    .unwrap();
    std::fs::write(
        session.join("c1.csv"),
        "t,X,Y,Z,A,C,dr\n0,100,0,0,0,0,0.5\n",
    )
    .unwrap();
    let json = tmp.path().join("v.json");
    let page = tmp.path().join("v.html");
    let out = mtcal(&[
        "volumetric",
        session.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
        "--report",
        page.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("no rtest run"),
        "{}",
        text(&out.stderr)
    );
    assert!(!json.exists() && !page.exists());
    // An output path that is a folder is told before any work, and so is a bad option.
    let good = simulate(&tmp.path().join("spindle"), VolumetricLoad::Spindle);
    let folder = tmp.path().join("a folder");
    std::fs::create_dir_all(&folder).unwrap();
    for args in [
        vec!["--json", folder.to_str().unwrap()],
        vec!["--time-base", "sideways"],
        vec!["--tolerance-share", "-1"],
        vec!["--phase", "40"],
    ] {
        let mut all = vec!["volumetric", good.to_str().unwrap(), "--report"];
        all.push(page.to_str().unwrap());
        all.extend(args.iter().copied());
        let out = mtcal(&all);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            text(&out.stderr)
        );
        assert!(
            text(&out.stderr).starts_with("error: "),
            "{}",
            text(&out.stderr)
        );
        assert!(!page.exists(), "{args:?}");
    }
}

/// The bundled example (README; `crates/volumetric/examples/write_example.rs` made it): the
/// Y-drive test on the trunnion is not uniform, as its truth (`truth/field.csv`) is — the
/// points differ by about a third of the mean deformation in Y and Z.
#[test]
fn the_bundled_example_is_not_uniform() {
    let session = mtcal_testkit::repo().join("examples/volumetric/session");
    let out = mtcal(&["volumetric", session.to_str().unwrap()]);
    let screen = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{screen}{}", text(&out.stderr));
    assert!(screen.starts_with("NOT UNIFORM"), "{screen}");
}

/// The bundled R-test sets (README; `write_example … rtest-sets` made them): `identify
/// --search` names A's and C's lines moving with their drives' temperatures at the planted
/// gains (0.8 and 0.5 µm/K, `truth/effects.toml`) and nothing else, and its JSON gives their
/// changes cycle by cycle, every other location error as the model says.
#[test]
fn the_bundled_rtest_sets_name_the_moving_lines_cycle_by_cycle() {
    let session = mtcal_testkit::repo().join("examples/volumetric/rtest-sets");
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("id.json");
    let out = mtcal(&[
        "identify",
        session.to_str().unwrap(),
        "--search",
        "--json",
        json.to_str().unwrap(),
    ]);
    let screen = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{screen}{}", text(&out.stderr));
    assert!(
        screen.contains("location errors cycle by cycle (36 cycles"),
        "{screen}"
    );
    let id: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let discoveries = id["discoveries"].as_array().unwrap();
    assert_eq!(discoveries.len(), 2, "{screen}");
    for (parameter, driver, planted) in [("EY0A", "T_adrive", 0.8), ("EX0C", "T_cdrive", 0.5)] {
        let d = discoveries
            .iter()
            .find(|d| d["component"] == parameter && d["driver"] == driver)
            .unwrap_or_else(|| panic!("{parameter} ({driver}) not named\n{screen}"));
        let p = &d["parameters"][0];
        let (value, u95) = (p["value"].as_f64().unwrap(), p["u95"].as_f64().unwrap());
        assert!(
            (value - planted).abs() <= u95,
            "{parameter}: {value} ± {u95}\n{screen}"
        );
    }
    let series = id["location_series"].as_array().unwrap();
    for l in series {
        let modelled = ["EY0A", "EX0C"].contains(&l["parameter"].as_str().unwrap());
        assert_eq!(l["modelled"].as_bool(), Some(modelled), "{l}");
        assert_eq!(l["departs"].as_bool(), Some(false), "{l}");
        assert_eq!(l["cycles"].as_array().unwrap().len(), 36, "{l}");
    }
    assert!(series.len() >= 8, "{screen}");
}
