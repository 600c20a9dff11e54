//! The physics search's first piece on simulated R-test sessions: a component error the fit
//! left out is named first and significant, with the fitted parameters it biased; a session
//! whose truth is inside the fitted model raises no claim. And the search's many refits read
//! nothing again: every set-up is loaded once, no file is read after the session is loaded.
//! A new instrument and a new effect family are each one registration: a test's own work
//! through the whole search.

mod common;

use mtcal_identify::search::{candidates, rank};
use mtcal_identify::{Study, identify};
use mtcal_simulate::simulate;
use mtcal_solve::{Options, Silent};
use mtcal_testkit::params::toml_list;
use mtcal_testkit::{ELEVEN, TRUNNION, five_axis_truth_file, machine_file};
use std::path::{Path, PathBuf};

/// Simulates the plan with `extra` added to the example's truth (the 11-error set) into
/// `dir/session`.
fn simulated(dir: &Path, extra: &str, seed: u64) -> PathBuf {
    let truth = std::fs::read_to_string(five_axis_truth_file()).unwrap() + extra;
    let truth_path = dir.join("truth.params.toml");
    std::fs::write(&truth_path, truth).unwrap();
    let machine = machine_file(TRUNNION);
    let runs = mtcal_testkit::plans::rtest_low_high(73, 61, Some("0.5"));
    let eleven = toml_list(&ELEVEN);
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth_path:?}\nseed = {seed}\n[identify]\nparameters = {eleven}\n{runs}"
    );
    let plan_path = dir.join("plan.toml");
    std::fs::write(&plan_path, plan).unwrap();
    let out = dir.join("session");
    simulate(&plan_path, &out).unwrap();
    out
}

/// Fits `session` (its `[identify]` parameters, with `also` added) and ranks the held-out
/// parameters.
fn ranked(session: &Path, also: &[&str]) -> Vec<mtcal_identify::search::Ranked> {
    let manifest = session.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let names: Vec<&str> = ELEVEN.iter().chain(also).copied().collect();
    let wanted = format!("parameters = {}", toml_list(&names));
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("parameters = ") {
                wanted.clone()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&manifest, text + "\n").unwrap();
    let study = Study::load(session).unwrap();
    let specs = mtcal_identify::param_specs(&study);
    let problem = mtcal_identify::FitProblem::new(&study);
    let solution = mtcal_solve::solve(&problem, &specs, &Options::default(), &mut Silent).unwrap();
    // The report path works on the same study (and agrees on the parameters).
    identify(&study, &Options::default(), &mut Silent).unwrap();
    let omitted = candidates(&study, Some(&["omitted-parameter".to_string()]));
    assert_eq!(
        omitted.len(),
        31 - also.len(),
        "30 component errors and the tool length, less those fitted"
    );
    rank(&study, &solution, omitted, 0.05).unwrap()
}

#[test]
fn an_omitted_axial_error_of_c_is_named_first_and_significant() {
    let dir = tempfile::tempdir().unwrap();
    // 3 µm of axial motion of C at twice per turn: outside the 11-error model.
    let extra = "\n[component.EZC]\nfunction = { kind = \"sine\", amplitude = 3.0, harmonic = 2, phase_deg = 20.0 }\n";
    let session = simulated(dir.path(), extra, 5);
    let ranked = ranked(&session, &[]);
    let best = &ranked[0];
    assert_eq!(best.candidate.label(), "EZC", "{}", best.describe());
    assert!(best.score.significant, "{}", best.describe());
    // Its once-per-turn part looks like the location errors of C (tilts move the ball's height
    // once per turn): partly absorbed, and the fit without it biased them.
    assert!(
        best.score.absorbed > 0.1 && best.score.absorbed < 0.99,
        "{}",
        best.describe()
    );
    assert!(!best.biased.is_empty(), "{}", best.describe());
    // Candidates that resemble it light up too (scored one at a time against the same
    // residuals), but less; once it is fitted, nothing is left to claim.
    assert!(ranked[1].score.statistic < 0.5 * best.score.statistic);
    let after = ranked_claims(&session, &["EZC"]);
    assert!(after.is_empty(), "{after:?}");
}

fn ranked_claims(session: &Path, also: &[&str]) -> Vec<String> {
    ranked(session, also)
        .iter()
        .filter(|r| r.score.significant)
        .map(|r| r.describe())
        .collect()
}

#[test]
fn a_session_inside_the_fitted_model_raises_no_claim() {
    let dir = tempfile::tempdir().unwrap();
    let session = simulated(dir.path(), "", 4);
    let claims = ranked_claims(&session, &[]);
    assert!(claims.is_empty(), "{claims:?}");
}

