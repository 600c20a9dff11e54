//! The shared conformance harness, both head models (the fixture alternates them by seed).

#[test]
fn rtest_passes_the_conformance_harness() {
    let report = mtcal_conformance::try_check_plugin("rtest", 8).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.without_analytic, 0);
    // Every shipped machine with a rotary axis offers a fixture.
    let with_rotary: Vec<String> = mtcal_conformance::shipped_machines()
        .into_iter()
        .filter(|(_, m)| {
            m.axes()
                .iter()
                .any(|a| a.kind() == mtcal_kinematics::AxisKind::Rotary)
        })
        .map(|(n, _)| n)
        .collect();
    assert_eq!(report.machines, with_rotary);
}

#[test]
fn fixtures_alternate_the_head_models() {
    let (_, m) = mtcal_conformance::shipped_machines()
        .into_iter()
        .find(|(n, _)| n == "mcu630-cafyxz")
        .expect("shipped");
    for seed in 0..4 {
        let f = mtcal_rtest::fixture(&m, seed).expect("a fixture");
        let head = f
            .setup
            .get("head")
            .and_then(|v| v.as_str())
            .unwrap_or("ideal");
        assert_eq!(
            head,
            if seed % 2 == 0 {
                "ideal"
            } else {
                "three-sensor"
            }
        );
        assert!(f.poses.len() >= 20);
    }
}
