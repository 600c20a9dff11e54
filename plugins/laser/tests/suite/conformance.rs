//! The shared conformance harness over every shipped machine.

// Links the plugin (inventory drops crates nobody names).
use mtcal_laser as _;

#[test]
fn laser_passes_the_conformance_harness() {
    // Seeds 0..10 cover every mode twice (seed mod 5), both optics and every offset.
    let report = mtcal_conformance::try_check_plugin("laser", 10).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.without_analytic, 0);
    // Every shipped machine has linear axes: each must offer a fixture for every seed.
    let all: Vec<String> = mtcal_conformance::shipped_machines()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(report.machines, all);
    assert_eq!(report.fixtures, 10 * all.len());
}

#[test]
fn fixtures_exercise_every_mode_both_optics_offsets_and_the_environment() {
    use mtcal_laser::{Mode, Optic};
    for (name, machine) in mtcal_conformance::shipped_machines() {
        let mut modes = Vec::new();
        let (mut table, mut offset, mut env, mut overrun) = (false, false, false, false);
        for seed in 0..10 {
            let f = mtcal_laser::fixture(&machine, seed)
                .unwrap_or_else(|| panic!("{name}: no fixture for seed {seed}"));
            let ctx = mtcal_instrument::SetupContext { machine: &machine };
            let s = mtcal_laser::load(&f.setup, &ctx).expect("the fixture loads");
            if !modes.contains(&s.mode()) {
                modes.push(s.mode());
            }
            table |= s.optic() == Optic::Table;
            offset |= s.optic_offset_m().norm() > 0.0;
            env |= s.environment().active();
            overrun |= f.setup.get("mode").and_then(|m| m.as_str()) == Some("linear")
                && f.poses.len() > 2 * 4 * 2;
        }
        assert_eq!(modes.len(), 5, "{name}: {modes:?}");
        assert!(modes.contains(&Mode::StepDiagonal));
        assert!(table && offset && env && overrun, "{name}");
    }
}
