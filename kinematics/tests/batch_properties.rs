//! The batched pose errors (`MachineModel::pose_errors_first_order`, `pose_errors`) against the
//! per-pose ones, on random machines, error models, poses and coefficients: every basis kind,
//! batch sizes that leave a partial chunk, both compiled kernels.

mod support;

use mtcal_kinematics::model::{BasisChoice, iso_full_config};
use mtcal_kinematics::{
    AxisKind, Basis, BatchKernel, BranchSpec, Direction, JointSpec, Machine, MachineModel,
    MachineSpec, ParamConfig, ParamName, Setup,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use support::{Mix, case, positions};

/// Sum of all lever lengths in the chain, at least 1 m (as in pose_properties.rs).
fn machine_size(m: &Machine) -> f64 {
    let spec = m.to_spec();
    let mut l = 0.0;
    for b in [&spec.workpiece, &spec.tool] {
        l += b.end.translation.vector.norm();
        l += b
            .joints
            .iter()
            .map(|j| {
                j.origin.translation.vector.norm()
                    + j.limits.map_or(0.0, |(a, b)| a.abs().max(b.abs()))
            })
            .sum::<f64>();
    }
    l.max(1.0)
}

/// Runs both batched evaluations with `kernel` and returns (first order, exact).
fn batched(
    model: &MachineModel,
    q: &[f64],
    coeffs: &[f64],
    kernel: BatchKernel,
) -> (Vec<[f64; 6]>, Vec<[f64; 6]>) {
    let n = q.len() / model.machine().n_axes();
    let mut ws = model.batch_workspace();
    ws.set_kernel(kernel);
    // NaN-filled: every pose must be written.
    let (mut first, mut exact) = (vec![[f64::NAN; 6]; n], vec![[f64::NAN; 6]; n]);
    model.pose_errors_first_order(q, coeffs, &mut ws, &mut first);
    model.pose_errors(q, coeffs, &mut ws, &mut exact);
    (first, exact)
}

/// Checks every pose of `q` (poses one after another) against the per-pose evaluations, with
/// both kernels, and that both kernels give the same bits.
///
/// Tolerances. First order: 1e-12 of the pose's largest error entry; both paths sum the same
/// terms, differing only in the rounding of the sine and cosine (an ulp or two) and in how a
/// few products are grouped, so any real difference (a sign, a missed term: the error's own
/// size) is ten orders above it. Exact: the same relative bound plus 2e-15 per metre of the
/// machine's levers: the per-pose path forms the error as the difference of two poses a metre
/// in size (`p − p₀`, `R·R₀ᵀ`), whose rounding is a few ulps of a metre per axis whatever the
/// error (the batched path carries the error itself along the chain, to its own relative
/// precision). A bound of 4e-16 per metre (two ulps) failed once in CI at 2.4 ulps on a
/// five-axis random machine; 2e-15 is nine ulps, still seven orders below the smallest error
/// term a missed sign or term would leave (1e-8 m).
fn check(model: &MachineModel, q: &[f64], coeffs: &[f64]) -> Result<(), TestCaseError> {
    let na = model.machine().n_axes();
    let (first, exact) = batched(model, q, coeffs, BatchKernel::Detect);
    let (first_p, exact_p) = batched(model, q, coeffs, BatchKernel::Portable);
    let bits = |v: &[[f64; 6]]| -> Vec<u64> { v.iter().flatten().map(|x| x.to_bits()).collect() };
    prop_assert_eq!(bits(&first), bits(&first_p), "kernels differ (first order)");
    prop_assert_eq!(bits(&exact), bits(&exact_p), "kernels differ (exact)");
    let size = machine_size(model.machine());
    let mut ws = model.workspace();
    for (k, pose) in q.chunks(na).enumerate() {
        let want_first = model
            .pose_error_first_order(pose, coeffs, &mut ws)
            .to_array();
        let want_exact = model.pose_error(pose, coeffs, &mut ws).to_array();
        for (what, got, want, abs) in [
            ("first order", first[k], want_first, 0.0),
            ("exact", exact[k], want_exact, 2e-15 * size),
        ] {
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for r in 0..6 {
                prop_assert!(
                    (got[r] - want[r]).abs() <= 1e-12 * scale + abs,
                    "{what}, pose {k} of {}, row {r}: batched {:e} per pose {:e}",
                    q.len() / na,
                    got[r],
                    want[r]
                );
            }
        }
    }
    Ok(())
}

fn mixes() -> impl Strategy<Value = Mix> {
    prop_oneof![Just(Mix::Prismatic), Just(Mix::Rotary), Just(Mix::Mixed)]
}

/// A random case of `support::case` with 1 to 11 poses (partial chunks of every size) and
/// coefficients of error size (2e-5) or large (1e-2: rotations beyond the small-angle series,
/// which the lanes leave to the scalar functions).
fn batch_case() -> impl Strategy<Value = (MachineModel, Vec<f64>, Vec<f64>)> {
    (
        mixes().prop_flat_map(case),
        proptest::collection::vec(0.0..1.0f64, 11 * 9),
        1..=11usize,
        prop::sample::select(vec![1.0, 500.0]),
    )
        .prop_map(|((model, _, coeffs), u, n, scale)| {
            let q: Vec<f64> = u
                .chunks(9)
                .take(n)
                .flat_map(|u| positions(model.machine(), u))
                .collect();
            let coeffs = coeffs.iter().map(|c| c * scale).collect();
            (model, q, coeffs)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(160))]

    /// Random machines (random origins, tilted axes), random error models mixing every basis,
    /// random poses: batched equals per pose.
    #[test]
    fn batched_equals_per_pose((model, q, coeffs) in batch_case()) {
        check(&model, &q, &coeffs)?;
    }
}

fn joint(letter: char, kind: AxisKind, axis: [f64; 3], at: [f64; 3], turn: [f64; 3]) -> JointSpec {
    JointSpec {
        letter,
        kind,
        origin: Isometry3::from_parts(
            Translation3::from(Vector3::from(at)),
            UnitQuaternion::from_scaled_axis(Vector3::from(turn)),
        ),
        axis: Vector3::from(axis),
        limits: match kind {
            AxisKind::Linear => Some((-0.4, 0.6)),
            AxisKind::Rotary => None,
        },
    }
}

/// A five-axis machine with a tilted B axis (a general rotation, not about a coordinate axis),
/// turned joint frames and an aligned C: every shape of joint the kernel distinguishes.
fn machine() -> Machine {
    use AxisKind::{Linear, Rotary};
    let spec = MachineSpec {
        name: "batch".into(),
        workpiece: BranchSpec {
            joints: vec![
                joint(
                    'B',
                    Rotary,
                    [0.0, -0.6, 0.8],
                    [0.0, 0.0, 0.1],
                    [0.1, 0.0, 0.0],
                ),
                joint('C', Rotary, [0.0, 0.0, 1.0], [0.01, -0.02, -0.1], [0.0; 3]),
            ],
            end: Isometry3::translation(0.05, 0.0, 0.02),
        },
        tool: BranchSpec {
            joints: vec![
                joint('Y', Linear, [0.0, 1.0, 0.0], [0.0, 0.0, 1.2], [0.0; 3]),
                joint(
                    'X',
                    Linear,
                    [1.0, 0.0, 0.0],
                    [0.0, 0.2, -0.1],
                    [0.0, 0.0, 0.3],
                ),
                joint('Z', Linear, [0.0, 0.0, 1.0], [0.0, 0.15, -0.15], [0.0; 3]),
            ],
            end: Isometry3::from_parts(
                Translation3::new(0.0, 0.0, -0.2),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.2, 0.0)),
            ),
        },
    };
    Machine::try_new(&spec).expect("valid machine")
}

