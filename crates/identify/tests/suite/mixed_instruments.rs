//! One identification across five instruments on the five-axis trunnion (`mcu630-cafyxz`):
//! laser linear runs along X, Y and Z, a laser-tracer campaign (four stations), R-test and
//! ball-bar runs about the rotary axes, and a calibrated hole plate probed twice — fitted
//! jointly, each instrument whitened by its own noise.
//!
//! The model: the positioning errors of X, Y and Z (Legendre `P1`, `P2`), the three squareness
//! errors and the eight location errors of A and C (17 parameters). Each instrument alone sees
//! part of it: the laser the positioning errors; the tracer the positioning errors and the
//! squareness; the plate X's and Y's positioning and `EC0Y`; R-test and ball-bar the location
//! errors and the squareness. Checked:
//! - the joint fit recovers all 17 (noise-free to 1e-6 µm/µrad; noisy within 2.5 × u95);
//! - on every parameter its interval is no wider than the best single instrument's, and
//!   strictly narrower (below 0.97 ×) wherever two or more instruments each identify it alone
//!   (laser, tracer and plate on X's and Y's positioning; tracer, plate, R-test and ball-bar on
//!   the squareness; R-test and ball-bar on the location errors);
//! - the information account adds up, and credits most of each parameter to the instruments
//!   built for it (laser and tracer for positioning, R-test and ball-bar for the rotary axes'
//!   locations).

use mtcal_identify::information::account;
use mtcal_identify::{Identification, Study, identify_with_solution};
use mtcal_simulate::simulate;
use mtcal_solve::Silent;
use mtcal_testkit::plans::{RTEST, Run, ballbar, with_noise};
use mtcal_testkit::{FIVE_AXIS_TRUTH, TRUNNION, machine_file};
use std::path::{Path, PathBuf};

const ERRORS: &str = r#"schema = "mtcal.errors/1"
components = ["EXX", "EYY", "EZZ"]
locations = "iso"
[basis.linear]
kind = "legendre"
degree = 2
"#;

/// The example's eleven errors and the positioning errors of X, Y and Z (`P1`, `P2`).
fn truth() -> String {
    mtcal_testkit::params::values_file(&FIVE_AXIS_TRUTH)
        + "[component.EXX]\ncoefficients = [6.0, -3.0]\n\
           [component.EYY]\ncoefficients = [-4.0, 2.5]\n\
           [component.EZZ]\ncoefficients = [3.0, 1.5]\n"
}

/// Laser linear runs along X, Y and Z, one set-up each.
fn laser() -> String {
    let mut runs = String::new();
    for axis in ["x", "y", "z"] {
        runs += &format!(
            "[setup.laser-{axis}]\nmode = \"linear\"\ndirection = \"{}\"\nsigma_um = 0.3\n",
            axis.to_uppercase()
        );
    }
    for (axis, path) in [
        (
            "x",
            "{ axis = \"X\", from = -300.0, to = 300.0, points = 13, cycles = 2, hold = { Z = -250.0 } }",
        ),
        (
            "y",
            "{ axis = \"Y\", from = -350.0, to = 350.0, points = 13, cycles = 2, hold = { Z = -250.0 } }",
        ),
        (
            "z",
            "{ axis = \"Z\", from = -500.0, to = -50.0, points = 13, cycles = 2 }",
        ),
    ] {
        let name = format!("laser-{axis}");
        runs += &Run::new(&name, "laser", &name)
            .noise("NOISE_LASER")
            .path(path);
    }
    format!("\n{runs}")
}

/// A laser-tracer campaign: four stations, each measuring a 3 × 3 × 3 grid.
fn tracer() -> String {
    let mut runs = String::from(
        "\n[setup.st1]\nstation = [450.0, 450.0, -600.0]\n\
         [setup.st2]\nstation = [-450.0, 450.0, -500.0]\n\
         [setup.st3]\nstation = [-450.0, -450.0, -650.0]\n\
         [setup.st4]\nstation = [450.0, -450.0, -450.0]\n",
    );
    for k in 1..=4 {
        runs += &Run::new(&format!("tracer-{k}"), "tracer", &format!("st{k}"))
            .noise("NOISE_TRACER")
            .path("{ kind = \"grid\", counts = [3, 3, 3] }");
    }
    runs
}

