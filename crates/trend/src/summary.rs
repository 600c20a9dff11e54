//! Everything the history of one parameter says, in one call, and which description of it the
//! data prefer.

use serde::Serialize;

use crate::compare::{Change, consecutive_changes};
use crate::drift::{DriftFit, fit_drift};
use crate::error::TrendError;
use crate::point::{Point, check_series};
use crate::step::{StepChange, StepOptions, find_step};
use crate::tolerance::{NextCheck, Tolerance, ToleranceStatus, next_check, tolerance_status};

/// Which description of the history the data prefer. A drift and a step look alike over a
/// short history, so only one is ever claimed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Verdict {
    /// Neither a significant drift nor a significant step.
    NoChange,
    /// A steady drift ([`DriftFit`]).
    Drift,
    /// A single step change ([`StepChange`]).
    Step,
}

/// The preferred description.
///
/// Whether the series changed at all is [`StepChange::any_change`]: one test for "a drift or a
/// step" whose false alarms stay at `alpha` (testing the drift and the step separately at 5 %
/// each would raise one in about 7 % of unchanged series). If it changed, the description whose
/// own test is significant is named; when both or neither are, the one with the lower Bayesian
/// information criterion with the scale estimated from the data, `n·ln χ² + p·ln n`: the step
/// has one parameter more than the line (its place), so it must lower χ² by the factor
/// `n^(−1/n)` (0.86 for 20 points) to be preferred. A series too short for a step
/// (`step = None`) is judged by the drift alone.
pub fn prefer(drift: &DriftFit, step: Option<&StepChange>) -> Verdict {
    let Some(step) = step else {
        return if drift.significant {
            Verdict::Drift
        } else {
            Verdict::NoChange
        };
    };
    if !step.any_change {
        return Verdict::NoChange;
    }
    match (drift.significant, step.significant) {
        (true, false) => Verdict::Drift,
        (false, true) => Verdict::Step,
        _ => {
            let n = drift.n as f64;
            if step.scatter.chi2 < drift.scatter.chi2 * n.powf(-1.0 / n) {
                Verdict::Step
            } else {
                Verdict::Drift
            }
        }
    }
}

/// Settings of [`analyse`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TrendOptions {
    /// The step test.
    pub step: StepOptions,
    /// The tolerance to check against, if any.
    pub tolerance: Option<Tolerance>,
    /// The longest interval between checks, days.
    pub max_interval_days: f64,
}

impl Default for TrendOptions {
    fn default() -> Self {
        TrendOptions {
            step: StepOptions::default(),
            tolerance: None,
            max_interval_days: 365.0,
        }
    }
}

/// What the history of one parameter says.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Trend {
    /// Each result against the one before.
    pub changes: Vec<Change>,
    /// The straight line through the history.
    pub drift: DriftFit,
    /// The best single step, `None` when the series is too short to split.
    pub step: Option<StepChange>,
    /// Which of the two the data prefer, if either.
    pub verdict: Verdict,
    /// The results against the tolerance, when one is given.
    pub tolerance: Option<ToleranceStatus>,
    /// When to check next, when a tolerance is given. Only a preferred drift is projected.
    pub next_check: Option<NextCheck>,
}

/// The whole analysis of a series in time order (at least 3 points at two or more times).
pub fn analyse(points: &[Point], options: &TrendOptions) -> Result<Trend, TrendError> {
    check_series(points, 3, "a trend")?;
    let drift = fit_drift(points)?;
    let step = match find_step(points, &options.step) {
        Ok(step) => Some(step),
        Err(TrendError::TooFewPoints { .. } | TrendError::NoSplit { .. }) => None,
        Err(e) => return Err(e),
    };
    let verdict = prefer(&drift, step.as_ref());
    let (tolerance, next) = match &options.tolerance {
        None => (None, None),
        Some(tol) => {
            let latest = &points[points.len() - 1];
            let projected = (verdict == Verdict::Drift).then_some(&drift);
            (
                Some(tolerance_status(points, tol)?),
                Some(next_check(
                    latest,
                    projected,
                    tol,
                    options.max_interval_days,
                )?),
            )
        }
    };
    Ok(Trend {
        changes: consecutive_changes(points)?,
        drift,
        step,
        verdict,
        tolerance,
        next_check: next,
    })
}
