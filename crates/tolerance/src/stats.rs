//! Percentiles, their distribution-free confidence intervals, histograms.

/// 1-based nearest rank of percentile `p` (0..=100) of `n` values: the smallest value with at
/// least `p` % of the data at or below it (the rule of
/// [`mtcal_kinematics::volmap::percentile_nearest_rank`]).
pub fn nearest_rank(n: usize, p: f64) -> usize {
    let x = p.clamp(0.0, 100.0) / 100.0 * n as f64;
    ((x - 1e-9).ceil() as usize).clamp(1, n.max(1))
}

/// Percentile `p` of `values` by nearest rank, reordering `buf` (a scratch copy).
pub fn percentile_in(values: &[f64], p: f64, buf: &mut Vec<f64>) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    buf.clear();
    buf.extend_from_slice(values);
    let rank = nearest_rank(values.len(), p);
    let (_, v, _) = buf.select_nth_unstable_by(rank - 1, f64::total_cmp);
    *v
}

/// Ranks `(lo, hi)` (1-based) of the order statistics that bracket the `p`-quantile with
/// confidence at least `confidence` (exact binomial, distribution-free): with `B ~ Bin(n, p)`
/// the number of samples below the true quantile, `P(X_(lo) ≤ ξ_p < X_(hi)) = P(lo ≤ B < hi)`.
/// Ranks are clamped to `1..=n`; for very few samples the interval is then the whole sample and
/// its coverage is below the nominal one.
pub fn quantile_ci_ranks(n: usize, p: f64, confidence: f64) -> (usize, usize) {
    if n == 0 {
        return (0, 0);
    }
    let alpha = 1.0 - confidence;
    let cdf = binomial_cdf(n, p);
    // lo: largest with P(B ≤ lo − 1) ≤ α/2.
    let mut lo = 1;
    for r in 1..=n {
        if cdf[r - 1] <= alpha / 2.0 {
            lo = r;
        } else {
            break;
        }
    }
    // hi: smallest with P(B ≤ hi − 1) ≥ 1 − α/2.
    let hi = (1..=n)
        .find(|&r| cdf[r - 1] >= 1.0 - alpha / 2.0)
        .unwrap_or(n);
    (lo, hi)
}

/// `P(B ≤ k)` for `k = 0..=n`, `B ~ Bin(n, p)`, summed in log space (no underflow trouble for
/// large `n`).
fn binomial_cdf(n: usize, p: f64) -> Vec<f64> {
    let (lp, lq) = (p.ln(), (1.0 - p).ln());
    let mut ln_choose = 0.0;
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(n + 1);
    for k in 0..=n {
        if k > 0 {
            ln_choose += ((n - k + 1) as f64).ln() - (k as f64).ln();
        }
        acc += (ln_choose + k as f64 * lp + (n - k) as f64 * lq).exp();
        out.push(acc.min(1.0));
    }
    out
}

/// Summary statistics of one set of sampled maxima (µm).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Summary {
    pub n: usize,
    pub mean_um: f64,
    pub std_um: f64,
    pub min_um: f64,
    pub p50_um: f64,
    pub p90_um: f64,
    pub p95_um: f64,
    pub max_um: f64,
    /// Confidence of the intervals below.
    pub confidence: f64,
    /// Distribution-free interval for the true P50 / P90 / P95 (order statistics).
    pub p50_ci_um: [f64; 2],
    pub p90_ci_um: [f64; 2],
    pub p95_ci_um: [f64; 2],
    /// Equal-width bins from `min` to `max`: `(lower edge, count)`.
    pub histogram: Vec<(f64, usize)>,
}

/// Number of histogram bins.
pub const BINS: usize = 20;

