//! Tests between groups of residuals (a categorical split such as direction of motion or
//! set-up): Welch's ANOVA for the means and the Brown–Forsythe test for the spreads.
//!
//! Both are scale-free and neither assumes equal variances across groups for the other's
//! question. With two groups Welch's ANOVA is exactly Welch's t-test (`F = t²`).

use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use crate::stats::Outcome;

/// Upper-tail F probability; 1 where the distribution is undefined.
fn f_sf(f: f64, dof1: f64, dof2: f64) -> f64 {
    FisherSnedecor::new(dof1, dof2).map_or(1.0, |d| d.sf(f))
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Unbiased sample variance.
fn variance(values: &[f64], mean: f64) -> f64 {
    values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (values.len() - 1) as f64
}

/// Welch's heteroscedastic one-way ANOVA on the group means. Every group needs at least two
/// samples. `statistic` is Welch's F, `detail` the largest difference between two group means
/// (in units of the residuals, i.e. σ for whitened residuals).
pub fn welch_anova(groups: &[&[f64]]) -> Outcome {
    let none = Outcome {
        statistic: 0.0,
        p_value: 1.0,
        detail: 0.0,
    };
    let k = groups.len() as f64;
    if groups.len() < 2 || groups.iter().any(|g| g.len() < 2) {
        return none;
    }
    let (mut w_sum, mut wm_sum) = (0.0, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for g in groups {
        let m = mean(g);
        let var = variance(g, m);
        if var <= 0.0 {
            return none; // a group without spread: the weights are undefined
        }
        let w = g.len() as f64 / var;
        w_sum += w;
        wm_sum += w * m;
        lo = lo.min(m);
        hi = hi.max(m);
    }
    let grand = wm_sum / w_sum;
    let (mut a, mut tmp) = (0.0, 0.0);
    for g in groups {
        let m = mean(g);
        let w = g.len() as f64 / variance(g, m);
        a += w * (m - grand).powi(2);
        tmp += (1.0 - w / w_sum).powi(2) / (g.len() - 1) as f64;
    }
    a /= k - 1.0;
    let b = 1.0 + 2.0 * (k - 2.0) / (k * k - 1.0) * tmp;
    let f = a / b;
    let dof2 = (k * k - 1.0) / (3.0 * tmp);
    Outcome {
        statistic: f,
        p_value: f_sf(f, k - 1.0, dof2),
        detail: hi - lo,
    }
}

/// Median of a sorted slice.
fn median_sorted(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// Brown–Forsythe test of equal spreads: one-way ANOVA on `|r − median of its group|`. Robust to
/// non-normal tails, unlike Bartlett's test. `statistic` is F, `detail` the ratio of the largest
/// to the smallest group standard deviation.
pub fn brown_forsythe(groups: &[&[f64]]) -> Outcome {
    let none = Outcome {
        statistic: 0.0,
        p_value: 1.0,
        detail: 1.0,
    };
    if groups.len() < 2 || groups.iter().any(|g| g.len() < 2) {
        return none;
    }
    let deviations: Vec<Vec<f64>> = groups.iter().map(|g| abs_deviations(g)).collect();
    let total: usize = deviations.iter().map(Vec::len).sum();
    let grand = deviations.iter().flatten().sum::<f64>() / total as f64;
    let (mut between, mut within) = (0.0, 0.0);
    for z in &deviations {
        let m = mean(z);
        between += z.len() as f64 * (m - grand).powi(2);
        within += z.iter().map(|v| (v - m).powi(2)).sum::<f64>();
    }
    let (dof1, dof2) = ((groups.len() - 1) as f64, (total - groups.len()) as f64);
    if within <= 0.0 {
        return none;
    }
    let f = (between / dof1) / (within / dof2);
    let sds = groups.iter().map(|g| variance(g, mean(g)).sqrt());
    let (lo, hi) = sds.fold((f64::INFINITY, 0.0_f64), |(lo, hi), s| {
        (lo.min(s), hi.max(s))
    });
    let ratio = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    Outcome {
        statistic: f,
        p_value: f_sf(f, dof1, dof2),
        detail: ratio,
    }
}

/// `|v − median|` for every value of a group.
fn abs_deviations(group: &[f64]) -> Vec<f64> {
    let mut sorted = group.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = median_sorted(&sorted);
    group.iter().map(|v| (v - median).abs()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const A1: [f64; 15] = [
        27.5, 21.0, 19.0, 23.6, 17.0, 17.9, 16.9, 20.1, 21.9, 22.6, 23.1, 19.6, 19.0, 21.7, 21.4,
    ];
    const A2: [f64; 15] = [
        27.1, 22.0, 20.8, 23.4, 23.4, 23.5, 25.8, 22.0, 24.8, 20.2, 21.9, 22.1, 22.9, 20.5, 24.4,
    ];

    #[test]
    fn two_group_welch_is_welch_t() {
        // Wikipedia's "Welch's t-test", example 1: t = −2.46, ν ≈ 25.0, two-sided p = 0.021.
        // More digits computed by hand (Python, Student t density integrated by Simpson's rule):
        // t = −2.455356, ν = 24.98853, p = 0.021378.
        let out = welch_anova(&[&A1, &A2]);
        assert!(
            (out.statistic - 2.455_356_4_f64.powi(2)).abs() < 1e-6,
            "F = {}",
            out.statistic
        );
        assert!(
            (out.p_value - 0.021_378).abs() < 2e-6,
            "p = {}",
            out.p_value
        );
        assert!((out.detail - (mean(&A2) - mean(&A1))).abs() < 1e-12);
    }

    #[test]
    fn brown_forsythe_matches_hand_value() {
        // Groups (1,2,3,4,5) and (2,4,6,8,10): medians 3 and 6, |deviations| (2,1,0,1,2) and
        // (4,2,0,2,4), means 1.2 and 2.4, grand 1.8; between = 5·0.36·2 = 3.6,
        // within = 2.8 + 11.2 = 14, F = 3.6/(14/8) = 2.0571, p = F(1,8) tail = 0.189404.
        let out = brown_forsythe(&[&[1.0, 2.0, 3.0, 4.0, 5.0], &[2.0, 4.0, 6.0, 8.0, 10.0]]);
        assert!(
            (out.statistic - 3.6 / 1.75).abs() < 1e-12,
            "F = {}",
            out.statistic
        );
        assert!(
            (out.p_value - 0.189_404).abs() < 2e-6,
            "p = {}",
            out.p_value
        );
        assert!((out.detail - 2.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_groups_give_no_evidence() {
        assert_eq!(welch_anova(&[&[1.0, 1.0], &[2.0, 3.0]]).p_value, 1.0);
        assert_eq!(welch_anova(&[&[1.0, 2.0]]).p_value, 1.0);
        assert_eq!(brown_forsythe(&[&[1.0], &[2.0, 3.0]]).p_value, 1.0);
    }
}
