//! mtcal's rule on any valid input: a result or a clean error, never a panic, a NaN or an
//! infinity. These tests run what `cargo xtask identify` runs (identify, the information
//! account, `--what-if`, `--search`) on sessions the shipped examples do not cover:
//! - a five-axis session with the default full ISO 230-1 error model and no `[identify]
//!   parameters`, where most parameters are unidentifiable (it used to panic in
//!   `information::updated_variances`);
//! - random shipped machines × random plans × random error models × random set-up offsets.

use crate::common;

use common::finite::non_finite;
use mtcal_identify::information::{account, what_if};
use mtcal_identify::report::IdentifyJson;
use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::{IdentifyError, Study, identify_with_solution};
use mtcal_simulate::simulate;
use mtcal_solve::Silent;
use mtcal_testkit::{TRUNNION, five_axis_truth_file, machine_file, repo};
use std::path::{Path, PathBuf};

/// What `cargo xtask identify SESSION --what-if EXTRA --search` computes, each number checked
/// to be finite. Returns the first clean error; panics (the test fails) on a non-finite number.
fn run_like_the_command_line(session: &Path, extra: Option<&Path>) -> Result<(), IdentifyError> {
    // As the command line: without `[identify] parameters`, the model the runs determine.
    let mtcal_identify::pipeline::Identified {
        study,
        solution,
        identification: id,
        base,
    } = mtcal_identify::pipeline::identify(
        Study::load(session)?,
        &Default::default(),
        &mut Silent,
    )?;
    let id = id.with_prediction_bands(&study, &solution);
    let acc = account(&study, &solution)?;
    for p in &acc.parameters {
        assert!(
            p.u95.is_finite() && p.u95_account.is_finite() && p.u95_account >= 0.0,
            "{}: ±{} (account ±{})",
            p.name,
            p.u95,
            p.u95_account
        );
        for r in &p.repeat {
            // Adding information never widens an interval (rounding aside).
            assert!(
                r.u95_after.is_finite()
                    && r.u95_after >= 0.0
                    && r.u95_after <= p.u95_account * (1.0 + 1e-9),
                "{}: repeating {} gives ±{} from ±{}",
                p.name,
                r.run,
                r.u95_after,
                p.u95_account
            );
        }
    }
    let bad = non_finite(&IdentifyJson::of(&id).information(Some(&acc)));
    assert!(bad.is_empty(), "non-finite numbers in the report: {bad:?}");
    if let Some(extra) = extra {
        let extra = Study::load(extra)?;
        let after = what_if(&study, &solution, &extra)?;
        for (name, u95) in &after {
            let now = id
                .parameters
                .iter()
                .find(|p| &p.name == name)
                .map(|p| p.u95);
            let account_now = acc
                .parameters
                .iter()
                .find(|p| &p.name == name)
                .map(|p| p.u95_account);
            assert!(
                u95.is_finite() && *u95 >= 0.0,
                "{name}: what-if ±{u95} (now ±{now:?})"
            );
            if let Some(before) = account_now {
                assert!(
                    *u95 <= before * (1.0 + 1e-9),
                    "{name}: more data widened ±{before} to ±{u95}"
                );
            }
        }
    }
    let mut result = search(study, &SearchOptions::default())?;
    if let Some(base) = &base {
        result = result.with_base(base)?;
    }
    let after = account(&result.study, &result.solution)?;
    let bad = non_finite(
        &IdentifyJson::of(&result.identification)
            .search(Some(&result.findings))
            .information(Some(&after)),
    );
    assert!(
        bad.is_empty(),
        "non-finite numbers after the search: {bad:?}"
    );
    let bad = non_finite(&IdentifyJson::of(&result.initial));
    assert!(
        bad.is_empty(),
        "non-finite numbers before the search: {bad:?}"
    );
    Ok(())
}

