//! The per-sample loop allocates nothing: a `Sampler` allocates its scratch once, and drawing
//! samples with every run (baseline and sensitivity levels) then allocates no byte. The counting
//! allocator (`allocation-counter`) counts this thread's allocations only: the test harness's own
//! threads allocate while the test runs, and a global count once failed CI on their 900 bytes.

use mtcal_machine::topology::Reading;
use mtcal_tolerance::{Analysis, load_spec};
use std::hint::black_box;
use std::path::Path;

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
    let during = allocation_counter::measure(|| {
        for i in 1..50 {
            sampler.sample(1, i, &mut row);
        }
    });
    // The counter sees allocations (so the zero above means something).
    let probe = allocation_counter::measure(|| drop(black_box(vec![0u8; 4096])));
    assert!(row[0] > 0.0 && row.len() > 1);
    assert_eq!(
        during.bytes_total, 0,
        "{} bytes allocated while sampling 49 machines",
        during.bytes_total
    );
    assert!(
        probe.bytes_total >= 4096,
        "the counting allocator missed a 4 kB allocation"
    );
}
