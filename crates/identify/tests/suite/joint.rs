//! One identification across instruments: R-test and ball-bar runs on the five-axis machine
//! fitted jointly, each whitened by its own noise.
//!
//! - The joint intervals are no wider than the best single instrument's on every parameter
//!   both estimate, and strictly narrower on the location errors both instruments see.
//! - The information account says which instrument and run constrain each parameter (shares
//!   sum to one), and predicts what repeating a run, or adding a run somewhere else, does to
//!   every interval: checked against actually fitting the larger session.

use mtcal_identify::information::{account, what_if};
use mtcal_identify::{Identification, Study, identify_with_solution};
use mtcal_simulate::simulate;
use mtcal_solve::Silent;
use mtcal_testkit::plans::{RTEST, ballbar, with_noise};
use mtcal_testkit::{ELEVEN, TRUNNION, five_axis_truth_file, machine_file};
use std::path::{Path, PathBuf};

/// Rotary-axis location errors: both instruments see them.
const LOCATIONS: [&str; 8] = [
    "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C",
];

/// The R-test run `r-xyc` once more, same set-up (a repeat).
const REPEAT: &str = r#"
[[run]]
name = "r-xyc-again"
instrument = "rtest"
setup = "ball"
noise = 0.5
path = { kind = "xyc", samples = 37 }
"#;

/// An R-test run with the ball moved higher and out: a set-up of its own.
const MOVED: &str = r#"
[setup.moved]
ball = [150.0, 50.0, 300.0]
ball_free = false
tool_length_free = false
[[run]]
name = "r-xyc-moved"
instrument = "rtest"
setup = "moved"
noise = 0.5
path = { kind = "xyc", samples = 37 }
"#;

/// Simulates the runs into `dir/<name>` (same truth, same seed) and returns the session.
fn session(dir: &Path, name: &str, runs: &str) -> PathBuf {
    let runs = with_noise(runs, 0.5, 1.0);
    let machine = machine_file(TRUNNION);
    let truth = five_axis_truth_file();
    let eleven = mtcal_testkit::params::toml_list(&ELEVEN);
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth:?}\nseed = 5\n[identify]\nparameters = {eleven}\n{runs}"
    );
    let plan_path = dir.join(format!("{name}.toml"));
    std::fs::write(&plan_path, plan).unwrap();
    let out = dir.join(name);
    simulate(&plan_path, &out).unwrap();
    out
}

fn fit(s: &Path) -> (Study, Identification, mtcal_solve::Solution) {
    let study = Study::load(s).unwrap();
    let (id, sol) = identify_with_solution(&study, &Default::default(), &mut Silent).unwrap();
    assert!(id.solver.converged, "{:?}", id.solver);
    (study, id, sol)
}

fn u95(id: &Identification, name: &str) -> Option<f64> {
    id.parameters.iter().find(|p| p.name == name).map(|p| p.u95)
}

#[test]
fn joint_intervals_are_no_wider_than_the_best_instrument_and_narrower_where_both_see() {
    let dir = tempfile::tempdir().unwrap();
    let (_, r, _) = fit(&session(dir.path(), "r", RTEST));
    let (_, b, _) = fit(&session(dir.path(), "b", &ballbar()));
    let joint_runs = format!("{RTEST}{}", ballbar());
    let (_, j, _) = fit(&session(dir.path(), "j", &joint_runs));
    let mut narrower = Vec::new();
    for p in &j.parameters {
        if p.kind != "machine" {
            continue;
        }
        let best = [u95(&r, &p.name), u95(&b, &p.name)]
            .into_iter()
            .flatten()
            .fold(f64::INFINITY, f64::min);
        assert!(
            p.u95 <= best * (1.0 + 1e-9),
            "{}: joint ±{} wider than the best single instrument's ±{best}",
            p.name,
            p.u95
        );
        if let (Some(ur), Some(ub)) = (u95(&r, &p.name), u95(&b, &p.name)) {
            narrower.push((p.name.clone(), p.u95 / ur.min(ub)));
        }
    }
    // Every parameter the joint fit identifies, and none it loses.
    for name in LOCATIONS {
        assert!(u95(&j, name).is_some(), "{name} not identified jointly");
        let ratio = narrower
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{name} is not identified by both instruments alone"))
            .1;
        assert!(
            ratio < 0.97,
            "{name}: joint interval is {ratio:.3} of the best single one, expected strictly narrower"
        );
    }
    eprintln!("joint / best single u95: {narrower:?}");
}

