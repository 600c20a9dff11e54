//! The drift rate against hand-computed values, an independent least-squares formulation, and
//! its interval's coverage and false alarms over seeded campaign series.

use crate::common;

use common::{Campaigns, DAY_S, EPOCH_S, rate};
use mtcal_trend::{Point, TrendError, fit_drift};
use nalgebra::{DMatrix, DVector};

/// Three campaigns, hand-computed: t = 0, 10, 20 days, values 1, 2, 4, equal U = 2 (u = 1).
/// Ordinary least squares: t̄ = 10, ȳ = 7/3, Sxx = 200, Sxy = (−10)(−4/3) + 0 + 10(5/3) = 30,
/// slope 0.15/day, residuals 1 − (7/3 − 1.5) = 1/6, 2 − 7/3 = −1/3, 4 − (7/3 + 1.5) = 1/6:
/// χ² = 1/36 + 1/9 + 1/36 = 1/6 on 1 dof (not inflated), u(slope) = 1/√200,
/// u(level) = 1/√3.
#[test]
fn three_campaigns_by_hand() {
    let points = [
        Point::new(EPOCH_S, 1.0, 2.0),
        Point::new(EPOCH_S + 10.0 * DAY_S, 2.0, 2.0),
        Point::new(EPOCH_S + 20.0 * DAY_S, 4.0, 2.0),
    ];
    let fit = fit_drift(&points).unwrap();
    assert!((fit.rate_per_day - 0.15).abs() < 1e-12);
    assert!((fit.scatter.chi2 - 1.0 / 6.0).abs() < 1e-12);
    assert!(!fit.scatter.inflated);
    assert_eq!(fit.scatter.coverage_factor, 2.0);
    assert!((fit.rate_u95_per_day - 2.0 / 200f64.sqrt()).abs() < 1e-12);
    assert!((fit.reference_time_s - (EPOCH_S + 10.0 * DAY_S)).abs() < 1e-3);
    assert!((fit.value_at_reference - 7.0 / 3.0).abs() < 1e-12);
    assert!((fit.value_at_reference_u95 - 2.0 / 3f64.sqrt()).abs() < 1e-12);
    // 0.15 > 2/√200 = 0.141: just significant.
    assert!(fit.significant);
    // χ² = 1/6 on 1 dof: p = P(χ²₁ ≥ 1/6) = 2·(1 − Φ(√(1/6))) = 0.6831.
    assert!((fit.scatter.p_value - 0.683_091).abs() < 1e-5);
    let (v, u) = fit.value_at(EPOCH_S + 30.0 * DAY_S);
    assert!((v - (7.0 / 3.0 + 3.0)).abs() < 1e-12);
    let expected = (4.0 / 3.0 + 400.0 * 4.0 / 200.0_f64).sqrt();
    assert!((u - expected).abs() < 1e-12);
}

/// The same three points with U = 0.2 (u = 0.1): χ² = 100/6 on 1 dof, inflated by the Birge
/// ratio √(100/6) with Student's t(1) at 97.5 % = 12.706.
#[test]
fn scatter_beyond_the_uncertainties_inflates_the_interval() {
    let points = [
        Point::new(EPOCH_S, 1.0, 0.2),
        Point::new(EPOCH_S + 10.0 * DAY_S, 2.0, 0.2),
        Point::new(EPOCH_S + 20.0 * DAY_S, 4.0, 0.2),
    ];
    let fit = fit_drift(&points).unwrap();
    assert!(fit.scatter.inflated);
    assert!((fit.scatter.birge_ratio - (100.0f64 / 6.0).sqrt()).abs() < 1e-9);
    assert!((fit.scatter.coverage_factor - 12.706_204_736).abs() < 1e-6);
    let u_slope = 0.1 / 200f64.sqrt();
    let expected = 12.706_204_736 * (100.0f64 / 6.0).sqrt() * u_slope;
    assert!((fit.rate_u95_per_day - expected).abs() < 1e-8);
    assert!(fit.scatter.p_value < 1e-4);
}

/// The fit against the whitened normal equations solved by nalgebra's SVD.
#[test]
fn agrees_with_an_independent_least_squares_solution() {
    for seed in 0..20 {
        let points = Campaigns {
            rate_um_per_day: 0.01,
            ..Default::default()
        }
        .draw(seed);
        let fit = fit_drift(&points).unwrap();
        let n = points.len();
        let a = DMatrix::from_fn(n, 2, |i, j| {
            let days = (points[i].time_s - EPOCH_S) / DAY_S;
            [1.0, days][j] / (points[i].u95 / 2.0)
        });
        let b = DVector::from_fn(n, |i, _| points[i].value / (points[i].u95 / 2.0));
        let svd = a.clone().svd(true, true);
        let x = svd.solve(&b, 1e-14).unwrap();
        let cov = (a.transpose() * &a).try_inverse().unwrap();
        let chi2 = (&a * &x - &b).norm_squared();
        assert!((fit.rate_per_day - x[1]).abs() < 1e-10, "seed {seed}");
        assert!((fit.scatter.chi2 - chi2).abs() < 1e-8 * chi2.max(1.0));
        let k = fit.scatter.coverage_factor * fit.scatter.birge_ratio.max(1.0);
        assert!((fit.rate_u95_per_day - k * cov[(1, 1)].sqrt()).abs() < 1e-10);
        let days_ref = (fit.reference_time_s - EPOCH_S) / DAY_S;
        assert!((fit.value_at_reference - (x[0] + x[1] * days_ref)).abs() < 1e-9);
    }
}

