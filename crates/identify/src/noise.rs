//! The noise the recordings really carry, as opposed to the σ the manifest states: per set-up
//! and channel a scale (the real σ over the stated one) and an AR(1) coefficient φ (noise that
//! is coloured: neighbouring samples share part of their error, as an instrument's filter or a
//! slowly wandering air path make them), estimated from the residuals of a fit.
//!
//! # Why
//! Every decision of the physics search is a χ² statistic: the score test's predicted drop,
//! the information criterion, the held-out mean square. They assume whitened residuals that
//! are independent with unit variance. Real recordings are not: a σ stated 20 % optimistic
//! inflates every χ² by 1.56, and AR(1) noise with φ = 0.6 inflates the χ² drop of a smooth
//! candidate (a drift, a slow cycle) by up to `(1 + φ)/(1 − φ)` = 4. Without a noise model the
//! search then "finds" higher orders and couplings in clean sessions.
//!
//! # How it enters the fit
//! [`crate::study::Changes::noise`]: every channel's σ becomes `scale × σ_stated`, and each
//! run's residual and Jacobian rows of one channel are prewhitened in sample order
//! (Prais–Winsten: the first row of a run as it is, then `(rₖ − φ·rₖ₋₁)/√(1 − φ²)`), so that
//! the fit is the generalised least-squares fit for that noise and every χ² the search
//! computes is one of independent unit-variance innovations. A sample after a gap (a held-out
//! block) starts the chain again; a run that continues another one's recording
//! ([`Study::continues`](crate::Study::continues): a thermal test cut into one file per cycle)
//! continues its chain, so that the first row "as it is" — the run's level, at full weight —
//! comes once per recording, not once per file.
//!
//! # How it is estimated
//! From the whitened residuals `e` of a fit (stated σ), pooled over the fitted runs of the
//! instrument's set-ups, through their short-lag differences: the variogram
//! `γ(h) = ½·E[(eₖ₊ₕ − eₖ)²]` of AR(1) noise of variance σ² is `σ²(1 − φʰ)`, and σ² and φ
//! are fitted to lags 1 to 4. Differences over a few samples are blind to what changes slowly
//! — a thermal drift, a slow cycle, a geometric error the model left out — so the estimate is
//! the noise's, not the structure's. Each `γ(h)` is a trimmed mean square (the largest 2 % left
//! out), so a few jumps (a reversal error's flips) do not count. What changes within a few
//! samples in a few places — a guideway bump several runs cross, a transient after a reversal
//! — would still read as noise larger and more coloured than it is, and hide itself by
//! weighing its own channel down: the differences are therefore taken in blocks of 32 samples
//! of a run, and a block whose mean square at the longest lag is over four times the median
//! block's is structure, left out.
//!
//! A scale is only ever raised above 1 (as everywhere in mtcal, the stated σ is a floor: a
//! simulated noise-free session or an over-cautious statement does not make the fit trust the
//! data more), and both are kept at the stated, white noise unless the residuals say
//! otherwise beyond their own sampling scatter.

use crate::IdentifyError;
use crate::fit::predict_run;
use crate::study::{Changes, Study};
pub use crate::whiten::{ChannelNoise, NoiseModel};
use std::fmt::Write as _;
use std::sync::Arc;

/// Fewer differences than this: the channel keeps the stated, white noise.
const MIN_DIFFERENCES: usize = 30;
/// At most this many differences per set-up and channel enter the medians (an even stride
/// through longer runs).
const MAX_DIFFERENCES: usize = 200_000;
/// The largest AR(1) coefficient used: beyond it the recordings are structure, not noise.
const MAX_PHI: f64 = 0.9;
/// φ is used when it is this many standard errors of its estimate above zero (and above
/// [`MIN_PHI`]); a scale when it is above 1 by [`MIN_SCALE_CHANGE`].
const SIGNIFICANT: f64 = 4.0;
const MIN_PHI: f64 = 0.05;
const MIN_SCALE_CHANGE: f64 = 0.05;

impl NoiseModel {
    /// One line per set-up whose noise differs from the stated one:
    /// `ball1 (rtest): dx 1.24 × the stated σ, φ = 0.58; …`.
    pub fn describe(&self, study: &Study) -> Vec<String> {
        let mut out = Vec::new();
        for (s, slot) in study.setups.iter().enumerate() {
            let channels = slot.setup.channels();
            let mut parts = Vec::new();
            for (c, ch) in channels.iter().enumerate() {
                let n = self.of(s, c);
                if n.is_stated() {
                    continue;
                }
                let mut p = format!("{} ", ch.name);
                if n.scale != 1.0 {
                    let _ = write!(p, "{:.2} × the stated σ", n.scale);
                    if n.phi != 0.0 {
                        p.push_str(", ");
                    }
                }
                if n.phi != 0.0 {
                    let _ = write!(p, "coloured (φ = {:.2})", n.phi);
                }
                parts.push(p);
            }
            if !parts.is_empty() {
                out.push(format!(
                    "{} ({}): {}",
                    slot.name,
                    slot.plugin.name,
                    parts.join("; ")
                ));
            }
        }
        out
    }
}

