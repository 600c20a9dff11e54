//! The trend of one parameter over 500 campaigns (the budget: 50 ms with the
//! database read), and one same-day thermal fit.

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_trend::{Point, ThermalOptions, Tolerance, TrendOptions, analyse, fit_thermal};
use std::hint::black_box;

/// A deterministic noisy series (no random-number crate needed here): a drift plus a
/// pseudo-random wobble of about U/2.
fn campaigns(n: usize) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let wobble = ((i as f64 + 1.0) * 12.9898).sin() * 43_758.545_3 % 1.0;
            Point::new(
                1.7e9 + 30.0 * 86_400.0 * i as f64,
                8.0 + 0.001 * i as f64 + wobble,
                2.0,
            )
        })
        .collect()
}

fn checks() -> Vec<Point> {
    (0..12)
        .map(|i| {
            let t = 1309.0 * i as f64;
            let wobble = ((i as f64 + 1.0) * 78.233).sin() * 0.8;
            Point::new(1.7e9 + t, -3.0 + 12.0 * (-t / 2700.0).exp() + wobble, 2.0)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let series = campaigns(500);
    let options = TrendOptions {
        tolerance: Some(Tolerance {
            limit: 20.0,
            guard_band: true,
        }),
        ..Default::default()
    };
    c.bench_function("analyse 500 campaigns", |b| {
        b.iter(|| analyse(black_box(&series), &options).unwrap())
    });
    let series = campaigns(20);
    c.bench_function("analyse 20 campaigns", |b| {
        b.iter(|| analyse(black_box(&series), &options).unwrap())
    });
    let checks = checks();
    c.bench_function("fit_thermal 12 checks", |b| {
        b.iter(|| fit_thermal(black_box(&checks), &ThermalOptions::default()).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
