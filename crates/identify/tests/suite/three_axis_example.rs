//! The bundled three-axis example (`examples/three-axis`): a laser-tracer campaign and ISO 230-2
//! laser runs on the ZFYX machine. Identifying it (the session is what its plan simulates:
//! `examples.rs`) recovers the 21 errors of its truth within their intervals,
//! evaluates the laser runs by ISO 230-2, and predicts the validation run to the noise; the
//! physics search claims nothing in it and finds a backlash planted in the same campaign.

use mtcal_identify::identify_session;
use mtcal_simulate::simulate;
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/three-axis")
}

#[test]
fn the_example_recovers_its_truth_and_evaluates_the_laser_runs() {
    let (study, id) = identify_session(&example().join("session")).unwrap();
    assert!(id.solver.converged, "{:?}", id.solver);
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    let truth = mtcal_machine::params::load_params(
        &example().join("truth.params.toml"),
        study.model.errors(),
    )
    .unwrap();
    let labels = study.model.errors().coefficient_labels();
    let mut machine = 0;
    for p in id.parameters.iter().filter(|p| p.kind == "machine") {
        let k = labels.iter().position(|l| *l == p.name).unwrap();
        let t = truth[k] * 1e6;
        assert!(
            (p.value - t).abs() < 3.0 * p.u95,
            "{}: {} ± {} vs truth {t}",
            p.name,
            p.value,
            p.u95
        );
        machine += 1;
    }
    assert_eq!(machine, 33, "every coefficient of the 21 errors");
    for run in ["laser-x", "laser-y", "laser-z"] {
        let fit = id.fit.runs.iter().find(|r| r.name == run).unwrap();
        let a = fit
            .metrics
            .iter()
            .find(|m| m.name == "A (ISO 230-2)")
            .unwrap_or_else(|| panic!("{run}: {:?}", fit.metrics));
        assert!(a.value > 1.0 && a.value < 30.0, "{run}: A = {} um", a.value);
    }
    assert!(
        id.validation[0].rms_um < 0.3,
        "validation rms {}",
        id.validation[0].rms_um
    );
}

/// The physics search across the new instruments: the clean example claims nothing; the same
/// campaign with a 1.5 µm backlash of X planted (which biases EXX, EC0Y and a pitch through the
/// tracer's bidirectional grid) finds it, names it, and its value lies in its interval.
#[test]
fn the_search_finds_a_backlash_in_a_tracer_campaign_and_nothing_in_the_clean_one() {
    use mtcal_identify::Study;
    use mtcal_identify::search::{SearchOptions, search};
    let clean = search(
        Study::load(&example().join("session")).unwrap(),
        &SearchOptions::default(),
    )
    .unwrap();
    assert!(
        clean.findings.discoveries.is_empty(),
        "{:?}",
        clean.findings.discoveries
    );

    let dir = tempfile::tempdir().unwrap();
    let ex = example();
    let plan = std::fs::read_to_string(ex.join("plan.toml"))
        .unwrap()
        .replace(
            "machine = \"machine/zfyx.urdf\"",
            &format!("machine = {:?}", ex.join("machine/zfyx.urdf")),
        )
        .replace(
            "truth = \"truth.params.toml\"",
            &format!("truth = {:?}", ex.join("truth.params.toml")),
        )
        + "\n[[effect]]\neffect = \"reversal\"\naxis = \"X\"\nbacklash_um = 1.5\n";
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    simulate(&dir.path().join("plan.toml"), &dir.path().join("s")).unwrap();
    let found = search(
        Study::load(&dir.path().join("s")).unwrap(),
        &SearchOptions::default(),
    )
    .unwrap();
    let d = &found.findings.discoveries;
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(
        (d[0].effect.as_str(), d[0].axis.as_deref()),
        ("reversal", Some("X"))
    );
    let b = &d[0].parameters[0];
    let u = b.u95.unwrap();
    assert!((b.value - 1.5).abs() < u, "backlash {} ± {u}", b.value);
}