/// The set-ups of the five-axis example's plan, the R-test balls off their nominal places.
const FIVE_AXIS_SETUPS: &str = r#"
[setup.ball-low]
ball = [100.0, 0.0, 200.0]
[setup.ball-high]
ball = [100.0, 0.0, 300.0]
[setup.bar]
pivot = [0.0, 0.0, 250.0]
length = 100.0
[nuisance.ball-low]
ball_x = 4.0
ball_z = -3.0
tool_length = 2.0
[nuisance.ball-high]
ball_y = -5.0
"#;

/// The runs of the five-axis example's plan (R-test about A and C, ball-bar circles in three
/// planes), every one fitted: name, instrument, set-up, path.
const FIVE_AXIS_RUNS: [(&str, &str, &str, &str); 7] = [
    (
        "rtest-xyc-a0",
        "rtest",
        "ball-low",
        "{ kind = \"xyc\", samples = 37 }",
    ),
    (
        "rtest-xyc-a+30",
        "rtest",
        "ball-low",
        "{ kind = \"xyc\", samples = 37, hold = { A = 30.0 } }",
    ),
    (
        "rtest-yza",
        "rtest",
        "ball-low",
        "{ kind = \"yza\", samples = 31 }",
    ),
    (
        "rtest-xyc-high",
        "rtest",
        "ball-high",
        "{ kind = \"xyc\", samples = 37 }",
    ),
    (
        "ballbar-xy",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"XY\", samples = 91 }",
    ),
    (
        "ballbar-yz",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"YZ\", samples = 61, start_deg = -90.0, sweep_deg = 180.0 }",
    ),
    (
        "ballbar-zx",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"ZX\", samples = 61, start_deg = 0.0, sweep_deg = 180.0 }",
    ),
];

/// [`FIVE_AXIS_SETUPS`] and [`FIVE_AXIS_RUNS`] as plan text.
fn five_axis_plan() -> String {
    let mut plan = FIVE_AXIS_SETUPS.to_string();
    for (name, instrument, setup, path) in FIVE_AXIS_RUNS {
        plan += &mtcal_testkit::plans::Run::new(name, instrument, setup).path(path);
    }
    plan
}

/// Runs of another session on the same machine: the R-test ball moved, an XYC at A = −30°.
const EXTRA_RUNS: &str = r#"
[setup.moved]
ball = [150.0, 50.0, 250.0]
[[run]]
name = "rtest-xyc-moved"
instrument = "rtest"
setup = "moved"
path = { kind = "xyc", samples = 37 }
[[run]]
name = "rtest-xyc-a-30"
instrument = "rtest"
setup = "moved"
path = { kind = "xyc", samples = 37, hold = { A = -30.0 } }
"#;

/// The shipped trunnion copied into `dir` without its `.errors.toml`: the default full ISO
/// 230-1 model applies (41 errors, cubic and two-harmonic component errors), far more than
/// R-test and ball-bar runs can separate.
fn full_model_machine(dir: &Path) -> PathBuf {
    let urdf = dir.join("trunnion.urdf");
    std::fs::copy(machine_file(TRUNNION), &urdf).unwrap();
    assert!(!dir.join("trunnion.errors.toml").exists());
    urdf
}

fn simulate_session(dir: &Path, name: &str, seed: u64, runs: &str) -> PathBuf {
    let plan = dir.join(format!("{name}.toml"));
    std::fs::write(
        &plan,
        format!(
            "machine = \"trunnion.urdf\"\ntruth = {:?}\nseed = {seed}\ninterval_s = 0.25\n{runs}",
            five_axis_truth_file()
        ),
    )
    .unwrap();
    let out = dir.join(name);
    simulate(&plan, &out).unwrap();
    out
}

