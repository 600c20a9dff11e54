//! The two statistics of "did the series change?" — the best step's and the straight line's
//! share of χ² — and their joint distribution under no change, simulated.
//!
//! Both statistics are shares of `χ²₀` (the χ² about the one weighted mean), so they depend
//! on neither the level nor a common factor on all uncertainties: their no-change distribution
//! is the same for every constant series whose true uncertainties are the stated ones times any
//! factor, and a simulation with the stated relative uncertainties gives it exactly.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The best split of one series and the sums behind it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Split {
    pub index: usize,
    /// `(χ²₀ − χ²_k)/χ²₀`, 0 for a series without any scatter.
    pub ratio: f64,
    pub chi2_step: f64,
    /// `W₁, S₁` and `W₂, S₂`: the sums of `w` and `w·y` before and after the step.
    pub w_before: f64,
    pub sum_before: f64,
    pub w_after: f64,
    pub sum_after: f64,
}

/// The split with the largest drop in χ²: with `W₁`, `S₁` the sums of `w` and `w·y` before
/// the step and `W₂`, `S₂` after it, the drop is `(S₂·W₁ − S₁·W₂)² / (W₁·W₂·(W₁ + W₂))`.
/// Both sides are summed directly (`after` is scratch for the suffix sums), never as a total
/// minus a part, which would cancel when the weights span many orders of magnitude.
pub(crate) fn best_split(
    y: &[f64],
    w: &[f64],
    splits: &[usize],
    after: &mut Vec<(f64, f64)>,
) -> Split {
    let n = y.len();
    after.clear();
    after.resize(n + 1, (0.0, 0.0));
    for i in (0..n).rev() {
        after[i] = (after[i + 1].0 + w[i], after[i + 1].1 + w[i] * y[i]);
    }
    let (w_total, sum_total) = after[0];
    let chi2_0 = (w.iter().zip(y).map(|(w, y)| w * y * y).sum::<f64>()
        - sum_total * sum_total / w_total)
        .max(0.0);
    let (mut w_before, mut sum_before, mut next) = (0.0, 0.0, 0);
    let mut best: Option<Split> = None;
    for &k in splits {
        while next < k {
            w_before += w[next];
            sum_before += w[next] * y[next];
            next += 1;
        }
        let (w_after, sum_after) = after[k];
        let drop = ((sum_after * w_before - sum_before * w_after).powi(2)
            / (w_before * w_after * (w_before + w_after)))
            .min(chi2_0);
        let ratio = if chi2_0 > 0.0 { drop / chi2_0 } else { 0.0 };
        if best.is_none_or(|b| ratio > b.ratio) {
            best = Some(Split {
                index: k,
                ratio,
                chi2_step: chi2_0 - drop,
                w_before,
                sum_before,
                w_after,
                sum_after,
            });
        }
    }
    // `find_step` checked that there is at least one split.
    best.expect("at least one split")
}

/// The straight line's share of χ², `(χ²₀ − χ²_line)/χ²₀ = S_xy² / (S_xx·χ²₀)`, for any
/// values at fixed times and weights.
pub(crate) struct LineBasis {
    /// Times less their weighted mean.
    centred: Vec<f64>,
    sxx: f64,
}

impl LineBasis {
    /// `None` when all times are equal.
    pub fn new(x: &[f64], w: &[f64]) -> Option<LineBasis> {
        let sw: f64 = w.iter().sum();
        let mean = x.iter().zip(w).map(|(x, w)| x * w).sum::<f64>() / sw;
        let centred: Vec<f64> = x.iter().map(|x| x - mean).collect();
        let sxx: f64 = centred.iter().zip(w).map(|(c, w)| w * c * c).sum();
        (sxx > 0.0 && sxx.is_finite()).then_some(LineBasis { centred, sxx })
    }

    pub fn ratio(&self, y: &[f64], w: &[f64]) -> f64 {
        let (mut sw, mut swy, mut swyy, mut sxy) = (0.0, 0.0, 0.0, 0.0);
        for ((y, w), c) in y.iter().zip(w).zip(&self.centred) {
            sw += w;
            swy += w * y;
            swyy += w * y * y;
            sxy += w * c * y;
        }
        let chi2_0 = (swyy - swy * swy / sw).max(0.0);
        let drop = (sxy * sxy / self.sxx).min(chi2_0);
        if chi2_0 > 0.0 { drop / chi2_0 } else { 0.0 }
    }
}

/// The two statistics of one series.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ratios {
    pub step: f64,
    pub line: f64,
}

/// The p-values from the simulations.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NullTest {
    /// Of the best step alone.
    pub step: f64,
    /// Of "a change of either kind", by the smaller of the two p-values (min-p).
    pub any: f64,
}

/// Simulates `simulations` no-change series with weights `w` (seeded) and ranks the observed
/// statistics among them. The observed series and the simulated ones are exchangeable under
/// no change, so with `N + 1` series in all:
/// - a statistic's p-value is the share of the `N + 1` at least as large,
/// - the min-p of a series is the smaller of its two p-values, and "any change" has the share
///   of the `N + 1` min-p at most as small as the observed one.
///
/// Both are valid p-values (`P(p ≤ α) ≤ α`); min-p holds the false alarms of "a drift or a
/// step" at `α` however strongly the two statistics are correlated.
pub(crate) fn null_test(
    observed: Ratios,
    w: &[f64],
    splits: &[usize],
    line: &LineBasis,
    simulations: usize,
    seed: u64,
) -> NullTest {
    let mut all = Vec::with_capacity(simulations + 1);
    all.push(observed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sd: Vec<f64> = w.iter().map(|w| 1.0 / w.sqrt()).collect();
    let mut y = vec![0.0; w.len()];
    let mut scratch = Vec::with_capacity(w.len() + 1);
    for _ in 0..simulations {
        for (yi, sd) in y.iter_mut().zip(&sd) {
            *yi = sd * rng.sample::<f64, _>(StandardNormal);
        }
        all.push(Ratios {
            step: best_split(&y, w, splits, &mut scratch).ratio,
            line: line.ratio(&y, w),
        });
    }
    let total = all.len() as f64;
    let step_p = upper_tail(all.iter().map(|r| r.step).collect());
    let line_p = upper_tail(all.iter().map(|r| r.line).collect());
    let min_p = |r: &Ratios| step_p(r.step).min(line_p(r.line));
    let observed_min = min_p(&observed);
    let as_small = all.iter().filter(|r| min_p(r) <= observed_min).count();
    NullTest {
        step: step_p(observed.step),
        any: as_small as f64 / total,
    }
}

/// `v ↦` the share of `values` at least `v`.
fn upper_tail(mut values: Vec<f64>) -> impl Fn(f64) -> f64 {
    values.sort_by(|a, b| b.total_cmp(a));
    let total = values.len() as f64;
    move |v| values.partition_point(|&r| r >= v) as f64 / total
}