/// Every component of every axis in `basis(axis kind, stroke)`, every location and set-up error.
fn model_with(basis: impl Fn(AxisKind, (f64, f64)) -> Basis) -> MachineModel {
    let m = machine();
    let cubic = BasisChoice::Legendre { degree: 3 };
    let mut config = iso_full_config(&m, &cubic, &cubic).expect("ISO model");
    for ax in m.axes() {
        let stroke = ax
            .limits()
            .unwrap_or((-std::f64::consts::PI, std::f64::consts::PI));
        for d in Direction::ALL {
            let name = ParamName::component(d, ax.letter());
            let c = config
                .iter_mut()
                .find(|c| c.name == name)
                .expect("component");
            c.basis = Some(basis(ax.kind(), stroke));
        }
    }
    for d in Direction::ALL {
        if !d.is_rotation() {
            config.push(setup(Setup::Tool(d)));
        }
        config.push(setup(Setup::Workpiece(d)));
    }
    MachineModel::new(m, &config).expect("model")
}

fn setup(s: Setup) -> ParamConfig {
    ParamConfig {
        name: ParamName::Setup(s),
        basis: None,
    }
}

/// Deterministic poses (`n` of them) and µm-sized coefficients.
fn poses_and_coeffs(model: &MachineModel, n: usize) -> (Vec<f64>, Vec<f64>) {
    let na = model.machine().n_axes();
    let q = (0..n)
        .flat_map(|s| {
            let u: Vec<f64> = (0..na)
                .map(|a| ((s * (a + 3) * 37 + 11) % 101) as f64 / 100.0)
                .collect();
            positions(model.machine(), &u)
        })
        .collect();
    let coeffs = (0..model.n_coeffs())
        .map(|k| 2e-6 * (((k * 7919) % 41) as f64 - 20.0))
        .collect();
    (q, coeffs)
}

