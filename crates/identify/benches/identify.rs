//! Identification time against the number of samples: simulated R-test sessions on the
//! five-axis trunnion (0.5 µm noise) with
//! - the 11-error set (3 squareness + 8 location; 5 runs, 19 parameters with the set-ups);
//! - the full error model (every component error too: most of it unidentifiable from R-test),
//!   as a user without `[identify] parameters` gets it: the model the runs determine chosen
//!   first (`base::identifiable_study`), then the fit — both timed;
//! - the C-axis model: the 11-error set plus the six error motions of C as Fourier series of
//!   harmonics 2…8 (84 coefficients), from 8 runs at three ball positions (each with an XYC
//!   and a YZA run, two also with a tilted XYC): 108 parameters, rank 106, condition 80 (the
//!   ~100-parameter case of the target).
//!
//! Besides the times, each case prints the peak heap that `identify` allocates on top of the
//! loaded session (the solver's working memory: it must not grow with the number of samples).
//!
//! The information account of the C-axis fit is timed too (`information_account`).
//!
//! `cargo bench -p mtcal-identify --bench identify`; the numbers go in the README.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use mtcal_identify::{Study, base, identify};
use mtcal_solve::{Options, Silent};
use mtcal_testkit::params::toml_list;
use mtcal_testkit::{ELEVEN, repo};
use peakmem_alloc::{INSTRUMENTED_SYSTEM, PeakMemAlloc, PeakMemAllocTrait};
use std::alloc::System;
use std::hint::black_box;

#[global_allocator]
static GLOBAL: &PeakMemAlloc<System> = &INSTRUMENTED_SYSTEM;

