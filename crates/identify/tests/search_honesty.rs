//! What every search must hold, whatever it is given: random sessions (a five-axis R-test and
//! ball-bar session, up to three effects of random class, size and axis, or none; random noise
//! seeds) and two sessions whose fits do not converge.
//! - A discovery is a determined, physical effect of the final fit: every parameter has an
//!   interval, narrower than its plausible range, its value inside that range; a shape (τ, a
//!   pitch, a decay) is determined to better than its own size, or held and said to be; its
//!   amplitudes together lie outside their 95 % region of zero (a Wald test in the final fit's
//!   covariance: a joint model's columns are correlated).
//! - No discovery comes from a fit that did not converge, before or after the search.
//! - The search's first line agrees with its discoveries.

mod common;

use common::planted::{Variant, session};
use mtcal_identify::search::{SearchOptions, SearchResult, SearchStop, search};
use mtcal_identify::{Study, param_specs};
use proptest::prelude::*;

/// Effects a random session plants, `{s}` scaled by the case's size (µm at 1).
const POOL: [&str; 8] = [
    "effect = \"thermal-drift\"\naxis = \"Z\"\namplitude_um = {2}\ntau_s = 400.0\n",
    "effect = \"reversal\"\naxis = \"X\"\nbacklash_um = {2}\n",
    "effect = \"cyclic\"\naxis = \"Y\"\nsin_um = {1}\ncos_um = {-1}\npitch_mm = 20.0\n",
    "effect = \"servo-lag\"\naxis = \"Y\"\nlag_ms = {1}\n",
    "effect = \"stick-slip\"\naxis = \"Y\"\nheight_um = {1}\ndecay_mm = 2.0\n",
    "effect = \"setup-drift\"\nsetup = \"low\"\nnuisance = \"ball_x\"\nrate_um_per_h = {3}\n",
    "effect = \"temperature-coupling\"\naxis = \"X\"\ndriver = \"T_bed\"\ngain_um_per_K = {0.6}\n",
    "effect = \"cross-coupling\"\naxis = \"Z\"\ndriver = \"X*Y\"\ncorner_um = {2}\n",
];

/// The `[[effect]]` tables of `picks` from [`POOL`], sizes times `scale`.
fn effects(picks: &[usize], scale: f64) -> String {
    let mut out = String::new();
    for &k in picks {
        let mut text = POOL[k].to_string();
        while let Some(open) = text.find('{') {
            let close = open + text[open..].find('}').expect("a closing brace");
            let v: f64 = text[open + 1..close].parse().expect("a number");
            text.replace_range(open..=close, &format!("{:.4}", v * scale));
        }
        out += "[[effect]]\n";
        out += &text;
    }
    out
}

