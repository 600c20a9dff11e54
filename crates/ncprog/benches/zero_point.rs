//! Source 004's zero-point search on its 10,164-point grid (source 004: ≤ 40 s; target here
//! < 0.1 s): the map of the three-axis `mcv754-zfyx` with random errors of a few µm/µrad, and
//! 10,164 uniformly random error vectors.

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_kinematics::MachineModel;
use mtcal_kinematics::volmap::{Grid, MapOptions, volumetric_map};
use mtcal_ncprog::zero_point::{ErrorVectors, zero_point, zero_point_naive};
use mtcal_testkit::random::uniform;
use std::hint::black_box;

fn map_vectors() -> ErrorVectors {
    let path = mtcal_testkit::machine_file("mcv754-zfyx.urdf");
    let loaded =
        mtcal_machine::load_machine(path.to_str().unwrap(), Default::default()).expect("machine");
    let model = MachineModel::new(loaded.machine, &loaded.config).expect("model");
    let coeffs: Vec<f64> = uniform(7, model.n_coeffs())
        .iter()
        .map(|u| u * 5e-6)
        .collect();
    let grid = Grid::source004(model.machine()).expect("grid");
    let map = volumetric_map(&model, &coeffs, &grid, &MapOptions::default());
    ErrorVectors::new(map.translations_um())
}

fn bench(c: &mut Criterion) {
    let d = map_vectors();
    assert_eq!(d.len(), 10_164);
    c.bench_function("zero_point/source004_map_10164", |b| {
        b.iter(|| zero_point(black_box(&d)))
    });
    let mut group = c.benchmark_group("zero_point_reference");
    group.sample_size(10);
    group.bench_function("naive_source004_map_10164", |b| {
        b.iter(|| zero_point_naive(black_box(&d)))
    });
    group.finish();
    let u = uniform(11, 3 * 10_164);
    let raw: Vec<[f64; 3]> = u
        .chunks(3)
        .map(|c| [c[0] * 30.0, c[1] * 30.0, c[2] * 30.0])
        .collect();
    let d = ErrorVectors::new(&raw);
    c.bench_function("zero_point/uniform_10164", |b| {
        b.iter(|| zero_point(black_box(&d)))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
