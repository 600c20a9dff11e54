//! One trial of the coverage tests (`coverage.rs`, `coverage_ballbar.rs`): a random truth of
//! the estimated parameters and the plan that simulates it on the trunnion.

#![allow(dead_code)]

use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};

/// Draws a truth for `names` from `dist` (µm, µrad) and writes it into `dir` with a plan of
/// `runs` on the trunnion, noise seed `seed`, that estimates `names`; returns the truth and the
/// plan's path.
pub fn random_truth_plan<'a>(
    dir: &Path,
    names: &[&'a str],
    rng: &mut ChaCha8Rng,
    dist: &Normal<f64>,
    seed: u64,
    runs: &str,
) -> (Vec<(&'a str, f64)>, PathBuf) {
    let truth: Vec<(&str, f64)> = names.iter().map(|n| (*n, dist.sample(rng))).collect();
    let values: String = truth.iter().map(|(n, v)| format!("{n} = {v}\n")).collect();
    std::fs::write(dir.join("truth.params.toml"), format!("[values]\n{values}")).unwrap();
    let machine = mtcal_testkit::machine_file(mtcal_testkit::TRUNNION);
    let list = mtcal_testkit::params::toml_list(names);
    let plan = format!(
        "machine = {machine:?}\ntruth = \"truth.params.toml\"\nseed = {seed}\n\
         [identify]\nparameters = {list}\n{runs}"
    );
    let path = dir.join("plan.toml");
    std::fs::write(&path, plan).unwrap();
    (truth, path)
}
