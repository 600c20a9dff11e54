//! Planted-effect sessions for the physics search: a five-axis R-test + ball-bar session whose
//! runs interleave three set-ups over about 14 minutes (so drifts, set-ups and temperatures do
//! not all follow one another), with a spindle-speed programme, a bed temperature that swings
//! without a trend and a spindle temperature that rises during one XYC run and falls during
//! another, one repeated reference run at the end, and an XYZAC validation run.
//! The R-test has its ball in the spindle (`mount = "ball-in-spindle"`): the planted effects'
//! concealments were designed with the nest's axes turning with the table.
//! The truth is the example's 11-error set plus the planted effects.

#![allow(dead_code)]

use mtcal_identify::Study;
use mtcal_identify::search::{SearchOptions, SearchResult, search};
use mtcal_simulate::simulate;
use mtcal_testkit::plans::Run;
use mtcal_testkit::{ELEVEN, TRUNNION, five_axis_truth_file, machine_file};
use std::path::{Path, PathBuf};

/// Noise of every reading (µm): R-test and ball-bar.
pub const NOISE_UM: f64 = 0.5;

/// The truth of examples/five-axis (µm, µrad): the planted sessions' machine before the effects.
pub const TRUTH: [(&str, f64); 11] = mtcal_testkit::FIVE_AXIS_TRUTH;

/// The plan's interval, estimated parameters, context and set-ups (`{dt}` the interval, the
/// eleven errors and `{also}` estimated).
pub const SETUPS: &str = r#"
interval_s = {dt}
[identify]
parameters = [{eleven}{also}]
[context]
S = [[0.0, 0.0], [150.0, 4000.0], [500.0, 8000.0], [700.0, 2000.0]]
T_spindle = [[0.0, 20.0], [264.0, 20.0], [336.0, 23.0], [516.0, 23.0], [588.0, 20.0]]
T_bed = [[0.0, 20.5], [150.0, 21.5], [300.0, 20.5], [450.0, 19.5], [600.0, 20.5], [750.0, 21.5], [900.0, 20.5], [1050.0, 19.5], [1200.0, 20.5], [1350.0, 21.5], [1500.0, 20.5]]
[setup.low]
ball = [100.0, 0.0, 200.0]
mount = "ball-in-spindle"
[setup.high]
ball = [100.0, 0.0, 300.0]
mount = "ball-in-spindle"
[setup.bar]
pivot = [0.0, 0.0, 250.0]
length = 100.0
sigma_um = 0.5
[nuisance.low]
ball_x = 4.0
ball_z = -3.0
tool_length = 2.0
"#;

/// The runs in their order: name, instrument, set-up, path (`{nK}`: K samples, more when the
/// session is dense; the tilted XYC runs keep theirs). The last, `xyzac`, validates.
pub const RUNS: [(&str, &str, &str, &str); 10] = [
    (
        "xyc-a0",
        "rtest",
        "low",
        "{ kind = \"xyc\", samples = {n145} }",
    ),
    (
        "bb-ccw",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"XY\", direction = \"ccw\", samples = {n181} }",
    ),
    (
        "xyc-high",
        "rtest",
        "high",
        "{ kind = \"xyc\", samples = {n145} }",
    ),
    (
        "xyc-a+30",
        "rtest",
        "low",
        "{ kind = \"xyc\", samples = 145, hold = { A = 30.0 } }",
    ),
    (
        "bb-cw",
        "ballbar",
        "bar",
        "{ kind = \"circle\", plane = \"XY\", direction = \"cw\", samples = {n181} }",
    ),
    (
        "yza",
        "rtest",
        "low",
        "{ kind = \"yza\", samples = {n121} }",
    ),
    (
        "xyc-a-30",
        "rtest",
        "low",
        "{ kind = \"xyc\", samples = 145, hold = { A = -30.0 } }",
    ),
    (
        "xyc-high-again",
        "rtest",
        "high",
        "{ kind = \"xyc\", samples = {n145} }",
    ),
    (
        "xyc-a0-again",
        "rtest",
        "low",
        "{ kind = \"xyc\", samples = {n145} }",
    ),
    (
        "xyzac",
        "rtest",
        "low",
        "{ kind = \"xyzac\", samples = {n97} }",
    ),
];

/// [`SETUPS`] and [`RUNS`] as plan text for `variant`.
pub fn setups_and_runs(variant: Variant) -> String {
    let mut text = SETUPS.to_string();
    for (name, instrument, setup, path) in RUNS {
        let run = Run::new(name, instrument, setup);
        let run = if name == "xyzac" {
            run.validation()
        } else {
            run
        };
        text += &run.path(path);
    }
    let k = if variant.dense { 2 } else { 1 };
    text = text
        .replace("{eleven}", &mtcal_testkit::params::quoted(&ELEVEN))
        .replace("{dt}", if variant.dense { "0.25" } else { "0.5" })
        .replace("{also}", variant.also);
    for n in [145, 181, 121, 97] {
        text = text.replace(&format!("{{n{n}}}"), &(k * n - (k - 1)).to_string());
    }
    text
}

/// What a case changes in the session besides its `[[effect]]` tables.
#[derive(Debug, Clone, Copy, Default)]
pub struct Variant {
    /// Appended to the truth parameter file (component errors, more values).
    pub truth: &'static str,
    /// Appended to the machine's error model for the truth only (a richer truth: a higher
    /// order than the session's model).
    pub truth_model: &'static str,
    /// Parameters estimated besides the 11-error set (`, "ECC"`).
    pub also: &'static str,
    /// Twice the samples at half the interval (same duration).
    pub dense: bool,
}

/// Simulates the session with `effects` (`[[effect]]` tables), `variant` and noise seed `seed`
/// into `dir/session`.
pub fn session(dir: &Path, effects: &str, seed: u64, variant: Variant) -> PathBuf {
    let machine = machine_file(TRUNNION);
    let truth_file = dir.join("truth.params.toml");
    let truth = std::fs::read_to_string(five_axis_truth_file()).unwrap() + "\n" + variant.truth;
    std::fs::write(&truth_file, truth).unwrap();
    let mut plan = format!("machine = {machine:?}\ntruth = {truth_file:?}\nseed = {seed}\n");
    if !variant.truth_model.is_empty() {
        let model = std::fs::read_to_string(machine_file("mcu630-cafyxz.errors.toml")).unwrap()
            + "\n"
            + variant.truth_model;
        let file = dir.join("truth.errors.toml");
        std::fs::write(&file, model).unwrap();
        plan += &format!("truth_errors = {file:?}\n");
    }
    plan += &setups_and_runs(variant);
    plan += effects;
    let file = dir.join("plan.toml");
    std::fs::write(&file, plan).unwrap();
    let out = dir.join("session");
    simulate(&file, &out).unwrap();
    out
}

/// Simulates and searches.
pub fn searched(effects: &str, seed: u64, variant: Variant) -> SearchResult {
    let dir = tempfile::tempdir().unwrap();
    let study = Study::load(&session(dir.path(), effects, seed, variant)).unwrap();
    search(study, &SearchOptions::default()).unwrap()
}
