//! Ball-bar circles in the XY, YZ and ZX planes identify the three squareness errors (`EC0Y`,
//! `EB0Z`, `EA0Z`) *and* the scale mismatch of the three linear axes: the linear term of the
//! positioning errors `EXX`, `EYY`, `EZZ`.
//!
//! The error model is the machine's own (`machines/mcu630-cafyxz.urdf`) with a small
//! `.errors.toml` written beside a copy of the URDF: the ISO location errors plus `EXX`, `EYY`,
//! `EZZ` as Legendre polynomials of degree 1 only. A positioning error has no constant term
//! (the set-up offsets carry it), so each is the single coefficient `P1`: the error in µm at the
//! positive end of the stroke, `P1(u) = u`, `u = 2(q − lo)/(hi − lo) − 1`. A scale error of `s`
//! µm/m is therefore `P1 = s · (hi − lo)/2` (m).
//!
//! What a circle sees (pivot at `p`, bar length `L`, angle `φ` in the plane `e1, e2`): with
//! scale errors `s1`, `s2` of the two axes and the squareness `ε` between them, the bar changes
//! by `L·(s1 cos²φ + s2 sin²φ ± ε sinφ cosφ)` (+ the pivot offsets, `cos φ`, `sin φ`). The
//! `cos 2φ` term gives `s1 − s2`, the `sin 2φ` term the squareness, and the constant the mean
//! scale `(s1 + s2)/2` — but only because the bar length is calibrated (ISO 230-4; ball-bar
//! set-ups default to `length_free = false`). With a free bar length the constant is a
//! bar-length error as well: the three circles then give the three differences `sX − sY`,
//! `sY − sZ`, `sZ − sX` (two independent) and the common scale `sX = sY = sZ` is not
//! separable from the bar length; more radii do not help, since every bar (or extension) has
//! its own length error. The second test shows that the identification says so.
//!
//! The tool-length offset of the spindle ball is held: with the rotary axes at rest it moves
//! the ball along Z exactly as the pivot's Z offset does, so the two cannot be told apart.

use mtcal_identify::{Identification, identify_session};
use mtcal_kinematics::model::Role;
use mtcal_simulate::simulate;
use mtcal_testkit::{FIVE_AXIS_TRUTH, TRUNNION, machine_file};
use std::path::Path;

/// The error model: ISO location and squareness errors, and positioning errors that are pure
/// scale (Legendre degree 1).
const ERRORS: &str = r#"schema = "mtcal.errors/1"
components = ["EXX", "EYY", "EZZ"]
locations = "iso"

[basis.linear]
kind = "legendre"
degree = 1
"#;

/// Squareness of the truth, µrad.
const SQUARENESS: [(&str, f64); 3] = [("EC0Y", 12.0), ("EB0Z", -8.0), ("EA0Z", 15.0)];

/// Scale errors of the truth, µm/m.
const SCALE: [(&str, f64); 3] = [("EXX", 20.0), ("EYY", -15.0), ("EZZ", 10.0)];

/// Strokes of X, Y and Z of the MCU 630 (mm): the Legendre basis spans them.
const STROKES: [(&str, f64, f64); 3] = [
    ("EXX", -350.0, 350.0),
    ("EYY", -410.0, 410.0),
    ("EZZ", -550.0, 0.0),
];

/// The `P1` coefficient (µm) of a scale error of `ppm` µm/m over the stroke of `name`.
fn p1_of_scale(name: &str, ppm: f64) -> f64 {
    let (_, lo, hi) = STROKES.iter().find(|(n, ..)| *n == name).unwrap();
    ppm * (hi - lo) * 1e-3 / 2.0
}

/// Circles of radius 100 mm about one pivot (`ballbar_circle_runs`), its bar length free or
/// calibrated (`LENGTH_FREE`), the tool length held.
fn runs() -> String {
    "\n[setup.bar]\npivot = [0.0, 0.0, 250.0]\nlength = 100.0\nlength_free = LENGTH_FREE\n\
     tool_length_free = false\n"
        .to_string()
        + &mtcal_testkit::plans::ballbar_circle_runs("", "bar", "NOISE")
}

