//! Calibration: on white Gaussian noise of the stated σ, `locate` must not claim an effect more
//! often than α allows, and each test's own p-values must not be anti-conservative.

use crate::common;

use std::collections::BTreeMap;

use mtcal_mismatch::{Options, RunResiduals, TestKind, locate};

const RUNS: u64 = 300;
const N: usize = 200;

/// Upper limit of a binomial count: mean + 3 standard deviations.
fn upper_limit(trials: usize, rate: f64) -> f64 {
    let n = trials as f64;
    n * rate + 3.0 * (n * rate * (1.0 - rate)).sqrt()
}

/// One white-noise run with two channels, four informative variables (time, an unevenly sampled
/// linear axis, a rotary axis with ties, a temperature that follows time), a constant spindle
/// speed (skipped) and a direction split.
fn white_run(seed: u64, alpha: f64) -> mtcal_mismatch::Analysis {
    let mut rng = common::rng(seed);
    let t = common::uneven_times(&mut rng, N, 600.0);
    let x = common::positions(&mut rng, N, 0.0, 500.0);
    let c = common::angles(&mut rng, N);
    let temp: Vec<f64> = t.iter().map(|t| 20.0 + 0.5 * (t / 600.0).sqrt()).collect();
    let s = vec![8000.0; N];
    let dir = common::directions(N, 17);
    let dx = common::white(&mut rng, N);
    let dz = common::white(&mut rng, N);
    let run_name = format!("white-{seed}");
    let run = RunResiduals::new(&run_name)
        .channel("dx", &dx)
        .channel("dz", &dz)
        .context("t", &t)
        .context("X", &x)
        .context("C", &c)
        .context("T_spindle", &temp)
        .context("S", &s)
        .split("direction", &dir);
    let options = Options {
        alpha,
        ..Options::default()
    };
    locate(&[run], &options).expect("valid input")
}

#[test]
fn family_wise_false_alarm_rate_is_at_most_alpha() {
    let alpha = 0.05;
    let mut alarms = 0;
    let mut per_test: BTreeMap<TestKind, (usize, usize)> = BTreeMap::new();
    for seed in 0..RUNS {
        let analysis = white_run(seed, alpha);
        assert_eq!(analysis.skipped.len(), 1, "the constant S is skipped");
        if analysis.mismatch.detected {
            alarms += 1;
        }
        for record in &analysis.tests {
            let entry = per_test.entry(record.test).or_default();
            entry.0 += 1;
            entry.1 += usize::from(record.p_value <= 0.05);
        }
    }
    let limit = upper_limit(RUNS as usize, alpha);
    assert!(
        f64::from(alarms) <= limit,
        "{alarms} false alarms in {RUNS} runs (limit {limit:.1})"
    );
    // Each test on its own, unadjusted: at most 5 % (+ binomial margin) of its p-values ≤ 0.05.
    // The exact and asymptotically exact tests must also not be far too conservative, or they
    // would waste power (CUSUM and Lomb–Scargle are conservative by construction).
    for (test, (count, rejected)) in &per_test {
        let rate = *rejected as f64 / *count as f64;
        assert!(
            *rejected as f64 <= upper_limit(*count, 0.05),
            "{test:?}: rate {rate:.4} of {count}"
        );
        if !matches!(test, TestKind::Cusum | TestKind::LombScargle) {
            assert!(
                rate >= 0.02,
                "{test:?}: rate {rate:.4} of {count} is too conservative"
            );
        }
    }
    assert_eq!(per_test.len(), 7, "every kind of test ran: {per_test:?}");
}

#[test]
fn family_over_all_runs_holds_alpha_for_the_whole_call() {
    // Ten runs per call, Family::All: the call as a whole raises at most α false alarms.
    let alpha = 0.1;
    let calls = 40;
    let mut alarms = 0;
    for call in 0..calls {
        let mut data = Vec::new();
        for k in 0..10_u64 {
            let mut rng = common::rng(10_000 + 10 * call + k);
            let t: Vec<f64> = (0..60).map(f64::from).collect();
            data.push((format!("run{k}"), t, common::white(&mut rng, 60)));
        }
        let runs: Vec<_> = data
            .iter()
            .map(|(name, t, r)| RunResiduals::new(name).channel("d", r).context("t", t))
            .collect();
        let options = Options {
            alpha,
            family: mtcal_mismatch::Family::All,
            ..Options::default()
        };
        alarms += usize::from(locate(&runs, &options).unwrap().mismatch.detected);
    }
    assert!(
        alarms as f64 <= upper_limit(calls as usize, alpha),
        "{alarms} of {calls}"
    );
}
