//! Is there a mismatch between model and recordings, and where?
//!
//! Given whitened residuals `rᵢ = (model − measured)/σ` of every run and channel and the context
//! each sample was recorded in, [`locate`] tests whether they look like white Gaussian noise of
//! unit variance — what a correct model and a correct noise model predict — and, where they do
//! not, along which variable and over which span the excess sits. The crate is independent of
//! the rest of mtcal: it sees only slices of numbers and their names.
//!
//! # The tests
//!
//! Per run and channel:
//! - **χ² goodness of fit**: `Σ rᵢ²` against χ² with `n` degrees of freedom, upper tail (a fit
//!   better than the noise allows is not a model mismatch). The only test that depends on σ.
//!
//! Per run, channel and continuous context variable (time `t`, each axis position, rotary angle,
//! each temperature column, spindle speed, feed…), on the residuals *sorted by that variable*
//! (ties in sample order; a constant variable is skipped and listed in [`Analysis::skipped`]):
//! - **Wald–Wolfowitz runs test** on the signs, two-sided; exact distribution up to 60 signs,
//!   normal approximation with continuity correction beyond.
//! - **Ljung–Box** over lags 1…10 (at most `n/4`), χ² p-value; the lag-1 autocorrelation is
//!   reported alongside.
//! - **CUSUM of the mean**, scaled by the sample standard deviation and `√n`, with the
//!   Kolmogorov (Brownian-bridge supremum) p-value; it also gives the value at the change.
//! - **Lomb–Scargle periodogram** (generalised, floating mean) of the residuals against the
//!   variable's values — not their ranks — so unevenly spaced positions are handled; the peak's
//!   false-alarm probability is **Baluev's (2008) bound**, not the independent-frequencies
//!   approximation (see [`periodogram`]).
//!
//! Per run, channel and categorical split (direction of motion ±1, CW/CCW, set-up index…), over
//! the groups with at least `min_group_samples` samples:
//! - **Welch's ANOVA** on the group means (for two groups, Welch's t-test).
//! - **Brown–Forsythe** test on the group spreads (ANOVA on absolute deviations from the group
//!   medians).
//!
//! All tests but χ² are scale-free: they normalise by the residuals' own spread. A σ stated too
//! small or too large therefore shows up in χ² alone, never as "structure along X".
//!
//! # Multiple testing: Holm
//!
//! A run with three channels and six variables is about eighty tests; at 5 % each, white noise
//! would raise a false alarm almost always. All p-values of one run (default, [`Family::Run`]) or
//! of all runs together ([`Family::All`]) form a family, and **Holm's step-down correction** holds
//! the family-wise false-alarm rate at `α`: the k-th smallest of `m` p-values is multiplied by
//! `m − k + 1`, the products made non-decreasing, and a test is rejected when its adjusted p is
//! at most `α`. Holm is valid under any dependence between the tests (they are strongly
//! dependent here — the same residuals in several orders) and rejects everything Bonferroni
//! rejects, and sometimes more. Holm needs valid individual p-values: they are exact (χ², runs
//! test up to 60 signs), asymptotic (Ljung–Box, Welch, Brown–Forsythe, larger runs tests) or err
//! on the large side (Kolmogorov for a discrete CUSUM, Baluev's bound). The calibration test
//! checks both the family-wise rate and each test's own rate on 300 seeded white-noise runs of
//! 200 samples. With [`Family::Run`] and many runs, the chance of *some* false alarm in the
//! call grows with the number of runs; use [`Family::All`] to bound the whole call by `α`.
//!
//! # Where: the span method
//!
//! For each run, channel and variable with a rejected test, the residuals sorted by the
//! variable are searched for the contiguous span that departs most from the noise, by two
//! generalised likelihood-ratio searches: a **mean shift** inside the span (`GLR = (Σ rᵢ)²/2m`;
//! offsets, steps, drifts) and a **larger spread** inside it (`GLR = (Q − m − m ln(Q/m))/2`,
//! `Q = Σ rᵢ²`; quick sign changes, extra noise); the larger GLR wins. Each search is Kadane's
//! maximum-sum segment of `qᵢ − κ` (`qᵢ = ±rᵢ` or `rᵢ² − 1`) with `κ` half the segment's own mean
//! of `q`, found by fixed-point iteration — the GLR's rule to first order. Concentrated effects
//! get sharp edges; an effect spread over the whole run gets the whole run. Samples with equal
//! values are never split; the cost is linear in `n`. See [`span`]. One exception: when the
//! strongest evidence along a variable is a Lomb–Scargle peak whose period is shorter than half
//! the variable's range, the effect repeats along it and the span is the whole range (a segment
//! search would cut out one bump of a cyclic error).
//!
//! The span's `share` is always measured in excess χ², `E = Σ rᵢ² − n`: with `S = Σ (rᵢ² − 1)`
//! inside the span, `share = S/E` when `0 ≤ S ≤ E`, 1 when the rest of the run is quieter than
//! the noise, 0 when the span holds no excess. For a split, `from` and `to` are labels.
//! Locations are listed strongest evidence (smallest adjusted p) first within each run and
//! channel, one per variable with a rejected test; a run-channel whose χ² alone is rejected gets
//! one location with `along`, `from` and `to` null: the excess is spread evenly — σ understated,
//! or a cause no tested variable orders.
//!
//! # Example
//!
//! ```
//! use mtcal_mismatch::{Options, RunResiduals, locate};
//!
//! // 300 s of whitened residuals with an unmodelled 2 σ offset from t = 100 s to 200 s.
//! let t: Vec<f64> = (0..300).map(f64::from).collect();
//! let r: Vec<f64> = t
//!     .iter()
//!     .map(|&t| {
//!         let noise = ((t * 7.3).sin() * 43.1).fract() - 0.5; // stand-in for measurement noise
//!         noise + if (100.0..200.0).contains(&t) { 2.0 } else { 0.0 }
//!     })
//!     .collect();
//! let run = RunResiduals::new("rtest-xyc-a0").channel("dz", &r).context("t", &t);
//! let analysis = locate(&[run], &Options::default())?;
//! assert!(analysis.mismatch.detected);
//! let place = &analysis.mismatch.locations[0];
//! assert_eq!(place.along.as_deref(), Some("t"));
//! assert_eq!((place.from, place.to), (Some(100.0), Some(199.0)));
//! # Ok::<(), mtcal_mismatch::MismatchError>(())
//! ```

mod error;
mod groups;
mod input;
mod locate;
mod options;
pub mod periodogram;
mod report;
pub mod span;
pub mod stats;

pub use error::MismatchError;
pub use groups::{brown_forsythe, welch_anova};
pub use input::{Channel, RunResiduals, Split, Variable};
pub use locate::locate;
pub use options::{Family, Options};
pub use periodogram::{LombScargleOptions, lomb_scargle};
pub use report::{Analysis, Location, Mismatch, Skipped, TestKind, TestRecord};