/// Negative control: clean sessions (truth inside the fitted model) with different noise; the
/// search may claim an effect in about α = 5 % of them (Holm over the candidates of each).
#[test]
fn clean_sessions_with_fifty_seeds_rarely_raise_a_claim() {
    let mut claimed = Vec::new();
    for seed in 100..150u64 {
        let dir = tempfile::tempdir().unwrap();
        let session = simulated(dir.path(), "", seed);
        let claims = ranked_claims(&session, &[]);
        if !claims.is_empty() {
            claimed.push((seed, claims));
        }
    }
    // 2.5 expected at most; 7 or more has probability below 0.5 % at a 5 % rate.
    assert!(claimed.len() < 7, "{} of 50: {claimed:?}", claimed.len());
    eprintln!("{} of 50 clean sessions raised a claim", claimed.len());
}

/// Set-ups loaded by the `counted-rtest` plugin: the R-test's own, counted.
static COUNTED_LOADS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

fn rtest() -> &'static mtcal_instrument::InstrumentPlugin {
    mtcal_plugins::find("rtest").expect("the R-test plugin is linked")
}

fn counted_load(
    table: &toml::Table,
    ctx: &mtcal_instrument::SetupContext<'_>,
) -> Result<Box<dyn mtcal_instrument::Setup>, mtcal_instrument::SetupError> {
    COUNTED_LOADS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    (rtest().load_setup)(table, ctx)
}

fn counted_fixture(
    machine: &mtcal_kinematics::Machine,
    seed: u64,
) -> Option<mtcal_instrument::Fixture> {
    (rtest().fixture)(machine, seed)
}

fn counted_path(
    spec: &mtcal_instrument::PathSpec<'_>,
) -> Result<Vec<Vec<f64>>, mtcal_instrument::SetupError> {
    (rtest().path)(spec)
}

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "counted-rtest",
        about: "the R-test, its set-ups counted as they are loaded (a test's)",
        load_setup: counted_load,
        fixture: counted_fixture,
        path: counted_path,
        path_labels: None,
        evaluate: None,
        polar_view: None,
        diagnose: None,
        planning: None,
    }
}

/// `identify --search` on the bundled warm five-axis session (R-tests on two set-ups, ball
/// bars) loads each set-up once however many candidates the search refits, and reads no file
/// after the session is loaded: with the session folder deleted once it is loaded, the search
/// and the report run and give the same result as with it there. Before the study was built
/// once, every refit loaded every set-up again (hundreds of loads) and the report read the
/// whole session a second time.
#[test]
fn a_search_loads_each_set_up_once_and_reads_nothing_again() {
    use mtcal_identify::pipeline::{PipelineOptions, Prepared};
    let tmp = tempfile::tempdir().unwrap();
    let session = mtcal_testkit::sessions::copied(
        &mtcal_testkit::repo().join("examples/five-axis-warm/session"),
        &tmp.path().join("session"),
    );
    let manifest = session.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let rtest_setups = ["ball-low", "ball-high"];
    assert!(
        rtest_setups
            .iter()
            .all(|s| text.contains(&format!("[setup.{s}]")))
    );
    std::fs::write(
        &manifest,
        text.replace("instrument = \"rtest\"", "instrument = \"counted-rtest\""),
    )
    .unwrap();
    let options = || PipelineOptions {
        search: true,
        ..PipelineOptions::default()
    };
    let run = |delete: bool| {
        COUNTED_LOADS.store(0, std::sync::atomic::Ordering::SeqCst);
        let prepared = Prepared::load(&session, options()).unwrap();
        let loaded = COUNTED_LOADS.load(std::sync::atomic::Ordering::SeqCst);
        let kept = tmp.path().join("kept");
        if delete {
            std::fs::rename(&session, &kept).unwrap();
        }
        let outcome = prepared.run(&mut Silent).unwrap();
        let page = mtcal_report::render(&outcome.report().unwrap()).unwrap();
        if delete {
            std::fs::rename(&kept, &session).unwrap();
        }
        let searched = outcome.search.as_ref().map_or(0, |s| {
            s.findings.report.steps.iter().map(Vec::len).sum::<usize>()
        });
        let loads = COUNTED_LOADS.load(std::sync::atomic::Ordering::SeqCst);
        (loaded, loads, searched, outcome.to_json(), page)
    };
    let (loaded, loads, searched, json, page) = run(false);
    assert_eq!(loaded, rtest_setups.len(), "set-ups loaded by Study::load");
    assert!(searched > 10, "the search refitted {searched} candidates");
    assert_eq!(
        loads,
        rtest_setups.len(),
        "set-ups loaded over a search of {searched} candidates"
    );
    let (_, _, _, json_deleted, page_deleted) = run(true);
    assert_eq!(json, json_deleted);
    assert_eq!(page, page_deleted);
}

/// A stub effect family registered by this test alone (one registration, nothing else
/// changed): an axis' position stepping by a fixed amount halfway through the session, as
/// when a fixture slips. No built-in family has this shape.
#[derive(Debug)]
struct Step {
    info: mtcal_effects::EffectInfo,
    params: Vec<mtcal_effects::ParamDef>,
    terms: Vec<mtcal_effects::Term>,
}