/// Simulates the three circles on the scale-error machine into `dir/s` and identifies them.
fn identify_circles(dir: &Path, noise: f64, length_free: bool) -> Identification {
    let urdf = dir.join("mcu630.urdf");
    std::fs::copy(machine_file(TRUNNION), &urdf).unwrap();
    std::fs::write(dir.join("mcu630.errors.toml"), ERRORS).unwrap();
    // Rotary location errors of the truth too: at A = C = 0 the circles see them only as a
    // displaced pivot, which is fitted.
    let mut truth = mtcal_testkit::params::values_file(&FIVE_AXIS_TRUTH);
    for (name, ppm) in SCALE {
        truth += &format!(
            "[component.{name}]\ncoefficients = [{}]\n",
            p1_of_scale(name, ppm)
        );
    }
    std::fs::write(dir.join("truth.params.toml"), truth).unwrap();
    let runs = runs()
        .replace("NOISE", &format!("{noise:?}"))
        .replace("LENGTH_FREE", &length_free.to_string());
    let plan = format!(
        "machine = \"mcu630.urdf\"\ntruth = \"truth.params.toml\"\nseed = 5\n\
         [identify]\nparameters = [\"EC0Y\", \"EB0Z\", \"EA0Z\", \"EXX\", \"EYY\", \"EZZ\"]\n{runs}"
    );
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    simulate(&dir.join("plan.toml"), &dir.join("s")).unwrap();
    let (study, id) = identify_session(&dir.join("s")).unwrap();
    // The convention of `p1_of_scale`: the model's basis spans the axis stroke.
    for (name, lo, hi) in STROKES {
        let p = study.model.errors().find(&name.parse().unwrap()).unwrap();
        let Role::Component { basis, .. } = &p.role else {
            panic!("{name} is not a component error")
        };
        let (blo, bhi) = basis.stroke().unwrap();
        assert!(
            (blo * 1e3 - lo).abs() < 1e-9 && (bhi * 1e3 - hi).abs() < 1e-9,
            "{name}: stroke {blo}..{bhi} m"
        );
        assert_eq!(basis.labels(), vec!["P1".to_string()], "{name}");
    }
    id
}

/// Every truth value by its name in the report (µm, µrad).
fn truth() -> Vec<(String, f64)> {
    SQUARENESS
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .chain(
            SCALE
                .iter()
                .map(|(n, ppm)| (format!("{n}.P1"), p1_of_scale(n, *ppm))),
        )
        .collect()
}

#[test]
fn ballbar_circles_in_three_planes_recover_squareness_and_scale() {
    let dir = tempfile::tempdir().unwrap();
    let id = identify_circles(dir.path(), 0.0, false);
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    for (name, t) in truth() {
        let p = id
            .parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} not identified: {:?}", id.parameters));
        assert!(
            (p.value - t).abs() < 1e-3,
            "{name}: {} vs truth {t}",
            p.value
        );
    }
    assert!(id.fit.rms_um < 1e-6, "noise-free fit rms {}", id.fit.rms_um);
}

#[test]
fn noisy_ballbar_circles_bracket_the_truth_with_their_intervals() {
    let dir = tempfile::tempdir().unwrap();
    let id = identify_circles(dir.path(), 1.0, false);
    assert!(id.solver.converged, "{:?}", id.solver);
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    for (name, t) in truth() {
        let p = id.parameters.iter().find(|p| p.name == name).unwrap();
        assert!(
            (p.value - t).abs() <= p.u95,
            "{name}: {} ± {} vs truth {t}",
            p.value,
            p.u95
        );
    }
}

#[test]
fn a_free_bar_length_leaves_the_common_scale_unidentified_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let id = identify_circles(dir.path(), 0.0, true);
    let named: Vec<&str> = id
        .unidentifiable
        .iter()
        .flat_map(|u| &u.parameters)
        .map(String::as_str)
        .collect();
    for n in ["EXX.P1", "EYY.P1", "EZZ.P1", "bar.length"] {
        assert!(named.contains(&n), "{n} not named: {:?}", id.unidentifiable);
    }
    // The squareness errors do not depend on the bar length.
    for (name, t) in SQUARENESS {
        let p = id.parameters.iter().find(|p| p.name == name).unwrap();
        assert!(
            (p.value - t).abs() < 1e-3,
            "{name}: {} vs truth {t}",
            p.value
        );
    }
    for n in ["EXX.P1", "EYY.P1", "EZZ.P1"] {
        assert!(
            id.parameters.iter().all(|p| p.name != n),
            "{n} is unidentifiable but was given a value"
        );
    }
}
