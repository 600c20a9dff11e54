//! Conformity against a tolerance (with and without the ISO 14253-1 guard band) and the next
//! check, on hand-computed cases.

use crate::common;

use common::{DAY_S, EPOCH_S};
use mtcal_trend::{
    Conformity, NextCheckReason, Point, Tolerance, TrendError, conformity, fit_drift, next_check,
    tolerance_status,
};

const PLAIN: Tolerance = Tolerance {
    limit: 10.0,
    guard_band: false,
};
const GUARDED: Tolerance = Tolerance {
    limit: 10.0,
    guard_band: true,
};

#[test]
fn each_result_against_the_limit() {
    let p = |v| Point::new(EPOCH_S, v, 2.0);
    let cases = [
        (7.9, Conformity::Conforms, Conformity::Conforms),
        (8.0, Conformity::Conforms, Conformity::Conforms),
        (-8.5, Conformity::Conforms, Conformity::CannotDecide),
        (10.0, Conformity::Conforms, Conformity::CannotDecide),
        (11.9, Conformity::OutOfTolerance, Conformity::CannotDecide),
        (12.0, Conformity::OutOfTolerance, Conformity::CannotDecide),
        (
            -12.1,
            Conformity::OutOfTolerance,
            Conformity::OutOfTolerance,
        ),
    ];
    for (v, plain, guarded) in cases {
        assert_eq!(conformity(&p(v), &PLAIN).unwrap(), plain, "{v}");
        assert_eq!(conformity(&p(v), &GUARDED).unwrap(), guarded, "{v}");
    }
}

#[test]
fn the_series_crosses_the_limit_where_it_first_leaves_it() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 2.0);
    let series = [p(0.0, 5.0), p(30.0, 8.5), p(60.0, 10.5), p(90.0, 12.5)];
    let plain = tolerance_status(&series, &PLAIN).unwrap();
    assert_eq!(plain.first_out, Some(2));
    assert_eq!(plain.first_undecided, None);
    assert!(plain.crossed());
    let guarded = tolerance_status(&series, &GUARDED).unwrap();
    assert_eq!(guarded.first_undecided, Some(1));
    assert_eq!(guarded.first_out, Some(3));
    assert_eq!(guarded.latest(), Some(Conformity::OutOfTolerance));
    let inside = tolerance_status(&series[..1], &GUARDED).unwrap();
    assert!(!inside.crossed());
}

/// Hand-computed: four campaigns 0, 100, 200, 300 days at 2, 3, 4, 5 µm (exactly 0.01
/// µm/day, χ² = 0), U = 0.2 µm: u(rate) = 0.1/√Sxx with Sxx = 50 000 day², so
/// U(rate) = 2·0.1/223.607 = 8.944e-4 µm/day. From the fitted 5 µm at day 300 to the limit
/// 10 µm at 0.01 + 8.944e-4 µm/day: 458.94 days — capped by a 365-day maximum, within a
/// 500-day one.
#[test]
fn next_check_where_the_conservative_drift_reaches_the_limit() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 0.2);
    let series = [p(0.0, 2.0), p(100.0, 3.0), p(200.0, 4.0), p(300.0, 5.0)];
    let drift = fit_drift(&series).unwrap();
    let u_rate = 2.0 * 0.1 / 50_000f64.sqrt();
    assert!((drift.rate_u95_per_day - u_rate).abs() < 1e-15);
    let reach_days = 5.0 / (0.01 + u_rate);
    let latest = &series[3];
    let next = next_check(latest, Some(&drift), &PLAIN, 500.0).unwrap();
    assert_eq!(next.reason, NextCheckReason::DriftReachesLimit);
    assert!(
        (next.interval_days - reach_days).abs() < 1e-9,
        "{}",
        next.interval_days
    );
    assert!((next.time_s - (latest.time_s + reach_days * DAY_S)).abs() < 1e-3);
    let capped = next_check(latest, Some(&drift), &PLAIN, 365.0).unwrap();
    assert_eq!(capped.interval_days, 365.0);
    match capped.reason {
        NextCheckReason::CappedByMaximumInterval { reach_time_s } => {
            assert!((reach_time_s - next.time_s).abs() < 1e-3)
        }
        other => panic!("{other:?}"),
    }
    // With the guard band the target is 10 − 0.2 µm: (4.8)/(0.01 + U).
    let guarded = next_check(latest, Some(&drift), &GUARDED, 500.0).unwrap();
    assert!((guarded.interval_days - 4.8 / (0.01 + u_rate)).abs() < 1e-9);
}

