//! The bundled three-axis example (`examples/three-axis`): a laser-tracer campaign and ISO 230-2
//! laser runs on the ZFYX machine. The shipped session is what its plan simulates (so it cannot
//! go stale), and identifying it recovers the 21 errors of its truth within their intervals,
//! evaluates the laser runs by ISO 230-2, and predicts the validation run to the noise.

use mtcal_identify::{identify_session, simulate::simulate};
// Links every instrument plugin (inventory drops crates nobody names).
use mtcal_plugins as _;
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/three-axis")
}

#[test]
fn the_shipped_session_is_what_its_plan_simulates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    simulate(&example().join("plan.toml"), &out).unwrap();
    let shipped = example().join("session");
    let mut names: Vec<String> = std::fs::read_dir(&shipped)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".csv") || n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 17, "{names:?}");
    for name in names {
        let a = std::fs::read(shipped.join(&name)).unwrap();
        let b = std::fs::read(out.join(&name)).unwrap();
        assert!(
            a == b,
            "{name} differs from a fresh simulation of plan.toml"
        );
    }
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