/// A component's basis from its axis' kind and stroke.
type BasisFor = dyn Fn(AxisKind, (f64, f64)) -> Basis;

/// Each basis kind the error model supports, alone on every axis, in its packed and its
/// general form: shared-stroke Legendre (packed), Legendre beyond the packed degree or on
/// another stroke, Fourier (packed, and beyond the packed harmonics) on the rotary axes,
/// tables and B-splines; each at batch sizes 1 to 9.
#[test]
fn every_basis_kind_batched_equals_per_pose() {
    let legendre = |lo, hi, max| Basis::legendre(lo, hi, 0, max).expect("basis");
    let cases: Vec<(&str, Box<BasisFor>)> = vec![
        ("legendre", Box::new(move |_, (lo, hi)| legendre(lo, hi, 3))),
        (
            "legendre degree 9",
            Box::new(move |_, (lo, hi)| legendre(lo, hi, 9)),
        ),
        (
            "legendre on a shorter stroke",
            Box::new(move |_, (lo, hi)| legendre(lo + 0.1 * (hi - lo), hi, 2)),
        ),
        (
            "fourier",
            Box::new(move |kind, (lo, hi)| match kind {
                AxisKind::Rotary => Basis::fourier(0, 3).expect("basis"),
                AxisKind::Linear => legendre(lo, hi, 2),
            }),
        ),
        (
            "fourier beyond the packed harmonics",
            Box::new(move |kind, (lo, hi)| match kind {
                AxisKind::Rotary => Basis::fourier(1, 20).expect("basis"),
                AxisKind::Linear => legendre(lo, hi, 2),
            }),
        ),
        (
            "table",
            Box::new(|_, (lo, hi)| {
                let knots = (0..6).map(|i| lo + (hi - lo) * i as f64 / 5.0).collect();
                Basis::table(knots, true, false).expect("basis")
            }),
        ),
        (
            "b-spline",
            Box::new(|_, (lo, hi)| Basis::bspline(lo, hi, 6, false, true).expect("basis")),
        ),
    ];
    for (name, basis) in cases {
        let model = model_with(basis);
        for n in 1..=9 {
            let (q, coeffs) = poses_and_coeffs(&model, n);
            if let Err(e) = check(&model, &q, &coeffs) {
                panic!("{name}, {n} poses: {e}");
            }
        }
    }
}

/// The shipped kind of model (full ISO set, cubic Legendre) on a long batch: the case the
/// benchmarks time.
#[test]
fn full_iso_model_long_batch() {
    let m = machine();
    let cubic = BasisChoice::Legendre { degree: 3 };
    let config = iso_full_config(&m, &cubic, &cubic).expect("ISO model");
    let model = MachineModel::new(m, &config).expect("model");
    let (q, coeffs) = poses_and_coeffs(&model, 257);
    check(&model, &q, &coeffs).unwrap();
}

/// Changing the coefficients between calls repacks (the workspace is reused), and an empty
/// batch is no work.
#[test]
fn workspace_reuse_and_empty_batch() {
    let model = model_with(|_, (lo, hi)| Basis::legendre(lo, hi, 0, 3).expect("basis"));
    let (q, coeffs) = poses_and_coeffs(&model, 5);
    let mut ws = model.batch_workspace();
    let mut out = vec![[0.0; 6]; 5];
    model.pose_errors(&q, &coeffs, &mut ws, &mut out);
    let doubled: Vec<f64> = coeffs.iter().map(|c| 2.0 * c).collect();
    model.pose_errors_first_order(&q, &doubled, &mut ws, &mut out);
    let mut single = model.workspace();
    for (k, pose) in q.chunks(model.machine().n_axes()).enumerate() {
        let want = model
            .pose_error_first_order(pose, &doubled, &mut single)
            .to_array();
        for r in 0..6 {
            assert!((out[k][r] - want[r]).abs() <= 1e-12 * want[r].abs().max(1e-9));
        }
    }
    model.pose_errors(&[], &coeffs, &mut ws, &mut []);
}
