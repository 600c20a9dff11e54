//! The statistics on one ordered sequence of whitened residuals: χ² goodness of fit, the
//! Wald–Wolfowitz runs test, Ljung–Box, and the CUSUM of the mean.
//!
//! Every function takes the residuals in the order to be tested and returns an [`Outcome`]; none
//! allocates. Apart from χ², the tests are *scale-free*: they normalise by the residuals' own
//! spread, so a noise σ that is stated too small or too large shows up in χ² alone and never as
//! structure along a variable.

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};
use statrs::function::factorial::ln_binomial;

/// What one test says about one sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// The test statistic (see each test for its definition).
    pub statistic: f64,
    /// Probability of a statistic at least this extreme under white noise.
    pub p_value: f64,
    /// One further number that says how or where; each test documents its meaning.
    pub detail: f64,
}

/// Upper-tail χ² probability with `dof` degrees of freedom; 1 where the distribution is undefined.
pub(crate) fn chi_square_sf(statistic: f64, dof: f64) -> f64 {
    ChiSquared::new(dof).map_or(1.0, |d| d.sf(statistic))
}

/// Two-sided standard-normal probability of |Z| ≥ |z|.
fn normal_two_sided(z: f64) -> f64 {
    // Normal::new(0, 1) cannot fail; the fallback keeps this function total.
    Normal::new(0.0, 1.0).map_or(1.0, |d| (2.0 * d.sf(z.abs())).min(1.0))
}

/// χ² goodness of fit: `Σ r²` against χ² with `n` degrees of freedom, upper tail only (a fit that
/// is *better* than the noise allows is not a mismatch of the model). `detail` is the reduced χ²,
/// `Σ r² / n`.
pub fn chi_square(residuals: &[f64]) -> Outcome {
    let chi2: f64 = residuals.iter().map(|r| r * r).sum();
    let n = residuals.len() as f64;
    Outcome {
        statistic: chi2,
        p_value: chi_square_sf(chi2, n),
        detail: chi2 / n,
    }
}

/// Up to this many signs the runs test uses the exact distribution, beyond it the normal
/// approximation (whose error at this size is already below a percent of the p-value's scale).
const RUNS_EXACT_MAX: u64 = 60;

/// Wald–Wolfowitz runs test on the signs of the residuals, two-sided (too few runs: residuals
/// cluster; too many: they alternate). Exact zeros carry no sign and are left out. The test is
/// conditional on the numbers of positive and negative signs, so an overall offset does not
/// trigger it. `statistic` is the number of runs, `detail` its z-score (negative: clustered).
pub fn runs_test(residuals: &[f64]) -> Outcome {
    let (mut n_pos, mut n_neg, mut runs, mut last) = (0_u64, 0_u64, 0_u64, 0_i8);
    for &r in residuals {
        let sign = if r > 0.0 {
            1
        } else if r < 0.0 {
            -1
        } else {
            continue;
        };
        if sign > 0 {
            n_pos += 1
        } else {
            n_neg += 1
        }
        if sign != last {
            runs += 1;
            last = sign;
        }
    }
    if n_pos == 0 || n_neg == 0 {
        return Outcome {
            statistic: runs as f64,
            p_value: 1.0,
            detail: 0.0,
        };
    }
    let (mean, var) = runs_moments(n_pos as f64, n_neg as f64);
    let z = if var > 0.0 {
        (runs as f64 - mean) / var.sqrt()
    } else {
        0.0
    };
    let p_value = if n_pos + n_neg <= RUNS_EXACT_MAX {
        runs_exact_p(n_pos, n_neg, runs)
    } else {
        // Continuity correction: the count is discrete, so move half a run towards the mean.
        let corrected = ((runs as f64 - mean).abs() - 0.5).max(0.0);
        if var > 0.0 {
            normal_two_sided(corrected / var.sqrt())
        } else {
            1.0
        }
    };
    Outcome {
        statistic: runs as f64,
        p_value,
        detail: z,
    }
}

