//! The search's cross-validation is computed from every fold's factor and normal equations
//! (the Gauss–Newton refit of each fold from the full fit, no iteration). Checked against the
//! slow way: each fold left out, the model refitted by the solver until it converges, the
//! left-out samples predicted. On an R-test session whose set-ups are calibrated (no direction
//! that only second-order effects identify, where a refit would creep) with a thermal drift in
//! the model (its time constant a nonlinear parameter).

use mtcal_identify::fit::Folds;
use mtcal_identify::search::{SearchOptions, heldout};
use mtcal_identify::study::Changes;
use mtcal_identify::whiten::{ChannelNoise, NoiseModel};
use mtcal_identify::{FitProblem, Study, param_specs_from, predict_runs, solve_from};
use mtcal_solve::{Options, Silent};
use std::path::Path;

const DRIFT: &str = "effect = \"thermal-drift\"\naxis = \"Z\"\namplitude_um = 3.0\ntau_s = 300.0\n";

fn session(dir: &Path, effect: &str) -> std::path::PathBuf {
    let mut plan = format!(
        "machine = {:?}\ntruth = {:?}\nseed = 11\ninterval_s = 0.5\n[identify]\n\
         parameters = {}\n\
         [setup.low]\nball = [100.0, 0.0, 200.0]\nmount = \"ball-in-spindle\"\nball_free = false\ntool_length_free = false\n\
         [setup.high]\nball = [100.0, 0.0, 300.0]\nmount = \"ball-in-spindle\"\nball_free = false\ntool_length_free = false\n",
        mtcal_testkit::machine_file(mtcal_testkit::TRUNNION),
        mtcal_testkit::five_axis_truth_file(),
        mtcal_testkit::params::toml_list(&mtcal_testkit::ELEVEN),
    );
    for (name, setup, path) in [
        ("a0", "low", "kind = \"xyc\""),
        ("a30", "low", "kind = \"xyc\", hold = { A = 30.0 }"),
        ("am30", "low", "kind = \"xyc\", hold = { A = -30.0 }"),
        ("yza", "low", "kind = \"yza\""),
        ("high", "high", "kind = \"xyc\""),
    ] {
        plan += &format!(
            "[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\npath = {{ {path}, samples = 145 }}\n"
        );
    }
    plan += &format!("[[effect]]\n{effect}");
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    mtcal_simulate::simulate(&dir.join("plan.toml"), &dir.join("s")).unwrap();
    dir.join("s")
}

/// Each residual (SI) of fold `k` of `folds` (blocks of every fitted run) predicted at `x`,
/// with its channel's σ.
fn held_out(study: &Study, x: &[f64], folds: usize, k: usize, mut f: impl FnMut(f64, f64)) {
    let pred = predict_runs(study, x, |r| study.runs[r].fit);
    for (r, p) in pred.iter().enumerate() {
        let Some(p) = p else { continue };
        let run = &study.runs[r];
        let readings = run.readings.as_ref().unwrap();
        let channels = study.channels(r);
        let nch = channels.len();
        let n = run.len();
        for i in (0..n).filter(|&i| Folds::fold_of(folds, i, n) == k) {
            for (c, ch) in channels.iter().enumerate() {
                f(p[i * nch + c] - readings.get(i, c), ch.sigma);
            }
        }
    }
}

#[test]
fn one_pass_cross_validation_equals_refitting_every_fold() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = Study::load(&session(dir.path(), DRIFT)).unwrap();
    let (drift, _) = mtcal_effects::plant(&toml::from_str(DRIFT).unwrap(), loaded.view()).unwrap();
    let study = loaded
        .rebuild(Changes {
            effects: vec![drift],
            ..Changes::default()
        })
        .unwrap();
    let fit = solve_from(&study, &study.initial_x(), &Options::default(), &mut Silent).unwrap();
    assert!(fit.converged);
    let options = SearchOptions::default();
    let fast = heldout(&study, &fit.x, &options).unwrap();
    let folds = options.folds;
    let (mut sum, mut count) = (0.0, 0usize);
    for k in 0..folds {
        let problem = FitProblem::with_folds(
            &study,
            Some(Folds {
                count: folds,
                held: k,
            }),
        );
        let sol = mtcal_solve::solve(
            &problem,
            &param_specs_from(&study, &fit.x),
            &Options::default(),
            &mut Silent,
        )
        .unwrap();
        assert!(sol.converged, "fold {k}: {:?}", sol.termination);
        held_out(&study, &sol.x, folds, k, |d, sigma| {
            sum += (d / sigma).powi(2);
            count += 1;
        });
    }
    let slow = sum / count as f64;
    assert_eq!(fast.samples, count);
    assert!(
        (fast.mean_square - slow).abs() <= 1e-3 * slow,
        "one pass {} vs refits {slow}",
        fast.mean_square
    );
    // Held-out data are predicted a little worse than fitted data (0.5 µm noise, σ = 0.5 µm).
    assert!(fast.mean_square > 0.9 && fast.mean_square < 1.2, "{fast:?}");
}

