//! Effects in the fit: the analytic Jacobian of the whitened residuals (machine coefficients,
//! set-up parameters, every effect's amplitudes and shape parameters) equals central finite
//! differences of the predictions, for one effect of every kind at once (and the shapes of
//! `SHAPES`); and a noise-free
//! session with planted effects (applied exactly: axes really displaced, set-up parameters
//! really moved) is fitted back to its planted values (the fit's first-order axis Jacobian
//! against the simulation's exact chain).

use mtcal_effects::Candidate;
use mtcal_identify::study::Changes;
use mtcal_identify::{FitProblem, Study, param_specs_from, predict_run};
use mtcal_simulate::simulate;
use mtcal_solve::{Options, Silent};
use mtcal_testkit::plans::Run;
use mtcal_testkit::{TRUNNION, five_axis_truth_file, machine_file};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The context programmes and set-ups of the plan.
const SETUPS: &str = r#"[context]
S = [[0.0, 0.0], [200.0, 3000.0], [900.0, 6000.0], [1500.0, 0.0]]
T_bed = [[0.0, 20.0], [800.0, 22.5], [2000.0, 21.0]]
[setup.low]
ball = [100.0, 0.0, 200.0]
[setup.high]
ball = [100.0, 0.0, 300.0]
[setup.bar]
pivot = [0.0, 0.0, 250.0]
length = 100.0
"#;

/// The runs: name, instrument, set-up, path.
const RUNS: [(&str, &str, &str, &str); 6] = [
    ("xyc", "rtest", "low", "{ kind = \"xyc\", samples = 145 }"),
    (
        "xyc-a30",
        "rtest",
        "low",
        "{ kind = \"xyc\", samples = 145, hold = { A = 30.0 } }",
    ),
    ("yza", "rtest", "low", "{ kind = \"yza\", samples = 121 }"),
    (
        "xyc-high",
        "rtest",
        "high",
        "{ kind = \"xyc\", samples = 145 }",
    ),
    (
        "bb-ccw",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"XY\", direction = \"ccw\", samples = 181 }",
    ),
    (
        "bb-cw",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"XY\", direction = \"cw\", samples = 181 }",
    ),
];

/// The plan without machine and truth: the eleven errors estimated, each run noise-free or
/// with its instrument's noise.
fn plan(noise_free: bool) -> String {
    let mut plan = format!(
        "\nseed = 3\ninterval_s = 1.0\n[identify]\nparameters = {}\n{SETUPS}",
        mtcal_testkit::params::toml_list(&mtcal_testkit::ELEVEN)
    );
    for (name, instrument, setup, path) in RUNS {
        plan += &Run::new(name, instrument, setup)
            .noise_if(noise_free.then_some("0.0"))
            .path(path);
    }
    plan
}

/// The effects below, planted with these values (their units) and fitted back.
const EFFECTS: &str = r#"
[[effect]]
effect = "thermal-drift"
axis = "Z"
amplitude_um = 4.0
tau_s = 700.0
[[effect]]
effect = "thermal-drift"
axis = "Y"
driver = "S^2"
gain_um_per_krpm2 = 0.08
tau_s = 400.0
[[effect]]
effect = "temperature-coupling"
axis = "X"
driver = "T_bed"
gain_um_per_K = 1.5
tau_s = 300.0
[[effect]]
effect = "reversal"
axis = "X"
backlash_um = 3.0
[[effect]]
effect = "cyclic"
axis = "Y"
sin_um = 1.0
cos_um = -0.6
pitch_mm = 20.0
[[effect]]
effect = "servo-lag"
axis = "Y"
lag_ms = 1.0
[[effect]]
effect = "stick-slip"
axis = "Y"
height_um = 2.0
decay_mm = 2.0
[[effect]]
effect = "cross-coupling"
axis = "Z"
driver = "X*Y"
corner_um = 2.0
[[effect]]
effect = "setup-drift"
setup = "low"
nuisance = "ball_x"
rate_um_per_h = 6.0
[[effect]]
effect = "instrument-scale"
channel = "dr"
gain_ppm = 30000.0
"#;