/// Every honesty rule on `result` (see the module docs); `Err` says which failed.
fn honest(result: &SearchResult) -> Result<(), String> {
    let id = &result.identification;
    let summary = id.search_summary();
    let first = summary.lines().next().unwrap_or_default();
    let n = id.discoveries.len();
    let says = match n {
        0 if !result.initial.solver.converged => "did not converge".to_string(),
        0 => "nothing added".to_string(),
        1 => "1 effect added".to_string(),
        n => format!("{n} effects added"),
    };
    if !first.contains(&says) {
        return Err(format!("{n} discoveries, but the first line says: {first}"));
    }
    if n == 0 {
        return Ok(());
    }
    if !result.initial.solver.converged || !id.solver.converged {
        return Err(format!(
            "discoveries on a fit that did not converge:\n{summary}"
        ));
    }
    let study = &result.study;
    let specs = param_specs(study);
    let index = |name: &str| (0..study.layout().n_x()).find(|&i| study.param_info(i).name == name);
    for d in &id.discoveries {
        let mut amplitudes = Vec::new();
        for p in &d.parameters {
            let full = if d.effect == "omitted-parameter" || d.effect == "component-order" {
                p.name.clone()
            } else {
                format!("{}.{}", d.label, p.name)
            };
            let i = index(&full).ok_or_else(|| format!("{full} is not in the final model"))?;
            let per_si = study.param_info(i).per_si;
            if p.held {
                if specs[i].bounds.is_none() || p.u95.is_some() {
                    return Err(format!("{}: {full} is held but not a shape", d.label));
                }
                continue;
            }
            let Some(u95) = p.u95 else {
                return Err(format!("{}: {full} has no interval\n{summary}", d.label));
            };
            if specs[i].bounds.is_some() {
                if u95 >= p.value.abs() {
                    return Err(format!("{}: shape {full} = {} ± {u95}", d.label, p.value));
                }
                continue;
            }
            amplitudes.push(i);
            if let Some(range) = specs[i].scale {
                let range = range * per_si;
                if p.value.abs() > range || u95 > range {
                    return Err(format!(
                        "{}: {full} = {} ± {u95} against a plausible range of ±{range}",
                        d.label, p.value
                    ));
                }
            }
        }
        if !amplitudes.is_empty() {
            let (w, limit) = wald(&result.solution, &amplitudes);
            if w <= limit {
                return Err(format!(
                    "{}: its amplitudes are within their 95 % region of zero (Wald {w:.1} ≤ \
                     {limit:.1})\n{summary}",
                    d.label
                ));
            }
        }
    }
    Ok(())
}

/// `xᵀC⁺x` of the parameters `idx` of `solution` and the χ² 95 % quantile of its rank.
fn wald(solution: &mtcal_solve::Solution, idx: &[usize]) -> (f64, f64) {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let k = idx.len();
    let c = nalgebra::DMatrix::from_fn(k, k, |a, b| solution.cov(idx[a], idx[b]));
    let x = nalgebra::DVector::from_iterator(k, idx.iter().map(|&i| solution.x[i]));
    let eps = 1e-12 * c.norm();
    let rank = c
        .clone()
        .svd(false, false)
        .singular_values
        .iter()
        .filter(|&&s| s > eps)
        .count();
    let pinv = c.pseudo_inverse(eps).unwrap();
    let w = (x.transpose() * pinv * &x)[(0, 0)];
    (
        w,
        ChiSquared::new(rank.max(1) as f64)
            .unwrap()
            .inverse_cdf(0.95),
    )
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 10,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn no_discovery_is_undetermined_implausible_or_unconverged(
        seed in 1u64..10_000,
        picks in proptest::collection::vec(0usize..POOL.len(), 0..=3),
        scale in 0.2f64..4.0,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let text = effects(&picks, scale);
        let study = Study::load(&session(dir.path(), &text, seed, Variant::default())).unwrap();
        let result = search(study, &SearchOptions::default()).unwrap();
        if let Err(why) = honest(&result) {
            return Err(TestCaseError::fail(format!("{text}\n{why}")));
        }
    }
}

/// A fit stopped before it converged (one iteration allowed): the search searches nothing,
/// claims nothing, and its first line says why and what to do.
#[test]
fn nothing_is_searched_on_a_fit_that_did_not_converge() {
    let dir = tempfile::tempdir().unwrap();
    let text = effects(&[0, 1], 3.0);
    let study = Study::load(&session(dir.path(), &text, 5, Variant::default())).unwrap();
    let mut options = SearchOptions::default();
    options.solver.max_iterations = 1;
    let result = search(study, &options).unwrap();
    let id = &result.identification;
    assert!(!id.solver.converged);
    assert!(id.discoveries.is_empty());
    let report = id.search.as_ref().unwrap();
    assert_eq!(report.stopped, SearchStop::BaseNotConverged);
    assert!(report.steps.is_empty());
    let first = id.search_summary().lines().next().unwrap().to_string();
    assert!(
        first.contains("did not converge") && first.contains("[identify] parameters"),
        "{first}"
    );
    honest(&result).unwrap();
}
