//! Planted-truth tests of the whole identification: simulate a session from a known machine,
//! identify it, compare with the truth.

use crate::common;

use common::planted::TRUTH;
use mtcal_identify::{Identification, identify_session};
use mtcal_simulate::simulate;
use mtcal_testkit::plans::Run;
use mtcal_testkit::{ELEVEN, TRUNNION, five_axis_truth_file, machine_file, repo};
use std::path::{Path, PathBuf};

/// Writes a plan into `dir` and simulates it into `dir/session`.
fn session(dir: &Path, setups_and_runs: &str, noise: f64) -> PathBuf {
    let machine = machine_file(TRUNNION);
    let truth = five_axis_truth_file();
    let runs = setups_and_runs.replace("NOISE", &format!("{noise}"));
    let eleven = mtcal_testkit::params::toml_list(&ELEVEN);
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth:?}\nseed = 11\n[identify]\nparameters = {eleven}\n{runs}"
    );
    let plan_path = dir.join("plan.toml");
    std::fs::write(&plan_path, plan).unwrap();
    let out = dir.join("session");
    simulate(&plan_path, &out).unwrap();
    out
}

/// The R-test runs (`mtcal_testkit::plans::rtest_low_high`) and a validation path through all five
/// axes; `NOISE` stands for each run's noise.
fn rtest_plan() -> String {
    mtcal_testkit::plans::rtest_low_high(37, 31, Some("NOISE"))
        + &Run::new("xyzac", "rtest", "low")
            .validation()
            .noise("NOISE")
            .path("{ kind = \"xyzac\", samples = 49 }")
}

fn value(id: &Identification, name: &str) -> Option<f64> {
    id.parameters
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.value)
}

#[test]
fn noise_free_rtest_recovers_the_eleven_errors_and_predicts_the_validation_path() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(dir.path(), &rtest_plan(), 0.0);
    let (_, id) = identify_session(&s).unwrap();
    // With the set-up calibrated (ball and tool length held), this plan separates all eleven.
    for (name, truth) in TRUTH {
        let v = value(&id, name)
            .unwrap_or_else(|| panic!("{name} not identified: {:?}", id.unidentifiable));
        assert!((v - truth).abs() < 1e-6, "{name}: {v} vs truth {truth}");
    }
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    assert!(id.fit.rms_um < 1e-6, "noise-free fit rms {}", id.fit.rms_um);
    assert_eq!(id.validation.len(), 1);
    assert!(
        id.validation[0].rms_um < 1e-6,
        "validation predicted to {} um",
        id.validation[0].rms_um
    );
}

#[test]
fn noisy_rtest_predicts_validation_within_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(dir.path(), &rtest_plan(), 0.5);
    let (_, id) = identify_session(&s).unwrap();
    assert!(id.solver.converged, "{:?}", id.solver);
    let v = id.validation[0].rms_um;
    assert!(v < 0.7, "validation rms {v} um with 0.5 um noise");
    assert!(
        (id.fit.chi2_reduced - 1.0).abs() < 0.2,
        "chi2/dof {}",
        id.fit.chi2_reduced
    );
    // Every identified parameter lies within a few of its intervals of the truth.
    for (name, truth) in TRUTH {
        if let Some(p) = id.parameters.iter().find(|p| p.name == name) {
            assert!(
                (p.value - truth).abs() < 2.5 * p.u95,
                "{name}: {} ± {} vs {truth}",
                p.value,
                p.u95
            );
        }
    }
}

#[test]
fn one_xyc_circle_cannot_separate_everything_and_says_so() {
    let plan = r#"
[setup.low]
ball = [100.0, 0.0, 200.0]
[[run]]
name = "xyc-a0"
instrument = "rtest"
setup = "low"
noise = NOISE
path = { kind = "xyc", samples = 37 }
"#;
    let dir = tempfile::tempdir().unwrap();
    let s = session(dir.path(), plan, 0.0);
    let (_, id) = identify_session(&s).unwrap();
    assert!(
        !id.unidentifiable.is_empty(),
        "an under-determined plan names combinations"
    );
    for u in &id.unidentifiable {
        for p in &u.parameters {
            assert!(
                id.parameters.iter().all(|q| &q.name != p),
                "{p} is unidentifiable but was given a value"
            );
        }
    }
    // Circles in one plane at A = 0 cannot see the tilt of Z towards Y and X alone.
    let named: Vec<&String> = id
        .unidentifiable
        .iter()
        .flat_map(|u| &u.parameters)
        .collect();
    assert!(
        named
            .iter()
            .any(|n| n.as_str() == "EZ0A" || n.as_str() == "EY0A"),
        "{named:?}"
    );
}