impl Summary {
    pub fn of(values: &[f64], confidence: f64) -> Summary {
        let n = values.len();
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let nan = f64::NAN;
        if n == 0 {
            return Summary {
                n,
                mean_um: nan,
                std_um: nan,
                min_um: nan,
                p50_um: nan,
                p90_um: nan,
                p95_um: nan,
                max_um: nan,
                confidence,
                p50_ci_um: [nan; 2],
                p90_ci_um: [nan; 2],
                p95_ci_um: [nan; 2],
                histogram: Vec::new(),
            };
        }
        let mean = sorted.iter().sum::<f64>() / n as f64;
        let var = sorted.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
        let at = |p: f64| sorted[nearest_rank(n, p) - 1];
        let ci = |p: f64| {
            let (lo, hi) = quantile_ci_ranks(n, p / 100.0, confidence);
            [sorted[lo - 1], sorted[hi - 1]]
        };
        let (min, max) = (sorted[0], sorted[n - 1]);
        let width = (max - min) / BINS as f64;
        let mut histogram: Vec<(f64, usize)> =
            (0..BINS).map(|b| (min + width * b as f64, 0)).collect();
        for v in &sorted {
            let b = if width > 0.0 {
                (((v - min) / width) as usize).min(BINS - 1)
            } else {
                0
            };
            histogram[b].1 += 1;
        }
        Summary {
            n,
            mean_um: mean,
            std_um: var.sqrt(),
            min_um: min,
            p50_um: at(50.0),
            p90_um: at(90.0),
            p95_um: at(95.0),
            max_um: max,
            confidence,
            p50_ci_um: ci(50.0),
            p90_ci_um: ci(90.0),
            p95_ci_um: ci(95.0),
            histogram,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::volmap::percentile_nearest_rank;

    #[test]
    fn nearest_rank_matches_volmap() {
        let values: Vec<f64> = (0..37).map(|k| ((k * 17) % 37) as f64).collect();
        let mut buf = Vec::new();
        for p in [1.0, 10.0, 50.0, 90.0, 95.0, 100.0] {
            assert_eq!(
                percentile_in(&values, p, &mut buf),
                percentile_nearest_rank(&values, p)
            );
        }
    }

    #[test]
    fn order_statistic_intervals() {
        // n = 1000, p = 0.9: the normal approximation gives ranks 900 ∓ 1.96·√90 ≈ 881 … 919.
        let (lo, hi) = quantile_ci_ranks(1000, 0.9, 0.95);
        assert!(
            (879..=883).contains(&lo) && (918..=922).contains(&hi),
            "{lo} {hi}"
        );
        let cdf = binomial_cdf(1000, 0.9);
        assert!(cdf[lo - 1] <= 0.025 && cdf[lo] > 0.025);
        assert!(cdf[hi - 1] >= 0.975 && cdf[hi - 2] < 0.975);
        assert!((cdf[1000] - 1.0).abs() < 1e-9);
        // Large n does not underflow.
        let (lo, hi) = quantile_ci_ranks(50_000, 0.9, 0.95);
        assert!(lo > 44_800 && hi < 45_200 && lo < 45_000 && hi > 45_000);
        // Tiny n: clamped to the sample.
        assert_eq!(quantile_ci_ranks(3, 0.9, 0.95), (1, 3));
    }

    #[test]
    fn coverage_of_the_interval_is_at_least_nominal() {
        // Uniform samples: the true P90 is 0.9; over 400 seeded repetitions of n = 200 the
        // interval must cover it in about 95 % (at least 91 %) of the cases.
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut covered = 0;
        for _ in 0..400 {
            let v: Vec<f64> = (0..200).map(|_| rng.random::<f64>()).collect();
            let s = Summary::of(&v, 0.95);
            if s.p90_ci_um[0] <= 0.9 && 0.9 <= s.p90_ci_um[1] {
                covered += 1;
            }
        }
        assert!(covered >= 364, "covered {covered} of 400");
    }

    #[test]
    fn summary_of_known_values() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        let s = Summary::of(&v, 0.95);
        assert_eq!(
            (s.p50_um, s.p90_um, s.p95_um, s.max_um),
            (5.0, 9.0, 10.0, 10.0)
        );
        assert_eq!(s.mean_um, 5.5);
        assert_eq!(s.histogram.iter().map(|b| b.1).sum::<usize>(), 10);
        assert!(Summary::of(&[], 0.95).p90_um.is_nan());
    }
}
