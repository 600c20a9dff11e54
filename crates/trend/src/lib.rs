//! What the history of one machine parameter says: pure functions on its series of results.
//!
//! A [`Point`] is one result: a time (seconds on one clock), a value, its expanded uncertainty
//! `u95` (k = 2) and optionally a temperature. Values stay in the parameter's own unit; every
//! result is in that unit (rates per day, time constants in minutes). The crate knows nothing
//! of machines or databases. Bad input (a NaN, a `u95` ≤ 0, a series out of time order, too
//! few points) is a [`TrendError`], never a panic or a NaN.
//!
//! # Two results: the normalised error
//!
//! [`normalised_error`]: `E_n = |a − b| / √(U_a² + U_b²)`; `E_n > 1` is a significant change
//! ([`compare`] between two campaigns, [`consecutive_changes`] along a series). Each such
//! comparison raises a false alarm for about 4.6 % of stable pairs (`P(|z| > 2)`), so a long
//! series shows some; whether the *series* changed is the next two tests' question.
//!
//! # Drift: a weighted straight line
//!
//! [`fit_drift`]: value against time by weighted least squares, weights `1/u²`, `u = U/2`.
//! If the residuals' `χ²/dof` exceeds 1 (its p-value reported), the stated uncertainties do not
//! explain the scatter: the standard uncertainties are multiplied by the Birge ratio
//! `√(χ²/dof)` and the coverage factor is Student's t(n − 2) at 97.5 % ([`Scatter`]); otherwise
//! k = 2. The drift is significant when `|rate| > u95(rate)`. The intercept is reported at the
//! weighted mean time, where it is uncorrelated with the rate.
//!
//! # Step: the best single change and an honest p-value
//!
//! [`find_step`]: every split between two different times with at least `min_segment` points
//! each side; the best has the smallest χ² about the two weighted means. Searching for the best
//! split makes some split look good in any series, so the p-value is that of the maximum: the
//! statistic `max_k (χ²₀ − χ²_k)/χ²₀` is free of the level and of a common factor on the
//! uncertainties, and its no-change distribution is simulated with a fixed seed.
//!
//! A drift and a step look alike over a short history; [`prefer`] names the one the data
//! prefer (information criterion, see there) and never both ([`Verdict`]). Whether the series
//! changed at all is one test, not two: the same simulations give the straight line's share
//! of χ² too, and the smaller of the two p-values is ranked among the simulated ones (min-p),
//! so "a drift or a step" is claimed for at most `alpha` of unchanged series.
//!
//! # Tolerance and the next check
//!
//! [`tolerance_status`] decides each result against `|value| ≤ limit`, optionally with the
//! ISO 14253-1 rule (within `U` of the limit: cannot decide). [`next_check`] projects a
//! significant drift at the upper end of its rate's interval to the limit, capped by a maximum
//! interval; without a drift the maximum interval is the answer, and says so.
//!
//! # Same-day thermal trajectory
//!
//! Repeated quick checks within a day (source 000: fast R-test location errors drifting by
//! about 12 µm/m as the machine warms) follow `v(t) = v∞ + (v0 − v∞)·exp(−(t − t0)/τ)`.
//! [`fit_thermal`] solves `v∞` and the amplitude exactly for each τ and searches τ on the
//! profile χ²; every interval (τ, amplitude, `v∞`) is a profile-likelihood one; a series too short, a τ at the end of the searched range or an interval reaching
//! it is [`NotDetermined`]. [`temperature_sensitivity`] is the weighted line against the
//! temperature column.
//!
//! # All at once
//!
//! [`analyse`] runs the comparisons, drift, step, verdict, tolerance and next check.
//!
//! ```
//! use mtcal_trend::{Point, Tolerance, TrendOptions, Verdict, analyse};
//!
//! // EXOC (µm) of one machine, one campaign a month, U = 1 µm, drifting 0.5 µm a month.
//! let month_s = 30.0 * 86_400.0;
//! let wobble = [0.2, -0.3, 0.1, 0.0, -0.2, 0.3, -0.1, 0.2, -0.2, 0.1];
//! let points: Vec<Point> = (0..10)
//!     .map(|i| Point::new(1.7e9 + month_s * i as f64, 4.0 + 0.5 * i as f64 + wobble[i], 1.0))
//!     .collect();
//! let options = TrendOptions {
//!     tolerance: Some(Tolerance { limit: 15.0, guard_band: true }),
//!     max_interval_days: 365.0,
//!     ..Default::default()
//! };
//! let trend = analyse(&points, &options)?;
//! assert_eq!(trend.verdict, Verdict::Drift);
//! assert!((trend.drift.rate_per_day * 30.0 - 0.5).abs() < 0.1);
//! // From about 8.5 µm towards 15 − 1 µm at the rate's upper bound: about 10 months.
//! let next = trend.next_check.unwrap();
//! assert!(next.interval_days > 250.0 && next.interval_days < 365.0);
//! # Ok::<(), mtcal_trend::TrendError>(())
//! ```

mod compare;
mod drift;
mod error;
mod line;
mod null;
mod point;
mod profile;
mod scatter;
mod sensitivity;
mod step;
mod summary;
mod thermal;
mod tolerance;

pub use compare::{Change, compare, consecutive_changes, normalised_error};
pub use drift::{DriftFit, fit_drift};
pub use error::TrendError;
pub use point::Point;
pub use scatter::Scatter;
pub use sensitivity::{Sensitivity, temperature_sensitivity};
pub use step::{StepChange, StepOptions, find_step};
pub use summary::{Trend, TrendOptions, Verdict, analyse, prefer};
pub use thermal::{
    NotDetermined, THERMAL_MIN_POINTS, ThermalFit, ThermalOptions, Trajectory, fit_thermal,
};
pub use tolerance::{
    Conformity, NextCheck, NextCheckReason, Tolerance, ToleranceStatus, conformity, next_check,
    tolerance_status,
};
