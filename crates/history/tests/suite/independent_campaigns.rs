//! A machine's history end to end on recordings mtcal did not write. Every campaign is a
//! five-axis R-test + ball-bar session written by the independent simulator (`mtcal-indsim`,
//! which shares no code with what it checks) with realistic faults:
//! - AR(1) noise (φ 0.6), with its σ stated 20 % small;
//! - readings quantised to 0.1 µm;
//! - every set-up re-mounted 20 µm away from where the session says.
//!
//! Each session is identified as `mtcal identify` does, with source 000's eleven errors named in
//! the session. Its JSON is read into a campaign as `mtcal history add` does, and the campaigns
//! are stored in a SQLite history. The trend is the one `mtcal history trend` prints.
//!
//! - A location error of the A axis (EY0A) drifting linearly over a year and a half: the
//!   planted rate lies within the reported drift interval in about 95 % of the series, and the
//!   drift is called in all of them.
//! - The same machine without drift: a drift or a step is claimed in at most 5 % of the series
//!   (plus binomial slack).
//! - On every campaign of both, the identified EY0A lies within its `u95` of that campaign's
//!   truth in about 95 % of the campaigns. The identification's intervals are honest on noise
//!   that is coloured and larger than stated: 139 and 140 of 144. Before the fit weighed by
//!   the noise its residuals show, it held in 87 of 144 and 85 of 143 (60 %, the worst 3.7 u95 off).
//!
//! - Every campaign's fit is a calibration (converged or settled: no creep to
//!   `max_iterations`).
//!
//! Bounds are binomial at 99 %, so each check can fail. mtcal's own simulator gives the trend
//! checks with many more seeds in `crates/trend/tests/suite/simulated_campaigns.rs`. Here the seeds
//! are fewer, because each campaign is a whole session (about 2,200 samples).

use mtcal_history::{Campaign, Limits, Store, Timestamp, TrendView, trend_view};
use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use mtcal_indsim::{Campaign as Sessions, Machine, Realism, Truth, shipped_machine};
use mtcal_testkit::ELEVEN;
use mtcal_trend::Verdict;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use statrs::distribution::{Binomial, DiscreteCDF};
use std::path::Path;

const MACHINE: &str = "trunnion-7";
/// The tracked error: where A's axis line passes in Y (µm).
const PARAMETER: &str = "EY0A";
/// Campaigns per series, 14–60 days apart.
const CAMPAIGNS: usize = 12;
/// Series per test.
const SERIES: u64 = 12;
/// The tracked error's value at the first campaign, µm.
const LEVEL_UM: f64 = 15.0;
/// Campaign-to-campaign scatter of the truth, µm. A machine is never in quite the same state.
/// This scatter is not in the identification's `u95`; the drift's scatter check must absorb it.
const SCATTER_UM: f64 = 0.25;
/// 2025-01-01 in Unix seconds.
const EPOCH_S: i64 = 1_735_689_600;
const DAY_S: f64 = 86_400.0;

/// One campaign's identified EY0A and its truth (µm); `None` when the fit is not a
/// calibration (the history shows such a campaign and does not count it).
struct Measured {
    truth_um: f64,
    value: Option<(f64, f64)>,
}

/// The machine: the shipped trunnion with the location and squareness errors of the
/// simulator's random draw 7, and no component errors (source 000's eleven-error machine).
fn machine_truth() -> (Machine, Truth) {
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let mut truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(7), 1.0);
    for axis in &mut truth.axes {
        axis.component = [[0.0; 4]; 6];
    }
    (machine, truth)
}

/// One series: `CAMPAIGNS` sessions of the machine with EY0A = `LEVEL_UM + rate·days` plus the
/// scatter. Each session is identified and added to a fresh history. Returns every campaign's
/// result and the history's trend of EY0A.
fn series(rate_um_per_day: f64, series: u64) -> (Vec<Measured>, TrendView) {
    let (machine, base) = machine_truth();
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite:{}", dir.path().join("history.sqlite").display());
    let mut store = Store::open(&url).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(series);
    let mut days = 0.0;
    let mut measured = Vec::with_capacity(CAMPAIGNS);
    for k in 0..CAMPAIGNS {
        if k > 0 {
            days += rng.random_range(14.0..=60.0);
        }
        let scatter: f64 = rng.sample(StandardNormal);
        let truth_um = LEVEL_UM + rate_um_per_day * days + SCATTER_UM * scatter;
        let mut truth = base.clone();
        truth.set(&machine, PARAMETER, truth_um * 1e-6).unwrap();
        let session = dir.path().join(format!("campaign-{k}"));
        let realism = Realism::realistic(series * 1_000 + k as u64);
        Sessions::trunnion_rtest_ballbar_with(&session, &truth, &realism).unwrap();
        as_a_user_has_it(&session);
        let outcome = Prepared::load(&session, PipelineOptions::default())
            .unwrap()
            .run(&mut mtcal_solve::Silent)
            .unwrap();
        let date = Timestamp::from_second(EPOCH_S + (days * DAY_S) as i64).unwrap();
        let campaign = Campaign::from_identify_json(&outcome.to_json(), MACHINE, date).unwrap();
        store.add(&campaign).unwrap();
        let id = &outcome.identification;
        let value = id.verdict().is_none().then(|| {
            let p = id
                .parameters
                .iter()
                .find(|p| p.name == PARAMETER)
                .unwrap_or_else(|| panic!("series {series}, campaign {k}: no {PARAMETER}"));
            (p.value, p.u95)
        });
        measured.push(Measured { truth_um, value });
    }
    let view = trend_view(&store, MACHINE, PARAMETER, &Limits::default(), 365.0).unwrap();
    // What the history counts is exactly the campaigns whose fit is a calibration.
    let counted: Vec<bool> = view.points.iter().map(|p| p.counts()).collect();
    let calibrations: Vec<bool> = measured.iter().map(|m| m.value.is_some()).collect();
    assert_eq!(counted, calibrations, "series {series}");
    (measured, view)
}

