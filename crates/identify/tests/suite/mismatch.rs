//! `identify` reports where the identified model and the recordings disagree (FORMATS.md
//! `mismatch`): nothing on white noise, the run, channel and variable of a planted drift.

use mtcal_identify::{Identification, identify_session};
use mtcal_simulate::{Plant, PlantSample, simulate_with};
use mtcal_testkit::params::toml_list;
use mtcal_testkit::plans::rtest_low_high_runs;
use mtcal_testkit::{ELEVEN, TRUNNION, five_axis_truth_file, machine_file};
use std::path::{Path, PathBuf};

/// Source 000's R-test plan on the trunnion, 0.5 µm noise, 11-error set.
fn plan(dir: &Path, seed: u64) -> PathBuf {
    let machine = machine_file(TRUNNION);
    let truth = five_axis_truth_file();
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth:?}\nseed = {seed}\ninterval_s = 1.0\n[identify]\n\
         parameters = {}\n\
         [setup.low]\nball = [100.0, 0.0, 200.0]\nmount = \"ball-in-spindle\"\n\
         [setup.high]\nball = [100.0, 0.0, 300.0]\nmount = \"ball-in-spindle\"\n{}",
        toml_list(&ELEVEN),
        rtest_low_high_runs(181, 151, None)
    );
    let file = dir.join("plan.toml");
    std::fs::write(&file, plan).unwrap();
    file
}

/// A first-order thermal drift of the `dz` reading in one run: `amplitude·(1 − e^(−t'/τ))`
/// with `t'` the time since that run started.
#[derive(Debug)]
struct Drift {
    run: &'static str,
    amplitude_m: f64,
    tau_s: f64,
}

impl Plant for Drift {
    fn apply(&self, s: &PlantSample<'_>, readings: &mut [f64]) {
        if s.run == self.run {
            let t = s.sample as f64;
            readings[2] += self.amplitude_m * (1.0 - (-t / self.tau_s).exp());
        }
    }
}

fn identify_with(plants: &[&dyn Plant], seed: u64) -> Identification {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    simulate_with(&plan(dir.path(), seed), &out, plants).unwrap();
    identify_session(&out).unwrap().1
}

#[test]
fn white_noise_gives_no_mismatch() {
    for seed in [1, 2, 3] {
        let id = identify_with(&[], seed);
        assert!(
            !id.mismatch.detected,
            "seed {seed}: {:#?}",
            id.mismatch_detail
        );
        assert!(id.mismatch.locations.is_empty());
        assert!(
            mtcal_identify::report::IdentifyJson::of(&id)
                .to_json()
                .contains("\"mismatch\"")
        );
    }
}

#[test]
fn a_planted_drift_is_located_in_its_run_and_channel() {
    // 2 µm over the run with τ = 60 s: per sample well inside the noise at first.
    let drift = Drift {
        run: "xyc-a+30",
        amplitude_m: 2e-6,
        tau_s: 60.0,
    };
    let id = identify_with(&[&drift], 1);
    assert!(id.mismatch.detected, "{:#?}", id.mismatch_detail);
    let first = &id.mismatch.locations[0];
    assert_eq!(
        (first.run.as_str(), first.channel.as_str()),
        ("xyc-a+30", "dz"),
        "{:#?}",
        id.mismatch.locations
    );
    // In an XYC circle time and C increase together: either names the ordering.
    assert!(
        matches!(first.along.as_deref(), Some("t" | "C")),
        "{:?}",
        first.along
    );
    assert!(first.share > 0.5, "share {}", first.share);
    assert!(
        id.summary()
            .contains("mismatch: the residuals are not noise")
    );
}
