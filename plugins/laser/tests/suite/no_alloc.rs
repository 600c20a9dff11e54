//! `predict` and `derivatives` run once per sample: they must not allocate (the nominal pose
//! at `q` comes from the set-up's own copy of the machine, on the stack). The counting allocator
//! (`allocation-counter`) counts this thread's allocations only, so the test harness's own threads
//! cannot make it fail.

use mtcal_instrument::{At, SetupContext};
use std::hint::black_box;

#[test]
fn predict_and_derivatives_do_not_allocate() {
    let mut checked = 0;
    for (name, machine) in mtcal_conformance::shipped_machines() {
        for seed in 0..10 {
            let Some(f) = mtcal_laser::fixture(&machine, seed) else {
                continue;
            };
            let setup =
                mtcal_laser::load_setup(&f.setup, &SetupContext { machine: &machine }).unwrap();
            let nn = setup.nuisance().len();
            let nuis = vec![1e-5; nn];
            let mut out = [0.0];
            let mut d_pose = [0.0; 6];
            let mut d_nuis = vec![0.0; nn];
            let poses: Vec<_> = f
                .poses
                .iter()
                .map(|q| machine.tool_in_workpiece(q))
                .collect();
            let mut evaluate = || {
                for (q, pose) in f.poses.iter().zip(&poses) {
                    let at = At {
                        q,
                        t: 0.0,
                        w_t_t: pose,
                        label: 0,
                    };
                    setup.predict(&at, &nuis, &mut out);
                    black_box(&out);
                    assert!(setup.derivatives(&at, &nuis, &mut d_pose, &mut d_nuis));
                    black_box(&d_pose);
                }
            };
            evaluate();
            let during = allocation_counter::measure(&mut evaluate).bytes_total;
            assert_eq!(during, 0, "{name}, seed {seed}: {during} bytes allocated");
            checked += 1;
        }
    }
    assert!(checked > 0);
    // The counter sees allocations (so the zero above means something).
    let probe = allocation_counter::measure(|| drop(black_box(vec![0u8; 4096])));
    assert!(probe.bytes_total >= 4096);
}
