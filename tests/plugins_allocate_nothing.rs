//! Every registered instrument plugin's `predict` and `derivatives` allocate nothing (they run
//! once per sample of every pass of every fit): on each shipped machine, at each pose of the
//! plugin's conformance fixtures, with nonzero nuisance values. The counting allocator
//! (`allocation-counter`) counts this thread's allocations only, so the test harness's own threads
//! cannot make it fail.

use mtcal_instrument::{At, SetupContext};
use std::hint::black_box;

#[test]
fn predict_and_derivatives_allocate_nothing() {
    let mut checked = Vec::new();
    for plugin in mtcal_plugins::plugins() {
        for (machine_name, machine) in mtcal_conformance::shipped_machines() {
            for seed in 0..3 {
                let Some(fixture) = (plugin.fixture)(&machine, seed) else {
                    continue;
                };
                let setup =
                    (plugin.load_setup)(&fixture.setup, &SetupContext { machine: &machine })
                        .unwrap_or_else(|e| panic!("{} on {machine_name}: {e}", plugin.name));
                let (nc, nn) = (setup.channels().len(), setup.nuisance().len());
                let labels: Vec<u32> = fixture
                    .labels
                    .iter()
                    .map(|v| {
                        let refs: Vec<&str> = v.iter().map(String::as_str).collect();
                        setup.resolve_label(&refs).unwrap()
                    })
                    .collect();
                let poses: Vec<_> = fixture
                    .poses
                    .iter()
                    .map(|q| machine.tool_in_workpiece(q))
                    .collect();
                let nuis: Vec<f64> = (0..nn).map(|k| 1e-5 * (k as f64 + 1.0)).collect();
                let mut out = vec![0.0; nc];
                let mut d_pose = vec![0.0; nc * 6];
                let mut d_nuis = vec![0.0; nc * nn];
                let pass = |out: &mut [f64], d_pose: &mut [f64], d_nuis: &mut [f64]| {
                    for (k, (q, pose)) in fixture.poses.iter().zip(&poses).enumerate() {
                        let at = At {
                            q,
                            t: k as f64,
                            w_t_t: pose,
                            label: labels.get(k).copied().unwrap_or(0),
                        };
                        setup.predict(&at, &nuis, out);
                        black_box(setup.derivatives(&at, &nuis, d_pose, d_nuis));
                    }
                };
                // Warm-up (anything lazily initialised), then count.
                pass(&mut out, &mut d_pose, &mut d_nuis);
                let grew = allocation_counter::measure(|| pass(&mut out, &mut d_pose, &mut d_nuis))
                    .bytes_total;
                assert_eq!(
                    grew, 0,
                    "{} on {machine_name} (seed {seed}): predict/derivatives allocated {grew} bytes",
                    plugin.name
                );
                checked.push(plugin.name);
            }
        }
    }
    checked.dedup();
    for name in mtcal_plugins::names() {
        assert!(
            checked.contains(&name),
            "{name} was never checked: no fixture on any machine"
        );
    }
}
