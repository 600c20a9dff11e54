//! The per-sample loop allocates nothing: a `Sampler` allocates its scratch once, and drawing
//! samples with every run (baseline and sensitivity levels) then allocates no byte. A counting global allocator sees every allocation of this test binary, which holds this one
//! test only.

use mtcal_machine::topology::Reading;
use mtcal_tolerance::{Analysis, load_spec};
use peakmem_alloc::{INSTRUMENTED_SYSTEM, PeakMemAlloc, PeakMemAllocTrait};
use std::alloc::System;
use std::path::Path;

#[global_allocator]
static GLOBAL: &PeakMemAlloc<System> = &INSTRUMENTED_SYSTEM;

#[test]
fn sampling_allocates_nothing() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/three-axis");
    let machine = mtcal_machine::load_machine(
        root.join("machine/zfyx.urdf").to_str().unwrap(),
        Reading::FromTool,
    )
    .unwrap()
    .machine;
    let spec = load_spec(&root.join("tolerances.toml"), &machine).unwrap();
    let analysis = Analysis::new(&machine, &spec, &[4, 4, 3]).unwrap();
    let mut sampler = analysis.sampler();
    let mut row = vec![0.0; analysis.n_runs()];
    // Warm-up (anything lazily initialised), then count.
    sampler.sample(1, 0, &mut row);
    GLOBAL.reset_peak_memory();
    for i in 1..50 {
        sampler.sample(1, i, &mut row);
    }
    let during = GLOBAL.get_peak_memory();
    // The counter sees allocations (so the zero above means something).
    let probe = std::hint::black_box(vec![0u8; 4096]);
    let after = GLOBAL.get_peak_memory();
    drop(probe);
    assert!(row[0] > 0.0 && row.len() > 1);
    assert_eq!(
        during, 0,
        "{during} bytes allocated while sampling 49 machines"
    );
    assert!(
        after >= 4096,
        "the counting allocator missed a 4 kB allocation"
    );
}