/// The shapes of real machines beyond those (lost motion changing along the stroke, lateral
/// play as a step and taken up over travel, a reversal spike first-order and damped decaying in time, a local bump of a straightness, the spindle growing
/// every set-up's tool length in time and with speed, a location error and a squareness
/// following a temperature): their columns against differences.
const SHAPES: &str = r#"
[[effect]]
effect = "reversal"
axis = "Y"
backlash_um = 2.0
backlash_change_um = 1.0
[[effect]]
effect = "lateral-play"
axis = "X"
across = "Z"
play_um = 2.0
[[effect]]
effect = "lateral-play"
axis = "Y"
across = "X"
play_um = 1.5
take_up_mm = 4.0
[[effect]]
effect = "reversal-spike"
axis = "Y"
height_um = 2.0
tau_s = 3.0
[[effect]]
effect = "reversal-spike"
axis = "Y"
recovery = "damped"
height_um = 1.5
tau_s = 2.0
[[effect]]
effect = "local-error"
axis = "X"
across = "Z"
amplitude_um = 2.0
centre_mm = 20.0
half_width_mm = 40.0
[[effect]]
effect = "local-error"
axis = "Y"
amplitude_um = -1.5
centre_mm = -10.0
half_width_mm = 30.0
[[effect]]
effect = "spindle-growth"
amplitude_um = 3.0
tau_s = 600.0
[[effect]]
effect = "spindle-growth"
driver = "S"
gain_um_per_krpm = 0.5
tau_s = 300.0
[[effect]]
effect = "thermal-location"
parameter = "EY0A"
driver = "T_bed"
gain_um_per_K = 2.0
[[effect]]
effect = "thermal-location"
parameter = "EC0Y"
driver = "T_bed"
gain_urad_per_K = 3.0
tau_s = 500.0
"#;

fn session(dir: &Path, noise: f64, effects: &str) -> PathBuf {
    let machine = machine_file(TRUNNION);
    let truth = five_axis_truth_file();
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth:?}\n{}{effects}",
        plan(noise == 0.0)
    );
    std::fs::create_dir_all(dir).unwrap();
    let file = dir.join("plan.toml");
    std::fs::write(&file, plan).unwrap();
    let out = dir.join("session");
    simulate(&file, &out).unwrap();
    out
}

/// The effects of `text` (`[[effect]]` tables), rebuilt against the fitted study's view (same
/// families, same keys).
fn effects_of(study: &Study, text: &str) -> (Vec<Arc<dyn mtcal_effects::Effect>>, Vec<f64>) {
    let plan: toml::Table = toml::from_str(text).unwrap();
    let mut effects = Vec::new();
    let mut values = Vec::new();
    for t in plan["effect"].as_array().unwrap() {
        let (e, v) = mtcal_effects::plant(t.as_table().unwrap(), study.view()).unwrap();
        effects.push(e);
        values.extend(v);
    }
    (effects, values)
}

#[test]
fn effect_columns_equal_finite_differences() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = Study::load(&session(dir.path(), 0.5, "")).unwrap();
    let (effects, values) = effects_of(&loaded, &format!("{EFFECTS}{SHAPES}"));
    assert_eq!(effects.len(), 21);
    let study = loaded
        .rebuild(Changes {
            effects,
            ..Changes::default()
        })
        .unwrap();
    // Machine and set-up parameters of some µm / µrad, the effects at their planted values.
    let mut x: Vec<f64> = (0..study.layout().n_x())
        .map(|i| 3e-6 * ((i as f64 * 1.7).sin() + 0.3))
        .collect();
    x[study.layout().effect_offset()..].copy_from_slice(&values);
    assert_columns_match(&study, &x);
}

