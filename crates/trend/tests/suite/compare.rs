//! The normalised error on hand-computed examples, and consecutive comparisons.

use crate::common;

use common::{DAY_S, EPOCH_S, rate};
use mtcal_trend::{Change, Point, TrendError, compare, consecutive_changes, normalised_error};

/// 10.0 ± 3 against 14.0 ± 4: E_n = 4/5 = 0.8, no significant change. 10 ± 0.6 against
/// 11.6 ± 0.8: 1.6/1.0 = 1.6, significant. Exactly at 1: not (the criterion is E_n > 1).
#[test]
fn hand_computed_normalised_errors() {
    let a = Point::new(EPOCH_S, 10.0, 3.0);
    let b = Point::new(EPOCH_S + DAY_S, 14.0, 4.0);
    assert!((normalised_error(&a, &b).unwrap() - 0.8).abs() < 1e-15);
    let c = compare(&a, &b).unwrap();
    assert_eq!(
        c,
        Change {
            from: 0,
            to: 1,
            difference: 4.0,
            difference_u95: 5.0,
            normalised_error: 0.8,
            significant: false,
        }
    );
    let x = Point::new(EPOCH_S, 10.0, 0.6);
    let y = Point::new(EPOCH_S, 11.6, 0.8);
    let c = compare(&y, &x).unwrap();
    assert!((c.normalised_error - 1.6).abs() < 1e-12);
    assert!((c.difference + 1.6).abs() < 1e-12);
    assert!(c.significant);
    let edge = compare(&Point::new(0.0, 0.0, 3.0), &Point::new(0.0, 5.0, 4.0)).unwrap();
    assert_eq!(edge.normalised_error, 1.0);
    assert!(!edge.significant);
}

#[test]
fn each_result_against_the_one_before() {
    let p = |d: f64, v, u| Point::new(EPOCH_S + d * DAY_S, v, u);
    let series = [p(0.0, 1.0, 2.0), p(30.0, 2.0, 2.0), p(60.0, 6.0, 2.0)];
    let changes = consecutive_changes(&series).unwrap();
    assert_eq!(changes.len(), 2);
    assert_eq!((changes[1].from, changes[1].to), (1, 2));
    assert!((changes[0].normalised_error - 1.0 / 8f64.sqrt()).abs() < 1e-15);
    assert!((changes[1].normalised_error - 4.0 / 8f64.sqrt()).abs() < 1e-15);
    assert_eq!(
        changes.iter().map(|c| c.significant).collect::<Vec<_>>(),
        [false, true]
    );
    assert!(consecutive_changes(&series[..1]).unwrap().is_empty());
    assert!(consecutive_changes(&[]).unwrap().is_empty());
}

/// For correct uncertainties each comparison flags a stable pair with probability
/// P(|z| > 2) = 4.55 %: over 400 seeds × 19 pairs, between 3.5 % and 5.6 %.
#[test]
fn each_comparison_false_alarms_at_about_4_6_percent() {
    let campaigns = common::Campaigns::default();
    let (mut flagged, mut pairs) = (0, 0);
    for seed in 0..400 {
        for c in consecutive_changes(&campaigns.draw(seed)).unwrap() {
            flagged += usize::from(c.significant);
            pairs += 1;
        }
    }
    let share = rate(flagged, pairs);
    eprintln!("E_n > 1 in {share:.4} of stable pairs");
    assert!((0.035..=0.056).contains(&share), "{share}");
}

#[test]
fn points_without_an_uncertainty_are_clear_errors() {
    let good = Point::new(0.0, 1.0, 1.0);
    assert_eq!(
        normalised_error(&good, &Point::new(0.0, 1.0, 0.0)),
        Err(TrendError::NonPositiveUncertainty { index: 1, u95: 0.0 })
    );
    assert!(matches!(
        normalised_error(&Point::new(0.0, f64::INFINITY, 1.0), &good),
        Err(TrendError::NotFinite {
            index: 0,
            field: "value",
            ..
        })
    ));
    let unordered = [Point::new(10.0, 1.0, 1.0), Point::new(5.0, 1.0, 1.0)];
    assert!(matches!(
        consecutive_changes(&unordered),
        Err(TrendError::NotInTimeOrder {
            index: 1,
            previous: 0,
            ..
        })
    ));
}