/// Regression: the full default model on the five-axis trunnion, no `[identify] parameters`.
/// Most of its parameters are unidentifiable, the account's covariance is a pseudo-inverse on
/// the identified subspace, and the Woodbury update of `information::updated_variances` used
/// to meet an indefinite `𝟙 + Uᵀ C U` and panic in its `expect`.
#[test]
fn the_full_default_model_on_a_five_axis_session_gives_a_result() {
    let dir = tempfile::tempdir().unwrap();
    full_model_machine(dir.path());
    let session = simulate_session(dir.path(), "session", 3, &five_axis_plan());
    let extra = simulate_session(dir.path(), "extra", 4, EXTRA_RUNS);
    let study = Study::load(&session).unwrap();
    assert!(
        study.layout().n_machine() > 100,
        "the default model should be the full one, not {} coefficients",
        study.layout().n_machine()
    );
    // The account's own covariance must be the fit's: it used to invert the rounding noise of
    // the information matrix along the weakest identified directions (singular values down to
    // 10⁻⁹ of the largest, squared below the rounding of `JᵀJ`), and its intervals were off by
    // factors of 1.5 to 4 from the fit's.
    let (id, solution) = identify_with_solution(&study, &Default::default(), &mut Silent).unwrap();
    let acc = account(&study, &solution).unwrap();
    assert_eq!(
        acc.parameters.len(),
        id.parameters.iter().filter(|p| p.kind == "machine").count(),
        "the account covers every identified machine parameter"
    );
    for p in &acc.parameters {
        assert!(
            (p.u95_account - p.u95).abs() <= 1e-2 * p.u95,
            "{}: the account's ±{} vs the fit's ±{}",
            p.name,
            p.u95_account,
            p.u95
        );
        let total: f64 = p.runs.iter().map(|s| s.share).sum();
        assert!(
            (total - 1.0).abs() < 1e-4,
            "{}: shares sum to {total}",
            p.name
        );
    }
    run_like_the_command_line(&session, Some(&extra)).unwrap();
}

/// Regression: the first random case that panicked in `updated_variances` (`𝟙 + Uᵀ C U is
/// positive definite …`): the five-axis MCU 6300 with the default full model and one laser
/// linear run, so nearly every parameter is unidentifiable.
#[test]
fn a_single_laser_run_against_the_full_model_gives_a_result() {
    let case = Case {
        machine: "mu6300-caxfyz.urdf".into(),
        errors: None,
        truth: "schema = \"mtcal.params/1\"\n[values]\nEA0Z = -6.9\nEB0A = 20.9\nEC0Y = -9.5\n\
                EX0C = -19.5\nEY0A = -1.3\nEY0C = -21.7\nEZ0A = 18.1\n"
            .into(),
        plan: "[setup.s0]\nmode = \"linear\"\ndirection = \"X\"\noffset_free = true\n\
               [nuisance.s0]\nzero = -3.9\ntilt_1 = -39.3\ntilt_2 = -23.2\n\
               [[run]]\nname = \"run0-laser\"\ninstrument = \"laser\"\nsetup = \"s0\"\n\
               use = \"fit\"\npath = { axis = \"X\", points = 6, cycles = 2 }\n"
            .into(),
        seed: 10487259860704964141,
    };
    assert_eq!(run_case(&case), Outcome::Identified);
}

// ---------------------------------------------------------------------------------------------
// Property test: random shipped machine × random plan × random error model × random set-up
// offsets × `[identify] parameters` present or absent.

use proptest::arbitrary::any;
use proptest::test_runner::{Config as ProptestConfig, TestCaseError, TestRunner};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;

/// One random session: the machine file, the error model written beside its copy (`None`: no
/// `.errors.toml`, the default full model), the truth, and the plan's body (its `[identify]`,
/// set-ups, offsets and runs).
#[derive(Debug, Clone)]
struct Case {
    machine: String,
    errors: Option<String>,
    truth: String,
    plan: String,
    seed: u64,
}

/// What became of a case.
#[derive(Debug, PartialEq)]
enum Outcome {
    /// The simulator refused the plan (an axis limit, a path the machine cannot follow).
    Refused(String),
    /// Everything ran and returned a result.
    Identified,
    /// A clean error from loading, identifying, the account or the search.
    CleanError(String),
}

