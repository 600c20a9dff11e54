//! The history against a tolerance: which results conform, and when to check next.

use serde::Serialize;

use crate::drift::{DriftFit, SECONDS_PER_DAY};
use crate::error::TrendError;
use crate::point::{Point, check_point, check_series};

/// An upper tolerance on the parameter's magnitude, `|value| ≤ limit`, in its unit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerance {
    /// The limit on `|value|`; positive.
    pub limit: f64,
    /// Apply ISO 14253-1's decision rule: a result within its `U` of the limit on either side
    /// is [`Conformity::CannotDecide`]. Without it the limit alone decides.
    pub guard_band: bool,
}

/// What one result says about the tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Conformity {
    /// Within the limit (by at least `U` with the guard band).
    Conforms,
    /// With the guard band: within `U` of the limit, inside or outside — the uncertainty
    /// range of ISO 14253-1, where neither conformity nor non-conformity is proven.
    CannotDecide,
    /// Beyond the limit (by more than `U` with the guard band).
    OutOfTolerance,
}

/// The series against the tolerance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ToleranceStatus {
    /// One verdict per point.
    pub conformity: Vec<Conformity>,
    /// The first point out of tolerance: the series crossed the limit there.
    pub first_out: Option<usize>,
    /// The first point where the guard band leaves the decision open.
    pub first_undecided: Option<usize>,
}

impl ToleranceStatus {
    /// Whether any point is out of tolerance.
    pub fn crossed(&self) -> bool {
        self.first_out.is_some()
    }

    /// The verdict on the latest point (`None` for an empty series).
    pub fn latest(&self) -> Option<Conformity> {
        self.conformity.last().copied()
    }
}

/// When to check next, and why then.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NextCheck {
    /// The suggested time of the next check.
    pub time_s: f64,
    /// Days from the latest result to it.
    pub interval_days: f64,
    /// Why.
    pub reason: NextCheckReason,
}

/// Why the next check falls when it does.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum NextCheckReason {
    /// No significant drift: next check by the maximum interval.
    NoSignificantDrift,
    /// The drift line, drifting at the upper end of its 95 % interval, reaches the limit then.
    DriftReachesLimit,
    /// The drift would reach the limit only at `reach_time_s`, later than the maximum interval.
    CappedByMaximumInterval {
        /// When the conservative drift line reaches the limit.
        reach_time_s: f64,
    },
    /// The latest result is already at the limit (within `U` of it with the guard band):
    /// check, or act, now.
    AlreadyAtLimit,
}

/// One result against the tolerance.
pub fn conformity(point: &Point, tolerance: &Tolerance) -> Result<Conformity, TrendError> {
    check_point(0, point)?;
    check_tolerance(tolerance)?;
    Ok(decide(point, tolerance))
}

/// Every result of a series in time order against the tolerance.
pub fn tolerance_status(
    points: &[Point],
    tolerance: &Tolerance,
) -> Result<ToleranceStatus, TrendError> {
    check_series(points, 0, "a tolerance check")?;
    check_tolerance(tolerance)?;
    let conformity: Vec<Conformity> = points.iter().map(|p| decide(p, tolerance)).collect();
    let first = |c| conformity.iter().position(|&x| x == c);
    Ok(ToleranceStatus {
        first_out: first(Conformity::OutOfTolerance),
        first_undecided: first(Conformity::CannotDecide),
        conformity,
    })
}

/// The suggested time of the next check after the `latest` result.
///
/// With a significant drift (pass `None` when the history is better described otherwise, e.g.
/// by a step), the line is projected from its fitted value at the latest time `v_L` at the
/// upper end of the rate's 95 % interval, in the direction it drifts, `|r| + U_r`, to the
/// limit it heads for: `t = t_L + (L ∓ v_L)/(|r| + U_r)`. With the guard band the target is
/// `L − U_latest`, so the next result can still prove conformity. The time is capped at
/// `max_interval_days` after the latest result; without a significant drift it is that cap.
pub fn next_check(
    latest: &Point,
    drift: Option<&DriftFit>,
    tolerance: &Tolerance,
    max_interval_days: f64,
) -> Result<NextCheck, TrendError> {
    check_point(0, latest)?;
    check_tolerance(tolerance)?;
    if !(max_interval_days.is_finite() && max_interval_days > 0.0) {
        return Err(TrendError::BadSetting {
            what: "max_interval_days",
            value: max_interval_days,
            expected: "a positive number of days",
        });
    }
    let target = if tolerance.guard_band {
        tolerance.limit - latest.u95
    } else {
        tolerance.limit
    };
    let after = |days: f64, reason| NextCheck {
        time_s: latest.time_s + days * SECONDS_PER_DAY,
        interval_days: days,
        reason,
    };
    if latest.value.abs() >= target {
        return Ok(after(0.0, NextCheckReason::AlreadyAtLimit));
    }
    let Some(drift) = drift.filter(|d| d.significant) else {
        return Ok(after(
            max_interval_days,
            NextCheckReason::NoSignificantDrift,
        ));
    };
    let (fitted, _) = drift.value_at(latest.time_s);
    // Distance to the limit the line heads for: +L when rising, −L when falling.
    let remaining = (target - fitted * drift.rate_per_day.signum()).max(0.0);
    let fastest = drift.rate_per_day.abs() + drift.rate_u95_per_day;
    let reach_days = remaining / fastest;
    if reach_days <= max_interval_days {
        Ok(after(reach_days, NextCheckReason::DriftReachesLimit))
    } else {
        let reach_time_s = latest.time_s + reach_days * SECONDS_PER_DAY;
        Ok(after(
            max_interval_days,
            NextCheckReason::CappedByMaximumInterval { reach_time_s },
        ))
    }
}

fn check_tolerance(tolerance: &Tolerance) -> Result<(), TrendError> {
    if tolerance.limit.is_finite() && tolerance.limit > 0.0 {
        Ok(())
    } else {
        Err(TrendError::BadSetting {
            what: "the tolerance limit",
            value: tolerance.limit,
            expected: "a positive finite number",
        })
    }
}

fn decide(point: &Point, tolerance: &Tolerance) -> Conformity {
    let magnitude = point.value.abs();
    let band = if tolerance.guard_band { point.u95 } else { 0.0 };
    if magnitude <= tolerance.limit - band {
        Conformity::Conforms
    } else if magnitude > tolerance.limit + band {
        Conformity::OutOfTolerance
    } else {
        Conformity::CannotDecide
    }
}