/// A location error following a temperature moves the readings as the machine model moves
/// them when that error really is larger by the same amount (the exact chain, not the
/// first-order column the effect is carried by): at every sample, within a hundredth of the
/// change for a change of 20 µm (second order: tens of µrad times the arm).
#[test]
fn a_location_change_moves_the_readings_as_the_parameter_itself() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = Study::load(&session(dir.path(), 0.5, "")).unwrap();
    for (text, name, gain_si) in [
        (
            "[[effect]]\neffect = \"thermal-location\"\nparameter = \"EY0A\"\ndriver = \"T_bed\"\ngain_um_per_K = 8.0\n",
            "EY0A",
            8e-6,
        ),
        (
            "[[effect]]\neffect = \"thermal-location\"\nparameter = \"EB0C\"\ndriver = \"T_bed\"\ngain_urad_per_K = 8.0\n",
            "EB0C",
            8e-6,
        ),
    ] {
        let (effects, _) = effects_of(&loaded, text);
        let study = loaded
            .rebuild(Changes {
                effects,
                ..Changes::default()
            })
            .unwrap();
        let n = loaded.layout().n_x();
        let x0: Vec<f64> = (0..n)
            .map(|i| 3e-6 * ((i as f64 * 1.7).sin() + 0.3))
            .collect();
        let mut x = x0.clone();
        x.push(gain_si);
        let k = (0..n)
            .find(|&i| loaded.param_info(i).name == name)
            .unwrap_or_else(|| panic!("{name} is estimated"));
        let mut checked = 0;
        for (r, run) in study.runs.iter().enumerate() {
            if !run.fit {
                continue;
            }
            let with = predict_run(&study, r, &x);
            let nch = study.channels(r).len();
            let view = study.view();
            let rises = view.input(&mtcal_effects::Input::Context("T_bed".into()));
            for i in (0..run.len()).step_by(37) {
                let rise = rises[view.timeline_index(r, i)];
                let mut moved = x0.clone();
                moved[k] += gain_si * rise;
                let exact = predict_run(&loaded, r, &moved);
                for c in 0..nch {
                    let (a, b) = (with[i * nch + c], exact[i * nch + c]);
                    assert!(
                        (a - b).abs() <= 0.01 * gain_si * rise.abs() + 1e-10,
                        "{name}, run {}, sample {i}, channel {c}: {a:e} with the effect, \
                         {b:e} with the parameter moved by {:e}",
                        run.name,
                        gain_si * rise
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 20, "{checked} samples checked");
    }
}

/// A reversal's side of its play in a run the axis arrived at from an unknown side (the
/// session's first, recorded with A standing) and in a run it moves in: nuisance shapes in ±1
/// whose columns, and the backlash's beside them, equal differences.
#[test]
fn start_state_columns_equal_finite_differences() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = Study::load(&session(dir.path(), 0.5, "")).unwrap();
    let all = mtcal_identify::search::candidates(&loaded, None);
    let with_states: Vec<Arc<dyn mtcal_effects::Effect>> = all
        .iter()
        .filter_map(|c| match c {
            Candidate::Effect(e) if e.params().iter().any(|p| p.nuisance) => Some(Arc::clone(e)),
            _ => None,
        })
        .collect();
    let labels: Vec<&str> = with_states
        .iter()
        .map(|e| e.info().label.as_str())
        .collect();
    assert!(
        labels.contains(&"reversal A (A)") && labels.iter().any(|l| l.starts_with("lateral-play")),
        "{labels:?}"
    );
    let reversal = with_states
        .iter()
        .find(|e| e.info().label == "reversal A (A)")
        .unwrap();
    // A side in the run recorded standing (xyc), and in every run A moves in (yza): its
    // approach is not in the file either.
    let names: Vec<&str> = reversal.params().iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["backlash_urad", "start_xyc", "start_yza"]);
    let (study, mut x, o) = with_effect(&loaded, reversal);
    // 40 µrad of play, the axis on 0.6 of the way to its + side in one run, −0.3 in the other.
    x[o] = 40e-6;
    x[o + 1] = 0.6;
    x[o + 2] = -0.3;
    assert_columns_match(&study, &x);
    // A damped reversal spike whose first turn in a run is unknown: its side is a nuisance
    // too, and the transient after the first motion moves with it.
    let spike = with_states
        .iter()
        .find(|e| e.info().label == "reversal-spike X (X, damped)")
        .unwrap_or_else(|| panic!("no damped spike of X with a start state: {labels:?}"));
    let names: Vec<&str> = spike.params().iter().map(|p| p.name.as_str()).collect();
    assert!(
        names[..2] == ["height_um", "tau_s"] && names[2..].iter().all(|n| n.starts_with("start_")),
        "{names:?}"
    );
    let (study, mut x, o) = with_effect(&loaded, spike);
    x[o] = 3e-6;
    x[o + 1] = spike.params()[1].initial;
    for (k, side) in (o + 2..study.layout().n_x()).enumerate() {
        x[side] = [-0.4, 0.7, 0.1][k % 3];
    }
    assert_columns_match(&study, &x);
}