fn shipped_machines() -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(repo().join("machines"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "urdf"))
        .collect();
    out.sort();
    assert!(out.len() >= 5, "shipped machines: {out:?}");
    out
}

fn pick<'a, T>(rng: &mut impl Rng, items: &'a [T]) -> &'a T {
    &items[rng.random_range(0..items.len())]
}

/// A random subset of `items` (each kept with probability `p`).
fn subset(rng: &mut impl Rng, items: &[String], p: f64) -> Vec<String> {
    items
        .iter()
        .filter(|_| rng.random_bool(p))
        .cloned()
        .collect()
}

fn toml_list(names: &[String]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("{n:?}")).collect();
    format!("[{}]", quoted.join(", "))
}

/// ±`max`, rounded to 0.1 (the plan is printed when a case fails).
fn offset(rng: &mut impl Rng, max: f64) -> f64 {
    (rng.random_range(-max..=max) * 10.0).round() / 10.0
}

/// A random case on `machine` from the generator `seed`.
fn random_case(machine: &Path, seed: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let loaded = mtcal_machine::load_machine(&machine.to_string_lossy(), Default::default())
        .expect("a shipped machine loads");
    let letters: Vec<char> = loaded.machine.letters().chars().collect();
    let has = |c: char| letters.contains(&c);
    let rotary: Vec<char> = letters
        .iter()
        .copied()
        .filter(|c| "ABC".contains(*c))
        .collect();
    let linear: Vec<char> = letters
        .iter()
        .copied()
        .filter(|c| "XYZ".contains(*c))
        .collect();

    // The error model: components, locations, exclusions, bases, set-up parameters.
    let components: Vec<String> = letters
        .iter()
        .flat_map(|a| ['X', 'Y', 'Z', 'A', 'B', 'C'].map(|d| format!("E{d}{a}")))
        .collect();
    let locations: Vec<String> = mtcal_kinematics::model::iso_location_names(&loaded.machine)
        .iter()
        .map(|n| n.to_string())
        .collect();
    let (errors, mut model_names) = if rng.random_bool(0.2) {
        (None, [components.clone(), locations.clone()].concat())
    } else {
        let mut t = String::from("schema = \"mtcal.errors/1\"\n");
        let (comp_value, mut comps) = match rng.random_range(0..4) {
            0 => ("\"all\"".to_string(), components.clone()),
            1 => ("\"none\"".to_string(), Vec::new()),
            _ => {
                let s = subset(&mut rng, &components, 0.25);
                (toml_list(&s), s)
            }
        };
        let (loc_value, mut locs) = match rng.random_range(0..4) {
            0 => ("\"iso\"".to_string(), locations.clone()),
            1 => ("\"none\"".to_string(), Vec::new()),
            _ => {
                let s = subset(&mut rng, &locations, 0.5);
                (toml_list(&s), s)
            }
        };
        writeln!(t, "components = {comp_value}\nlocations = {loc_value}").unwrap();
        // Set-up parameters the instruments' own offsets compete with: rank-deficient on
        // purpose.
        let setup = subset(
            &mut rng,
            &["TOOL_DZ".into(), "WP_DX".into(), "WP_DC".into()],
            0.2,
        );
        if !setup.is_empty() {
            writeln!(t, "setup = {}", toml_list(&setup)).unwrap();
        }
        let mut selected = [comps.clone(), locs.clone()].concat();
        if rng.random_bool(0.3) && !selected.is_empty() {
            let exclude = subset(&mut rng, &selected, 0.15);
            if !exclude.is_empty() {
                writeln!(t, "exclude = {}", toml_list(&exclude)).unwrap();
                comps.retain(|n| !exclude.contains(n));
                locs.retain(|n| !exclude.contains(n));
                selected.retain(|n| !exclude.contains(n));
            }
        }
        // Straightness needs degree 2 at least (its constant and slope are left out).
        writeln!(
            t,
            "[basis.linear]\nkind = \"legendre\"\ndegree = {}",
            rng.random_range(2..=7)
        )
        .unwrap();
        if rng.random_bool(0.7) {
            writeln!(
                t,
                "[basis.rotary]\nkind = \"fourier\"\nharmonics = {}",
                rng.random_range(1..=4)
            )
            .unwrap();
        } else {
            writeln!(
                t,
                "[basis.rotary]\nkind = \"legendre\"\ndegree = {}",
                rng.random_range(1..=5)
            )
            .unwrap();
        }
        (Some(t), selected)
    };
    model_names.sort();

    // The truth: some location errors (scalars) of the model, µm / µrad.
    let mut truth = String::from("schema = \"mtcal.params/1\"\n[values]\n");
    for name in model_names.iter().filter(|n| locations.contains(n)) {
        if rng.random_bool(0.5) {
            writeln!(truth, "{name} = {}", offset(&mut rng, 30.0)).unwrap();
        }
    }

    let mut plan = String::new();
    if !model_names.is_empty() && rng.random_bool(0.5) {
        let mut chosen = subset(&mut rng, &model_names, 0.3);
        if chosen.is_empty() {
            chosen.push(pick(&mut rng, &model_names).clone());
        }
        writeln!(plan, "[identify]\nparameters = {}", toml_list(&chosen)).unwrap();
    }

    // The runs: R-test paths the machine's axes allow, ball-bar circles, laser linear runs.
    let mut kinds: Vec<&str> = vec!["ballbar", "laser"];
    if (1..=2).contains(&rotary.len()) && linear.len() == 3 {
        kinds.push("rtest");
        kinds.push("rtest");
    }
    let n_runs = rng.random_range(1..=5);
    let mut last_rtest_setup: Option<String> = None;
    for i in 0..n_runs {
        let kind = *pick(&mut rng, &kinds);
        let name = format!("run{i}-{kind}");
        let mut setup = format!("s{i}");
        let mut head = String::new();
        let path = match kind {
            "rtest" => {
                let mut presets = Vec::new();
                if has('C') {
                    presets.push("xyc");
                }
                if has('A') {
                    presets.push("yza");
                }
                if has('B') {
                    presets.push("zxb");
                }
                if has('A') && has('C') {
                    presets.push("xyzac");
                }
                let preset = *pick(&mut rng, &presets);
                let samples = rng.random_range(9..=37);
                let tilt = rotary.iter().copied().find(|&c| c != 'C');
                // The presets sweep a tilting axis over most of its limits, where the ball
                // often leaves the linear axes' reach: half the time a narrower sweep.
                let hold = match (preset, tilt) {
                    ("xyc", Some(t)) if rng.random_bool(0.4) => {
                        format!(
                            ", hold = {{ {t} = {} }}",
                            pick(&mut rng, &[-15.0, 15.0, 30.0])
                        )
                    }
                    ("yza" | "zxb", Some(t)) if rng.random_bool(0.5) => {
                        format!(", sweep = {{ {t} = [-15.0, 15.0] }}")
                    }
                    _ => String::new(),
                };
                match &last_rtest_setup {
                    Some(s) if rng.random_bool(0.4) => setup = s.clone(),
                    _ => {
                        writeln!(
                            head,
                            "[setup.{setup}]\nball = [{}, {}, {}]\nball_free = {}\ntool_length_free = {}",
                            pick(&mut rng, &[0.0, 50.0, 100.0]),
                            pick(&mut rng, &[-50.0, 0.0, 50.0]),
                            pick(&mut rng, &[200.0, 250.0, 300.0]),
                            rng.random_bool(0.7),
                            rng.random_bool(0.5),
                        )
                        .unwrap();
                        writeln!(
                            head,
                            "[nuisance.{setup}]\nball_x = {}\nball_y = {}\nball_z = {}\ntool_length = {}",
                            offset(&mut rng, 10.0),
                            offset(&mut rng, 10.0),
                            offset(&mut rng, 10.0),
                            offset(&mut rng, 10.0),
                        )
                        .unwrap();
                        last_rtest_setup = Some(setup.clone());
                    }
                }
                format!("{{ kind = \"{preset}\", samples = {samples}{hold} }}")
            }
            "ballbar" => {
                let plane = *pick(&mut rng, &["XY", "YZ", "ZX"]);
                let arc = if plane == "XY" {
                    String::new()
                } else {
                    format!(
                        ", start_deg = {}, sweep_deg = 180.0",
                        pick(&mut rng, &[-90.0, 0.0])
                    )
                };
                let length = *pick(&mut rng, &[50.0, 100.0]);
                let length_free = rng.random_bool(0.3);
                writeln!(
                    head,
                    "[setup.{setup}]\npivot = [{}, {}, {}]\nlength = {length}\npivot_free = {}\n\
                     tool_length_free = {}\nlength_free = {length_free}{}",
                    pick(&mut rng, &[-50.0, 0.0, 50.0]),
                    pick(&mut rng, &[-50.0, 0.0, 50.0]),
                    pick(&mut rng, &[250.0, 300.0]),
                    rng.random_bool(0.7),
                    rng.random_bool(0.5),
                    if length_free && rng.random_bool(0.5) {
                        "\nlength_u_um = 2.0"
                    } else {
                        ""
                    },
                )
                .unwrap();
                writeln!(
                    head,
                    "[nuisance.{setup}]\npivot_x = {}\npivot_y = {}\npivot_z = {}\ntool_length = {}",
                    offset(&mut rng, 10.0),
                    offset(&mut rng, 10.0),
                    offset(&mut rng, 10.0),
                    offset(&mut rng, 10.0),
                )
                .unwrap();
                let samples = rng.random_range(13..=91);
                format!(
                    "{{ kind = \"circle\", plane = \"{plane}\", direction = \"{}\", samples = {samples}{arc} }}",
                    pick(&mut rng, &["ccw", "cw"])
                )
            }
            _ => {
                let axis = *pick(&mut rng, &linear);
                writeln!(
                    head,
                    "[setup.{setup}]\nmode = \"linear\"\ndirection = \"{axis}\"\noffset_free = {}",
                    rng.random_bool(0.8)
                )
                .unwrap();
                writeln!(
                    head,
                    "[nuisance.{setup}]\nzero = {}\ntilt_1 = {}\ntilt_2 = {}",
                    offset(&mut rng, 5.0),
                    offset(&mut rng, 50.0),
                    offset(&mut rng, 50.0),
                )
                .unwrap();
                format!(
                    "{{ axis = \"{axis}\", points = {}, cycles = {} }}",
                    rng.random_range(3..=11),
                    rng.random_range(1..=2)
                )
            }
        };
        let use_ = if i > 0 && rng.random_bool(0.2) {
            "validate"
        } else {
            "fit"
        };
        let noise = if rng.random_bool(0.15) {
            "noise = 0.0\n"
        } else {
            ""
        };
        write!(
            plan,
            "{head}[[run]]\nname = \"{name}\"\ninstrument = \"{kind}\"\nsetup = \"{setup}\"\n\
             use = \"{use_}\"\n{noise}path = {path}\n"
        )
        .unwrap();
    }
    Case {
        machine: machine.file_name().unwrap().to_string_lossy().into_owned(),
        errors,
        truth,
        plan,
        seed,
    }
}

