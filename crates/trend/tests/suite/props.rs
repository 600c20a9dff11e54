//! Properties over arbitrary series: invariances under a change of unit, level or clock, and
//! no panic, NaN or infinity for any finite input.

use mtcal_trend::{
    Point, StepOptions, ThermalFit, ThermalOptions, Tolerance, TrendError, TrendOptions, analyse,
    find_step, fit_drift, fit_thermal, next_check, normalised_error,
};
use proptest::prelude::*;

const DAY_S: f64 = 86_400.0;

/// A series in time order: gaps of 0 (ties) to 90 days, values ±50, U from 0.01 to 10.
fn series(min: usize, max: usize) -> impl Strategy<Value = Vec<Point>> {
    prop::collection::vec((0.0f64..90.0, -50.0f64..50.0, 0.01f64..10.0), min..max).prop_map(
        |rows| {
            let mut days = 0.0;
            rows.into_iter()
                .enumerate()
                .map(|(i, (gap, value, u95))| {
                    // Every third gap is a tie: two campaigns on one day.
                    if i % 3 != 2 {
                        days += gap;
                    }
                    Point::new(1.7e9 + days * DAY_S, value, u95)
                })
                .collect()
        },
    )
}

fn quick() -> StepOptions {
    StepOptions {
        simulations: 199,
        ..Default::default()
    }
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-9 * scale.max(a.abs()).max(b.abs())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A unit change (values and U × λ), a new level (+ c) and a new clock (+ Δ) change the
    /// drift as they must and nothing else.
    #[test]
    fn the_drift_follows_a_change_of_unit_level_and_clock(
        points in series(3, 30),
        lambda in 1e-3f64..1e3,
        c in -100.0f64..100.0,
        shift_days in -1000.0f64..1000.0,
    ) {
        let base = match fit_drift(&points) {
            Ok(fit) => fit,
            Err(TrendError::IdenticalTimes { .. }) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        let moved: Vec<Point> = points
            .iter()
            .map(|p| Point::new(p.time_s + shift_days * DAY_S, lambda * p.value + c, lambda * p.u95))
            .collect();
        let fit = fit_drift(&moved).unwrap();
        let scale = lambda * (base.rate_u95_per_day + base.rate_per_day.abs());
        prop_assert!(close(fit.rate_per_day, lambda * base.rate_per_day, scale));
        prop_assert!(close(fit.rate_u95_per_day, lambda * base.rate_u95_per_day, scale));
        prop_assert!(close(fit.scatter.chi2, base.scatter.chi2, 1.0));
        prop_assert_eq!(fit.significant, base.significant);
        let value_scale = 100.0 + lambda * 100.0;
        prop_assert!((fit.value_at_reference - (lambda * base.value_at_reference + c)).abs() < 1e-7 * value_scale);
        prop_assert!((fit.reference_time_s - base.reference_time_s - shift_days * DAY_S).abs() < 1e-3);
    }

    /// The step test is free of the unit and the level: the same place, and the same p-value
    /// (the simulations use the relative uncertainties) but for a rare rounding tie.
    #[test]
    fn the_step_test_is_free_of_unit_and_level(
        points in series(4, 25),
        lambda in 1e-3f64..1e3,
        c in -100.0f64..100.0,
    ) {
        let base = match find_step(&points, &quick()) {
            Ok(step) => step,
            Err(TrendError::NoSplit { .. }) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        let moved: Vec<Point> = points
            .iter()
            .map(|p| Point::new(p.time_s, lambda * p.value + c, lambda * p.u95))
            .collect();
        let step = find_step(&moved, &quick()).unwrap();
        prop_assert!((step.p_value - base.p_value).abs() <= 2.0 / 200.0);
        prop_assert!(step.p_value > 0.0 && step.p_value <= 1.0);
        prop_assert!(close(step.shift, lambda * base.shift, lambda * (base.shift_u95 + base.shift.abs())) || step.index != base.index);
    }

    #[test]
    fn the_normalised_error_is_symmetric_and_scale_free(
        a in -100.0f64..100.0, b in -100.0f64..100.0,
        ua in 0.01f64..10.0, ub in 0.01f64..10.0, lambda in 1e-6f64..1e6,
    ) {
        let (pa, pb) = (Point::new(0.0, a, ua), Point::new(1.0, b, ub));
        let e = normalised_error(&pa, &pb).unwrap();
        prop_assert_eq!(e, normalised_error(&pb, &pa).unwrap());
        let scaled = normalised_error(
            &Point::new(0.0, lambda * a, lambda * ua),
            &Point::new(1.0, lambda * b, lambda * ub),
        ).unwrap();
        prop_assert!(close(e, scaled, 1.0));
        prop_assert!(e >= 0.0 && e.is_finite());
    }

    /// The next check is never later than the maximum interval, never before the latest
    /// result, and a wider tolerance never brings it earlier.
    #[test]
    fn the_next_check_is_within_its_bounds(
        points in series(3, 20),
        limit in 1.0f64..200.0,
        more in 0.0f64..50.0,
        max_days in 1.0f64..1000.0,
        guard_band in any::<bool>(),
    ) {
        let Ok(drift) = fit_drift(&points) else { return Ok(()) };
        let latest = points.last().unwrap();
        let at = |limit| {
            let tol = Tolerance { limit, guard_band };
            next_check(latest, Some(&drift), &tol, max_days).unwrap()
        };
        let (near, far) = (at(limit), at(limit + more));
        prop_assert!(near.interval_days >= 0.0 && near.interval_days <= max_days);
        prop_assert!(far.interval_days >= near.interval_days);
        prop_assert!(close(near.time_s, latest.time_s + near.interval_days * DAY_S, latest.time_s));
    }

    /// Any finite series: an answer or a clear error, never a panic, NaN or infinity.
    #[test]
    fn any_finite_series_gives_finite_numbers_or_an_error(points in series(0, 25)) {
        let options = TrendOptions {
            step: quick(),
            tolerance: Some(Tolerance { limit: 20.0, guard_band: true }),
            ..Default::default()
        };
        if let Ok(trend) = analyse(&points, &options) {
            let shown = format!("{trend:?}");
            for bad in ["NaN", ": inf", ": -inf"] {
                prop_assert!(!shown.contains(bad), "{}", shown);
            }
        }
        let fit = fit_thermal(&points, &ThermalOptions { grid_points: 40, ..Default::default() });
        if let Ok(ThermalFit::Determined(t)) = fit {
            let shown = format!("{t:?}");
            prop_assert!(!shown.contains("NaN") && !shown.contains(": inf"), "{}", shown);
            prop_assert!(t.tau_low_min <= t.tau_min && t.tau_min <= t.tau_high_min);
            prop_assert!(t.amplitude_low <= t.amplitude && t.amplitude <= t.amplitude_high);
        }
    }

    /// The trajectory does not depend on the clock: shifting every check in time moves only
    /// its start.
    #[test]
    fn the_trajectory_is_free_of_the_clock(shift_s in -1e6f64..1e6, seed in 0u64..1000) {
        let points: Vec<Point> = (0..10)
            .map(|i| {
                let t = 1500.0 * i as f64;
                let noise = ((seed as f64 + 1.0) * (i as f64 + 1.0) * 12.9898).sin();
                Point::new(1.7e9 + t, 5.0 * (-t / 2700.0).exp() + 0.3 * noise, 0.6)
            })
            .collect();
        let moved: Vec<Point> = points.iter().map(|p| Point { time_s: p.time_s + shift_s, ..*p }).collect();
        let (a, b) = (
            fit_thermal(&points, &ThermalOptions::default()).unwrap(),
            fit_thermal(&moved, &ThermalOptions::default()).unwrap(),
        );
        match (a, b) {
            (ThermalFit::Determined(a), ThermalFit::Determined(b)) => {
                prop_assert!((a.tau_min - b.tau_min).abs() < 1e-4 * a.tau_min);
                prop_assert!((a.tau_high_min - b.tau_high_min).abs() < 1e-4 * a.tau_high_min);
                prop_assert!((a.amplitude - b.amplitude).abs() < 1e-4 * a.amplitude_u95);
            }
            (ThermalFit::NotDetermined(_), ThermalFit::NotDetermined(_)) => {}
            (a, b) => prop_assert!(false, "{:?} vs {:?}", a, b),
        }
    }
}
