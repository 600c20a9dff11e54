//! mtcal's batched pose errors against pinocchio's forward kinematics, in one run, on the
//! shipped five-axis trunnion (MCU 630, CAFYXZ) with the full error set of benches/kinematics.rs
//! (cubic Legendre components): issue 35 asks the first-order error to run at least twice as
//! fast per pose as pinocchio's forward kinematics, and the exact error at least as fast.
//!
//! `cargo bench --bench vs_pinocchio`. pinocchio's side is a C++ program
//! (benches/pinocchio/fk.cpp) compiled at run time with `g++ -O3 -march=native` against the
//! pinocchio that `python3` imports (pip's `pin`, its headers under the cmeel prefix; Eigen from
//! there or /usr/include/eigen3; override the prefix with `PINOCCHIO_PREFIX`). Per pose it runs
//! `forwardKinematics` and places the `tool` and `workpiece` frames: the two frames mtcal's
//! pose error relates. Both sides time passes through the same 256 poses and report the median
//! ns per pose. When python3, pinocchio, its headers, Eigen or g++ are missing, the comparison
//! is skipped with the reason; mtcal's numbers are measured regardless. Outside `--bench`
//! (`cargo test --benches`) nothing is compiled and each benchmark runs once.

use criterion::{Criterion, Throughput};
use mtcal::kinematics::model::iso_full_config;
use mtcal::kinematics::{BasisChoice, BatchKernel, MachineModel};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const POSES: usize = 256;

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn urdf() -> PathBuf {
    manifest().join("machines/mcu630-cafyxz.urdf")
}

/// The trunnion and coefficients of benches/kinematics.rs.
fn trunnion() -> (MachineModel, Vec<f64>) {
    let machine = mtcal::machine::urdf::load_urdf_file(&urdf()).expect("shipped machine loads");
    let cubic = BasisChoice::Legendre { degree: 3 };
    let config = iso_full_config(&machine, &cubic, &cubic).expect("ISO model");
    let model = MachineModel::new(machine, &config).expect("model");
    let coeffs = (0..model.n_coeffs())
        .map(|k| 1e-6 * (((k * 7919) % 41) as f64 - 20.0))
        .collect();
    (model, coeffs)
}

/// The poses of benches/kinematics.rs, one after another (one position per axis each).
fn poses(model: &MachineModel, n: usize) -> Vec<f64> {
    let axes = model.machine().axes();
    (0..n)
        .flat_map(|i| {
            axes.iter().enumerate().map(move |(a, ax)| {
                let (lo, hi) = ax.limits().unwrap_or((-3.0, 3.0));
                let t = ((i * (a + 3) * 37) % 101) as f64 / 100.0;
                lo + (hi - lo) * t
            })
        })
        .collect()
}

/// Median ns per pose over `repeats` passes of `pass` (which evaluates `poses` poses), after a
/// tenth as many warm-up passes: the same statistic the C++ harness prints.
fn median_ns_per_pose(poses: usize, repeats: usize, mut pass: impl FnMut()) -> f64 {
    for _ in 0..repeats.div_ceil(10) {
        pass();
    }
    let mut ns: Vec<f64> = (0..repeats)
        .map(|_| {
            let t0 = Instant::now();
            pass();
            t0.elapsed().as_nanos() as f64 / poses as f64
        })
        .collect();
    ns.sort_by(f64::total_cmp);
    ns[ns.len() / 2]
}

