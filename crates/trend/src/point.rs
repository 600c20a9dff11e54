//! One result of a parameter in its history, and the checks every analysis makes on a series.

use serde::{Deserialize, Serialize};

use crate::error::TrendError;

/// One calibration result of one parameter: when, what, how well known.
///
/// `value` and `u95` are in the parameter's own unit (µm, µrad, µm/m…), the same for every
/// point of a series; the analyses never convert it, so their results are in that unit too.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Time of the measurement in seconds on one fixed clock (Unix time for campaigns).
    pub time_s: f64,
    /// The parameter's value.
    pub value: f64,
    /// Its expanded uncertainty, k = 2; positive.
    pub u95: f64,
    /// Machine or ambient temperature at the measurement, °C, when recorded.
    pub temperature_c: Option<f64>,
}

impl Point {
    /// A point without a temperature.
    pub fn new(time_s: f64, value: f64, u95: f64) -> Point {
        Point {
            time_s,
            value,
            u95,
            temperature_c: None,
        }
    }

    /// The same point with a temperature.
    pub fn with_temperature_c(self, temperature_c: f64) -> Point {
        Point {
            temperature_c: Some(temperature_c),
            ..self
        }
    }

    /// The standard uncertainty `u = U/2` the fits weigh by.
    pub(crate) fn sigma(&self) -> f64 {
        self.u95 / 2.0
    }
}

/// Every number finite, every `u95` positive.
pub(crate) fn check_point(index: usize, p: &Point) -> Result<(), TrendError> {
    let fields = [("time_s", p.time_s), ("value", p.value), ("u95", p.u95)];
    let temperature = p.temperature_c.map(|t| ("temperature_c", t));
    for (field, value) in fields.into_iter().chain(temperature) {
        if !value.is_finite() {
            return Err(TrendError::NotFinite {
                index,
                field,
                value,
            });
        }
    }
    if p.u95 <= 0.0 {
        return Err(TrendError::NonPositiveUncertainty { index, u95: p.u95 });
    }
    Ok(())
}

/// The checks of [`check_point`] on every point, the series in time order (ties allowed) and at
/// least `needed` points for `what`.
pub(crate) fn check_series(
    points: &[Point],
    needed: usize,
    what: &'static str,
) -> Result<(), TrendError> {
    for (index, p) in points.iter().enumerate() {
        check_point(index, p)?;
    }
    for (index, pair) in points.windows(2).enumerate() {
        if pair[1].time_s < pair[0].time_s {
            return Err(TrendError::NotInTimeOrder {
                index: index + 1,
                previous: index,
                time_s: pair[1].time_s,
                previous_time_s: pair[0].time_s,
            });
        }
    }
    if points.len() < needed {
        return Err(TrendError::TooFewPoints {
            what,
            needed,
            found: points.len(),
        });
    }
    Ok(())
}

/// The number of different times in a series in time order.
pub(crate) fn distinct_times(points: &[Point]) -> usize {
    match points.first() {
        None => 0,
        Some(_) => {
            1 + points
                .windows(2)
                .filter(|w| w[1].time_s > w[0].time_s)
                .count()
        }
    }
}
