//! Why a history could not be analysed.

/// Bad input or settings. Each variant says what is wrong and what is needed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrendError {
    /// A number of a point is NaN or infinite.
    #[error("point {index}: {field} is {value}; it must be a finite number")]
    NotFinite {
        /// Position of the point in the series.
        index: usize,
        /// `time_s`, `value`, `u95` or `temperature_c`.
        field: &'static str,
        /// The value found.
        value: f64,
    },
    /// A stated uncertainty is zero or negative: such a point cannot be weighed.
    #[error(
        "point {index}: u95 is {u95}; an expanded uncertainty must be positive (a value without \
         an uncertainty cannot be weighed against the others)"
    )]
    NonPositiveUncertainty {
        /// Position of the point in the series.
        index: usize,
        /// The value found.
        u95: f64,
    },
    /// The series is not sorted by time.
    #[error(
        "point {index} (t = {time_s} s) is earlier than point {previous} (t = {previous_time_s} \
         s); give the series in time order"
    )]
    NotInTimeOrder {
        /// The later position with the earlier time.
        index: usize,
        /// The position before it.
        previous: usize,
        /// Its time.
        time_s: f64,
        /// The time of the point before.
        previous_time_s: f64,
    },
    /// Too short a series for the question asked.
    #[error("{what} needs at least {needed} points; the series has {found}")]
    TooFewPoints {
        /// The analysis.
        what: &'static str,
        /// Points it needs.
        needed: usize,
        /// Points given.
        found: usize,
    },
    /// Every point has the same time, so no rate can be estimated.
    #[error("all {n} points are at the same time; {what} needs at least two different times")]
    IdenticalTimes {
        /// The analysis.
        what: &'static str,
        /// Points given.
        n: usize,
    },
    /// Ties in time leave no place for a step between two different times.
    #[error(
        "the step test finds no place to split the series with at least {min_segment} points on \
         each side between two different times"
    )]
    NoSplit {
        /// Fewest points each side of a step.
        min_segment: usize,
    },
    /// Some points carry a temperature and some do not.
    #[error("{with} of {n} points carry a temperature; give it for every point or for none")]
    PartialTemperature {
        /// Points with a temperature.
        with: usize,
        /// Points given.
        n: usize,
    },
    /// All temperatures are equal, so no sensitivity to temperature can be estimated.
    #[error(
        "all {n} temperatures are {temperature_c} °C; a sensitivity needs at least two \
         different temperatures"
    )]
    IdenticalTemperatures {
        /// Points given.
        n: usize,
        /// The one temperature.
        temperature_c: f64,
    },
    /// A setting is out of its range.
    #[error("{what} is {value}; it must be {expected}")]
    BadSetting {
        /// The setting.
        what: &'static str,
        /// The value given.
        value: f64,
        /// Its valid range in words.
        expected: &'static str,
    },
    /// The arithmetic left floating-point range (uncertainties spanning hundreds of orders of
    /// magnitude); no result is better than a NaN.
    #[error(
        "{what}: the numbers leave floating-point range (values or uncertainties differ by too \
         many orders of magnitude)"
    )]
    OutOfRange {
        /// The analysis.
        what: &'static str,
    },
}
