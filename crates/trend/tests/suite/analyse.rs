//! The whole analysis: one verdict, the next check from the preferred description only, and
//! clear errors for every degenerate series.

use crate::common;

use common::{Campaigns, DAY_S, EPOCH_S};
use mtcal_trend::{NextCheckReason, Point, Tolerance, TrendError, TrendOptions, Verdict, analyse};

fn options(limit: f64) -> TrendOptions {
    TrendOptions {
        tolerance: Some(Tolerance {
            limit,
            guard_band: true,
        }),
        max_interval_days: 365.0,
        ..Default::default()
    }
}

#[test]
fn a_drifting_parameter_gets_a_drift_and_an_earlier_check() {
    let points = Campaigns {
        rate_um_per_day: 0.02,
        ..Default::default()
    }
    .draw(5);
    let trend = analyse(&points, &options(25.0)).unwrap();
    assert_eq!(trend.verdict, Verdict::Drift);
    assert_eq!(trend.changes.len(), points.len() - 1);
    let next = trend.next_check.unwrap();
    assert_eq!(next.reason, NextCheckReason::DriftReachesLimit);
    // The conservative projection from the fitted line, checked against the drift fit.
    let latest = &points[points.len() - 1];
    let (fitted, _) = trend.drift.value_at(latest.time_s);
    let fastest = trend.drift.rate_per_day + trend.drift.rate_u95_per_day;
    let expected = (25.0 - latest.u95 - fitted) / fastest;
    assert!((next.interval_days - expected).abs() < 1e-9);
    assert!(next.interval_days < 365.0);
}

/// A step after campaign 10: the verdict is a step, so its (look-alike) drift is not projected
/// and the next check comes by the maximum interval.
#[test]
fn a_step_is_not_projected_as_a_drift() {
    let points = Campaigns {
        step_um: 5.0,
        step_at: 10,
        ..Default::default()
    }
    .draw(8);
    let trend = analyse(&points, &options(40.0)).unwrap();
    assert_eq!(trend.verdict, Verdict::Step);
    assert!(
        trend.drift.significant,
        "the look-alike drift is significant on its own"
    );
    assert_eq!(trend.step.unwrap().index, 10);
    let next = trend.next_check.unwrap();
    assert_eq!(next.reason, NextCheckReason::NoSignificantDrift);
    assert_eq!(next.interval_days, 365.0);
}

#[test]
fn three_points_get_a_drift_but_no_step() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 2.0);
    let trend = analyse(
        &[p(0.0, 1.0), p(30.0, 1.2), p(60.0, 0.9)],
        &Default::default(),
    )
    .unwrap();
    assert!(trend.step.is_none());
    assert_eq!(trend.verdict, Verdict::NoChange);
    assert!(trend.tolerance.is_none() && trend.next_check.is_none());
}

/// Every degenerate series gets an error that says what is wrong, never NaN or a panic.
#[test]
fn degenerate_series_are_clear_errors() {
    let p = |d: f64, v, u| Point::new(EPOCH_S + d * DAY_S, v, u);
    let o = TrendOptions::default();
    let cases: Vec<(Vec<Point>, &str)> = vec![
        (vec![], "a trend needs at least 3 points; the series has 0"),
        (
            vec![p(0.0, 1.0, 2.0), p(1.0, 1.0, 2.0)],
            "a trend needs at least 3 points; the series has 2",
        ),
        (
            vec![p(0.0, 1.0, 2.0), p(1.0, 1.0, 0.0), p(2.0, 1.0, 2.0)],
            "point 1: u95 is 0; an expanded uncertainty must be positive (a value without an \
             uncertainty cannot be weighed against the others)",
        ),
        (
            vec![p(0.0, 1.0, 2.0), p(1.0, 1.0, -1.0), p(2.0, 1.0, 2.0)],
            "point 1: u95 is -1; an expanded uncertainty must be positive (a value without an \
             uncertainty cannot be weighed against the others)",
        ),
        (
            vec![
                p(3.0, 1.0, 2.0),
                p(3.0, 2.0, 2.0),
                p(3.0, 3.0, 2.0),
                p(3.0, 1.0, 2.0),
            ],
            "all 4 points are at the same time; a drift rate needs at least two different times",
        ),
        (
            vec![p(0.0, 1.0, 2.0), p(2.0, f64::NAN, 2.0), p(3.0, 1.0, 2.0)],
            "point 1: value is NaN; it must be a finite number",
        ),
        (
            vec![p(0.0, 1.0, 2.0), p(2.0, 1.0, 2.0), p(1.0, 1.0, 2.0)],
            "point 2 (t = 1735776000 s) is earlier than point 1 (t = 1735862400 s); give the \
             series in time order",
        ),
    ];
    for (points, message) in cases {
        let err = analyse(&points, &o).unwrap_err();
        assert_eq!(err.to_string(), message);
    }
    let bad = TrendOptions {
        max_interval_days: f64::NAN,
        ..options(10.0)
    };
    let fine = [p(0.0, 1.0, 2.0), p(1.0, 1.0, 2.0), p(2.0, 1.0, 2.0)];
    assert!(matches!(
        analyse(&fine, &bad),
        Err(TrendError::BadSetting {
            what: "max_interval_days",
            ..
        })
    ));
}

/// Values in metres and uncertainties spanning 60 orders of magnitude still give finite
/// numbers (the weights are relative to the smallest uncertainty).
#[test]
fn extreme_units_stay_finite() {
    let p = |d: f64, v, u| Point::new(EPOCH_S + d * DAY_S, v, u);
    let points = [
        p(0.0, 1e-6, 1e-36),
        p(30.0, 2e-6, 1e-6),
        p(60.0, 3e-6, 1e24),
        p(90.0, 2.5e-6, 1e-6),
        p(120.0, 4e-6, 1e-6),
    ];
    let trend = analyse(&points, &TrendOptions::default()).unwrap();
    let shown = format!("{trend:?}");
    for bad in ["NaN", ": inf", ": -inf"] {
        assert!(!shown.contains(bad), "{shown}");
    }
}
