//! Seeded synthetic runs for the integration tests.
#![allow(dead_code)] // each test binary uses a different part

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// `n` standard-normal samples.
pub fn white(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| rng.sample(StandardNormal)).collect()
}

/// Strictly increasing, unevenly spaced times over about `[0, duration]`.
pub fn uneven_times(rng: &mut ChaCha8Rng, n: usize, duration: f64) -> Vec<f64> {
    let steps: Vec<f64> = (0..n).map(|_| rng.random_range(0.2..1.8)).collect();
    let total: f64 = steps.iter().sum();
    let mut t = 0.0;
    steps
        .iter()
        .map(|s| {
            let now = t;
            t += s * duration / total;
            now
        })
        .collect()
}

/// Uniform random positions in `[lo, hi)` (unevenly spaced once sorted).
pub fn positions(rng: &mut ChaCha8Rng, n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n).map(|_| rng.random_range(lo..hi)).collect()
}

/// Rotary angles on a coarse grid (many ties), in degrees.
pub fn angles(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| 45.0 * f64::from(rng.random_range(0..8_i32)))
        .collect()
}

/// Direction of motion in blocks of `block` samples: +1, −1, +1, …
pub fn directions(n: usize, block: usize) -> Vec<i32> {
    (0..n)
        .map(|i| if (i / block) % 2 == 0 { 1 } else { -1 })
        .collect()
}