/// `study` rebuilt on the noise its residuals at `x` show ([`estimate`]), or `None` when that
/// is the noise it already assumes (the stated, white noise when it assumes none). The plain
/// fit and every step of the physics search refit on it.
pub fn rebuilt_on_estimate(study: &Study, x: &[f64]) -> Result<Option<Study>, IdentifyError> {
    let noise = estimate(study, x);
    let same = match study.changes().noise.as_deref() {
        Some(now) => *now == noise,
        None => noise.is_stated(),
    };
    if same {
        return Ok(None);
    }
    let changes = Changes {
        noise: (!noise.is_stated()).then(|| Arc::new(noise)),
        ..study.changes().clone()
    };
    study.rebuild(changes).map(Some)
}

/// The noise model the residuals of `study` at `x` show (stated σ, white where they show
/// nothing else). Only fitted runs count; the set-ups of one instrument (plugin) share their
/// channels' noise (one instrument, however many places it was set up in).
pub fn estimate(study: &Study, x: &[f64]) -> NoiseModel {
    let mut per_setup: Vec<Vec<ChannelNoise>> = study
        .setups
        .iter()
        .map(|s| vec![ChannelNoise::STATED; s.setup.channels().len()])
        .collect();
    let mut plugins: Vec<&str> = study.setups.iter().map(|s| s.plugin.name).collect();
    plugins.sort_unstable();
    plugins.dedup();
    for plugin in plugins {
        let setups: Vec<usize> = (0..study.setups.len())
            .filter(|&s| study.setups[s].plugin.name == plugin)
            .collect();
        // Channel names of the instrument, in first-seen order.
        let mut names: Vec<String> = Vec::new();
        for &s in &setups {
            for ch in study.setups[s].setup.channels() {
                if !names.contains(&ch.name) {
                    names.push(ch.name.clone());
                }
            }
        }
        let runs: Vec<usize> = (0..study.runs.len())
            .filter(|&r| study.runs[r].fit && setups.contains(&study.runs[r].setup))
            .collect();
        let total: usize = runs.iter().map(|&r| study.runs[r].len()).sum();
        let stride = total.div_ceil(MAX_DIFFERENCES).max(1);
        let mut lagged: Vec<Vec<Block>> = vec![Vec::new(); names.len()];
        for r in runs {
            let channels = study.channels(r);
            let index: Vec<usize> = channels
                .iter()
                .map(|ch| {
                    names
                        .iter()
                        .position(|n| *n == ch.name)
                        .expect("named above")
                })
                .collect();
            collect_differences(study, r, x, stride, &index, &mut lagged);
        }
        let noise: Vec<ChannelNoise> = lagged.iter().map(|l| channel_noise(l)).collect();
        for &s in &setups {
            for (c, ch) in study.setups[s].setup.channels().iter().enumerate() {
                let k = names
                    .iter()
                    .position(|n| *n == ch.name)
                    .expect("named above");
                per_setup[s][c] = noise[k];
            }
        }
    }
    NoiseModel { per_setup }
}

/// The noise of a channel whose whitened residuals (stated σ) in each run are `runs`: what
/// [`estimate`] finds for one set-up's channel.
pub fn channel_noise_of(runs: &[&[f64]]) -> ChannelNoise {
    let mut lagged: Vec<Block> = Vec::new();
    for e in runs {
        push_lagged(e, 1, &mut lagged);
    }
    channel_noise(&lagged)
}

/// The lag-`h` differences (`[h − 1]`, h = 1..=[`MAX_LAG`]) ending in one stretch of
/// [`BLOCK`] samples of one run.
type Block = Vec<Vec<f64>>;

/// Samples per [`Block`]: short enough that a local structure (a bump several runs cross, a
/// reversal's transient) fills few of them, long enough that a block's mean square scatters
/// little under noise alone.
const BLOCK: usize = 32;
/// A block whose mean square at the longest lag exceeds this many times the median block's
/// holds structure, not noise (under AR(1) noise with φ up to 0.9 a block exceeds it with a
/// probability of about 1 %): it is left out of the variogram.
const BLOCK_OUTLIER: f64 = 4.0;

/// Lags of the variogram the estimate fits.
const MAX_LAG: usize = 4;
/// Grid step of the φ search.
const PHI_STEP: f64 = 0.005;