/// Mean and variance of the number of runs given `n1` and `n2` signs.
fn runs_moments(n1: f64, n2: f64) -> (f64, f64) {
    let n = n1 + n2;
    let mean = 2.0 * n1 * n2 / n + 1.0;
    let var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / (n * n * (n - 1.0));
    (mean, var)
}

/// Binomial coefficient as f64, 0 outside the triangle.
fn binomial(n: i64, k: i64) -> f64 {
    if n < 0 || k < 0 || k > n {
        0.0
    } else {
        ln_binomial(n as u64, k as u64).exp()
    }
}

/// Exact probability of exactly `runs` runs among `n1` and `n2` signs in random order.
fn runs_pmf(n1: u64, n2: u64, runs: u64) -> f64 {
    let (a, b) = (n1 as i64 - 1, n2 as i64 - 1);
    let total = binomial((n1 + n2) as i64, n1 as i64);
    let m = (runs / 2) as i64;
    let ways = if runs % 2 == 0 {
        2.0 * binomial(a, m - 1) * binomial(b, m - 1)
    } else {
        binomial(a, m) * binomial(b, m - 1) + binomial(a, m - 1) * binomial(b, m)
    };
    ways / total
}

/// Exact two-sided p-value: twice the smaller tail, capped at 1.
fn runs_exact_p(n1: u64, n2: u64, observed: u64) -> f64 {
    let max_runs = 2 * n1.min(n2) + u64::from(n1 != n2);
    let (mut lower, mut upper) = (0.0, 0.0);
    for runs in 2..=max_runs {
        let p = runs_pmf(n1, n2, runs);
        if runs <= observed {
            lower += p;
        }
        if runs >= observed {
            upper += p;
        }
    }
    (2.0 * f64::min(lower, upper)).min(1.0)
}

/// Mean and sum of squared deviations.
fn mean_and_ss(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let ss = values.iter().map(|v| (v - mean).powi(2)).sum();
    (mean, ss)
}

/// Sample autocorrelation at `lag` of a sequence with the given mean and sum of squares.
fn autocorrelation(values: &[f64], mean: f64, ss: f64, lag: usize) -> f64 {
    let cross: f64 = values
        .iter()
        .zip(&values[lag..])
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum();
    cross / ss
}

/// Ljung–Box portmanteau test over lags `1..=lags`: `Q = n(n+2) Σ ρₖ²/(n−k)` against χ² with
/// `lags` degrees of freedom. `detail` is the lag-1 autocorrelation ρ₁ (positive: neighbours
/// agree, as a smooth unmodelled error makes them). `lags` is capped at `n/4`.
pub fn ljung_box(residuals: &[f64], lags: usize) -> Outcome {
    let n = residuals.len();
    let lags = lags.min(n / 4).max(1);
    let (mean, ss) = mean_and_ss(residuals);
    if n <= lags + 1 || ss <= 0.0 {
        return Outcome {
            statistic: 0.0,
            p_value: 1.0,
            detail: 0.0,
        };
    }
    let mut q = 0.0;
    let mut rho1 = 0.0;
    for lag in 1..=lags {
        let rho = autocorrelation(residuals, mean, ss, lag);
        if lag == 1 {
            rho1 = rho;
        }
        q += rho * rho / (n - lag) as f64;
    }
    q *= (n * (n + 2)) as f64;
    Outcome {
        statistic: q,
        p_value: chi_square_sf(q, lags as f64),
        detail: rho1,
    }
}

/// CUSUM of the mean with its largest departure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cusum {
    /// `statistic` is `max |Sₖ| / (s √n)`, `detail` the same as `change_index` (as f64).
    pub outcome: Outcome,
    /// Position (0-based, in the tested order) of the largest departure: the last sample before
    /// the change of mean.
    pub change_index: usize,
}

