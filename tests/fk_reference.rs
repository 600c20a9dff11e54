//! Forward kinematics of every shipped machine agrees with pinocchio's, an independent URDF
//! implementation: frame→tool and frame→workpiece placements at random axis positions within
//! the limits, to 1e-9 m and 1e-9 rad.
//!
//! This pins down everything a loader can get subtly wrong — rpy order, fixed-joint collapse,
//! axis signs, continuous joints — against the reading every other URDF tool uses. Needs
//! `python3` with pinocchio (`pip install pin`); without them the test is skipped with a
//! message, except under CI (env `CI` set), where it fails.

use mtcal::kinematics::{Machine, Rigid, Side};
use mtcal::machine::urdf::load_urdf_file;
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const SAMPLES: usize = 64;
const TOLERANCE: f64 = 1e-9;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Whether `python3 -c "import pinocchio"` works; panics under CI when it does not.
fn pinocchio_available() -> bool {
    let status = Command::new("python3")
        .args(["-c", "import pinocchio"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    let ok = status.is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var_os("CI").is_none(),
            "python3 with pinocchio is needed for the FK reference test: pip install pin"
        );
        eprintln!("skipped: python3 or pinocchio not installed (pip install pin)");
    }
    ok
}

/// A small deterministic generator (SplitMix64): reproducible samples without a dependency.
struct SplitMix(u64);

impl SplitMix {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Axis positions in canonical order: the limit corners first, then uniform samples within the
/// limits; unlimited rotary axes sweep ±3π so that pinocchio's (cos, sin) wrap-around is hit.
fn positions(m: &Machine, seed: u64) -> Vec<Vec<f64>> {
    let range = |i: usize| {
        m.axes()[i]
            .limits()
            .unwrap_or((-3.0 * std::f64::consts::PI, 3.0 * std::f64::consts::PI))
    };
    let n = m.n_axes();
    let mut out = vec![
        (0..n).map(|i| range(i).0).collect(),
        (0..n).map(|i| range(i).1).collect(),
    ];
    let mut rng = SplitMix(seed);
    while out.len() < SAMPLES {
        out.push(
            (0..n)
                .map(|i| {
                    let (lo, hi) = range(i);
                    lo + (hi - lo) * rng.unit()
                })
                .collect(),
        );
    }
    out
}

/// pinocchio's placements for each sample, as (tool, workpiece) 4×4 matrices.
fn pinocchio_poses(urdf: &Path, m: &Machine, samples: &[Vec<f64>]) -> Vec<(Value, Value)> {
    let input: Vec<Value> = samples
        .iter()
        .map(|q| {
            let obj: serde_json::Map<String, Value> = m
                .axes()
                .iter()
                .zip(q)
                .map(|(a, &v)| (a.letter().to_string(), json!(v)))
                .collect();
            Value::Object(obj)
        })
        .collect();
    let mut child = Command::new("python3")
        .arg(root().join("tests/fk_reference.py"))
        .arg(urdf)
        .arg("-")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run python3 tests/fk_reference.py");
    let mut stdin = child.stdin.take().expect("stdin");
    stdin
        .write_all(Value::Array(input).to_string().as_bytes())
        .expect("send positions");
    drop(stdin);
    let out = child.wait_with_output().expect("fk_reference.py output");
    assert!(
        out.status.success(),
        "fk_reference.py failed on {}:\n{}",
        urdf.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let parsed: Value = serde_json::from_slice(&out.stdout).expect("JSON from fk_reference.py");
    parsed["poses"]
        .as_array()
        .expect("poses array")
        .iter()
        .map(|p| (p["tool"].clone(), p["workpiece"].clone()))
        .collect()
}

/// Largest deviation in translation (m) and in rotation-matrix entries (≈ rad).
fn deviation(mine: &Rigid, reference: &Value) -> (f64, f64) {
    let at = |r: usize, c: usize| reference[r][c].as_f64().expect("matrix entry");
    let mut dt: f64 = 0.0;
    let mut dr: f64 = 0.0;
    for r in 0..3 {
        dt = dt.max((mine.t[r] - at(r, 3)).abs());
        for c in 0..3 {
            dr = dr.max((mine.r[(r, c)] - at(r, c)).abs());
        }
    }
    (dt, dr)
}

fn compare_machine(urdf: &Path, seed: u64) {
    let m = load_urdf_file(urdf).unwrap_or_else(|e| panic!("{e}"));
    let samples = positions(&m, seed);
    let reference = pinocchio_poses(urdf, &m, &samples);
    assert_eq!(reference.len(), samples.len());
    for (q, (tool, workpiece)) in samples.iter().zip(&reference) {
        for (side, pose) in [(Side::Tool, tool), (Side::Workpiece, workpiece)] {
            let (dt, dr) = deviation(&m.branch_pose(side, q), pose);
            assert!(
                dt <= TOLERANCE && dr <= TOLERANCE,
                "{}: {side:?} pose differs from pinocchio by {dt:e} m / {dr:e} at q = {q:?} ({})",
                urdf.display(),
                m.letters()
            );
        }
    }
}

#[test]
fn shipped_machines_match_pinocchio() {
    if !pinocchio_available() {
        return;
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("machines"))
        .expect("machines/ exists")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "urdf"))
        .collect();
    files.sort();
    assert!(files.len() >= 6, "expected the six shipped machines");
    for (k, file) in files.iter().enumerate() {
        compare_machine(file, 0x5EED + k as u64);
    }
}