impl Step {
    fn on(view: &mtcal_effects::SessionView, a: usize) -> Step {
        let letter = view.axes[a].letter;
        Step {
            info: mtcal_effects::EffectInfo {
                class: "stub-step",
                axis: Some(letter),
                component: None,
                driver: Some("t".into()),
                label: format!("stub-step {letter}"),
            },
            params: vec![mtcal_effects::ParamDef {
                name: "step_um".into(),
                unit: "um".into(),
                per_si: 1e6,
                kind: mtcal_effects::ParamKind::Amplitude,
                initial: 0.0,
                bounds: None,
                scale: 1e-3,
                prior: None,
                nuisance: false,
            }],
            terms: vec![mtcal_effects::Term {
                amplitude: 0,
                target: mtcal_effects::Target::Axis(a),
            }],
        }
    }
}

/// The step's feature: 0 before the middle of the session's time, 1 from it.
struct StepFeatures {
    view: std::sync::Arc<mtcal_effects::SessionView>,
    at_s: f64,
}

impl mtcal_effects::Features for StepFeatures {
    fn eval(&self, r: usize, i: usize, f: &mut [f64], _df: &mut [f64]) {
        let t = self.view.timeline().get(self.view.timeline_index(r, i));
        f[0] = if t >= self.at_s { 1.0 } else { 0.0 };
    }
}

impl mtcal_effects::Effect for Step {
    fn info(&self) -> &mtcal_effects::EffectInfo {
        &self.info
    }
    fn params(&self) -> &[mtcal_effects::ParamDef] {
        &self.params
    }
    fn terms(&self) -> &[mtcal_effects::Term] {
        &self.terms
    }
    fn prepare(
        &self,
        view: &std::sync::Arc<mtcal_effects::SessionView>,
        _shape: &[f64],
    ) -> Box<dyn mtcal_effects::Features> {
        Box::new(StepFeatures {
            view: std::sync::Arc::clone(view),
            at_s: view.t0() + 0.5 * view.duration(),
        })
    }
    fn describe(&self, values: &[f64], _u95: &[Option<f64>]) -> String {
        format!(
            "a step of {:.2} um halfway through the session",
            values[0] * 1e6
        )
    }
}

fn step_candidates(view: &mtcal_effects::SessionView) -> Vec<mtcal_effects::Candidate> {
    (0..view.axes.len())
        .filter(|&a| !view.axes[a].rotary && view.any_pose_reading())
        .map(|a| mtcal_effects::Candidate::Effect(std::sync::Arc::new(Step::on(view, a))))
        .collect()
}

fn step_plant(
    table: &toml::Table,
    view: &mtcal_effects::SessionView,
) -> Result<mtcal_effects::Planted, mtcal_effects::PlantError> {
    let letter = table
        .get("axis")
        .and_then(|v| v.as_str())
        .and_then(|s| s.chars().next())
        .ok_or_else(|| mtcal_effects::PlantError::at("axis", "give `axis`"))?;
    let a = view
        .axis_index(letter)
        .ok_or_else(|| mtcal_effects::PlantError::at("axis", "no such axis"))?;
    let step_um = table
        .get("step_um")
        .and_then(|v| v.as_float())
        .ok_or_else(|| mtcal_effects::PlantError::at("step_um", "give `step_um`"))?;
    Ok((
        std::sync::Arc::new(Step::on(view, a)),
        vec![Some(step_um * 1e-6)],
    ))
}

inventory::submit! {
    mtcal_effects::EffectFamily {
        name: "stub-step",
        about: "an axis stepping halfway through the session (a test's stub family)",
        candidates: step_candidates,
        plant: Some(step_plant),
        separated_by: Some("a test's stub: nothing to measure"),
        told_from: &[],
    }
}

/// The stub family above, planted through the simulator's `[[effect]]` table (which finds it
/// by name as it finds every family) on the R-test and ball-bar session of the planted tests:
/// the search proposes it, names it with its planted value (3.04 ± 0.0x µm for 3) and claims
/// nothing else, and says what its registration says separates it. Nothing outside this file
/// knows of it.
#[test]
fn a_new_effect_family_is_one_registration() {
    use common::planted::{Variant, searched};
    let result = searched(
        "[[effect]]\neffect = \"stub-step\"\naxis = \"X\"\nstep_um = 3.0\n",
        3,
        Variant::default(),
    );
    let found = &result.findings;
    let summary = found.summary();
    let d = found
        .discoveries
        .iter()
        .find(|d| d.effect == "stub-step" && d.axis.as_deref() == Some("X"))
        .unwrap_or_else(|| panic!("the stub family's step not named\n{summary}"));
    let q = &d.parameters[0];
    let u95 = q.u95.expect("determined");
    assert!((q.value - 3.0).abs() <= u95, "{q:?}\n{summary}");
    assert_eq!(found.discoveries.len(), 1, "{summary}");
    // Its registration's words reach the discovery's sentence.
    assert!(
        summary.contains("a test's stub: nothing to measure"),
        "{summary}"
    );
}