/// CUSUM of the mean: `Sₖ = Σᵢ≤ₖ (rᵢ − r̄)` scaled by the sample standard deviation and `√n`
/// tends to the supremum of a Brownian bridge under white noise, so its p-value is Kolmogorov's
/// `Q(D) = 2 Σ (−1)ʲ⁻¹ exp(−2j²D²)`. The discrete maximum is smaller than the continuous one, so
/// for finite `n` the p-value errs on the large (safe) side.
pub fn cusum(residuals: &[f64]) -> Cusum {
    let n = residuals.len();
    let (mean, ss) = mean_and_ss(residuals);
    if n < 2 || ss <= 0.0 {
        let outcome = Outcome {
            statistic: 0.0,
            p_value: 1.0,
            detail: 0.0,
        };
        return Cusum {
            outcome,
            change_index: 0,
        };
    }
    let (mut sum, mut max_abs, mut change_index) = (0.0_f64, 0.0_f64, 0);
    for (i, r) in residuals.iter().enumerate() {
        sum += r - mean;
        if sum.abs() > max_abs {
            max_abs = sum.abs();
            change_index = i;
        }
    }
    let sd = (ss / (n - 1) as f64).sqrt();
    let d = max_abs / (sd * (n as f64).sqrt());
    let outcome = Outcome {
        statistic: d,
        p_value: kolmogorov_sf(d),
        detail: change_index as f64,
    };
    Cusum {
        outcome,
        change_index,
    }
}

