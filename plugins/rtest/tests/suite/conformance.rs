//! The shared conformance harness on both mounts and both head models (the registered fixture
//! varies them with the seed; the second test forces each mount on every seed).

use mtcal_kinematics::{AxisKind, Machine};
use mtcal_rtest::{Mount, fixture_mount, fixture_with_mount};
use std::collections::BTreeSet;

fn with_rotary() -> Vec<(String, Machine)> {
    mtcal_conformance::shipped_machines()
        .into_iter()
        .filter(|(_, m)| m.axes().iter().any(|a| a.kind() == AxisKind::Rotary))
        .collect()
}

fn head_of(setup: &toml::Table) -> &str {
    setup
        .get("head")
        .and_then(|v| v.as_str())
        .unwrap_or("ideal")
}

#[test]
fn rtest_passes_the_conformance_harness() {
    let report = mtcal_conformance::try_check_plugin("rtest", 8).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.without_analytic, 0);
    // Every shipped machine with a rotary axis offers a fixture.
    let names: Vec<String> = with_rotary().into_iter().map(|(n, _)| n).collect();
    assert_eq!(report.machines, names);
}

#[test]
fn both_mounts_with_both_heads_pass_on_every_shipped_machine() {
    let plugin = mtcal_instrument::find("rtest").expect("registered");
    let machines = with_rotary();
    assert!(!machines.is_empty());
    for (name, m) in &machines {
        let mut seen = BTreeSet::new();
        for mount in Mount::ALL {
            for seed in 0..8 {
                let f = fixture_with_mount(m, seed, mount)
                    .unwrap_or_else(|| panic!("{name}: no fixture for seed {seed}, {mount:?}"));
                assert_eq!(
                    f.setup.get("mount").and_then(|v| v.as_str()),
                    Some(mount.as_str())
                );
                let analytic = mtcal_conformance::check_fixture(plugin, name, m, seed, &f)
                    .unwrap_or_else(|e| panic!("{mount:?}: {e}"));
                assert!(analytic, "{name} seed {seed} {mount:?}");
                seen.insert((mount.as_str(), head_of(&f.setup).to_string()));
            }
        }
        assert_eq!(seen.len(), 4, "{name}: {seen:?}");
    }
}

#[test]
fn fixtures_alternate_the_head_models_and_the_mounts() {
    let (_, m) = mtcal_conformance::shipped_machines()
        .into_iter()
        .find(|(n, _)| n == "mcu630-cafyxz")
        .expect("shipped");
    let mut pairs = BTreeSet::new();
    for seed in 0..8 {
        let f = mtcal_rtest::fixture(&m, seed).expect("a fixture");
        let head = head_of(&f.setup);
        assert_eq!(
            head,
            if seed % 2 == 0 {
                "ideal"
            } else {
                "three-sensor"
            }
        );
        let mount = f
            .setup
            .get("mount")
            .and_then(|v| v.as_str())
            .expect("mount");
        assert_eq!(mount, fixture_mount(seed).as_str());
        pairs.insert((head.to_string(), mount.to_string()));
        assert!(f.poses.len() >= 20);
    }
    // The registered harness (seeds 0..8) sees every head on every mount.
    assert_eq!(pairs.len(), 4, "{pairs:?}");
}