/// Runs `program`, returning its standard output, or why it failed.
fn run(program: &mut Command) -> Result<String, String> {
    let out = program
        .output()
        .map_err(|e| format!("cannot run {:?}: {e}", program.get_program()))?;
    if !out.status.success() {
        return Err(format!(
            "{:?} failed ({}): {}",
            program.get_program(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// pinocchio's median ns per pose on `q`, or why it could not be measured.
fn pinocchio_ns_per_pose(model: &MachineModel, q: &[f64]) -> Result<f64, String> {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("vs_pinocchio");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    // The model from pinocchio's own URDF parser, and where pinocchio's headers are.
    let model_txt = dir.join("model.txt");
    let script = "import sys, os, sysconfig, pinocchio as pin, cmeel.consts as c\n\
                  pin.buildModelFromUrdf(sys.argv[1]).saveToText(sys.argv[2])\n\
                  print(pin.__version__)\n\
                  print(os.path.join(sysconfig.get_paths()['purelib'], c.CMEEL_PREFIX))";
    let out = run(Command::new("python3")
        .args(["-c", script])
        .arg(urdf())
        .arg(&model_txt))
    .map_err(|e| format!("pinocchio for python3 (pip install pin): {e}"))?;
    let mut lines = out.lines();
    let version = lines.next().unwrap_or("?").to_string();
    let prefix = match std::env::var_os("PINOCCHIO_PREFIX") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(lines.next().unwrap_or_default()),
    };
    let include = prefix.join("include");
    if !include.join("pinocchio/config.hpp").exists() {
        return Err(format!("no pinocchio headers under {}", include.display()));
    }
    let eigen = [include.join("eigen3"), PathBuf::from("/usr/include/eigen3")]
        .into_iter()
        .find(|p| p.join("Eigen/Core").exists())
        .ok_or("no Eigen headers (apt-get install libeigen3-dev, or pip install cmeel-eigen)")?;
    let exe = compile_harness(&dir, &include, &eigen, &prefix.join("lib"))?;

    let poses_txt = dir.join("poses.txt");
    let n = model.machine().n_axes();
    let header: Vec<String> = model
        .machine()
        .axes()
        .iter()
        .map(|a| a.letter().to_string())
        .collect();
    let mut text = header.join(" ") + "\n";
    for pose in q.chunks(n) {
        let row: Vec<String> = pose.iter().map(|v| format!("{v:.17e}")).collect();
        text += &(row.join(" ") + "\n");
    }
    std::fs::write(&poses_txt, text).map_err(|e| format!("{}: {e}", poses_txt.display()))?;
    let out = run(Command::new(&exe)
        .arg(&model_txt)
        .arg(&poses_txt)
        .arg("4000"))?;
    let ns = out
        .lines()
        .find_map(|l| l.strip_prefix("ns_per_pose "))
        .and_then(|l| l.split_whitespace().next()?.parse::<f64>().ok())
        .ok_or_else(|| format!("unexpected harness output: {out}"))?;
    println!(
        "pinocchio {version} (C++, g++ -O3 -march=native, {}): {ns:.1} ns/pose",
        exe.display()
    );
    Ok(ns)
}

/// Compiles benches/pinocchio/fk.cpp into `dir` unless a build of the same source is there
/// (a minute of g++: pinocchio is header templates).
fn compile_harness(
    dir: &Path,
    include: &Path,
    eigen: &Path,
    lib: &Path,
) -> Result<PathBuf, String> {
    let source = manifest().join("benches/pinocchio/fk.cpp");
    let text = std::fs::read(&source).map_err(|e| format!("{}: {e}", source.display()))?;
    let exe = dir.join("fk");
    let stamp = dir.join("fk.source");
    if exe.exists() && std::fs::read(&stamp).is_ok_and(|s| s == text) {
        return Ok(exe);
    }
    println!("compiling {} (about a minute) ...", source.display());
    run(Command::new("g++")
        .args(["-O3", "-march=native", "-DNDEBUG", "-std=c++17"])
        // What pinocchio's CMake config adds for its joint variant (boost::variant of 25 types).
        .args([
            "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
            "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
            "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
            "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
        ])
        .arg(format!("-I{}", include.display()))
        .arg(format!("-I{}", eigen.display()))
        .arg(&source)
        .arg("-o")
        .arg(&exe)
        .arg(format!("-L{}", lib.display()))
        .arg(format!("-Wl,-rpath,{}", lib.display()))
        .arg("-lboost_serialization"))
    .map_err(|e| format!("compiling the pinocchio harness: {e}"))?;
    std::fs::write(&stamp, text).map_err(|e| format!("{}: {e}", stamp.display()))?;
    Ok(exe)
}

/// Criterion's view: per-pose and batched, first order and exact, per pose of 256.
fn criterion_benches(c: &mut Criterion, model: &MachineModel, coeffs: &[f64], q: &[f64]) {
    let n = model.machine().n_axes();
    let mut ws = model.workspace();
    let mut bws = model.batch_workspace();
    let mut out = vec![[0.0; 6]; q.len() / n];
    let mut g = c.benchmark_group("vs_pinocchio_trunnion");
    g.throughput(Throughput::Elements(out.len() as u64));
    g.bench_function("first_order_per_pose", |b| {
        b.iter(|| {
            for pose in q.chunks(n) {
                black_box(model.pose_error_first_order(black_box(pose), coeffs, &mut ws));
            }
        })
    });
    g.bench_function("first_order_batched", |b| {
        b.iter(|| model.pose_errors_first_order(black_box(q), coeffs, &mut bws, &mut out))
    });
    g.bench_function("exact_per_pose", |b| {
        b.iter(|| {
            for pose in q.chunks(n) {
                black_box(model.pose_error(black_box(pose), coeffs, &mut ws));
            }
        })
    });
    g.bench_function("exact_batched", |b| {
        b.iter(|| model.pose_errors(black_box(q), coeffs, &mut bws, &mut out))
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let (model, coeffs) = trunnion();
    let q = poses(&model, POSES);
    criterion_benches(&mut c, &model, &coeffs, &q);
    c.final_summary();
    // Only a real benchmark run compiles and times pinocchio.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }

    let n = model.machine().n_axes();
    let repeats = 4000;
    let mut ws = model.workspace();
    let mut bws = model.batch_workspace();
    let mut out = vec![[0.0; 6]; POSES];
    let mut per_pose = |exact: bool| {
        median_ns_per_pose(POSES, repeats, || {
            for pose in q.chunks(n) {
                black_box(if exact {
                    model.pose_error(black_box(pose), &coeffs, &mut ws)
                } else {
                    model.pose_error_first_order(black_box(pose), &coeffs, &mut ws)
                });
            }
        })
    };
    let (first_single, exact_single) = (per_pose(false), per_pose(true));
    let mut batched = |exact: bool, kernel: BatchKernel| {
        bws.set_kernel(kernel);
        median_ns_per_pose(POSES, repeats, || {
            if exact {
                model.pose_errors(black_box(&q), &coeffs, &mut bws, &mut out);
            } else {
                model.pose_errors_first_order(black_box(&q), &coeffs, &mut bws, &mut out);
            }
            black_box(&out);
        })
    };
    let rows = [
        ("first order, per pose", first_single),
        ("first order, batched", batched(false, BatchKernel::Detect)),
        (
            "first order, batched, portable kernel",
            batched(false, BatchKernel::Portable),
        ),
        ("exact, per pose", exact_single),
        ("exact, batched", batched(true, BatchKernel::Detect)),
        (
            "exact, batched, portable kernel",
            batched(true, BatchKernel::Portable),
        ),
    ];

    println!("\nmtcal vs pinocchio, {POSES} poses of the MCU 630 trunnion, median ns per pose");
    let pin = pinocchio_ns_per_pose(&model, &q);
    if let Err(why) = &pin {
        println!("pinocchio comparison skipped: {why}");
    }
    for (what, ns) in rows {
        match &pin {
            Ok(p) => println!(
                "  mtcal {what:<40} {ns:8.1} ns/pose   pinocchio/mtcal = {:.2}",
                p / ns
            ),
            Err(_) => println!("  mtcal {what:<40} {ns:8.1} ns/pose"),
        }
    }
    if let Ok(p) = pin {
        println!(
            "  targets (issue 35): first order batched >= 2.00, exact batched >= 1.00 (pinocchio {p:.1} ns/pose)"
        );
    }
}