/// `loaded` with `effect` added, a point of small machine and set-up errors to evaluate it
/// at, and where the effect's parameters start in it.
fn with_effect(
    loaded: &Study,
    effect: &Arc<dyn mtcal_effects::Effect>,
) -> (Study, Vec<f64>, usize) {
    let study = loaded
        .rebuild(Changes {
            effects: vec![Arc::clone(effect)],
            ..Changes::default()
        })
        .unwrap();
    let x = (0..study.layout().n_x())
        .map(|i| 3e-6 * ((i as f64 * 1.7).sin() + 0.3))
        .collect();
    let o = study.layout().effect_offset();
    (study, x, o)
}

/// JᵀJ of the whitened residuals at `x` from the analytic factor equals that of central
/// differences of the predictions (every parameter: machine, set-up, effects).
fn assert_columns_match(study: &Study, x: &[f64]) {
    let specs = param_specs_from(study, x);
    let problem = FitProblem::new(study);
    let lin = mtcal_solve::linearize(&problem, &specs, x, 0).unwrap();
    let n = study.layout().n_x();
    // JᵀJ from the factor and from differences of the whitened predictions.
    let jtj =
        |i: usize, j: usize| -> f64 { (0..n).map(|k| lin.r[k * n + i] * lin.r[k * n + j]).sum() };
    let mut columns: Vec<Vec<f64>> = Vec::with_capacity(n);
    for i in 0..n {
        let h = match study.effect_param(i) {
            // A side of the play (±1): the readings are linear in it.
            Some(p) if p.nuisance => 1e-2,
            Some(p) if p.kind == mtcal_effects::ParamKind::Shape => {
                1e-5 * p.initial.abs().max(1e-3)
            }
            _ => 1e-8,
        };
        let mut plus = x.to_vec();
        plus[i] += h;
        let mut minus = x.to_vec();
        minus[i] -= h;
        let mut col = Vec::new();
        for (r, run) in study.runs.iter().enumerate() {
            if !run.fit {
                continue;
            }
            let (p, m) = (predict_run(study, r, &plus), predict_run(study, r, &minus));
            let nch = study.channels(r).len();
            for (k, (a, b)) in p.iter().zip(&m).enumerate() {
                col.push((a - b) / (2.0 * h) / study.channels(r)[k % nch].sigma);
            }
        }
        columns.push(col);
    }
    for i in 0..n {
        for j in 0..=i {
            let fd: f64 = columns[i].iter().zip(&columns[j]).map(|(a, b)| a * b).sum();
            let an = jtj(i, j);
            let scale = (jtj(i, i) * jtj(j, j)).sqrt().max(1e-300);
            assert!(
                (an - fd).abs() <= 2e-5 * scale,
                "JᵀJ[{}, {}] = {an:e} analytic, {fd:e} from differences (scale {scale:e})",
                study.param_info(i).name,
                study.param_info(j).name
            );
        }
    }
}

