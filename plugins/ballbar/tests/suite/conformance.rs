//! The conformance harness every instrument plugin must pass.

#[test]
fn conformance() {
    mtcal_conformance::check_plugin("ballbar", 8);
}

#[test]
fn fixtures_on_every_shipped_machine() {
    // The harness only needs one machine with a fixture; the ball-bar fits on all of them.
    for (name, machine) in mtcal_conformance::shipped_machines() {
        for seed in 0..8 {
            assert!(
                mtcal_ballbar::fixture(&machine, seed).is_some(),
                "{name}: no fixture for seed {seed}"
            );
        }
    }
}