/// A calibrated 5 × 5 hole plate (50 mm pitch, certificate ±0.5 µm) on the table, probed at
/// one placement; readings in mm (noise 0.5 µm).
fn plate() -> String {
    let mut s = String::from(
        "\n[setup.plate]\nsigma_um = 0.5\nfeature_sigma_um = 0.5\norigin = [0.0, 0.0, -300.0]\n\
         [setup.plate.features]\n",
    );
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (-100.0 + 50.0 * i as f64, -100.0 + 50.0 * j as f64);
            s += &format!("h{i}{j} = [{x:?}, {y:?}]\n");
        }
    }
    s + "[[run]]\nname = \"plate\"\ninstrument = \"artefact\"\nsetup = \"plate\"\n\
         noise = NOISE_PLATE\npath = { placements = [\"p1\"], repeat = 2 }\n"
}

/// Which instruments see which parameters (by this test's design; the account is checked
/// against it).
fn seen_by(name: &str) -> &'static [&'static str] {
    match name {
        n if n.starts_with("EXX") || n.starts_with("EYY") => &["laser", "tracer", "artefact"],
        n if n.starts_with("EZZ") => &["laser", "tracer"],
        "EC0Y" => &["tracer", "artefact", "rtest", "ballbar"],
        "EB0Z" | "EA0Z" => &["tracer", "rtest", "ballbar"],
        _ => &["rtest", "ballbar"],
    }
}

/// Simulates `runs` into `dir/<name>` on the trunnion with this test's error model.
fn session(dir: &Path, name: &str, runs: &str, noisy: bool) -> PathBuf {
    let machine = dir.join("m.urdf");
    if !machine.exists() {
        std::fs::copy(machine_file(TRUNNION), &machine).unwrap();
        std::fs::write(dir.join("m.errors.toml"), ERRORS).unwrap();
        std::fs::write(dir.join("truth.params.toml"), truth()).unwrap();
    }
    let scale = if noisy { 1.0 } else { 0.0 };
    let runs = with_noise(runs, 0.5 * scale, 1.0 * scale)
        .replace("NOISE_LASER", &format!("{:?}", 0.3 * scale))
        .replace("NOISE_TRACER", &format!("{:?}", 0.2 * scale))
        .replace("NOISE_PLATE", &format!("{:?}", 0.0005 * scale));
    let plan = format!(
        "machine = {machine:?}\ntruth = \"truth.params.toml\"\nseed = 3\n{runs}",
        machine = machine
    );
    let plan_path = dir.join(format!("{name}.toml"));
    std::fs::write(&plan_path, plan).unwrap();
    let out = dir.join(name);
    simulate(&plan_path, &out).unwrap();
    out
}

fn fit(s: &Path) -> (Study, Identification, mtcal_solve::Solution) {
    let study = Study::load(s).unwrap();
    let (id, sol) = identify_with_solution(&study, &Default::default(), &mut Silent).unwrap();
    assert!(id.solver.converged, "{}: {:?}", s.display(), id.solver);
    (study, id, sol)
}

fn u95(id: &Identification, name: &str) -> Option<f64> {
    id.parameters.iter().find(|p| p.name == name).map(|p| p.u95)
}

/// The instruments' runs, by instrument name.
fn instruments() -> Vec<(&'static str, String)> {
    vec![
        ("laser", laser()),
        ("tracer", tracer()),
        ("rtest", RTEST.to_string()),
        ("ballbar", ballbar()),
        ("artefact", plate()),
    ]
}

fn truth_of(name: &str) -> f64 {
    let t: toml::Table = toml::from_str(&truth()).unwrap();
    if let Some(v) = t["values"].get(name) {
        return v.as_float().unwrap();
    }
    let (comp, coeff) = name.split_once('.').unwrap();
    let k: usize = coeff[1..].parse().unwrap();
    t["component"][comp]["coefficients"].as_array().unwrap()[k - 1]
        .as_float()
        .unwrap()
}

