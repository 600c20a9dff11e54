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

use crate::common;

use common::honesty::honest;
use common::planted::{Variant, session};
use mtcal_identify::Study;
use mtcal_identify::search::{SearchOptions, SearchStop, search};
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

/// A fit stopped before it converged (no iteration allowed: one Gauss–Newton step may already
/// converge on this nearly linear problem): the search searches nothing,
/// claims nothing, and its first line says why and what to do.
#[test]
fn nothing_is_searched_on_a_fit_that_did_not_converge() {
    let dir = tempfile::tempdir().unwrap();
    let text = effects(&[0, 1], 3.0);
    let study = Study::load(&session(dir.path(), &text, 5, Variant::default())).unwrap();
    let mut options = SearchOptions::default();
    options.solver.max_iterations = 0;
    let result = search(study, &options).unwrap();
    let id = &result.identification;
    let found = &result.findings;
    assert!(!id.solver.converged);
    assert!(found.discoveries.is_empty());
    let report = &found.report;
    assert_eq!(report.stopped, SearchStop::BaseNotConverged);
    assert!(report.steps.is_empty());
    let first = found.summary().lines().next().unwrap().to_string();
    assert!(
        first.contains("did not converge") && first.contains("[identify] parameters"),
        "{first}"
    );
    honest(&result).unwrap();
}

/// The five-axis example (no effect planted) with every set-up's σ stated a third of the noise
/// its recordings carry. The search weighs the runs by the noise their residuals show, and at
/// that noise the model explains them: it must still say, first, that at the stated σ it does
/// not — the plain fit says so, and a search that found nothing to add changes nothing in it.
#[test]
fn a_sigma_stated_too_small_is_not_explained_away_by_the_search() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = mtcal_testkit::sessions::copied(
        &mtcal_testkit::repo().join("examples/five-axis/session"),
        &tmp.path().join("session"),
    );
    // The simulated noise is the plugins' default σ (0.5 µm R-test, 1 µm ball bar).
    let manifest = std::fs::read_to_string(dir.join("session.toml")).unwrap();
    let stated = manifest
        .replace(
            "mount = \"ball-in-spindle\"\n",
            "mount = \"ball-in-spindle\"\nsigma_um = 0.17\n",
        )
        .replace("length = 100.0\n", "length = 100.0\nsigma_um = 0.33\n");
    assert_eq!(stated.matches("sigma_um").count(), 3, "{stated}");
    std::fs::write(dir.join("session.toml"), stated).unwrap();
    let run = |search: bool| {
        let options = mtcal_identify::pipeline::PipelineOptions {
            search,
            ..Default::default()
        };
        mtcal_identify::pipeline::Prepared::load(&dir, options)
            .unwrap()
            .run(&mut mtcal_solve::Silent)
            .unwrap()
    };
    let plain = run(false);
    let plain_verdict = plain
        .identification
        .verdict()
        .expect("the plain fit's verdict");
    assert!(
        plain_verdict.starts_with("THE MODEL DOES NOT EXPLAIN THE RECORDINGS:"),
        "{plain_verdict}"
    );
    let searched = run(true);
    let id = &searched.identification;
    let found = &searched.search.as_ref().expect("the search ran").findings;
    assert!(found.discoveries.is_empty(), "{}", found.summary());
    assert!(
        !id.noise.is_empty(),
        "the search weighs by the residuals' noise"
    );
    let verdict = id.verdict().expect("a verdict after the search too");
    assert!(
        verdict.starts_with(
            "THE MODEL DOES NOT EXPLAIN THE RECORDINGS AT THE NOISE THEIR FILES STATE"
        ) && verdict.contains("× the stated σ"),
        "{verdict}"
    );
    assert!(!id.model_explains_recordings());
    assert!(
        searched.screen(false).starts_with(&verdict),
        "{}",
        searched.screen(false)
    );
}
