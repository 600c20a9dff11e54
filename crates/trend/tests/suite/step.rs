//! The step test against a brute-force search, its false alarms without a change, its power on
//! a planted step, and which of drift and step the verdict prefers.

use crate::common;

use common::{Campaigns, DAY_S, EPOCH_S, rate};
use mtcal_trend::{Point, StepOptions, TrendError, TrendOptions, Verdict, analyse, find_step};

/// The best split by brute force: both weighted means and χ² computed from scratch for every
/// split between different times with two points each side.
fn brute_force(points: &[Point]) -> (usize, f64, f64) {
    let mean = |s: &[Point]| {
        let w: f64 = s.iter().map(|p| 4.0 / (p.u95 * p.u95)).sum();
        s.iter()
            .map(|p| 4.0 / (p.u95 * p.u95) * p.value)
            .sum::<f64>()
            / w
    };
    let chi2 = |s: &[Point], m: f64| {
        s.iter()
            .map(|p| ((p.value - m) / (p.u95 / 2.0)).powi(2))
            .sum::<f64>()
    };
    let mut best = (0, f64::INFINITY, 0.0);
    for k in 2..=points.len() - 2 {
        if points[k].time_s == points[k - 1].time_s {
            continue;
        }
        let (a, b) = points.split_at(k);
        let (ma, mb) = (mean(a), mean(b));
        let c = chi2(a, ma) + chi2(b, mb);
        if c < best.1 {
            best = (k, c, mb - ma);
        }
    }
    best
}

#[test]
fn the_best_split_agrees_with_a_brute_force_search() {
    for seed in 0..30 {
        let mut points = Campaigns {
            step_um: 3.0,
            step_at: 5 + (seed as usize % 10),
            ..Default::default()
        }
        .draw(seed);
        // A tie in time: no step may be placed between points 7 and 8.
        points[8].time_s = points[7].time_s;
        let step = find_step(&points, &StepOptions::default()).unwrap();
        let (k, chi2, shift) = brute_force(&points);
        assert_eq!(step.index, k, "seed {seed}");
        assert_ne!(step.index, 8);
        assert!(
            (step.scatter.chi2 - chi2).abs() < 1e-9 * chi2.max(1.0),
            "seed {seed}"
        );
        assert!((step.shift - shift).abs() < 1e-9, "seed {seed}");
    }
}

/// Four campaigns, hand-computed: 0, 0 then 3, 3 with U = 2: the step is at 2, shift 3 ± 2·√(1/2 + 1/2) = 2,
/// χ² = 0 on 2 dof.
#[test]
fn a_clean_step_by_hand() {
    let p = |d: f64, v| Point::new(EPOCH_S + d * DAY_S, v, 2.0);
    let points = [p(0.0, 0.0), p(30.0, 0.0), p(60.0, 3.0), p(90.0, 3.0)];
    let step = find_step(&points, &StepOptions::default()).unwrap();
    assert_eq!(step.index, 2);
    assert_eq!(step.shift, 3.0);
    assert!((step.shift_u95 - 2.0).abs() < 1e-12);
    assert_eq!(step.scatter.chi2, 0.0);
    assert_eq!(step.time_before_s, EPOCH_S + 30.0 * DAY_S);
    // With four points only one split is allowed: nothing was searched, and a perfect split
    // of a 1-split search is as extreme as any (R = 1): p = 1/(N + 1).
    assert!((step.p_value - 1.0 / 2000.0).abs() < 1e-12);
}

/// Without a change, p < 5 % in at most 5 % of 1000 seeds plus two binomial standard
/// deviations (1.4 %); the p-values are roughly uniform (p < 0.5 in 45–55 %). The same holds
/// for "any change" (drift or step).
#[test]
fn a_series_without_change_raises_few_false_alarms() {
    let campaigns = Campaigns::default();
    let (mut alarms, mut below_half, mut any) = (0, 0, 0);
    for seed in 0..1000 {
        let step = find_step(&campaigns.draw(1000 + seed), &StepOptions::default()).unwrap();
        alarms += usize::from(step.significant);
        below_half += usize::from(step.p_value < 0.5);
        any += usize::from(step.any_change);
    }
    eprintln!(
        "step false alarms {:.3}, p < 0.5 in {:.3}; any change {:.3}",
        rate(alarms, 1000),
        rate(below_half, 1000),
        rate(any, 1000)
    );
    assert!(alarms <= 64, "false alarms {alarms}/1000");
    assert!(any <= 64, "any-change false alarms {any}/1000");
    assert!(
        (450..=550).contains(&below_half),
        "p < 0.5 in {below_half}/1000"
    );
}