#[test]
fn planted_effects_are_fitted_back_without_noise() {
    let dir = tempfile::tempdir().unwrap();
    let loaded = Study::load(&session(dir.path(), 0.0, EFFECTS)).unwrap();
    let (effects, values) = effects_of(&loaded, EFFECTS);
    let study = loaded
        .rebuild(Changes {
            effects,
            ..Changes::default()
        })
        .unwrap();
    assert_eq!(study.layout().effect_offset(), loaded.layout().n_x());
    // Start from the fit without effects (as the search does: an instrument's gain has no
    // column while the machine predicts nothing), the time constants and the decay length
    // 30 % off their truth, amplitudes at zero: the fit must find them. (A screw's pitch is a
    // standard lead the candidates start from; 30 % off it the phase would wrap several times
    // over the stroke.)
    let (plain, plain_solution) =
        mtcal_identify::identify_with_solution(&loaded, &Options::default(), &mut Silent).unwrap();
    eprintln!(
        "plain: chi2 {} it {} {:?} x {:?}",
        plain.fit.chi2, plain.solver.iterations, plain.solver.termination, &plain_solution.x
    );
    let mut x0 = study.initial_x();
    x0[..loaded.layout().n_x()].copy_from_slice(&plain_solution.x);
    for i in study.layout().effects() {
        if let Some(p) = study.effect_param(i)
            && p.kind == mtcal_effects::ParamKind::Shape
        {
            let factor = if p.name == "pitch_mm" { 1.0 } else { 1.3 };
            x0[i] = values[i - study.layout().effect_offset()] * factor;
        }
    }
    let sol = mtcal_identify::solve_from(&study, &x0, &Options::default(), &mut Silent).unwrap();
    for i in study.layout().effects() {
        let truth = values[i - study.layout().effect_offset()];
        let got = sol.x[i];
        // The fit carries the effects to first order (through the axis Jacobian of the
        // nominal machine); the simulation displaces the axes exactly. What is left is of the
        // order of the effects times the machine's errors.
        assert!(
            (got - truth).abs() <= 2e-3 * truth.abs(),
            "{}: fitted {got:e}, planted {truth:e}",
            study.param_info(i).name
        );
    }
    assert!(sol.chi2 < 1e-3, "noise-free fit leaves χ² {}", sol.chi2);
}

#[test]
fn every_family_proposes_candidates_on_a_rich_session() {
    let dir = tempfile::tempdir().unwrap();
    let study = Study::load(&session(dir.path(), 0.5, "")).unwrap();
    let all = mtcal_identify::search::candidates(&study, None);
    for family in mtcal_effects::families() {
        let n = all.iter().filter(|c| c.class() == family.name).count();
        // The 11-error fit leaves component errors out (omitted) but estimates no component
        // error (nothing to raise): every other family must propose something here.
        if family.name == "component-order" {
            assert_eq!(n, 0);
        } else if family.name == "thermal-model" {
            // A joint thermal model's shortest lag (5 min) must fit six times into the fitted
            // span: this session is too short for one.
            assert_eq!(n, 0);
        } else {
            assert!(n > 0, "{} proposes nothing", family.name);
        }
    }
    // Every effect candidate's label is unique together with its starting shape.
    let mut names: Vec<String> = all
        .iter()
        .filter_map(|c| match c {
            Candidate::Effect(e) => Some(format!(
                "{} {:?}",
                e.info().label,
                e.params().iter().map(|p| p.initial).collect::<Vec<_>>()
            )),
            Candidate::Model(_) => None,
        })
        .collect();
    let total = names.len();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), total);
}

/// `below_noise = 0.5` scales a planted effect so that its largest change of any reading is
/// half that reading's noise (here the channels' σ: the runs are noise-free).
#[test]
fn below_noise_scales_a_planted_effect_to_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    let plain = Study::load(&session(&dir.path().join("a"), 0.0, "")).unwrap();
    let planted = Study::load(&session(
        &dir.path().join("b"),
        0.0,
        "[[effect]]\neffect = \"thermal-drift\"\naxis = \"Z\"\namplitude_um = 40.0\ntau_s = 300.0\nbelow_noise = 0.5\n",
    ))
    .unwrap();
    let mut largest: f64 = 0.0;
    for (r, run) in plain.runs.iter().enumerate() {
        let (a, b) = (
            run.readings.as_ref().unwrap().to_row_major(),
            planted.runs[r].readings.as_ref().unwrap().to_row_major(),
        );
        let channels = plain.channels(r);
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            largest = largest.max((x - y).abs() / channels[k % channels.len()].sigma);
        }
    }
    assert!((largest - 0.5).abs() < 1e-3, "largest change {largest} σ");
}
