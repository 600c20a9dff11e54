//! The shared conformance harness over every shipped machine.

#[test]
fn displacement_passes_the_conformance_harness() {
    let report =
        mtcal_conformance::try_check_plugin("displacement", 8).unwrap_or_else(|f| panic!("{f}"));
    // Every fixture has analytic derivatives, so the Jacobian check ran on all of them.
    assert_eq!(report.without_analytic, 0);
    // A machine held still fits every machine: each shipped one must offer a fixture.
    let all: Vec<String> = mtcal_conformance::shipped_machines()
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    assert_eq!(report.machines, all);
    assert_eq!(report.fixtures, 8 * all.len());
}

#[test]
fn fixtures_exercise_every_kind_of_sensor_and_a_tilted_tool() {
    use mtcal_instrument::Setup;
    for (name, machine) in mtcal_conformance::shipped_machines() {
        let mut tilted = false;
        for seed in 0..8 {
            let f = mtcal_displacement::fixture(&machine, seed)
                .unwrap_or_else(|| panic!("{name}: no fixture for seed {seed}"));
            let ctx = mtcal_instrument::SetupContext { machine: &machine };
            let s = mtcal_displacement::load(&f.setup, &ctx).expect("the fixture loads");
            let sensors = s.sensors();
            assert!(sensors.iter().any(|s| s.direction().is_none()), "{name}");
            assert!(sensors.iter().any(|s| s.at_m().norm() > 0.0), "{name}");
            assert!(
                sensors.iter().any(|s| matches!(
                    s.direction(),
                    Some(mtcal_displacement::SensorDirection::Vector(_))
                )),
                "{name}"
            );
            assert!(s.touches().orientation && s.touches().position);
            let r = machine.tool_in_workpiece(&f.poses[0]).r;
            tilted |= (r - nalgebra::Matrix3::identity()).norm() > 1e-3;
        }
        let has_rotary = machine
            .axes()
            .iter()
            .any(|a| a.kind() == mtcal_kinematics::AxisKind::Rotary);
        // Seeds 3 and 7 tilt the rotary axes, so the aligned-frame check meets a turned tool.
        assert!(
            tilted || !has_rotary,
            "{name}: no fixture turns the tool although the machine has rotary axes"
        );
    }
}