#[test]
fn ballbar_circles_in_three_planes_recover_squareness() {
    let plan = r#"
[identify]
[setup.bar]
pivot = [0.0, 0.0, 250.0]
length = 100.0
[[run]]
name = "xy"
instrument = "ballbar"
setup = "bar"
noise = NOISE
path = { kind = "circle", plane = "XY", samples = 90 }
[[run]]
name = "yz"
instrument = "ballbar"
setup = "bar"
noise = NOISE
path = { kind = "circle", plane = "YZ", samples = 90, start_deg = -90.0, sweep_deg = 180.0 }
[[run]]
name = "zx"
instrument = "ballbar"
setup = "bar"
noise = NOISE
path = { kind = "circle", plane = "ZX", samples = 90, start_deg = 0.0, sweep_deg = 180.0 }
"#
    .replace("[identify]\n", "");
    let dir = tempfile::tempdir().unwrap();
    // Only the squareness errors are estimated.
    let machine = machine_file(TRUNNION);
    let truth = five_axis_truth_file();
    let text = format!(
        "machine = {machine:?}\ntruth = {truth:?}\n[identify]\nparameters = [\"EC0Y\", \"EB0Z\", \"EA0Z\"]\n{}",
        plan.replace("NOISE", "0.0")
    );
    std::fs::write(dir.path().join("plan.toml"), text).unwrap();
    // The truth has location errors too; the ball-bar circles at A = C = 0 do not see them
    // except as pivot offsets, which are fitted.
    simulate(&dir.path().join("plan.toml"), &dir.path().join("s")).unwrap();
    let (_, id) = identify_session(&dir.path().join("s")).unwrap();
    for (name, truth) in [("EC0Y", 12.0), ("EB0Z", -8.0), ("EA0Z", 15.0)] {
        let v = value(&id, name)
            .unwrap_or_else(|| panic!("{name} not identified: {:?}", id.unidentifiable));
        assert!((v - truth).abs() < 1e-3, "{name}: {v} vs {truth}");
    }
}

/// The five-axis ball-bar tests about calibrated pivots (`ballbar_rotary_runs`).
fn five_axis_ballbar() -> String {
    format!(
        "\n{}{}",
        mtcal_testkit::plans::BALLBAR_PIVOTS,
        mtcal_testkit::plans::ballbar_rotary_runs("", "NOISE", true)
    )
}

#[test]
fn five_axis_ballbar_tests_recover_the_rotary_location_errors() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(dir.path(), &five_axis_ballbar(), 0.0);
    let (_, id) = identify_session(&s).unwrap();
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    for (name, truth) in TRUTH {
        let v = value(&id, name).unwrap();
        assert!((v - truth).abs() < 1e-6, "{name}: {v} vs truth {truth}");
    }
}

#[test]
fn the_bundled_mixed_session_identifies_and_predicts_its_validation_run() {
    // examples/five-axis: R-test and ball-bar runs with free set-ups and 0.5 / 1 µm noise.
    let (_, id) = identify_session(&repo().join("examples/five-axis/session")).unwrap();
    assert!(id.solver.converged, "{:?}", id.solver);
    let instruments: Vec<&str> = id.fit.runs.iter().map(|r| r.instrument.as_str()).collect();
    assert!(instruments.contains(&"rtest") && instruments.contains(&"ballbar"));
    assert!(
        id.validation[0].rms_um < 0.7,
        "validation rms {}",
        id.validation[0].rms_um
    );
    assert!(
        (id.fit.chi2_reduced - 1.0).abs() < 0.2,
        "chi2/dof {}",
        id.fit.chi2_reduced
    );
    for p in &id.parameters {
        if let Some((_, t)) = TRUTH.iter().find(|(n, _)| *n == p.name) {
            assert!(
                (p.value - t).abs() < 2.5 * p.u95,
                "{}: {} ± {} vs {t}",
                p.name,
                p.value,
                p.u95
            );
        }
    }
    // Nothing the data cannot separate gets a value.
    for u in &id.unidentifiable {
        assert!(
            u.parameters
                .iter()
                .all(|n| id.parameters.iter().all(|p| &p.name != n))
        );
    }
}

#[test]
fn simulate_writes_nc_programs_that_keep_the_tool_point_on_the_ball() {
    let dir = tempfile::tempdir().unwrap();
    let s = session(dir.path(), &rtest_plan(), 0.0);
    let text = std::fs::read_to_string(s.join("programs/xyc-a+30.nc")).unwrap();
    let machine = mtcal_machine::urdf::load_urdf_file(&machine_file(TRUNNION)).unwrap();
    let letters: Vec<char> = machine
        .axes()
        .iter()
        .map(|a| a.letter().as_char())
        .collect();
    let mut moves = 0;
    for line in text.lines().filter(|l| l.contains("G01")) {
        let mut q = vec![f64::NAN; letters.len()];
        for word in line.split_whitespace() {
            let (c, v) = word.split_at(1);
            if let Some(i) = letters.iter().position(|l| l.to_string() == c) {
                let v: f64 = v.parse().unwrap();
                let ax = &machine.axes()[i];
                q[i] = ax.kind().from_file(v);
            }
        }
        let p = machine.tool_in_workpiece(&q).t * 1e3;
        // 4 decimals in the program: the tool point is on the ball to ~0.1 µm.
        assert!(
            (p - nalgebra::Vector3::new(100.0, 0.0, 200.0)).norm() < 2e-4,
            "{line}: {p}"
        );
        moves += 1;
    }
    assert_eq!(moves, 37);
}
