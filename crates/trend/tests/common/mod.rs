//! Seeded series for the tests: campaigns and same-day checks with realistic noise.
#![allow(dead_code)]

use mtcal_trend::Point;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

pub const DAY_S: f64 = 86_400.0;
/// 2025-01-01 in Unix seconds: campaigns live on a real clock.
pub const EPOCH_S: f64 = 1_735_689_600.0;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// `n` campaigns 20–40 days apart, each with its own U between 1.5 and 3 µm (different
/// instruments and set-ups), the value `level + rate·days + step after `step_at`` plus normal
/// noise of standard deviation `noise_factor · U/2`.
pub struct Campaigns {
    pub n: usize,
    pub level_um: f64,
    pub rate_um_per_day: f64,
    pub step_um: f64,
    pub step_at: usize,
    pub noise_factor: f64,
}

impl Default for Campaigns {
    fn default() -> Self {
        Campaigns {
            n: 20,
            level_um: 8.0,
            rate_um_per_day: 0.0,
            step_um: 0.0,
            step_at: usize::MAX,
            noise_factor: 1.0,
        }
    }
}

impl Campaigns {
    pub fn draw(&self, seed: u64) -> Vec<Point> {
        let mut r = rng(seed);
        let mut days = 0.0;
        (0..self.n)
            .map(|i| {
                if i > 0 {
                    days += r.random_range(20.0..40.0);
                }
                let u95 = r.random_range(1.5..3.0);
                let step = if i >= self.step_at { self.step_um } else { 0.0 };
                let truth = self.level_um + self.rate_um_per_day * days + step;
                let value = truth + self.noise_factor * u95 / 2.0 * normal(&mut r);
                Point::new(EPOCH_S + days * DAY_S, value, u95)
            })
            .collect()
    }
}

/// Same-day checks: `n` checks evenly over `span_min` minutes (each a few seconds off), value
/// `v∞ + amplitude·exp(−t/τ)` plus normal noise `sigma_um`, U = 2·sigma_um.
pub fn warm_up(
    seed: u64,
    n: usize,
    span_min: f64,
    tau_min: f64,
    amplitude_um: f64,
    settled_um: f64,
    sigma_um: f64,
) -> Vec<Point> {
    let mut r = rng(seed);
    let start_s = EPOCH_S + 7.0 * 3600.0;
    (0..n)
        .map(|i| {
            let jitter_min = if i == 0 {
                0.0
            } else {
                r.random_range(-0.2..0.2)
            };
            let t_min = span_min * i as f64 / (n - 1) as f64 + jitter_min;
            let truth = settled_um + amplitude_um * (-t_min / tau_min).exp();
            let value = truth + sigma_um * normal(&mut r);
            Point::new(start_s + 60.0 * t_min, value, 2.0 * sigma_um)
        })
        .collect()
}

/// The share of `hits` in `n` and whether it lies in `[lo, hi]`, for messages.
pub fn rate(hits: usize, n: usize) -> f64 {
    hits as f64 / n as f64
}