/// Seeds whose interval holds the planted rate; seeds inflated; seeds whose interval would hold
/// it with k = 2 on the stated uncertainties alone.
fn coverage(campaigns: &Campaigns, seeds: u64) -> (usize, usize, usize) {
    let (mut covered, mut inflated, mut covered_uninflated) = (0, 0, 0);
    for seed in 0..seeds {
        let fit = fit_drift(&campaigns.draw(seed)).unwrap();
        let error = (fit.rate_per_day - campaigns.rate_um_per_day).abs();
        covered += usize::from(error <= fit.rate_u95_per_day);
        inflated += usize::from(fit.scatter.inflated);
        let stated = fit.rate_u95_per_day * 2.0
            / (fit.scatter.coverage_factor * fit.scatter.birge_ratio.max(1.0));
        covered_uninflated += usize::from(error <= stated);
    }
    (covered, inflated, covered_uninflated)
}

/// 20 campaigns drifting 0.01 µm/day (about 6 µm over the series) with the stated noise: the
/// planted rate lies within the interval in 90–99 % of 400 seeds.
#[test]
fn the_planted_rate_lies_within_its_interval_in_about_95_percent_of_seeds() {
    let campaigns = Campaigns {
        rate_um_per_day: 0.01,
        ..Default::default()
    };
    let (covered, inflated, _) = coverage(&campaigns, 400);
    eprintln!(
        "drift coverage {:.3} (inflated in {:.3})",
        rate(covered, 400),
        rate(inflated, 400)
    );
    assert!((360..=396).contains(&covered), "coverage {covered}/400");
}

/// The campaigns scatter 1.5 times more than their U says: the Birge ratio and t(n − 2) keep
/// the coverage near 95 %; without them (k = 2 on the stated U) it would be about 81 %.
#[test]
fn understated_uncertainties_are_caught_by_the_birge_ratio() {
    let campaigns = Campaigns {
        rate_um_per_day: -0.02,
        noise_factor: 1.5,
        ..Default::default()
    };
    let (covered, inflated, uninflated) = coverage(&campaigns, 400);
    eprintln!(
        "understated U: coverage {:.3} (inflated in {:.3}, {:.3} without inflation)",
        rate(covered, 400),
        rate(inflated, 400),
        rate(uninflated, 400)
    );
    assert!((360..=396).contains(&covered), "coverage {covered}/400");
    assert!(inflated > 380, "inflated in {inflated}/400");
    assert!(uninflated < 350, "k = 2 alone covered {uninflated}/400");
}

/// Without drift, a significant drift is claimed in at most 5 % of 400 seeds plus two binomial
/// standard deviations (1.1 %).
#[test]
fn a_series_without_drift_is_rarely_flagged() {
    let campaigns = Campaigns::default();
    let flagged = (0..400)
        .filter(|&seed| fit_drift(&campaigns.draw(seed)).unwrap().significant)
        .count();
    eprintln!("drift false alarms {:.3}", rate(flagged, 400));
    assert!(flagged <= 29, "flagged {flagged}/400");
}

/// A drift of 0.02 µm/day (12 µm over the series, U ≈ 2 µm) is found nearly always.
#[test]
fn a_real_drift_is_found() {
    let campaigns = Campaigns {
        rate_um_per_day: 0.02,
        ..Default::default()
    };
    let found = (0..200)
        .filter(|&seed| fit_drift(&campaigns.draw(seed)).unwrap().significant)
        .count();
    eprintln!("drift power at 0.02 µm/day {:.3}", rate(found, 200));
    assert!(found >= 190, "found {found}/200");
}

#[test]
fn too_few_points_or_one_time_is_a_clear_error() {
    let p = |days: f64, v| Point::new(EPOCH_S + days * DAY_S, v, 2.0);
    assert!(matches!(
        fit_drift(&[p(0.0, 1.0), p(1.0, 2.0)]),
        Err(TrendError::TooFewPoints {
            needed: 3,
            found: 2,
            ..
        })
    ));
    assert!(matches!(
        fit_drift(&[p(5.0, 1.0), p(5.0, 2.0), p(5.0, 3.0)]),
        Err(TrendError::IdenticalTimes { n: 3, .. })
    ));
    // Two campaigns on one day and one later is enough.
    let fit = fit_drift(&[p(5.0, 1.0), p(5.0, 2.0), p(9.0, 3.0)]).unwrap();
    assert!((fit.rate_per_day - 1.5 / 4.0).abs() < 1e-12);
}