/// With coloured noise every row is prewhitened against the sample before it, and a fold's
/// refit starts the filter again after each stretch it leaves out. The one-pass
/// cross-validation (rows evaluated once, reduced fold by fold) must give each fold's training
/// problem exactly as the fit without the fold gives it: checked against the Gauss–Newton step
/// of `FitProblem::with_folds`, whose filter restarts by construction, and against the refit.
#[test]
fn with_coloured_noise_each_fold_is_refitted_as_the_fit_without_it() {
    let dir = tempfile::tempdir().unwrap();
    // Noise of AR(1) coefficient 0.7 on every channel: every row is prewhitened against the
    // one before it. The model is the geometry alone (linear to far below these tolerances;
    // the drift in the recordings is left to the residuals).
    let loaded = Study::load(&session(dir.path(), DRIFT)).unwrap();
    let coloured = ChannelNoise {
        scale: 1.0,
        phi: 0.7,
        samples: 1000,
    };
    let noise = NoiseModel {
        per_setup: loaded
            .setups
            .iter()
            .map(|s| vec![coloured; s.setup.channels().len()])
            .collect(),
    };
    let study = loaded
        .rebuild(Changes {
            noise: Some(std::sync::Arc::new(noise)),
            ..Changes::default()
        })
        .unwrap();
    let first = solve_from(&study, &study.initial_x(), &Options::default(), &mut Silent).unwrap();
    let fit = solve_from(&study, &first.x, &Options::default(), &mut Silent).unwrap();
    assert!(fit.converged);
    let options = SearchOptions::default();
    let fast = heldout(&study, &fit.x, &options).unwrap();
    let folds = options.folds;
    // Per fold, the RMS (µm) of its samples predicted at the step and at the refit.
    let (mut step_sum, mut refit_sum, mut count) = (0.0, 0.0, 0usize);
    for k in 0..folds {
        let problem = FitProblem::with_folds(
            &study,
            Some(Folds {
                count: folds,
                held: k,
            }),
        );
        let specs = param_specs_from(&study, &fit.x);
        let delta = mtcal_solve::linearize(&problem, &specs, &fit.x, 0)
            .unwrap()
            .step(options.solver.rank_tolerance)
            .unwrap();
        let stepped: Vec<f64> = fit.x.iter().zip(&delta).map(|(x, d)| x + d).collect();
        let refit = mtcal_solve::solve(&problem, &specs, &Options::default(), &mut Silent).unwrap();
        assert!(refit.converged, "fold {k}: {:?}", refit.termination);
        held_out(&study, &stepped, folds, k, |d, _| step_sum += d * d);
        held_out(&study, &refit.x, folds, k, |d, _| {
            refit_sum += d * d;
            count += 1;
        });
    }
    let rms = |sum: f64| (sum / count as f64).sqrt() * 1e6;
    assert_eq!(fast.samples, count);
    // The same step: equal but for rounding and the model's curvature over the step.
    let (stepped, refitted) = (rms(step_sum), rms(refit_sum));
    assert!(
        (fast.rms_um - stepped).abs() <= 1e-6 * stepped,
        "one pass {} µm vs the step without each fold {stepped} µm",
        fast.rms_um
    );
    assert!(
        (fast.rms_um - refitted).abs() <= 1e-3 * refitted,
        "one pass {} µm vs refits {refitted} µm",
        fast.rms_um
    );
}