/// Error model of the C-axis case: location and squareness errors plus C's error motions
/// (harmonic 1 of each is left to the location and set-up parameters).
fn c_axis_errors() -> String {
    let mut toml = String::from(
        "schema = \"mtcal.errors/1\"
\
         components = [\"EXC\", \"EYC\", \"EZC\", \"EAC\", \"EBC\", \"ECC\"]
\
         locations = \"iso\"
setup = [\"TOOL_DZ\"]
\
         [basis.rotary]
kind = \"fourier\"
harmonics = 8
",
    );
    for c in ["EXC", "EYC", "EZC", "EAC", "EBC", "ECC"] {
        toml += &format!(
            "[component.{c}]
min_harmonic = 2
"
        );
    }
    toml
}

/// The C-axis case: 8 R-test runs at three ball positions (two heights, two radii), each with
/// an XYC and a YZA run, two with an XYC at A = ±30° too; about `samples` samples in all.
/// Every ball position has a YZA run: with XYC alone its height and the tool length separate
/// only through second-order effects of the errors (a near-null direction, condition 10⁵, and
/// a degenerate start).
fn c_axis_session(samples: usize) -> (tempfile::TempDir, Study) {
    let dir = tempfile::tempdir().unwrap();
    let repo = repo();
    std::fs::copy(
        repo.join("machines/mcu630-cafyxz.urdf"),
        dir.path().join("m.urdf"),
    )
    .unwrap();
    std::fs::write(dir.path().join("m.errors.toml"), c_axis_errors()).unwrap();
    let n = (samples / 8).max(2);
    let runs = [
        ("c1", "s1", "xyc", ""),
        ("c2", "s2", "xyc", ""),
        ("c3", "s3", "xyc", ""),
        ("c1a", "s1", "xyc", ", hold = { A = 30.0 }"),
        ("c2a", "s2", "xyc", ", hold = { A = -30.0 }"),
        ("a1", "s1", "yza", ""),
        ("a2", "s2", "yza", ""),
        ("a3", "s3", "yza", ""),
    ];
    let mut plan = format!(
        r#"machine = {machine:?}
truth = {truth:?}
interval_s = 0.01
[setup.s1]
ball = [100.0, 0.0, 200.0]
[setup.s2]
ball = [100.0, 0.0, 350.0]
[setup.s3]
ball = [200.0, 0.0, 200.0]
"#,
        machine = dir.path().join("m.urdf"),
        truth = repo.join("examples/five-axis/truth.params.toml"),
    );
    for (name, setup, kind, hold) in runs {
        plan += &format!(
            "[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\n\
             path = {{ kind = \"{kind}\", samples = {n}{hold} }}\n"
        );
    }
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    mtcal_simulate::simulate(&dir.path().join("plan.toml"), &dir.path().join("s")).unwrap();
    let study = Study::load(&dir.path().join("s")).unwrap();
    (dir, study)
}

/// A simulated session with about `samples` samples in a temporary folder.
fn session(samples: usize, eleven: bool) -> (tempfile::TempDir, Study) {
    let dir = tempfile::tempdir().unwrap();
    let repo = repo();
    let per_run = (samples / 5).max(2);
    let identify = if eleven {
        format!("parameters = {}", toml_list(&ELEVEN))
    } else {
        String::new()
    };
    let plan = format!(
        r#"machine = {machine:?}
truth = {truth:?}
interval_s = 0.01
[identify]
{identify}
[setup.low]
ball = [100.0, 0.0, 200.0]
[setup.high]
ball = [100.0, 0.0, 300.0]
[[run]]
name = "a0"
instrument = "rtest"
setup = "low"
path = {{ kind = "xyc", samples = {per_run} }}
[[run]]
name = "a30"
instrument = "rtest"
setup = "low"
path = {{ kind = "xyc", samples = {per_run}, hold = {{ A = 30.0 }} }}
[[run]]
name = "am30"
instrument = "rtest"
setup = "low"
path = {{ kind = "xyc", samples = {per_run}, hold = {{ A = -30.0 }} }}
[[run]]
name = "yza"
instrument = "rtest"
setup = "low"
path = {{ kind = "yza", samples = {per_run} }}
[[run]]
name = "high"
instrument = "rtest"
setup = "high"
path = {{ kind = "xyc", samples = {per_run} }}
"#,
        machine = repo.join("machines/mcu630-cafyxz.urdf"),
        truth = repo.join("examples/five-axis/truth.params.toml"),
    );
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    mtcal_simulate::simulate(&dir.path().join("plan.toml"), &dir.path().join("s")).unwrap();
    let study = Study::load(&dir.path().join("s")).unwrap();
    (dir, study)
}

fn bench_identify(c: &mut Criterion) {
    let mut g = c.benchmark_group("identify_rtest_trunnion");
    g.sample_size(10);
    for &n in &[1_000usize, 10_000, 100_000, 1_000_000] {
        let (_dir, study) = session(n, true);
        GLOBAL.reset_peak_memory();
        let once = identify(&study, &Options::default(), &mut Silent).unwrap();
        eprintln!(
            "11-errors/{n}: peak heap during identify {:.1} MiB, {} parameters, {} iterations",
            GLOBAL.get_peak_memory() as f64 / (1024.0 * 1024.0),
            study.layout().n_x(),
            once.solver.iterations
        );
        g.bench_with_input(BenchmarkId::new("11-errors", n), &study, |b, study| {
            b.iter(|| black_box(identify(study, &Options::default(), &mut Silent).unwrap()))
        });
    }
    // The full model as a user without `[identify] parameters` gets it: the model the runs
    // determine chosen first (one linearisation, `base::select`), then the fit with the rest
    // held by their prior. Timed together.
    for &n in &[1_000usize, 10_000, 100_000, 1_000_000] {
        let (_dir, study) = session(n, false);
        let full = |study: &Study| {
            let copy = study.rebuild(study.changes().clone()).unwrap();
            let (reduced, _) = base::identifiable_study(copy, &Options::default()).unwrap();
            identify(&reduced, &Options::default(), &mut Silent).unwrap()
        };
        GLOBAL.reset_peak_memory();
        let once = full(&study);
        eprintln!(
            "full-model/{n}: peak heap during selection and identify {:.1} MiB, {} parameters, \
             {} iterations, converged {}",
            GLOBAL.get_peak_memory() as f64 / (1024.0 * 1024.0),
            study.layout().n_x(),
            once.solver.iterations,
            once.solver.converged
        );
        g.bench_with_input(BenchmarkId::new("full-model", n), &study, |b, study| {
            b.iter(|| black_box(full(study)))
        });
    }
    for n in [1_000usize, 10_000, 100_000, 1_000_000] {
        let (_dir, study) = c_axis_session(n);
        GLOBAL.reset_peak_memory();
        let once = identify(&study, &Options::default(), &mut Silent).unwrap();
        eprintln!(
            "c-axis/{n}: peak heap during identify {:.1} MiB, {} parameters, {} iterations, \
             {} passes ({} with a factorisation), converged {}",
            GLOBAL.get_peak_memory() as f64 / (1024.0 * 1024.0),
            study.layout().n_x(),
            once.solver.iterations,
            once.solver.passes,
            once.solver.factorizations,
            once.solver.converged
        );
        g.bench_with_input(BenchmarkId::new("c-axis", n), &study, |b, study| {
            b.iter(|| black_box(identify(study, &Options::default(), &mut Silent).unwrap()))
        });
    }
    g.finish();
}

/// The information account (shares by run, repeat gains) of the C-axis fit: one pass over the
/// data per run for its factor, then dense algebra in the 108 parameters per run.
fn bench_information(c: &mut Criterion) {
    let mut g = c.benchmark_group("information_account");
    g.sample_size(10);
    for n in [10_000usize, 100_000] {
        let (_dir, study) = c_axis_session(n);
        let (_, solution) =
            mtcal_identify::identify_with_solution(&study, &Options::default(), &mut Silent)
                .unwrap();
        g.bench_with_input(BenchmarkId::new("c-axis", n), &study, |b, study| {
            b.iter(|| black_box(mtcal_identify::information::account(study, &solution).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_identify, bench_information);
criterion_main!(benches);