/// A falling drift heads for −L: from −5 µm at −0.01 µm/day the distance is 5 µm.
#[test]
fn a_falling_drift_heads_for_the_lower_limit() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 0.2);
    let series = [p(0.0, -2.0), p(100.0, -3.0), p(200.0, -4.0), p(300.0, -5.0)];
    let drift = fit_drift(&series).unwrap();
    let next = next_check(&series[3], Some(&drift), &PLAIN, 1000.0).unwrap();
    let u_rate = 2.0 * 0.1 / 50_000f64.sqrt();
    assert!((next.interval_days - 5.0 / (0.01 + u_rate)).abs() < 1e-9);
    // Rising from −5 µm towards +10 µm: 15 µm to go.
    let rising = [p(0.0, -8.0), p(100.0, -7.0), p(200.0, -6.0), p(300.0, -5.0)];
    let drift = fit_drift(&rising).unwrap();
    let next = next_check(&rising[3], Some(&drift), &PLAIN, 2000.0).unwrap();
    assert!((next.interval_days - 15.0 / (0.01 + u_rate)).abs() < 1e-9);
}

#[test]
fn without_a_significant_drift_the_maximum_interval_decides() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 2.0);
    let series = [p(0.0, 5.0), p(100.0, 5.5), p(200.0, 4.8), p(300.0, 5.1)];
    let drift = fit_drift(&series).unwrap();
    assert!(!drift.significant);
    for given in [Some(&drift), None] {
        let next = next_check(&series[3], given, &PLAIN, 180.0).unwrap();
        assert_eq!(next.reason, NextCheckReason::NoSignificantDrift);
        assert_eq!(next.interval_days, 180.0);
        assert_eq!(next.time_s, series[3].time_s + 180.0 * DAY_S);
    }
}

#[test]
fn a_result_at_the_limit_means_check_now() {
    let latest = Point::new(EPOCH_S, -9.0, 2.0);
    let now = next_check(&latest, None, &GUARDED, 365.0).unwrap();
    assert_eq!(now.reason, NextCheckReason::AlreadyAtLimit);
    assert_eq!(now.interval_days, 0.0);
    assert_eq!(now.time_s, latest.time_s);
    // Without the guard band 9 µm is inside 10 µm.
    let later = next_check(&latest, None, &PLAIN, 365.0).unwrap();
    assert_eq!(later.reason, NextCheckReason::NoSignificantDrift);
}

#[test]
fn bad_tolerances_and_intervals_are_clear_errors() {
    let latest = Point::new(EPOCH_S, 1.0, 2.0);
    for limit in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let t = Tolerance {
            limit,
            guard_band: false,
        };
        assert!(matches!(
            conformity(&latest, &t),
            Err(TrendError::BadSetting {
                what: "the tolerance limit",
                ..
            })
        ));
    }
    for days in [0.0, -5.0, f64::NAN] {
        assert!(matches!(
            next_check(&latest, None, &PLAIN, days),
            Err(TrendError::BadSetting {
                what: "max_interval_days",
                ..
            })
        ));
    }
    let zero_u = Point::new(EPOCH_S, 1.0, 0.0);
    assert_eq!(
        conformity(&zero_u, &PLAIN),
        Err(TrendError::NonPositiveUncertainty { index: 0, u95: 0.0 })
    );
}
