//! Two results of one parameter compared: the normalised error `E_n`.

use serde::Serialize;

use crate::error::TrendError;
use crate::point::{Point, check_point, check_series};

/// The change from one result to another.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Change {
    /// Position of the earlier result (0 for [`compare`]'s `a`).
    pub from: usize,
    /// Position of the later result (1 for [`compare`]'s `b`).
    pub to: usize,
    /// `value(to) − value(from)`.
    pub difference: f64,
    /// Its expanded uncertainty `√(U_from² + U_to²)`, the two results independent.
    pub difference_u95: f64,
    /// `E_n = |difference| / difference_u95`.
    pub normalised_error: f64,
    /// `E_n > 1`: the two results disagree beyond their uncertainties.
    pub significant: bool,
}

/// `E_n = |a − b| / √(U_a² + U_b²)` (ISO/IEC 17043): above 1 the results disagree beyond their
/// expanded uncertainties. Errors on a non-finite number or a `u95` that is not positive.
pub fn normalised_error(a: &Point, b: &Point) -> Result<f64, TrendError> {
    compare(a, b).map(|c| c.normalised_error)
}

/// `a` against `b`: the difference `b − a`, its `u95`, `E_n` and whether `E_n > 1`.
pub fn compare(a: &Point, b: &Point) -> Result<Change, TrendError> {
    check_point(0, a)?;
    check_point(1, b)?;
    Ok(change(0, a, 1, b))
}

/// Each result against the one before it, in a series in time order.
///
/// Each `E_n > 1` is a test at about 4.6 % false alarms (for correct `U` with k = 2, the
/// difference over its `U` exceeds 1 with probability `P(|z| > 2)`), so a series of 20 stable
/// results shows on average 0.9 such flags. Whether the *series* changed is the drift and step
/// tests' question ([`fit_drift`](crate::fit_drift), [`find_step`](crate::find_step)).
pub fn consecutive_changes(points: &[Point]) -> Result<Vec<Change>, TrendError> {
    check_series(points, 0, "comparing consecutive results")?;
    Ok(points
        .windows(2)
        .enumerate()
        .map(|(i, w)| change(i, &w[0], i + 1, &w[1]))
        .collect())
}

fn change(from: usize, a: &Point, to: usize, b: &Point) -> Change {
    let difference = b.value - a.value;
    // hypot keeps U² from overflowing or underflowing for any unit.
    let difference_u95 = a.u95.hypot(b.u95);
    let normalised_error = difference.abs() / difference_u95;
    Change {
        from,
        to,
        difference,
        difference_u95,
        normalised_error,
        significant: normalised_error > 1.0,
    }
}
