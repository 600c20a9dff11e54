//! The physics search's ranking step against the number of samples: every registered effect
//! family's candidates (thermal drifts in time and driven by spindle speed, temperature
//! couplings, reversal, cyclic errors at the screw pitches, servo lag, stick-slip,
//! cross-coupling, set-up drift, instrument scale, the model's held-out parameters) scored
//! against the fit of a simulated R-test session on the five-axis trunnion with a spindle
//! speed programme and a bed temperature — score tests, one or more passes over the data,
//! no refit.
//!
//! Target: 100+ candidates against a fit of 1e5 samples in under a second.
//! Also the cross-validation every refitted candidate is judged by (`heldout`: eight blocks
//! of every run and three forecasts, each refitted from the full fit).
//! `cargo bench -p mtcal-identify --bench search`; the numbers go in the README.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use mtcal_identify::search::{SearchOptions, candidates, heldout, rank};
use mtcal_identify::{FitProblem, Study, param_specs};
use mtcal_solve::{Options, Silent};
use std::hint::black_box;

/// An R-test session of about `samples` samples over 1000 s, with context columns.
fn session(samples: usize) -> (tempfile::TempDir, Study) {
    let dir = tempfile::tempdir().unwrap();
    let repo = mtcal_testkit::repo();
    let per_run = (samples / 5).max(2);
    let interval = 1000.0 / samples as f64;
    let mut plan = format!(
        r#"machine = {machine:?}
truth = {truth:?}
interval_s = {interval}
[identify]
parameters = {eleven}
[context]
S = [[0.0, 0.0], [150.0, 4000.0], [500.0, 8000.0], [700.0, 2000.0]]
T_bed = [[0.0, 20.5], [250.0, 21.5], [500.0, 20.5], [750.0, 19.5], [1000.0, 20.5]]
[setup.low]
ball = [100.0, 0.0, 200.0]
[setup.high]
ball = [100.0, 0.0, 300.0]
"#,
        machine = repo.join("machines/mcu630-cafyxz.urdf"),
        truth = repo.join("examples/five-axis/truth.params.toml"),
        eleven = mtcal_testkit::params::toml_list(&mtcal_testkit::ELEVEN),
    );
    for (name, setup, path) in [
        ("a0", "low", "kind = \"xyc\""),
        ("a30", "low", "kind = \"xyc\", hold = { A = 30.0 }"),
        ("am30", "low", "kind = \"xyc\", hold = { A = -30.0 }"),
        ("yza", "low", "kind = \"yza\""),
        ("high", "high", "kind = \"xyc\""),
    ] {
        plan += &format!(
            "[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\n\
             path = {{ {path}, samples = {per_run} }}\n"
        );
    }
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    mtcal_simulate::simulate(&dir.path().join("plan.toml"), &dir.path().join("s")).unwrap();
    let study = Study::load(&dir.path().join("s")).unwrap();
    (dir, study)
}

/// [`session`] and its fit.
fn fitted(samples: usize) -> (tempfile::TempDir, Study, mtcal_solve::Solution) {
    let (dir, study) = session(samples);
    let solution = mtcal_solve::solve(
        &FitProblem::new(&study),
        &param_specs(&study),
        &Options::default(),
        &mut Silent,
    )
    .unwrap();
    (dir, study, solution)
}

fn bench_rank(c: &mut Criterion) {
    let mut g = c.benchmark_group("search_rank_rtest_trunnion");
    g.sample_size(10);
    for n in [10_000usize, 100_000] {
        let (_dir, study, solution) = fitted(n);
        let all = candidates(&study, None);
        let columns: usize = all
            .iter()
            .map(|c| match c {
                mtcal_effects::Candidate::Effect(e) => e
                    .params()
                    .iter()
                    .filter(|p| p.kind == mtcal_effects::ParamKind::Amplitude)
                    .count(),
                mtcal_effects::Candidate::Model(_) => 1,
            })
            .sum();
        let ranked = rank(&study, &solution, all.clone(), 0.05).unwrap();
        eprintln!(
            "{n} samples: {} candidates ({} columns at least), {} significant (clean session)",
            all.len(),
            columns,
            ranked.iter().filter(|r| r.score.significant).count()
        );
        g.bench_with_input(BenchmarkId::new("all-families", n), &all, |b, all| {
            b.iter(|| black_box(rank(&study, &solution, all.clone(), 0.05).unwrap()))
        });
    }
    g.finish();
}

fn bench_heldout(c: &mut Criterion) {
    let mut g = c.benchmark_group("search_heldout_rtest_trunnion");
    g.sample_size(10);
    let options = SearchOptions::default();
    for n in [10_000usize, 100_000] {
        let (_dir, study, solution) = fitted(n);
        g.bench_with_input(BenchmarkId::new("blocks-and-forecasts", n), &n, |b, _| {
            b.iter(|| black_box(heldout(&study, &solution.x, &options).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_rank, bench_heldout);
criterion_main!(benches);