/// Kolmogorov's survival function `P(sup |B(t)| > x)` for the Brownian bridge `B`.
pub fn kolmogorov_sf(x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < 1.0 {
        // For small x the alternating series converges slowly; the Jacobi-theta form of the
        // CDF, √(2π)/x Σ exp(−(2j−1)²π²/(8x²)), converges in a few terms there.
        let pi2 = std::f64::consts::PI.powi(2);
        let cdf: f64 = (1..=8)
            .map(|j| (-((2 * j - 1) as f64).powi(2) * pi2 / (8.0 * x * x)).exp())
            .sum::<f64>()
            * (2.0 * std::f64::consts::PI).sqrt()
            / x;
        return (1.0 - cdf).clamp(0.0, 1.0);
    }
    let sf: f64 = (1..=100)
        .map(|j| {
            let sign = if j % 2 == 1 { 1.0 } else { -1.0 };
            sign * (-2.0 * (j * j) as f64 * x * x).exp()
        })
        .sum::<f64>()
        * 2.0;
    sf.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
    }

    #[test]
    fn chi_square_of_two_dof_is_exponential() {
        // χ²₂ has survival exp(−x/2): residuals (1, 1) give Σr² = 2, p = e⁻¹.
        let out = chi_square(&[1.0, -1.0]);
        close(out.statistic, 2.0, 1e-15);
        close(out.p_value, (-1.0_f64).exp(), 1e-12);
        close(out.detail, 1.0, 1e-15);
    }

    #[test]
    fn runs_pmf_sums_to_one_and_matches_enumeration() {
        // Enumerate all arrangements of 4 plus and 3 minus signs (35 of them).
        let (n1, n2) = (4_u64, 3_u64);
        let mut counts = [0_u32; 9];
        for mask in 0_u32..(1 << 7) {
            if mask.count_ones() != 4 {
                continue;
            }
            let runs = 1
                + (0..6)
                    .filter(|i| ((mask >> i) & 1) != ((mask >> (i + 1)) & 1))
                    .count();
            counts[runs] += 1;
        }
        for (runs, &count) in counts.iter().enumerate().skip(2) {
            close(
                runs_pmf(n1, n2, runs as u64),
                f64::from(count) / 35.0,
                1e-12,
            );
        }
    }

    #[test]
    fn runs_test_on_known_sequence() {
        // + + − − + − : n1 = n2 = 3, 4 runs. Of the 20 arrangements, 2 have 2 runs, 4 have 3,
        // 8 have 4, 4 have 5, 2 have 6: P(R ≤ 4) = 14/20, P(R ≥ 4) = 14/20 → p = 1.
        let out = runs_test(&[1.0, 2.0, -1.0, -0.5, 0.3, -2.0]);
        assert_eq!(out.statistic, 4.0);
        close(out.p_value, 1.0, 1e-12);
        // + + + − − − : 2 runs, P(R ≤ 2) = 2/20 → two-sided p = 0.2.
        let out = runs_test(&[1.0, 2.0, 0.0, 3.0, -1.0, -0.5, -2.0]);
        assert_eq!(out.statistic, 2.0);
        close(out.p_value, 0.2, 1e-12);
    }

    #[test]
    fn runs_test_normal_approximation_matches_hand_value() {
        // 50 plus and 50 minus in 40 runs: mean 51, variance 2·2500·4900/(10⁴·99) = 24.7475,
        // corrected z = (11 − 0.5)/4.97469 = 2.11068, p = erfc(z/√2) = 0.034800.
        let mut seq = Vec::new();
        for run in 0..40 {
            let sign = if run % 2 == 0 { 1.0 } else { -1.0 };
            // 20 runs of each sign: 18 singletons and two long runs of 16 per sign.
            let len = if run >= 36 { 16 } else { 1 };
            seq.extend(std::iter::repeat_n(sign, len));
        }
        assert_eq!(seq.len(), 100);
        let out = runs_test(&seq);
        assert_eq!(out.statistic, 40.0);
        close(out.p_value, 0.034_800, 2e-6);
        close(out.detail, -11.0 / 24.747_474_747_f64.sqrt(), 1e-9);
    }

    #[test]
    fn ljung_box_matches_hand_value() {
        // 1..5: deviations −2..2, Σ = 10, ρ₁ = 4/10, ρ₂ = −1/10 (lags capped at n/4 = 1, so ask
        // for one lag explicitly): Q = 5·7·0.16/4 = 1.4, p = χ²₁ tail = erfc(√(1.4/2)) = 0.23672.
        let out = ljung_box(&[1.0, 2.0, 3.0, 4.0, 5.0], 1);
        close(out.detail, 0.4, 1e-15);
        close(out.statistic, 1.4, 1e-12);
        close(out.p_value, 0.236_724, 2e-6);
        // Eight samples allow two lags: 1..8 with deviations ±0.5..±3.5, Σ = 42,
        // ρ₁ = 26.25/42 = 0.625, ρ₂ = 11.5/42; Q = 8·10·(ρ₁²/7 + ρ₂²/6) = 5.46391, χ²₂ tail
        // e^{−Q/2}.
        let seq: Vec<f64> = (1..=8).map(f64::from).collect();
        let out = ljung_box(&seq, 10);
        let (r1, r2) = (26.25 / 42.0, 11.5 / 42.0);
        let q = 80.0 * (r1 * r1 / 7.0 + r2 * r2 / 6.0);
        close(q, 5.463_91, 1e-5);
        close(out.statistic, q, 1e-12);
        close(out.p_value, (-q / 2.0).exp(), 1e-12);
        close(out.detail, 0.625, 1e-15);
    }

    #[test]
    fn kolmogorov_matches_table() {
        // Classical critical values (4 digits): Q(1.3581) = 0.05, Q(1.6276) = 0.01,
        // Q(1.2238) = 0.10; the 4-digit rounding of x moves Q by up to 3e-5.
        close(kolmogorov_sf(1.3581), 0.05, 3e-5);
        close(kolmogorov_sf(1.6276), 0.01, 3e-5);
        close(kolmogorov_sf(1.2238), 0.10, 3e-5);
        // Both series agree where they meet.
        close(kolmogorov_sf(1.0 - 1e-9), kolmogorov_sf(1.0 + 1e-9), 1e-8);
        close(kolmogorov_sf(0.5), 0.963_945, 2e-6);
    }

    #[test]
    fn cusum_finds_the_step() {
        // 10 samples at −1 then 10 at +1: Sₖ falls linearly to −10 at k = 9, then climbs back.
        let seq: Vec<f64> = (0..20).map(|i| if i < 10 { -1.0 } else { 1.0 }).collect();
        let out = cusum(&seq);
        assert_eq!(out.change_index, 9);
        // s² = 20/19, D = 10/(√(20/19)·√20).
        close(
            out.outcome.statistic,
            10.0 / ((20.0_f64 / 19.0).sqrt() * 20.0_f64.sqrt()),
            1e-12,
        );
    }
}
