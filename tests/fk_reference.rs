//! Forward kinematics of every shipped machine agrees with pinocchio's, an independent URDF
//! implementation: frame→tool and frame→workpiece placements at random axis positions within
//! the limits, to 1e-9 m and 1e-9 rad.
//!
//! This pins down everything a loader can get subtly wrong — rpy order, fixed-joint collapse,
//! axis signs, continuous joints — against the reading every other URDF tool uses. Needs
//! `python3` with pinocchio (`pip install pin`); without them the test is skipped with a
//! message, except under CI (env `CI` set), where it fails.

use mtcal::kinematics::{AxisKind, BranchSpec, JointSpec, Machine, MachineSpec, Rigid, Side};
use mtcal::machine::urdf::{load_urdf_file, write_urdf};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
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

/// The shipped files have no rotated origins; this one exercises the rpy convention, fixed
/// joints with rotations between moving joints (collapsed by mtcal, kept as frames by
/// pinocchio), a horizontal spindle (pitch 90°) and skewed axis vectors.
const ROTATED: &str = r#"<?xml version="1.0"?>
<robot name="rotated">
  <link name="frame"/>
  <link name="base"/>
  <joint name="base_mount" type="fixed">
    <origin xyz="0.1 -0.2 0.3" rpy="0.1 -0.2 0.3"/>
    <parent link="frame"/><child link="base"/>
  </joint>
  <link name="x_slide"/>
  <joint name="X" type="prismatic">
    <origin xyz="0 0 -0.4" rpy="0.02 0.01 -0.03"/>
    <parent link="base"/><child link="x_slide"/>
    <axis xyz="-1 0.01 0"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <link name="bracket"/>
  <joint name="bracket_mount" type="fixed">
    <origin xyz="0.05 0.02 0.2" rpy="0 0 1.2"/>
    <parent link="x_slide"/><child link="bracket"/>
  </joint>
  <link name="a_table"/>
  <joint name="A" type="revolute">
    <origin xyz="0 0.1 0.15" rpy="-1.2 0.3 0.4"/>
    <parent link="bracket"/><child link="a_table"/>
    <axis xyz="-1 0 0.02"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <link name="c_table"/>
  <joint name="C" type="continuous">
    <origin xyz="0.01 0 0.05" rpy="0.001 0 0"/>
    <parent link="a_table"/><child link="c_table"/>
    <axis xyz="0.01 0 -1"/>
  </joint>
  <link name="workpiece"/>
  <joint name="wp" type="fixed">
    <origin xyz="0.1 0.1 0.02" rpy="0.3 0.2 0.1"/>
    <parent link="c_table"/><child link="workpiece"/>
  </joint>
  <link name="y_column"/>
  <joint name="Y" type="prismatic">
    <origin xyz="0 1 0" rpy="0 0 0.5"/>
    <parent link="frame"/><child link="y_column"/>
    <axis xyz="0 1 0"/>
    <limit lower="-0.4" upper="0.4" effort="1" velocity="1"/>
  </joint>
  <link name="z_head"/>
  <joint name="Z" type="prismatic">
    <origin xyz="0 -0.5 0.8" rpy="0 1.5707963267948966 0"/>
    <parent link="y_column"/><child link="z_head"/>
    <axis xyz="0 0 1"/>
    <limit lower="-0.6" upper="0" effort="1" velocity="1"/>
  </joint>
  <link name="guard"/>
  <joint name="guard_mount" type="fixed">
    <origin xyz="0 0 0.5"/>
    <parent link="z_head"/><child link="guard"/>
  </joint>
  <link name="tool"/>
  <joint name="spindle" type="fixed">
    <origin xyz="0.2 0 -0.3" rpy="3.141592653589793 -1.5707963267948966 0.7"/>
    <parent link="z_head"/><child link="tool"/>
  </joint>
</robot>
"#;

#[test]
fn rotated_fixed_frames_match_pinocchio() {
    if !pinocchio_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("rotated.urdf");
    std::fs::write(&path, ROTATED).expect("write URDF");
    compare_machine(&path, 0xA11CE);
}

fn joint(letter: char, origin: Isometry3<f64>, axis: [f64; 3]) -> JointSpec {
    let rotary = matches!(letter, 'A' | 'B' | 'C');
    JointSpec {
        letter,
        kind: if rotary {
            AxisKind::Rotary
        } else {
            AxisKind::Linear
        },
        origin,
        axis: Vector3::from(axis),
        limits: if letter == 'C' {
            None
        } else {
            Some((-1.0, 1.0))
        },
    }
}

fn iso(t: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(Vector3::from(t)),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// `write_urdf` output, including rotations at and near gimbal lock, reads the same in
/// pinocchio as in mtcal.
#[test]
fn written_machine_matches_pinocchio() {
    if !pinocchio_available() {
        return;
    }
    let half_pi = std::f64::consts::FRAC_PI_2;
    let spec = MachineSpec {
        name: "written".into(),
        workpiece: BranchSpec {
            joints: vec![
                joint(
                    'X',
                    iso([0.0, 0.0, -0.3], [0.1, 0.2, 0.3]),
                    [-1.0, 0.0, 0.0],
                ),
                joint(
                    'B',
                    iso([0.2, 0.0, 0.3], [0.0, half_pi, 0.4]),
                    [0.0, -1.0, 0.0],
                ),
                joint(
                    'C',
                    iso([0.0, 0.0, 0.1], [0.0, half_pi - 1e-9, 0.0]),
                    [0.0, 0.0, -1.0],
                ),
            ],
            end: iso([0.01, 0.02, 0.03], [-0.3, -half_pi, 1.0]),
        },
        tool: BranchSpec {
            joints: vec![
                joint('Y', iso([0.0, 0.8, -0.4], [0.0, 0.0, 0.0]), [0.0, 1.0, 0.0]),
                joint(
                    'Z',
                    iso([0.0, -0.5, 1.2], [2.0, -1.0, 3.0]),
                    [0.0, 0.3, 1.0],
                ),
            ],
            end: iso([0.0, 0.0, -0.2], [0.0, 0.0, 0.0]),
        },
    };
    let m = Machine::try_new(&spec).expect("valid spec");
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("written.urdf");
    std::fs::write(&path, write_urdf(&m, None)).expect("write URDF");
    compare_machine(&path, 0xB0B);
}
