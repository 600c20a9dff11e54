//! Where along a variable the excess χ² sits.
//!
//! Along the residuals sorted by a variable, two kinds of segment are looked for, each by the
//! generalised likelihood-ratio (GLR) test against the stated noise (white, unit variance):
//! - a **mean shift**: inside the segment `r ~ N(μ, 1)`; `GLR = (Σ rᵢ)² / 2m`. Offsets, steps
//!   and drifts are found this way; using the signed residuals locates them far more sharply
//!   than their squares would (a 1.5 σ step has a per-sample signal-to-noise of 1.5 in `r` but
//!   0.7 in `r²`).
//! - a **spread change**: inside the segment `r ~ N(0, ρ)`; `GLR = (Q − m − m ln(Q/m))/2` with
//!   `Q = Σ rᵢ²`. Errors whose sign changes quickly along the variable (a short period, a
//!   direction effect seen along time) are found this way.
//!
//! The segment with the larger GLR is the span. Each search is Kadane's maximum-sum segment of
//! `qᵢ − κ` (`qᵢ = ±rᵢ` for the two signs of a mean shift, `qᵢ = rᵢ² − 1` for spread), where the
//! penalty `κ` is half the mean of `q` *inside the segment*, found by fixed-point iteration:
//! start with half the run's mean, find the segment, set `κ` to half its mean, repeat until the
//! segment no longer changes (a few rounds). That is the GLR's own rule to first order — a sample
//! improves a mean-shift segment when `μ rᵢ − μ²/2 > 0`, i.e. `rᵢ > μ/2`, and a spread segment
//! when `rᵢ² − 1 > ln ρ/(1 − 1/ρ) − 1 ≈ (ρ − 1)/2`. With `κ = 0` the segment would wander on into
//! the effect-free rest of the run (a zero-drift random walk); with `κ` equal to the run's mean
//! (the epidemic change-point estimator) an effect spread evenly over the run would yield a
//! random sub-span. Half the in-segment mean gives concentrated effects sharp edges and keeps
//! the whole run for even ones. Cost: linear in `n` per round.
//!
//! Samples with equal values of the variable are one group: a span never splits them (a span
//! "from 120 s to 300 s" must mean every sample at 300 s).
//!
//! The *share* is always measured in excess χ², `eᵢ = rᵢ² − 1`, whatever kind of segment was
//! found: `S⁺ / (S⁺ + (E − S)⁺)` with `S = Σ eᵢ` inside the span, `E` the run-channel's total
//! excess and `x⁺ = max(x, 0)` — the fraction `S/E` whenever `0 ≤ S ≤ E`, 1 when the rest of the
//! run is quieter than the noise allows, 0 when the span carries no excess.

/// A span along a sorted variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// First sample of the span, as a position in the sorted order.
    pub first: usize,
    /// Last sample of the span (inclusive), as a position in the sorted order.
    pub last: usize,
    /// Value of the variable at `first`.
    pub from: f64,
    /// Value of the variable at `last`.
    pub to: f64,
    /// What distinguishes the span from the rest.
    pub kind: SpanKind,
    /// `Σ (rᵢ² − 1)` over the span.
    pub excess: f64,
    /// Share of the run-channel's excess χ² inside the span (see the module docs).
    pub share: f64,
}

/// Which departure from the noise a span shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpanKind {
    /// The residuals' mean is shifted (offset, step, drift).
    Mean,
    /// The residuals scatter more than the noise (quick sign changes, extra noise).
    Spread,
    /// The whole range, given by the caller for an effect that repeats along the variable.
    Whole,
}

