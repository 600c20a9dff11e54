//! Scratch probe (not to commit): indsim sessions with crude post-processed effects, searched
//! in the default full model.
use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::{Study, base};
use mtcal_indsim::{Campaign, JointKind, Machine, Realism, Truth, shipped_machine};
use mtcal_plugins as _;
use mtcal_solve::Options;
use rand::SeedableRng;
use std::path::Path;

fn bare(dir: &Path) {
    let manifest = dir.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let line = text.lines().find(|l| l.starts_with("machine")).unwrap();
    let rel = line.split('"').nth(1).unwrap();
    std::fs::copy(dir.join(rel), dir.join("machine.urdf")).unwrap();
    let text = text.replace(line, "machine = \"machine.urdf\"");
    std::fs::write(&manifest, text).unwrap();
}

/// Adds `f(t, x, y, z, ccw?) -> (dx, dy, dz)` tool displacement (µm, machine frame) to the
/// readings of every run.
fn plant(dir: &Path, f: &dyn Fn(f64, &[f64], &[f64]) -> [f64; 3]) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "csv") {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        let col = |n: &str| header.iter().position(|h| h == n);
        let (ix, iy, iz) = (col("X").unwrap(), col("Y").unwrap(), col("Z").unwrap());
        let mut out = header.join(",") + "\n";
        for (k, r) in rows.iter().enumerate() {
            let prev = if k > 0 { &rows[k - 1] } else { r };
            let q = [r[ix], r[iy], r[iz]];
            let qp = [prev[ix], prev[iy], prev[iz]];
            let d = f(r[0], &q, &qp);
            let mut r = r.clone();
            if let (Some(a), Some(b), Some(c)) = (col("dx"), col("dy"), col("dz")) {
                r[a] -= d[0];
                r[b] -= d[1];
                r[c] -= d[2];
            }
            if let Some(a) = col("dr") {
                // pivot [0,0,200], length 100: unit vector from pivot to tool (XY circle at z 200).
                let v = [q[0], q[1], q[2] - 200.0];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                r[a] += (v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) / n;
            }
            out += &r.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(",");
            out += "\n";
        }
        std::fs::write(&p, out).unwrap();
    }
}

fn session(seed: u64, dir: &Path) {
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let mut truth = Truth::random(&machine, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed), 1.0);
    for (axis, joint) in truth.axes.iter_mut().zip(&machine.joints) {
        if joint.kind == JointKind::Rotary {
            axis.component = [[0.0; 4]; 6];
        }
    }
    let mut realism = Realism::realistic(1000 + seed);
    realism.interval_s = 1.0;
    Campaign::trunnion_rtest_ballbar_with(dir, &truth, &realism).unwrap();
    bare(dir);
}

fn run(name: &str, f: &dyn Fn(f64, &[f64], &[f64]) -> [f64; 3]) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    session(std::env::var("SEED").map_or(3, |s| s.parse().unwrap()), &dir);
    plant(&dir, f);
    let t0 = std::time::Instant::now();
    let (study, _b) = base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let result = search(study, &SearchOptions::default()).unwrap();
    eprintln!("=== {name} ({:.1} s)\n{}", t0.elapsed().as_secs_f64(), result.initial.summary().lines().take(3).collect::<Vec<_>>().join("\n"));
    eprintln!("{}", result.identification.search_summary());
}

#[test]
fn probe() {
    let which = std::env::var("PROBE").unwrap_or_default();
    if which.contains("clean") {
        run("clean", &|_, _, _| [0.0; 3]);
    }
    if which.contains("drift") {
        run("drift Z 10 um tau 600", &|t, _, _| [0.0, 0.0, 10.0 * (1.0 - (-t / 600.0).exp())]);
    }
    if which.contains("backlash") {
        run("backlash X 3 um", &|_, q, p| {
            let s = if q[0] > p[0] { 1.0 } else if q[0] < p[0] { -1.0 } else { 0.0 };
            [-1.5 * s, 0.0, 0.0]
        });
    }
    if which.contains("cyclic") {
        run("cyclic X 1 um 7 mm", &|_, q, _| [1.0 * (std::f64::consts::TAU * q[0] / 7.0).sin(), 0.0, 0.0]);
    }
    if which.contains("twist") {
        run("twist Z 5 um at corners", &|_, q, _| [0.0, 0.0, 5.0 * q[0] / 150.0 * q[1] / 150.0]);
    }
}

#[test]
fn noise_estimator_on_the_true_noise() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let truth = Truth::random(&machine, &mut rand_chacha::ChaCha8Rng::seed_from_u64(3), 1.0);
    let realism = Realism::realistic(1003);
    let w = Campaign::trunnion_rtest_ballbar_with(&dir, &truth, &realism).unwrap();
    for (setup, nch) in [("ball1", 3), ("bar1", 1)] {
        for c in 0..nch {
            let series: Vec<Vec<f64>> = w.runs.iter().filter(|r| r.setup == setup && !r.name.contains("validate")).map(|r| {
                r.clean_um.iter().zip(&r.written_um).map(|(a, b)| (b[c] - a[c]) / 0.24).collect()
            }).collect();
            let refs: Vec<&[f64]> = series.iter().map(|v| v.as_slice()).collect();
            let n = mtcal_identify::noise::channel_noise_of(&refs);
            let all: Vec<f64> = series.concat();
            let ms = all.iter().map(|v| v * v).sum::<f64>() / all.len() as f64;
            eprintln!("{setup} ch{c}: {n:?}; plain rms {:.3}", ms.sqrt());
        }
    }
}