/// Simulates `case` and runs it like the command line (the session itself as `--what-if`).
fn run_case(case: &Case) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(
        repo().join("machines").join(&case.machine),
        d.join("m.urdf"),
    )
    .unwrap();
    if let Some(errors) = &case.errors {
        std::fs::write(d.join("m.errors.toml"), errors).unwrap();
    }
    std::fs::write(d.join("truth.params.toml"), &case.truth).unwrap();
    let plan = d.join("plan.toml");
    std::fs::write(
        &plan,
        format!(
            "machine = \"m.urdf\"\ntruth = \"truth.params.toml\"\nseed = {}\ninterval_s = 0.5\n{}",
            case.seed & (i64::MAX as u64),
            case.plan
        ),
    )
    .unwrap();
    let session = d.join("session");
    if let Err(e) = simulate(&plan, &session) {
        return Outcome::Refused(e.to_string());
    }
    match run_like_the_command_line(&session, Some(&session)) {
        Ok(()) => Outcome::Identified,
        Err(e) => {
            let message = e.to_string();
            assert!(
                !message.is_empty() && !message.contains("NaN"),
                "an error that says nothing: {message:?}"
            );
            Outcome::CleanError(message)
        }
    }
}

/// Seeds a case tries until the simulator accepts its plan.
const ATTEMPTS: u64 = 4;