/// The span carrying the excess along `values` (sorted ascending) with the residuals in the
/// same order. `None` only for empty input or different lengths.
pub fn excess_span(values: &[f64], residuals: &[f64]) -> Option<Span> {
    let n = residuals.len();
    if n == 0 || values.len() != n {
        return None;
    }
    let up = refine(values, residuals, |r| r);
    let down = refine(values, residuals, |r| -r);
    let spread = refine(values, residuals, |r| r * r - 1.0);
    let candidates = [
        (up, mean_glr(residuals, up)),
        (down, mean_glr(residuals, down)),
    ];
    let (mean_segment, mean_score) = candidates
        .into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((up, 0.0));
    let (kind, (first, last)) = if spread_glr(residuals, spread) > mean_score {
        (SpanKind::Spread, spread)
    } else {
        (SpanKind::Mean, mean_segment)
    };
    let excess = residuals[first..=last].iter().map(|r| r * r - 1.0).sum();
    let total = residuals.iter().map(|r| r * r - 1.0).sum();
    let share = share(excess, total);
    Some(Span {
        first,
        last,
        from: values[first],
        to: values[last],
        kind,
        excess,
        share,
    })
}

/// The whole range as a span (for an effect that repeats along the variable, see the crate
/// docs), with its share of the excess. `None` only for empty input or different lengths.
pub fn whole_span(values: &[f64], residuals: &[f64]) -> Option<Span> {
    let n = residuals.len();
    if n == 0 || values.len() != n {
        return None;
    }
    let total = residuals.iter().map(|r| r * r - 1.0).sum();
    let (from, to) = (values[0], values[n - 1]);
    let kind = SpanKind::Whole;
    Some(Span {
        first: 0,
        last: n - 1,
        from,
        to,
        kind,
        excess: total,
        share: share(total, total),
    })
}

/// Rounds of the fixed-point iteration for `κ`; it settles in two or three.
const MAX_ROUNDS: usize = 10;

/// The maximum-sum segment of `q(rᵢ) − κ` with `κ` half the segment's own mean of `q` (fixed
/// point, starting from the whole run).
fn refine(values: &[f64], residuals: &[f64], q: impl Fn(f64) -> f64 + Copy) -> (usize, usize) {
    let mut segment = (0, residuals.len() - 1);
    for _ in 0..MAX_ROUNDS {
        let inside = &residuals[segment.0..=segment.1];
        let kappa =
            0.5 * (inside.iter().map(|&r| q(r)).sum::<f64>() / inside.len() as f64).max(0.0);
        let next = max_segment(values, residuals, |r| q(r) - kappa);
        if next == segment {
            break;
        }
        segment = next;
    }
    segment
}

/// GLR of a mean shift inside `segment` against zero mean: `(Σ r)² / 2m`.
fn mean_glr(residuals: &[f64], (first, last): (usize, usize)) -> f64 {
    let inside = &residuals[first..=last];
    inside.iter().sum::<f64>().powi(2) / (2 * inside.len()) as f64
}

/// GLR of a larger variance inside `segment` against unit variance: `(Q − m − m ln(Q/m))/2`,
/// zero when the segment scatters less than the noise.
fn spread_glr(residuals: &[f64], (first, last): (usize, usize)) -> f64 {
    let inside = &residuals[first..=last];
    let m = inside.len() as f64;
    let q: f64 = inside.iter().map(|r| r * r).sum();
    if q <= m {
        0.0
    } else {
        0.5 * (q - m - m * (q / m).ln())
    }
}

/// `S⁺ / (S⁺ + (E − S)⁺)`.
fn share(inside: f64, total: f64) -> f64 {
    let inside = inside.max(0.0);
    let outside = (total - inside).max(0.0);
    if inside <= 0.0 {
        0.0
    } else {
        inside / (inside + outside)
    }
}

