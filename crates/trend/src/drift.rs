//! The drift rate of a parameter over its history, with its interval.

use serde::Serialize;

use crate::error::TrendError;
use crate::line::fit_line;
use crate::point::{Point, check_series, distinct_times};
use crate::scatter::Scatter;

/// Seconds per day: the rate is reported per day.
pub(crate) const SECONDS_PER_DAY: f64 = 86_400.0;

/// A straight line through the history, `value(t) = value_at_reference + rate·(t − t_ref)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DriftFit {
    /// Points fitted.
    pub n: usize,
    /// The drift rate, the parameter's unit per day.
    pub rate_per_day: f64,
    /// Its expanded uncertainty (k = 2, or Student's t(n − 2) with the Birge ratio when
    /// [`Scatter::inflated`]).
    pub rate_u95_per_day: f64,
    /// The reference time: the weighted mean time of the points, where the intercept and the
    /// rate are uncorrelated.
    pub reference_time_s: f64,
    /// The intercept: the fitted value at `reference_time_s`.
    pub value_at_reference: f64,
    /// Its expanded uncertainty.
    pub value_at_reference_u95: f64,
    /// Time of the latest point.
    pub last_time_s: f64,
    /// Scatter about the line against the stated uncertainties.
    pub scatter: Scatter,
    /// `|rate| > rate_u95`: the data show a drift.
    pub significant: bool,
}

impl DriftFit {
    /// The fitted line's value at `time_s` and its expanded uncertainty (the intercept and the
    /// rate are uncorrelated at the reference time, so their parts add in quadrature).
    pub fn value_at(&self, time_s: f64) -> (f64, f64) {
        let days = (time_s - self.reference_time_s) / SECONDS_PER_DAY;
        let value = self.value_at_reference + self.rate_per_day * days;
        let u95 = self
            .value_at_reference_u95
            .hypot(days * self.rate_u95_per_day);
        (value, u95)
    }
}

/// The weighted least-squares line of value against time, weights `1/u²` with `u = U/2`.
///
/// Needs at least 3 points (one degree of freedom to check the scatter) at two or more
/// different times, in time order.
pub fn fit_drift(points: &[Point]) -> Result<DriftFit, TrendError> {
    const WHAT: &str = "a drift rate";
    check_series(points, 3, WHAT)?;
    if distinct_times(points) < 2 {
        return Err(TrendError::IdenticalTimes {
            what: WHAT,
            n: points.len(),
        });
    }
    // Days since the first point: Unix seconds (~1.7e9) would cost digits in the sums.
    let t0 = points[0].time_s;
    let days: Vec<f64> = points
        .iter()
        .map(|p| (p.time_s - t0) / SECONDS_PER_DAY)
        .collect();
    let values: Vec<f64> = points.iter().map(|p| p.value).collect();
    let sigma: Vec<f64> = points.iter().map(Point::sigma).collect();
    let line = fit_line(&days, &values, &sigma).ok_or(TrendError::OutOfRange { what: WHAT })?;
    let scatter = Scatter::new(line.chi2, points.len() - 2);
    let expansion = scatter.expansion();
    let rate_u95_per_day = expansion * line.sd_slope;
    Ok(DriftFit {
        n: points.len(),
        rate_per_day: line.slope,
        rate_u95_per_day,
        reference_time_s: t0 + line.x_ref * SECONDS_PER_DAY,
        value_at_reference: line.level,
        value_at_reference_u95: expansion * line.sd_level,
        last_time_s: points[points.len() - 1].time_s,
        scatter,
        significant: line.slope.abs() > rate_u95_per_day,
    })
}
