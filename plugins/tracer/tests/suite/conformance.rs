//! The shared conformance harness over every shipped machine.

// Links the plugin (inventory drops crates nobody names).
use mtcal_tracer as _;

#[test]
fn tracer_passes_the_conformance_harness() {
    let report = mtcal_conformance::try_check_plugin("tracer", 8).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.without_analytic, 0);
    // Every shipped machine has linear X, Y and Z axes: each must offer a fixture.
    let all: Vec<String> = mtcal_conformance::shipped_machines()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(report.machines, all);
    assert_eq!(report.fixtures, 8 * all.len());
}