#[test]
fn noise_free_joint_fit_recovers_every_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let all: String = instruments().into_iter().map(|(_, r)| r).collect();
    let (_, id, _) = fit(&session(dir.path(), "joint", &all, false));
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    let machine: Vec<_> = id
        .parameters
        .iter()
        .filter(|p| p.kind == "machine")
        .collect();
    assert_eq!(machine.len(), 17, "{machine:?}");
    for p in machine {
        let t = truth_of(&p.name);
        assert!(
            (p.value - t).abs() < 1e-6,
            "{}: {} vs truth {t}",
            p.name,
            p.value
        );
    }
}

#[test]
fn joint_intervals_beat_every_single_instrument() {
    let dir = tempfile::tempdir().unwrap();
    let singles: Vec<(&str, Identification)> = instruments()
        .into_iter()
        .map(|(inst, runs)| (inst, fit(&session(dir.path(), inst, &runs, true)).1))
        .collect();
    let all: String = instruments().into_iter().map(|(_, r)| r).collect();
    let (study, joint, sol) = fit(&session(dir.path(), "joint", &all, true));
    assert!(
        joint.unidentifiable.is_empty(),
        "{:?}",
        joint.unidentifiable
    );
    let acc = account(&study, &sol).unwrap();
    let mut report = String::new();
    for p in joint.parameters.iter().filter(|p| p.kind == "machine") {
        let t = truth_of(&p.name);
        assert!(
            (p.value - t).abs() < 2.5 * p.u95,
            "{}: {} ± {} vs truth {t}",
            p.name,
            p.value,
            p.u95
        );
        let alone: Vec<(&str, f64)> = singles
            .iter()
            .filter_map(|(inst, id)| u95(id, &p.name).map(|u| (*inst, u)))
            .collect();
        let best = alone.iter().map(|a| a.1).fold(f64::INFINITY, f64::min);
        assert!(
            p.u95 <= best * (1.0 + 1e-9),
            "{}: joint ±{} wider than the best single instrument ({alone:?})",
            p.name,
            p.u95
        );
        let expected: Vec<&str> = seen_by(&p.name)
            .iter()
            .copied()
            .filter(|i| singles.iter().any(|(s, _)| s == i))
            .collect();
        for inst in &expected {
            assert!(
                alone.iter().any(|(i, _)| i == inst),
                "{}: {inst} alone should identify it ({alone:?})",
                p.name
            );
        }
        if expected.len() >= 2 {
            assert!(
                p.u95 < 0.97 * best,
                "{}: seen by {expected:?} but the joint ±{} is not narrower than {best}",
                p.name,
                p.u95
            );
        }
        let shares = &acc
            .parameters
            .iter()
            .find(|a| a.name == p.name)
            .unwrap()
            .instruments;
        let total: f64 = shares.iter().map(|s| s.share).sum();
        assert!(
            (total - 1.0).abs() < 1e-9,
            "{}: shares sum to {total}",
            p.name
        );
        // The instruments built for a parameter carry most of what is known of it.
        let main: &[&str] = match p.name.as_str() {
            n if n.starts_with("EXX") || n.starts_with("EYY") || n.starts_with("EZZ") => {
                &["laser", "tracer"]
            }
            "EC0Y" | "EB0Z" | "EA0Z" => &["tracer", "rtest", "ballbar", "artefact"],
            _ => &["rtest", "ballbar"],
        };
        let carried: f64 = shares
            .iter()
            .filter(|s| main.contains(&s.instrument.as_str()))
            .map(|s| s.share)
            .sum();
        assert!(
            carried > 0.75,
            "{}: {main:?} carry only {carried:.3} ({shares:?})",
            p.name
        );
        report += &format!(
            "{:<8} joint ±{:.4}  alone {alone:?}  shares {:?}\n",
            p.name,
            p.u95,
            shares
                .iter()
                .map(|s| (s.instrument.as_str(), (s.share * 1000.0).round() / 1000.0))
                .collect::<Vec<_>>()
        );
    }
    eprintln!("{report}");
}
