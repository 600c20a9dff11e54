//! The conformance harness on every shipped machine with linear X, Y, Z axes along the
//! workpiece axes (all shipped machines: their fixtures hold the rotary axes at 0).

use mtcal_artefact as _;

#[test]
fn artefact_passes_the_conformance_harness() {
    let report =
        mtcal_conformance::try_check_plugin("artefact", 6).unwrap_or_else(|f| panic!("{f}"));
    // Every fixture has analytic derivatives, so the Jacobian check ran on all of them.
    assert_eq!(report.without_analytic, 0, "{report:?}");
    assert!(!report.machines.is_empty(), "{report:?}");
    eprintln!(
        "conformance: {} fixtures on {:?}",
        report.fixtures, report.machines
    );
}