/// Appends the lag-`h` differences `e[k] − e[k−h]` of `e` (h = 1..=MAX_LAG), every
/// `stride`-th `k`, in [`Block`]s of [`BLOCK`] consecutive `k`.
fn push_lagged(e: &[f64], stride: usize, out: &mut Vec<Block>) {
    for start in (0..e.len()).step_by(BLOCK * stride) {
        let end = (start + BLOCK * stride).min(e.len());
        let block: Block = (1..=MAX_LAG)
            .map(|h| {
                (start.max(h)..end)
                    .step_by(stride)
                    .map(|k| e[k] - e[k - h])
                    .filter(|d| d.is_finite())
                    .collect()
            })
            .collect();
        if !block[0].is_empty() {
            out.push(block);
        }
    }
}

/// The blocks' differences pooled per lag, without the blocks that hold structure
/// ([`BLOCK_OUTLIER`]).
fn pooled_without_structure(blocks: &[Block]) -> Vec<Vec<f64>> {
    let mean_square = |d: &[f64]| d.iter().map(|v| v * v).sum::<f64>() / d.len().max(1) as f64;
    let longest: Vec<f64> = blocks
        .iter()
        .map(|b| mean_square(&b[MAX_LAG - 1]))
        .collect();
    let mut sorted = longest.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let mut pooled = vec![Vec::new(); MAX_LAG];
    for (b, m) in blocks.iter().zip(&longest) {
        if *m <= BLOCK_OUTLIER * median {
            for (p, d) in pooled.iter_mut().zip(b) {
                p.extend_from_slice(d);
            }
        }
    }
    pooled
}

/// Appends run `r`'s lagged differences of the whitened residuals (stated σ): channel `c` to
/// `out[index[c]]`.
fn collect_differences(
    study: &Study,
    r: usize,
    x: &[f64],
    stride: usize,
    index: &[usize],
    out: &mut [Vec<Block>],
) {
    let run = &study.runs[r];
    let Some(readings) = run.readings.as_ref() else {
        return;
    };
    let channels = study.channels(r);
    let nch = channels.len();
    let pred = predict_run(study, r, x);
    for (c, ch) in channels.iter().enumerate() {
        let e: Vec<f64> = (0..run.len())
            .map(|i| (pred[i * nch + c] - readings.get(i, c)) / ch.sigma)
            .collect();
        push_lagged(&e, stride, &mut out[index[c]]);
    }
}

/// The noise of one channel from its lagged differences in blocks ([`Block`]), those that
/// hold structure left out ([`pooled_without_structure`]).
///
/// The variogram `γ(h) = ½·E[(eₖ₊ₕ − eₖ)²]` of AR(1) noise is `σ²(1 − φʰ)`: `σ²` and `φ` are
/// fitted to lags 1 to [`MAX_LAG`] (relative errors, φ on a fine grid, σ² in closed form).
/// Short lags see the noise, not what changes slowly; each `γ(h)` is a trimmed mean square
/// (the largest 2 % left out and the rest corrected for it), so a few jumps do not count.
fn channel_noise(blocks: &[Block]) -> ChannelNoise {
    let lagged = pooled_without_structure(blocks);
    let n = lagged.first().map_or(0, Vec::len);
    if n < MIN_DIFFERENCES {
        return ChannelNoise::STATED;
    }
    let gamma: Vec<f64> = lagged.iter().map(|d| 0.5 * trimmed_variance(d)).collect();
    if gamma.iter().any(|g| !(*g > 0.0 && g.is_finite())) {
        return ChannelNoise::STATED;
    }
    // Least squares in relative terms: Σ (1 − σ²(1 − φʰ)/γₕ)², σ² in closed form per φ.
    let fit = |phi: f64| {
        let f: Vec<f64> = (1..=gamma.len())
            .map(|h| (1.0 - phi.powi(h as i32)) / gamma[h - 1])
            .collect();
        let s2 = f.iter().sum::<f64>() / f.iter().map(|v| v * v).sum::<f64>();
        let loss: f64 = f.iter().map(|v| (1.0 - s2 * v).powi(2)).sum();
        (loss, s2)
    };
    let (mut best, mut best_phi) = (f64::INFINITY, 0.0);
    for k in 0..=((MAX_PHI / PHI_STEP).round() as usize) {
        let phi = k as f64 * PHI_STEP;
        let (loss, _) = fit(phi);
        if loss < best {
            (best, best_phi) = (loss, phi);
        }
    }
    // Sampling scatter of the estimates (that of the lag-1 correlation, √((1 − φ²)/n)).
    let se_phi = ((1.0 - best_phi * best_phi) / n as f64).sqrt();
    let phi = if best_phi >= MIN_PHI && best_phi > SIGNIFICANT * se_phi {
        best_phi
    } else {
        0.0
    };
    // The scale is the better estimate whatever its scatter; only a change too small to
    // matter keeps the stated σ.
    let scale_hat = fit(phi).1.sqrt();
    let scale = if scale_hat - 1.0 > MIN_SCALE_CHANGE {
        scale_hat
    } else {
        1.0
    };
    ChannelNoise {
        scale,
        phi,
        samples: n,
    }
}

