//! The Monte Carlo of source 001 on the shipped ZFYX machine (MCV 754 Quick): 1000 sampled
//! machines, six rail-straightness tolerances of 30 µm (the source's baseline), an 11 × 11 × 11
//! grid, one thread, baseline only (no sensitivity runs) and with the default sensitivity levels.
//!
//! `cargo bench -p mtcal-tolerance --bench monte_carlo`

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_machine::topology::Reading;
use mtcal_tolerance::{Analysis, Options, parse_spec};
use std::hint::black_box;
use std::path::Path;

fn analysis(levels: &str) -> Analysis {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/three-axis");
    let machine = mtcal_machine::load_machine(
        root.join("machine/zfyx.urdf").to_str().unwrap(),
        Reading::FromTool,
    )
    .expect("shipped machine")
    .machine;
    let path = root.join("tolerances.toml");
    let text = std::fs::read_to_string(&path).expect("shipped spec");
    // Only the six rail tolerances, as in the source's baseline.
    let rails: String = text
        .split("[[tolerance]]")
        .enumerate()
        .filter(|(k, part)| *k == 0 || part.contains("kind = \"rail\""))
        .map(|(k, part)| {
            if k == 0 {
                part.to_string()
            } else {
                format!("[[tolerance]]{part}")
            }
        })
        .collect();
    let rails = rails.replace(
        "levels = [0.0, 0.5, 1.5, 2.0]",
        &format!("levels = {levels}"),
    );
    let spec = parse_spec(&rails, &path, &machine).expect("spec");
    assert_eq!(spec.tolerances.len(), 6);
    Analysis::new(&machine, &spec, &[11, 11, 11]).expect("analysis")
}

fn bench(c: &mut Criterion) {
    let opts = Options {
        samples: 1000,
        threads: 1,
        bootstrap: 0,
        ..Options::default()
    };
    let mut group = c.benchmark_group("monte_carlo_zfyx_1000_samples_11x11x11");
    group.sample_size(10);
    let base = analysis("[]");
    group.bench_function("baseline", |b| {
        b.iter(|| black_box(base.sample_maxima(&opts).unwrap()))
    });
    let sens = analysis("[0.0, 0.5, 1.5, 2.0]");
    group.bench_function("with_sensitivity_25_runs", |b| {
        b.iter(|| black_box(sens.sample_maxima(&opts).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