/// Random cases: never a panic or a non-finite number; most cases must really run.
#[test]
fn random_sessions_give_a_result_or_a_clean_error() {
    let machines = shipped_machines();
    let cases = std::env::var("NO_PANIC_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(12);
    let mut runner = TestRunner::new(ProptestConfig {
        cases,
        // A failing case prints its seed and machine; shrinking a seed means nothing, and each
        // case costs a fit and a search.
        max_shrink_iters: 0,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let outcomes = std::cell::RefCell::new(Vec::new());
    let result = runner.run(&(0..machines.len(), any::<u64>()), |(m, seed)| {
        // A plan the simulator refuses is skipped and counted; the case then tries the
        // next seed, a few times.
        for attempt in 0..ATTEMPTS {
            let seed = seed.wrapping_add(attempt);
            let case = random_case(&machines[m], seed);
            let outcome = std::panic::catch_unwind(|| run_case(&case)).map_err(|e| {
                let why = e
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                TestCaseError::fail(format!("{why}\ncase: {case:#?}"))
            })?;
            let refused = matches!(outcome, Outcome::Refused(_));
            outcomes
                .borrow_mut()
                .push((case.machine.clone(), seed, outcome));
            if !refused {
                break;
            }
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let outcomes = outcomes.into_inner();
    for o in &outcomes {
        eprintln!("{o:?}");
    }
    let ran = outcomes
        .iter()
        .filter(|o| !matches!(o.2, Outcome::Refused(_)))
        .count();
    let identified = outcomes
        .iter()
        .filter(|o| o.2 == Outcome::Identified)
        .count();
    eprintln!(
        "{} plans: {ran} simulated ({identified} identified, {} clean errors), {} refused",
        outcomes.len(),
        ran - identified,
        outcomes.len() - ran
    );
    // Most cases must really run (each case retries a refused plan), and most of those must
    // reach a result, or the test would only exercise the error paths.
    assert!(
        3 * ran >= 2 * cases as usize,
        "only {ran} of {cases} cases could be simulated"
    );
    assert!(
        2 * identified >= ran,
        "only {identified} of {ran} simulated cases were identified"
    );
}

/// Hard cases by hand, each a corner the random plans reach only by chance.
#[test]
fn hand_picked_hard_cases_give_a_result_or_a_clean_error() {
    let rtest = |setup: &str, kind: &str, noise: &str| {
        format!(
            "[[run]]\nname = \"r-{kind}-{setup}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\n\
             {noise}path = {{ kind = \"{kind}\", samples = 25 }}\n"
        )
    };
    let ball =
        "[setup.b]\nball = [100.0, 0.0, 250.0]\n[nuisance.b]\nball_x = 3.0\ntool_length = -2.0\n";
    let circle = "[setup.bar]\npivot = [0.0, 0.0, 250.0]\nlength = 100.0\n[nuisance.bar]\npivot_z = 4.0\n\
                  [[run]]\nname = \"circle\"\ninstrument = \"ballbar\"\nsetup = \"bar\"\n\
                  path = { kind = \"circle\", plane = \"XY\", samples = 37 }\n";
    let laser = "[[run]]\nname = \"laser-y\"\ninstrument = \"laser\"\n\
                 path = { axis = \"Y\", points = 5, cycles = 1 }\n\
                 [run.setup]\nmode = \"linear\"\ndirection = \"Y\"\n";
    let errors = |body: &str| Some(format!("schema = \"mtcal.errors/1\"\n{body}"));
    let truth = "schema = \"mtcal.params/1\"\n[values]\n".to_string();
    let cases = [
        // The empty model: only the set-ups' own offsets are fitted.
        (
            "mcu630-cafyxz.urdf",
            errors("components = \"none\"\nlocations = \"none\"\n"),
            format!("{ball}{}", rtest("b", "xyc", "")),
        ),
        // Noise-free readings on the full default model: χ² = 0.
        (
            "mcu630-cafyxz.urdf",
            None,
            format!(
                "{ball}{}{}{circle}",
                rtest("b", "xyc", "noise = 0.0\n"),
                rtest("b", "yza", "noise = 0.0\n")
            ),
        ),
        // High-order bases seen by one ball-bar circle: hundreds of null directions.
        (
            "mixed-c-table-b-head.urdf",
            errors(
                "[basis.linear]\nkind = \"legendre\"\ndegree = 7\n\
                 [basis.rotary]\nkind = \"fourier\"\nharmonics = 4\n",
            ),
            circle.to_string(),
        ),
        // Set-up parameters of the model that duplicate the instruments' offsets exactly.
        (
            "mcv1000-5ax220-bc.urdf",
            errors("components = \"none\"\nsetup = [\"TOOL_DZ\", \"WP_DX\", \"WP_DC\"]\n"),
            format!("{ball}{}{}", rtest("b", "xyc", ""), rtest("b", "zxb", "")),
        ),
        // One estimated parameter no run sees, a validation run besides.
        (
            "headhead-xyzca.urdf",
            None,
            format!(
                "[identify]\nparameters = [\"EZZ\"]\n{ball}{}[[run]]\nname = \"check\"\n\
                 instrument = \"rtest\"\nsetup = \"b\"\nuse = \"validate\"\n\
                 path = {{ kind = \"xyzac\", samples = 13 }}\n",
                rtest("b", "xyc", "")
            ),
        ),
        // Nothing to estimate at all: the empty model and a calibrated R-test set-up.
        (
            "mu6300-caxfyz.urdf",
            errors("components = \"none\"\nlocations = \"none\"\n"),
            format!(
                "[setup.fixed]\nball = [50.0, 0.0, 250.0]\nball_free = false\n\
                 tool_length_free = false\n{}",
                rtest("fixed", "xyc", "")
            ),
        ),
        // A three-axis machine, its full model, one laser run.
        ("mcv754-zfyx.urdf", None, laser.to_string()),
    ];
    for (i, (machine, errors, plan)) in cases.into_iter().enumerate() {
        let case = Case {
            machine: machine.into(),
            errors,
            truth: truth.clone(),
            plan,
            seed: i as u64,
        };
        let outcome = run_case(&case);
        assert!(
            !matches!(outcome, Outcome::Refused(_)),
            "a hand-picked case must simulate: {outcome:?}\n{case:#?}"
        );
        eprintln!("{machine}: {outcome:?}");
    }
}

/// The finiteness walk finds what `serde_json` would hide as `null`.
#[test]
fn the_finiteness_walk_finds_nan_and_infinity() {
    #[derive(serde::Serialize)]
    struct Inner {
        u95: Option<f64>,
        pairs: Vec<(String, f64)>,
    }
    let value = Inner {
        u95: Some(f64::NAN),
        pairs: vec![("a".into(), 1.0), ("b".into(), f64::NEG_INFINITY)],
    };
    assert_eq!(
        non_finite(&value),
        vec![".u95 = NaN", ".pairs[1][1] = -inf"]
    );
    let fine = Inner {
        u95: None,
        pairs: vec![("a".into(), 0.0)],
    };
    assert!(non_finite(&fine).is_empty());
}