#[test]
fn shares_sum_to_one_and_predict_a_repeat_and_a_moved_run() {
    let dir = tempfile::tempdir().unwrap();
    let joint_runs = format!("{RTEST}{}", ballbar());
    let (study, id, sol) = fit(&session(dir.path(), "j", &joint_runs));
    let acc = account(&study, &sol).unwrap();
    assert!(!acc.parameters.is_empty());
    for p in &acc.parameters {
        let total: f64 = p.runs.iter().map(|s| s.share).sum();
        assert!(
            (total - 1.0).abs() < 1e-9,
            "{}: shares sum to {total}",
            p.name
        );
        let by_instrument: f64 = p.instruments.iter().map(|s| s.share).sum();
        assert!((by_instrument - total).abs() < 1e-9);
        assert!(p.runs.iter().all(|s| s.share >= -1e-12));
        let reported = u95(&id, &p.name).unwrap();
        assert!((p.u95 - reported).abs() <= 1e-12 * reported);
        assert!(
            (p.u95_account - reported).abs() < 1e-3 * reported,
            "{}: the account's own interval ±{} vs the fit's ±{reported}",
            p.name,
            p.u95_account
        );
    }
    // Where both instruments see a parameter both carry a real part of it.
    for name in LOCATIONS {
        let p = acc.parameters.iter().find(|p| p.name == name).unwrap();
        for inst in ["rtest", "ballbar"] {
            let s = p
                .instruments
                .iter()
                .find(|s| s.instrument == inst)
                .map_or(0.0, |s| s.share);
            assert!(s > 0.02, "{name}: {inst} share {s:.4}");
        }
    }

    // Repeat r-xyc: predicted from the account, then fitted for real.
    let (_, again, _) = fit(&session(
        dir.path(),
        "again",
        &format!("{RTEST}{REPEAT}{}", ballbar()),
    ));
    let mut checked = 0;
    for p in &acc.parameters {
        let predicted = p
            .repeat
            .iter()
            .find(|r| r.run == "r-xyc")
            .unwrap()
            .u95_after;
        let actual = u95(&again, &p.name).unwrap();
        assert!(
            (predicted - actual).abs() < 0.01 * actual,
            "{}: repeat predicted ±{predicted}, fitted ±{actual}",
            p.name
        );
        assert!(predicted <= p.u95 * (1.0 + 1e-12));
        checked += 1;
    }
    assert_eq!(checked, acc.parameters.len());

    // A moved run (its own set-up), as a separate session, against the real joint fit.
    let extra = Study::load(&session(dir.path(), "moved", MOVED)).unwrap();
    let predicted = what_if(&study, &sol, &extra).unwrap();
    let (_, bigger, _) = fit(&session(
        dir.path(),
        "bigger",
        &format!("{RTEST}{}{MOVED}", ballbar()),
    ));
    let mut gained = 0;
    for (name, after) in &predicted {
        let actual = u95(&bigger, name).unwrap();
        let before = u95(&id, name).unwrap();
        assert!(
            (after - actual).abs() < 0.01 * actual,
            "{name}: moved run predicted ±{after}, fitted ±{actual}"
        );
        if *after < 0.97 * before {
            gained += 1;
        }
    }
    assert!(
        gained >= 3,
        "the moved ball narrows few intervals: {predicted:?}"
    );
}

/// The shipped example has free set-up parameters and an unidentifiable combination: the
/// account must still add up, and a repeat can at best halve a variance.
#[test]
fn the_account_adds_up_with_free_set_ups_and_null_directions() {
    let s = mtcal_testkit::repo().join("examples/five-axis/session");
    let (study, id, sol) = fit(&s);
    assert!(
        !id.unidentifiable.is_empty(),
        "the example should have a null direction"
    );
    let acc = account(&study, &sol).unwrap();
    assert!(acc.parameters.len() >= 5);
    for p in &acc.parameters {
        let total: f64 = p.runs.iter().map(|s| s.share).sum();
        // Exact in exact arithmetic; here the information matrix of the example's weakest
        // kept direction is 10⁻¹⁰ of its strongest, so rounding (10⁻¹⁶) shows at 10⁻⁶.
        assert!(
            (total - 1.0).abs() < 1e-5,
            "{}: shares sum to {total}",
            p.name
        );
        assert!(
            p.runs
                .iter()
                .all(|s| (-1e-9..=1.0 + 1e-9).contains(&s.share))
        );
        assert!(
            (p.u95_account - p.u95).abs() < 1e-2 * p.u95,
            "{}: ±{} vs ±{}",
            p.name,
            p.u95_account,
            p.u95
        );
        for r in &p.repeat {
            assert!(
                r.u95_after >= p.u95_account / 2f64.sqrt() * (1.0 - 1e-9)
                    && r.u95_after <= p.u95_account * (1.0 + 1e-9),
                "{}: repeating {} gives ±{} from ±{}",
                p.name,
                r.run,
                r.u95_after,
                p.u95_account
            );
        }
    }
    let json = mtcal_identify::report::IdentifyJson::of(&id)
        .information(Some(&acc))
        .to_json();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let first = &v["information"]["parameters"][0];
    assert!(first["runs"][0]["share"].as_f64().unwrap() > 0.0);
    assert!(first["repeat"][0]["u95_after"].as_f64().is_some());
}