/// The same with uncertainties understated by 1.5: the statistic does not depend on a common
/// factor, so the false-alarm rate stays at 5 %.
#[test]
fn understated_uncertainties_raise_no_more_false_alarms() {
    let campaigns = Campaigns {
        noise_factor: 1.5,
        ..Default::default()
    };
    let alarms = (0..400)
        .filter(|&seed| {
            find_step(&campaigns.draw(2000 + seed), &StepOptions::default())
                .unwrap()
                .significant
        })
        .count();
    eprintln!(
        "step false alarms, U understated 1.5×: {:.3}",
        rate(alarms, 400)
    );
    assert!(alarms <= 29, "false alarms {alarms}/400");
}

/// A 3 µm step (U ≈ 2 µm per campaign) after campaign 12 of 20: found in ≥ 90 % of 200 seeds,
/// at the right place in most, the planted shift within its interval.
#[test]
fn a_planted_step_is_found() {
    let campaigns = Campaigns {
        step_um: 3.0,
        step_at: 12,
        ..Default::default()
    };
    let (mut found, mut placed, mut covered) = (0, 0, 0);
    for seed in 0..200 {
        let step = find_step(&campaigns.draw(3000 + seed), &StepOptions::default()).unwrap();
        found += usize::from(step.significant);
        placed += usize::from(step.index == 12);
        covered += usize::from((step.shift - 3.0).abs() <= step.shift_u95);
    }
    eprintln!(
        "step power {:.3}, placed {:.3}, shift covered {:.3}",
        rate(found, 200),
        rate(placed, 200),
        rate(covered, 200)
    );
    assert!(found >= 180, "found {found}/200");
    assert!(placed >= 120, "placed {placed}/200");
    assert!(covered >= 170, "shift covered {covered}/200");
}

fn verdicts(campaigns: &Campaigns, seeds: std::ops::Range<u64>) -> [usize; 3] {
    let mut count = [0; 3];
    for seed in seeds {
        let trend = analyse(&campaigns.draw(seed), &TrendOptions::default()).unwrap();
        count[trend.verdict as usize] += 1;
    }
    count
}

/// Drift and step are look-alikes; the verdict names the one planted.
#[test]
fn the_verdict_tells_a_drift_from_a_step() {
    let drift = verdicts(
        &Campaigns {
            rate_um_per_day: 0.015,
            ..Default::default()
        },
        0..200,
    );
    let step = verdicts(
        &Campaigns {
            step_um: 4.0,
            step_at: 10,
            ..Default::default()
        },
        0..200,
    );
    eprintln!("verdicts [none, drift, step]: drift {drift:?}, step {step:?}");
    assert!(drift[Verdict::Drift as usize] >= 170, "{drift:?}");
    assert!(step[Verdict::Step as usize] >= 170, "{step:?}");
}

/// The acceptance: a series without change is said to have changed (a drift or a
/// step) in at most 5 % of 1000 seeds plus two binomial standard deviations.
#[test]
fn a_series_without_change_is_said_unchanged_in_95_percent_of_seeds() {
    let none = verdicts(&Campaigns::default(), 4000..5000);
    eprintln!("verdicts without change [none, drift, step]: {none:?}");
    assert!(none[Verdict::NoChange as usize] >= 936, "{none:?}");
}

#[test]
fn too_short_or_untied_series_and_bad_settings_are_clear_errors() {
    let p = |d: f64| Point::new(EPOCH_S + d * DAY_S, 1.0, 2.0);
    let options = StepOptions::default();
    assert!(matches!(
        find_step(&[p(0.0), p(1.0), p(2.0)], &options),
        Err(TrendError::TooFewPoints {
            needed: 4,
            found: 3,
            ..
        })
    ));
    assert_eq!(
        find_step(&[p(0.0), p(1.0), p(1.0), p(2.0)], &options),
        Err(TrendError::NoSplit { min_segment: 2 })
    );
    let few = StepOptions {
        simulations: 10,
        ..options
    };
    assert!(matches!(
        find_step(&[p(0.0), p(1.0), p(2.0), p(3.0)], &few),
        Err(TrendError::BadSetting {
            what: "simulations",
            ..
        })
    ));
    // Identical values: no change at all, p = 1.
    let flat = find_step(&[p(0.0), p(1.0), p(2.0), p(3.0), p(4.0)], &options).unwrap();
    assert_eq!(flat.p_value, 1.0);
    assert_eq!(flat.shift, 0.0);
}
