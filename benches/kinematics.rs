//! Hot paths of the kinematic error model on the shipped five-axis trunnion (MCU 630, CAFYXZ)
//! with the full error set: 8 rotary location errors + 3 squareness + 30 component errors as
//! cubic Legendre polynomials.
//!
//! `cargo bench --bench kinematics`; the numbers go in the README.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mtcal::kinematics::model::iso_full_config;
use mtcal::kinematics::volmap::{Grid, MapOptions, volumetric_map};
use mtcal::kinematics::{BasisChoice, MachineModel};
use std::hint::black_box;
use std::path::Path;

fn trunnion() -> (MachineModel, Vec<f64>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("machines/mcu630-cafyxz.urdf");
    let machine = mtcal::machine::urdf::load_urdf_file(&path).expect("shipped machine loads");
    let cubic = BasisChoice::Legendre { degree: 3 };
    let config = iso_full_config(&machine, &cubic, &cubic).expect("ISO model");
    let model = MachineModel::new(machine, &config).expect("model");
    // Deterministic, µm-sized coefficients.
    let coeffs = (0..model.n_coeffs())
        .map(|k| 1e-6 * (((k * 7919) % 41) as f64 - 20.0))
        .collect();
    (model, coeffs)
}

/// Axis positions spread over the strokes, cycling through a fixed set.
fn poses(model: &MachineModel, n: usize) -> Vec<Vec<f64>> {
    (0..n)
        .map(|i| {
            model
                .machine()
                .axes()
                .iter()
                .enumerate()
                .map(|(a, ax)| {
                    let (lo, hi) = ax.limits().unwrap_or((-3.0, 3.0));
                    let t = ((i * (a + 3) * 37) % 101) as f64 / 100.0;
                    lo + (hi - lo) * t
                })
                .collect()
        })
        .collect()
}

fn bench_pose_error(c: &mut Criterion) {
    let (model, coeffs) = trunnion();
    let qs = poses(&model, 256);
    let mut ws = model.workspace();
    let mut jac = vec![0.0; 6 * model.n_coeffs()];
    let mut g = c.benchmark_group("trunnion_full_error_set");
    g.throughput(Throughput::Elements(qs.len() as u64));
    g.bench_function("pose_error_first_order", |b| {
        b.iter(|| {
            for q in &qs {
                black_box(model.pose_error_first_order(black_box(q), &coeffs, &mut ws));
            }
        })
    });
    g.bench_function("pose_error_exact", |b| {
        b.iter(|| {
            for q in &qs {
                black_box(model.pose_error(black_box(q), &coeffs, &mut ws));
            }
        })
    });
    // The same poses batched (lanes = poses, AVX2 + FMA kernel when the processor has it).
    let flat: Vec<f64> = qs.iter().flatten().copied().collect();
    let mut bws = model.batch_workspace();
    let mut out = vec![[0.0; 6]; qs.len()];
    g.bench_function("pose_errors_first_order_batched", |b| {
        b.iter(|| model.pose_errors_first_order(black_box(&flat), &coeffs, &mut bws, &mut out))
    });
    g.bench_function("pose_errors_exact_batched", |b| {
        b.iter(|| model.pose_errors(black_box(&flat), &coeffs, &mut bws, &mut out))
    });
    g.bench_function("pose_error_with_full_jacobian", |b| {
        b.iter(|| {
            for q in &qs {
                black_box(model.pose_error_jacobian(black_box(q), &coeffs, &mut ws, &mut jac));
            }
        })
    });
    g.finish();
}

fn bench_volumetric_map(c: &mut Criterion) {
    let (model, coeffs) = trunnion();
    let grid = Grid::source004(model.machine()).expect("grid");
    let opts = MapOptions::default();
    c.bench_function("volumetric_map_10164_points", |b| {
        b.iter(|| black_box(volumetric_map(&model, &coeffs, &grid, &opts)))
    });
}

criterion_group!(benches, bench_pose_error, bench_volumetric_map);
criterion_main!(benches);