/// Kadane's algorithm over groups of equal `values` on the per-sample `score`; returns the first
/// and last sample of the maximum-sum segment.
fn max_segment(values: &[f64], residuals: &[f64], score: impl Fn(f64) -> f64) -> (usize, usize) {
    let mut best = (f64::NEG_INFINITY, 0, 0);
    let (mut current, mut current_start) = (0.0, 0);
    let mut start = 0;
    while start < values.len() {
        let end = group_end(values, start);
        let group: f64 = residuals[start..end].iter().map(|&r| score(r)).sum();
        if current <= 0.0 {
            current = group;
            current_start = start;
        } else {
            current += group;
        }
        if current > best.0 {
            best = (current, current_start, end - 1);
        }
        start = end;
    }
    (best.1, best.2)
}

/// One past the last index whose value equals `values[start]`.
fn group_end(values: &[f64], start: usize) -> usize {
    let v = values[start];
    start + values[start..].iter().take_while(|&&w| w == v).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_block_of_large_residuals() {
        let values: Vec<f64> = (0..10).map(f64::from).collect();
        let r = [0.5, -0.8, 1.0, 3.0, -3.0, 3.0, 0.2, -1.0, 0.9, 0.1];
        let span = excess_span(&values, &r).unwrap();
        assert_eq!((span.first, span.last, span.kind), (3, 5, SpanKind::Spread));
        // Inside: 3·(9 − 1) = 24. Total: Σr² − 10 = 30.75 − 10 = 20.75, so the rest is quieter
        // than the noise (−3.25) and the span holds all of the excess.
        assert!((span.excess - 24.0).abs() < 1e-12);
        assert_eq!(span.share, 1.0);
        // With a noisier rest (two samples of r = 2 outside) the share is the plain fraction S/E.
        let r2 = [0.5, -0.8, 1.0, 3.0, -3.0, 3.0, 0.2, -1.0, 2.0, 2.0];
        let span = excess_span(&values, &r2).unwrap();
        assert_eq!((span.first, span.last), (3, 5));
        let total: f64 = r2.iter().map(|x| x * x - 1.0).sum();
        assert!(
            (span.share - 24.0 / total).abs() < 1e-12,
            "{} vs {}",
            span.share,
            24.0 / total
        );
    }

    #[test]
    fn a_shifted_mean_is_a_mean_span() {
        // A step of +1 on samples 3..=6 between small alternating values: the signed search
        // finds it, and its edges are where the GLR puts them (rᵢ > μ/2 = 0.5).
        let values: Vec<f64> = (0..11).map(f64::from).collect();
        let r = [0.1, -0.1, 0.1, 1.0, 1.1, 0.9, 1.0, -0.1, 0.1, -0.1, 0.1];
        let span = excess_span(&values, &r).unwrap();
        assert_eq!((span.first, span.last, span.kind), (3, 6, SpanKind::Mean));
        // Inside Σ(r² − 1) = 0 + 0.21 − 0.19 + 0 = 0.02; outside 7·(0.01 − 1) = −6.93.
        assert!((span.excess - 0.02).abs() < 1e-12);
        assert_eq!(span.share, 1.0);
    }

    #[test]
    fn never_splits_ties() {
        // The large residual sits at value 2, which three samples share.
        let values = [0.0, 1.0, 2.0, 2.0, 2.0, 3.0];
        let r = [0.1, 0.1, 0.2, 4.0, 0.3, 0.1];
        let span = excess_span(&values, &r).unwrap();
        assert_eq!((span.first, span.last), (2, 4));
        assert_eq!((span.from, span.to), (2.0, 2.0));
    }

    #[test]
    fn even_excess_keeps_the_whole_run() {
        let values: Vec<f64> = (0..8).map(f64::from).collect();
        let r = [2.0, -2.1, 1.9, -2.0, 2.2, -1.8, 2.0, -2.0];
        let span = excess_span(&values, &r).unwrap();
        assert_eq!((span.first, span.last), (0, 7));
        assert_eq!(span.share, 1.0);
    }

    #[test]
    fn share_is_clamped() {
        assert_eq!(share(5.0, 10.0), 0.5);
        assert_eq!(share(5.0, 2.0), 1.0);
        assert_eq!(share(-1.0, 2.0), 0.0);
    }
}