/// The session as a user has it: the machine's URDF beside it (without the error-model file of
/// the shipped one), and the eleven errors named in `[identify] parameters`.
fn as_a_user_has_it(dir: &Path) {
    mtcal_testkit::sessions::as_a_user_has_it(dir, Some(&format!("{ELEVEN:?}")));
}

/// The counts of `n` trials that an event of probability `p` gives with probability 99 %: the
/// 0.5 % and the 99.5 % quantiles of Binomial(n, p).
fn binomial_bounds(n: usize, p: f64) -> (usize, usize) {
    let binomial = Binomial::new(p, n as u64).unwrap();
    // The smallest k with P(X ≤ k) ≥ q (statrs' own inverse fails near 1 for small n).
    let quantile = |q: f64| (0..=n).find(|&k| binomial.cdf(k as u64) >= q).unwrap_or(n);
    (quantile(0.005), quantile(0.995))
}

/// Every calibration's identified EY0A against its truth: within `u95` in about 95 % of them.
fn check_identification(measured: &[Measured]) {
    let errors: Vec<f64> = measured
        .iter()
        .filter_map(|m| {
            let (value, u95) = m.value?;
            Some((value - m.truth_um).abs() / u95)
        })
        .collect();
    // Every fit is a calibration. Before the solver settled (`Termination::Settled`), 64 of
    // 144 crept along a direction the eleven errors see only to second order until
    // `max_iterations`, and were not counted.
    assert_eq!(
        errors.len(),
        measured.len(),
        "{} of {} campaigns not a calibration",
        measured.len() - errors.len(),
        measured.len()
    );
    let within = errors.iter().filter(|&&e| e <= 1.0).count();
    let (low, _) = binomial_bounds(errors.len(), 0.95);
    let worst = errors.iter().copied().fold(0.0, f64::max);
    println!(
        "{PARAMETER} within its u95 of the truth in {within} of {} campaigns (at least {low}; \
         worst {worst:.2} u95)",
        errors.len()
    );
    assert!(
        within >= low,
        "{PARAMETER} within u95 of the truth in only {within} of {} campaigns (at least {low})",
        errors.len()
    );
}

/// EY0A drifting by 0.02 µm/day (7.3 µm a year, about 8 µm over a series whose campaigns have
/// a u95 of about 0.6 µm): the planted rate lies within the reported interval in about 95 % of
/// the series, and the history calls it a drift in every one.
#[test]
fn a_drift_in_sessions_from_another_simulator_is_reported_with_an_honest_interval() {
    let rate = 0.02;
    let mut covered = 0;
    let mut drift_called = 0;
    let mut all = Vec::new();
    for s in 0..SERIES {
        let (measured, view) = series(rate, 100 + s);
        let trend = view
            .trend
            .unwrap_or_else(|| panic!("series {s}: no trend ({:?})", view.not_analysed));
        let d = &trend.drift;
        println!(
            "series {s}: {:.4} ± {:.4} µm/day (planted {rate}), {:?}",
            d.rate_per_day, d.rate_u95_per_day, trend.verdict
        );
        covered += usize::from((d.rate_per_day - rate).abs() <= d.rate_u95_per_day);
        drift_called += usize::from(trend.verdict == Verdict::Drift);
        all.extend(measured);
    }
    let (low, _) = binomial_bounds(SERIES as usize, 0.95);
    println!(
        "planted rate covered in {covered} of {SERIES} (at least {low}); drift called in {drift_called}"
    );
    assert!(
        covered >= low,
        "rate covered in {covered} of {SERIES} (at least {low})"
    );
    assert_eq!(
        drift_called, SERIES as usize,
        "the drift was not always called"
    );
    check_identification(&all);
}

/// The same machine, EY0A steady: the history claims a drift or a step in at most 5 % of the
/// series (plus binomial slack).
#[test]
fn a_steady_machine_measured_by_another_simulator_shows_no_change() {
    let mut claimed = 0;
    let mut all = Vec::new();
    for s in 0..SERIES {
        let (measured, view) = series(0.0, 200 + s);
        let trend = view
            .trend
            .unwrap_or_else(|| panic!("series {s}: no trend ({:?})", view.not_analysed));
        println!(
            "series {s}: {:.4} ± {:.4} µm/day, {:?}",
            trend.drift.rate_per_day, trend.drift.rate_u95_per_day, trend.verdict
        );
        claimed += usize::from(trend.verdict != Verdict::NoChange);
        all.extend(measured);
    }
    let (_, high) = binomial_bounds(SERIES as usize, 0.05);
    println!("a change claimed in {claimed} of {SERIES} steady series (at most {high})");
    assert!(
        claimed <= high,
        "a change claimed in {claimed} of {SERIES} steady series (at most {high})"
    );
    check_identification(&all);
}