/// Mean square of `d` (about zero) with the largest 2 % left out, corrected to the variance
/// of normal data: `E[z²; |z| < c]/P(|z| < c)` = 0.8733 for `c` = 2.326.
fn trimmed_variance(d: &[f64]) -> f64 {
    if d.is_empty() {
        return 0.0;
    }
    let mut sq: Vec<f64> = d.iter().map(|v| v * v).collect();
    let keep = (((sq.len() as f64) * 0.98).ceil() as usize).clamp(1, sq.len());
    if keep < sq.len() {
        sq.select_nth_unstable_by(keep - 1, f64::total_cmp);
        sq[..keep].iter().sum::<f64>() / keep as f64 / 0.8733
    } else {
        sq.iter().sum::<f64>() / sq.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::whiten::prewhiten;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn ar1(n: usize, phi: f64, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut e = 0.0;
        (0..n)
            .map(|k| {
                let z: f64 = StandardNormal.sample(&mut rng);
                e = if k == 0 {
                    sigma * z
                } else {
                    phi * e + (1.0 - phi * phi).sqrt() * sigma * z
                };
                e
            })
            .collect()
    }

    fn diffs(e: &[f64]) -> Vec<Block> {
        let mut out = Vec::new();
        push_lagged(e, 1, &mut out);
        out
    }

    #[test]
    fn white_noise_of_the_stated_sigma_stays_as_stated() {
        for seed in 0..20 {
            let n = channel_noise(&diffs(&ar1(2000, 0.0, 1.0, seed)));
            assert!(n.is_stated(), "seed {seed}: {n:?}");
        }
    }

    #[test]
    fn coloured_noise_stated_too_small_is_found() {
        for seed in 0..10 {
            // σ 0.3 stated as 0.24, φ = 0.6: in stated units σ = 1.25.
            let n = channel_noise(&diffs(&ar1(3000, 0.6, 1.25, seed)));
            assert!((n.phi - 0.6).abs() < 0.1, "seed {seed}: {n:?}");
            assert!((n.scale - 1.25).abs() < 0.12, "seed {seed}: {n:?}");
        }
    }

    #[test]
    fn a_slow_drift_and_a_few_jumps_do_not_look_like_noise() {
        let mut e = ar1(2000, 0.0, 1.0, 7);
        for (k, v) in e.iter_mut().enumerate() {
            // A drift of 30 σ over the run, and a ±3 σ step flipping every 400 samples.
            *v += 30.0 * (1.0 - (-(k as f64) / 500.0).exp());
            *v += if (k / 400) % 2 == 0 { 3.0 } else { -3.0 };
        }
        let n = channel_noise(&diffs(&e));
        assert!(n.is_stated(), "{n:?}");
    }

    /// A guideway bump several runs cross (a raised cosine of 12 σ over ±9 samples, in one
    /// block of 96 samples out of five) is structure: short lags see its slopes, and a
    /// variogram pooled over every sample reads them as noise that is larger and more
    /// coloured than it is.
    #[test]
    fn a_local_bump_in_some_runs_is_not_noise() {
        for seed in 0..10 {
            let mut e = ar1(4000, 0.6, 1.25, 40 + seed);
            for (k, v) in e.iter_mut().enumerate() {
                let u = (k % 480) as f64 - 48.0;
                if u.abs() < 9.0 {
                    *v += 6.0 * (1.0 + (std::f64::consts::PI * u / 9.0).cos());
                }
            }
            let n = channel_noise(&diffs(&e));
            assert!((n.phi - 0.6).abs() < 0.1, "seed {seed}: {n:?}");
            assert!((n.scale - 1.25).abs() < 0.12, "seed {seed}: {n:?}");
        }
    }

    #[test]
    fn a_smaller_noise_than_stated_keeps_the_stated_sigma() {
        let n = channel_noise(&diffs(&ar1(2000, 0.0, 0.3, 1)));
        assert_eq!(n.scale, 1.0);
    }

    #[test]
    fn prewhitening_ar1_noise_gives_white_innovations() {
        let e = ar1(20000, 0.7, 1.0, 3);
        let w = prewhiten(&e, 0.7);
        let var = w.iter().map(|v| v * v).sum::<f64>() / w.len() as f64;
        let lag1 = w.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / w.len() as f64;
        assert!((var - 1.0).abs() < 0.05, "{var}");
        assert!(lag1.abs() < 0.03, "{lag1}");
    }
}
