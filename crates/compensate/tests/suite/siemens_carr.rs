//! CYCLE800 swivel data ($TC_CARR): the written part program, applied the way the SINUMERIK
//! manuals say the control applies it, reproduces the identified model's tool pose relative to
//! the workpiece when the machine's errors are the ones $TC_CARR can hold (where the rotary
//! axis lines pass and how they tilt), and with every other error set the remaining difference
//! is exactly what those other errors cause: the list of errors not held is honest.
//!
//! The application below is written from the manuals, not from the writer: the file's text is
//! parsed here on its own, and
//! - head (IM9 p. 508, W1's chain): resulting tool length `L = I1 + R1·(I2 + R2·I3)` (tool
//!   length 0: the tool reference point is mtcal's tool point), tool tip = reference point − L,
//!   tool turned by `R1·R2`;
//! - table (IM9 p. 508): a workpiece point `w` goes to `I2 + R1·(I3 + R2·(I4 + w))` (P) or
//!   `I3 + R2·(I4 + w)` (M), from the machine reference point;
//! - `R(v, α)`: right-handed about the vector (W1: "positive for clockwise rotation facing the
//!   direction of the rotation vector"), α the position of the axis named in $TC_CARR21/22;
//! - machine coordinates: the axis positions X, Y, Z (mm) are the tool reference point's
//!   position, 0 where mtcal's tool point is with every axis at 0.

use crate::carr_control;
use crate::common;

use carr_control::{Record, record_of};
use common::{TOL_UM, load};
use mtcal_compensate::*;
use mtcal_kinematics::model::Role;
use mtcal_kinematics::{AxisKind, MachineModel};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;

/// The five-axis machines shipped with mtcal and their CYCLE800 type.
const MACHINES: [(&str, CarrKind); 5] = [
    ("mcu630-cafyxz.urdf", CarrKind::Part),
    ("mcv1000-5ax220-bc.urdf", CarrKind::Part),
    ("mu6300-caxfyz.urdf", CarrKind::Part),
    ("headhead-xyzca.urdf", CarrKind::Tool),
    ("mixed-c-table-b-head.urdf", CarrKind::Mixed),
];

// --- The model's side ------------------------------------------------------------------------

fn is_held(model: &MachineModel, role: &Role) -> bool {
    match *role {
        Role::Location { axis, direction } => {
            let a = &model.machine().axes()[axis];
            a.kind() == AxisKind::Rotary && direction.cartesian() != a.own_cartesian()
        }
        _ => false,
    }
}

/// Coefficients with the held location errors from `held` and everything else from `other`.
fn split(model: &MachineModel, coeffs: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut held, mut rest) = (vec![0.0; coeffs.len()], coeffs.to_vec());
    for p in model.errors().params() {
        if is_held(model, &p.role) {
            held[p.offset] = coeffs[p.offset];
            rest[p.offset] = 0.0;
        }
    }
    (held, rest)
}

/// Random coefficients: the held location errors up to 100 µm / 100 µrad; with `others`,
/// every other coefficient up to 5 µm / 5 µrad (components, squareness, set-up).
fn random_coeffs(model: &MachineModel, seed: u64, others: bool) -> Vec<f64> {
    let mut rng = mtcal_testkit::random::SplitMix64(seed);
    let mut c = vec![0.0; model.n_coeffs()];
    for p in model.errors().params() {
        let scale = if is_held(model, &p.role) {
            100e-6
        } else if others {
            5e-6
        } else {
            0.0
        };
        for k in 0..p.len {
            c[p.offset + k] = scale * rng.signed();
        }
    }
    c
}

/// Axis positions: linear ones anywhere in their strokes, rotary ones in their limits (one
/// turn when unlimited).
fn random_q(model: &MachineModel, rng: &mut mtcal_testkit::random::SplitMix64) -> Vec<f64> {
    model
        .machine()
        .axes()
        .iter()
        .map(|a| {
            let (lo, hi) = a
                .limits()
                .unwrap_or((-std::f64::consts::PI, std::f64::consts::PI));
            lo + (hi - lo) * rng.unit()
        })
        .collect()
}

/// The machine coordinates' origin in the workpiece frame, after checking that the shipped
/// machine's X, Y, Z move the tool along the workpiece frame's axes (so machine and workpiece
/// directions agree and the comparison needs no rotation).
fn origin(model: &MachineModel) -> Vector3<f64> {
    let m = model.machine();
    let zero = vec![0.0; m.n_axes()];
    let o = m.tool_in_workpiece(&zero).t;
    for (c, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        let mut q = zero.clone();
        q[m.axis_index(l).unwrap()] = 1.0;
        assert!((m.tool_in_workpiece(&q).t - o - Vector3::ith(c, 1.0)).norm() < 1e-12);
    }
    o
}

/// Over `poses` random poses: the control's tool point and turn from the record minus the
/// model's with `coeffs` (tool point in µm, turn as a rotation vector in µrad), each pose.
fn differences(
    model: &MachineModel,
    coeffs: &[f64],
    rec: &Record,
    poses: usize,
    seed: u64,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let m = model.machine();
    let o = origin(model);
    let idx = rec
        .axes
        .clone()
        .map(|a| m.axis_index(a.chars().next().unwrap()).unwrap());
    let lin = ['X', 'Y', 'Z'].map(|l| m.axis_index(l).unwrap());
    let mut ws = model.workspace();
    let r0 = m.tool_in_workpiece(&vec![0.0; m.n_axes()]).r;
    let mut rng = mtcal_testkit::random::SplitMix64(seed);
    (0..poses)
        .map(|_| {
            let q = random_q(model, &mut rng);
            let lin_mm = Vector3::new(q[lin[0]], q[lin[1]], q[lin[2]]) * 1e3;
            let (p_mm, turn) = rec.apply(lin_mm, [q[idx[0]].to_degrees(), q[idx[1]].to_degrees()]);
            let actual = model.tool_pose(&q, coeffs, &mut ws);
            let dp = (o + p_mm * 1e-3 - actual.t) * 1e6;
            let dr = small_turn(&(turn * r0 * actual.r.transpose())) * 1e6;
            (dp, dr)
        })
        .collect()
}

/// The rotation vector of a rotation within a few µrad of the identity, from its
/// antisymmetric part (an angle from the trace would lose half the digits).
fn small_turn(r: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    )
}

fn worst(d: &[(Vector3<f64>, Vector3<f64>)]) -> (f64, f64) {
    d.iter().fold((0.0f64, 0.0f64), |(a, b), (p, r)| {
        (a.max(p.norm()), b.max(r.norm()))
    })
}

fn text_of(model: &MachineModel, coeffs: &[f64]) -> (CarrData, String) {
    let data = carr_data(model, coeffs, 3, "mtcal five-axis").unwrap();
    let text = carr_text(&data, model.machine().name(), &[]).unwrap();
    (data, text)
}

// --- The tests -------------------------------------------------------------------------------

/// What the errors a record holds and those it does not turn the tool by together, beyond
/// the sum of what each does alone (second order), µrad.
const CROSS_TERMS_URAD: f64 = 0.05;

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// With only the errors $TC_CARR can hold, the control's chain reproduces the model's tool
    /// point within 0.1 µm (and its turn within 0.01 µrad) at random poses of every machine.
    #[test]
    fn the_control_applying_the_record_reproduces_the_model(
        machine in 0usize..MACHINES.len(),
        seed in any::<u64>(),
    ) {
        let (name, kind) = MACHINES[machine];
        let model = load(name);
        let coeffs = random_coeffs(&model, seed, false);
        let (data, text) = text_of(&model, &coeffs);
        prop_assert_eq!(data.kind, kind);
        prop_assert!(data.not_representable.is_empty(), "{:?}", data.not_representable);
        let rec = record_of(&text);
        let (dp, dr) = worst(&differences(&model, &coeffs, &rec, 60, seed ^ 1));
        prop_assert!(dp < TOL_UM, "{name}: tool point off by {dp} µm");
        prop_assert!(dr < 0.01, "{name}: tool turn off by {dr} µrad");
    }

    /// With every other error set as well, what remains is exactly what those errors cause on
    /// their own: the record holds all of the location errors it claims and nothing else, and
    /// the list of errors not held names exactly the others.
    #[test]
    fn what_remains_is_what_the_errors_not_held_cause(
        machine in 0usize..MACHINES.len(),
        seed in any::<u64>(),
    ) {
        let (name, _) = MACHINES[machine];
        let model = load(name);
        let coeffs = random_coeffs(&model, seed, true);
        let (held, rest) = split(&model, &coeffs);
        let (data, text) = text_of(&model, &coeffs);
        let rec = record_of(&text);
        let nominal = record_of(&carr_text(data.nominal.as_deref().unwrap(), name, &[]).unwrap());
        let residual = differences(&model, &coeffs, &rec, 40, seed ^ 2);
        // What the errors not held cause alone: the nominal record against the model with them.
        let alone = differences(&model, &rest, &nominal, 40, seed ^ 2);
        // Exactly but for the products of the errors held (up to 100 µrad) and the others (up
        // to 5 µrad a coefficient, several per axis): a few 10⁻⁸ rad of turn (seed
        // 13610979752508239187 gave 0.011 µrad).
        for ((p, r), (pa, ra)) in residual.iter().zip(&alone) {
            prop_assert!((p - pa).norm() < TOL_UM, "{name}: {p} vs {pa} µm");
            prop_assert!((r - ra).norm() < CROSS_TERMS_URAD, "{name}: {r} vs {ra} µrad");
        }
        // The errors not held do something, so the comparison can fail.
        prop_assert!(worst(&alone).0 > 1.0, "{name}: {:?}", worst(&alone));
        // Sanity of the split: the record of `held` alone is the same record.
        let (only, _) = text_of(&model, &held);
        prop_assert_eq!(&only.offsets_mm, &data.offsets_mm);
        prop_assert_eq!(&only.axis_vectors, &data.axis_vectors);
        let listed: Vec<&str> = data.not_representable.iter().map(|(n, _)| n.as_str()).collect();
        let expected: Vec<String> = model
            .errors()
            .params()
            .iter()
            .filter(|p| !is_held(&model, &p.role) && rest[p.offset..p.offset + p.len].iter().any(|v| *v != 0.0))
            .map(|p| p.name.to_string())
            .collect();
        prop_assert_eq!(listed, expected.iter().map(String::as_str).collect::<Vec<_>>());
        for (n, _) in &data.not_representable {
            prop_assert!(text.contains(&format!(";   {n} (")), "{n} not in the file");
        }
    }
}

#[test]
fn the_nominal_record_misses_identified_location_errors_the_test_can_fail() {
    for (name, _) in MACHINES {
        let model = load(name);
        let coeffs = random_coeffs(&model, 5, false);
        let (data, _) = text_of(&model, &coeffs);
        let nominal_text = carr_text(data.nominal.as_deref().unwrap(), name, &[]).unwrap();
        let (dp, _) = worst(&differences(
            &model,
            &coeffs,
            &record_of(&nominal_text),
            60,
            9,
        ));
        let text = carr_text(&data, name, &[]).unwrap();
        let (ok, ok_turn) = worst(&differences(&model, &coeffs, &record_of(&text), 60, 9));
        eprintln!(
            "{name}: {ok:.1e} µm ({ok_turn:.1e} µrad) with mtcal's record, {dp:.1} µm with the \
             nominal one"
        );
        assert!(ok < TOL_UM, "{name}: {ok} µm");
        assert!(dp > 20.0, "{name}: the nominal record is only {dp} µm off");
    }
}

#[test]
fn axis_vectors_follow_the_checklist_and_the_chain_closes() {
    for (name, kind) in MACHINES {
        let model = load(name);
        let data = carr_data(&model, &vec![0.0; model.n_coeffs()], 1, "n").unwrap();
        assert_eq!(data.kind, kind, "{name}");
        let m = model.machine();
        for k in 0..2 {
            let axis = &m.axes()[m.axis_index(data.axes[k].chars().next().unwrap()).unwrap()];
            let own = axis.letter().nominal_cartesian();
            let v = data.axis_vectors[k];
            // A head axis turns about +X/+Y/+Z, a table axis about −X/−Y/−Z (p. 581).
            let want = if kind.moves_tool(k) { 1.0 } else { -1.0 };
            assert_eq!(v[own], want, "{name} V{}: {v:?}", k + 1);
        }
        let i = data.offsets_mm.map(Vector3::from);
        let sum = match kind {
            CarrKind::Tool => i[0] + i[1] + i[2],
            CarrKind::Part => i[1] + i[2] + i[3],
            CarrKind::Mixed => i[0] + i[1] + i[2] + i[3],
        };
        assert!(sum.norm() < 1e-9, "{name}: {sum}");
    }
    // The trunnion: A (axis 1) carries C (axis 2); C's pivot is the table top centre, A's
    // 125 mm above it, so I3 runs 125 mm down.
    let model = load("mcu630-cafyxz.urdf");
    let data = carr_data(&model, &vec![0.0; model.n_coeffs()], 1, "n").unwrap();
    assert_eq!(data.axes, ["A".to_string(), "C".to_string()]);
    assert_eq!(data.offsets_mm[2], [0.0, 0.0, -125.0]);
    assert_eq!(data.axis_vectors, [[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]);
    assert_eq!(data.limits_deg, [(-30.0, 120.0), (0.0, 0.0)]);
}

#[test]
fn location_errors_move_the_pivots_and_tilt_the_vectors_by_their_own_size() {
    let model = load("mcu630-cafyxz.urdf");
    let mut coeffs = vec![0.0; model.n_coeffs()];
    let set = |c: &mut [f64], n: &str, v: f64| {
        let p = model.errors().find(&n.parse().unwrap()).unwrap();
        c[p.offset] = v;
    };
    set(&mut coeffs, "EX0C", 35e-6);
    set(&mut coeffs, "EY0A", 41e-6);
    set(&mut coeffs, "EA0C", 20e-6);
    let data = carr_data(&model, &coeffs, 1, "n").unwrap();
    let nom = data.nominal.as_deref().unwrap();
    let d = |k: usize, c: usize| data.offsets_mm[k][c] - nom.offsets_mm[k][c];
    // I2 reaches A's pivot: 41 µm further along Y; I3 from it to C's pivot: 35 µm along X,
    // 41 µm back along Y.
    assert!((d(1, 1) - 0.041).abs() < 2e-6 && d(1, 0).abs() < 2e-6);
    assert!((d(2, 0) - 0.035).abs() < 2e-6 && (d(2, 1) + 0.041).abs() < 2e-6);
    // C tilted 20 µrad about X: its vector (0, 0, −1) turns to (0, 20e-6, −1).
    assert!(
        (data.axis_vectors[1][1] - 20e-6).abs() < 1e-9,
        "{:?}",
        data.axis_vectors
    );
}

#[test]
fn records_round_trip_through_the_file() {
    for (k, (name, _)) in MACHINES.into_iter().enumerate() {
        let model = load(name);
        let coeffs = random_coeffs(&model, 40 + k as u64, true);
        let data = carr_data(&model, &coeffs, 7, "swivel 7").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("carr.mpf");
        write_carr(&path, &data, name, &[]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.is_ascii());
        assert!(text.trim_end().ends_with("M30"));
        assert!(text.contains("$TC_CARR23[7]=\""));
        assert!(text.contains("; format"), "the card is in the file");
        let back = read_carr(&path).unwrap();
        let mut expect = data.clone();
        expect.nominal = None;
        expect.not_representable.clear();
        assert_eq!(back, expect, "{name}");
    }
}

/// The trunnion's record without errors, to break in the validator tests.
fn sample() -> CarrData {
    let model = load("mcu630-cafyxz.urdf");
    carr_data(&model, &vec![0.0; model.n_coeffs()], 1, "trunnion").unwrap()
}

#[test]
fn the_validator_refuses_what_the_control_would_refuse_or_misread() {
    let check = |d: CarrData, want: &str| {
        let e = d.validate().unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
        let e = carr_text(&d, "m", &[]).unwrap_err().to_string();
        assert!(e.contains(want), "{e}");
    };
    let mut d = sample();
    d.offsets_mm[3][0] += 0.1;
    check(d, "the offset chain does not close, I2 + I3 + I4");
    let mut d = sample();
    d.offsets_mm[0] = [1.0, 0.0, 0.0];
    check(d, "I1 has no part in this kinematics");
    let mut d = sample();
    d.axis_vectors[0] = [0.0; 3];
    check(d, "V1 is zero");
    let mut d = sample();
    d.axis_vectors[1] = [0.0, 0.0, 1.0];
    check(
        d,
        "of C (table axis) has Z 1: the CYCLE800 checklist turns a table axis about -Z",
    );
    let mut d = sample();
    d.kind = CarrKind::Tool;
    d.offsets_mm = [[0.0, 0.0, 125.0], [0.0, 0.0, -125.0], [0.0; 3], [0.0; 3]];
    check(d, "V1 of A (head axis) has X -1");
    let mut d = sample();
    for v in &mut d.offsets_mm {
        for x in v.iter_mut() {
            *x *= 1e3;
        }
    }
    check(d, "unit mistake");
    let mut d = sample();
    d.number = 0;
    check(d, "clears them all");
    let mut d = sample();
    d.name = "say \"hi\"".into();
    check(d, "record name");
    let mut d = sample();
    d.name = "x".repeat(33);
    check(d, "too long");
    let mut d = sample();
    d.axes[0] = "1A".into();
    check(d, "not an axis identifier");
    let mut d = sample();
    d.limits_deg[0] = (10.0, -10.0);
    check(d, "minimum 10° is above maximum -10°");
    let mut d = sample();
    d.offsets_mm[1][2] = f64::NAN;
    check(d, "not finite");
    assert!(sample().validate().is_ok());
}

#[test]
fn machines_the_kinematics_types_cannot_express_are_refused() {
    let model = load("mcv754-zfyx.urdf");
    let e = carr_data(&model, &vec![0.0; model.n_coeffs()], 1, "n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cannot describe this machine") && e.contains("the machine has none"),
        "{e}"
    );
    // A linear axis carried by a rotary one (a quill on a swivel head).
    use mtcal_kinematics::{BranchSpec, JointSpec, Machine, MachineSpec};
    use nalgebra::Isometry3;
    let joint = |letter, kind, axis: [f64; 3]| JointSpec {
        letter,
        kind,
        origin: Isometry3::identity(),
        axis: Vector3::from(axis),
        limits: Some((-1.0, 1.0)),
    };
    let spec = MachineSpec {
        name: "quill".into(),
        workpiece: BranchSpec {
            joints: vec![joint('X', AxisKind::Linear, [-1.0, 0.0, 0.0])],
            end: Isometry3::identity(),
        },
        tool: BranchSpec {
            joints: vec![
                joint('Y', AxisKind::Linear, [0.0, 1.0, 0.0]),
                joint('C', AxisKind::Rotary, [0.0, 0.0, 1.0]),
                joint('A', AxisKind::Rotary, [1.0, 0.0, 0.0]),
                joint('Z', AxisKind::Linear, [0.0, 0.0, 1.0]),
            ],
            end: Isometry3::identity(),
        },
    };
    let model = MachineModel::new(Machine::try_new(&spec).unwrap(), &[]).unwrap();
    let e = carr_data(&model, &[], 1, "n").unwrap_err().to_string();
    assert!(e.contains("rotary axis A carries linear axis Z"), "{e}");
    let model = load("mcu630-cafyxz.urdf");
    assert!(matches!(
        carr_data(&model, &[0.0], 1, "n"),
        Err(CompensateError::CoeffsLength { .. })
    ));
}

/// Writes `text` to a file and reads it, returning the error message.
fn read_error(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.mpf");
    std::fs::write(&path, text).unwrap();
    let e = read_carr(&path).unwrap_err().to_string();
    let shown = path.display().to_string();
    assert!(e.starts_with(&shown), "{e}");
    e[shown.len()..].to_string()
}

/// The sample's file with the first `replace` replaced by `with`.
fn edited(replace: &str, with: &str) -> String {
    let text = carr_text(&sample(), "m", &[]).unwrap();
    assert!(text.contains(replace), "{replace}");
    text.replacen(replace, with, 1)
}

/// The 1-based line number of the first line containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn bad_files_are_refused_with_file_line_and_column() {
    let text = carr_text(&sample(), "m", &[]).unwrap();
    let at = |needle: &str| line_of(&text, needle);
    let cases: Vec<(String, String)> = vec![
        (
            edited("$TC_CARR4[1]=", "$TC_CARR41[1]=0 $TC_CARR4[1]="),
            format!(
                ":{}:1: $TC_CARR41 is not a field mtcal's swivel data set",
                at("$TC_CARR4[1]=")
            ),
        ),
        (
            edited("$TC_CARR5[1]=", "$TC_CARR4[1]=1 $TC_CARR5[1]="),
            format!(":{}:1: $TC_CARR4 is set twice", at("$TC_CARR5[1]=")),
        ),
        (
            edited("$TC_CARR6[1]=", "$TC_CARR6[1]=1,5 ;"),
            format!(
                ":{}:14: $TC_CARR6: expected a number, found `1,5`",
                at("$TC_CARR6[1]=")
            ),
        ),
        (
            edited("$TC_CARR7[1]=", "$TC_CARR7[2]="),
            format!(
                ":{}:1: every assignment must set record 1",
                at("$TC_CARR7[1]=")
            ),
        ),
        (
            edited("$TC_CARR23[1]=\"P\"", "$TC_CARR23[1]=\"X\""),
            format!(
                ":{}:15: $TC_CARR23: expected the kinematics type",
                at("$TC_CARR23[")
            ),
        ),
        (
            edited("$TC_CARR23[1]=\"P\"", "$TC_CARR23[1]=P"),
            format!(":{}:15: $TC_CARR23 takes a string", at("$TC_CARR23[")),
        ),
        (
            edited("$TC_CARR24[1]=0.000000", "$TC_CARR24[1]=5"),
            format!(":{}:15: $TC_CARR24: mtcal's swivel data", at("$TC_CARR24[")),
        ),
        (
            edited("$TC_CARR34[1]=\"trunnion\"", "$TC_CARR34[1]=\"trunnion"),
            format!(":{}:15: this string has no closing", at("$TC_CARR34[")),
        ),
        (
            edited("$TC_CARR35[1]=\"A\"", "$TC_CARR35[1]=\"B\""),
            format!(
                ":{}:15: $TC_CARR35: CYCLE800's axis name",
                at("$TC_CARR35[")
            ),
        ),
        (
            edited("M30\n", ""),
            format!(
                ":{}:1: expected the program end `M30`",
                text.lines().count()
            ),
        ),
        (
            edited("M30\n", "M30\nG0 X0\n"),
            format!(
                ":{}:1: nothing may follow the program end",
                text.lines().count() + 1
            ),
        ),
        (
            edited("$TC_CARR8[1]=", "G1 $TC_CARR8[1]="),
            format!(
                ":{}:1: expected `$TC_CARRk[n]=value`, `M30`",
                at("$TC_CARR8[1]=")
            ),
        ),
        (
            edited("$TC_CARR9[1]=0.000000000", "; gone"),
            format!(":{}:1: $TC_CARR9 is missing", text.lines().count() + 1),
        ),
        (
            edited("$TC_CARR18[1]=0.000000", "$TC_CARR18[1]=0.500000"),
            format!(
                ":{}:15: kinematics P: the offset chain does not close",
                at("$TC_CARR18[")
            ),
        ),
        (
            edited("$TC_CARR12[1]=-1.000000000", "$TC_CARR12[1]=1.000000000"),
            format!(
                ":{}:15: rotary axis vector V2 of C (table axis)",
                at("$TC_CARR12[")
            ),
        ),
    ];
    for (text, want) in cases {
        let e = read_error(&text);
        assert!(e.starts_with(&want), "got  {e}\nwant {want}");
    }
}

#[test]
fn the_reader_accepts_block_numbers_blanks_and_several_assignments_per_line() {
    let text = carr_text(&sample(), "m", &[]).unwrap();
    let mut loose = String::new();
    for (k, line) in text.lines().enumerate() {
        let code = line.split(';').next().unwrap().trim();
        if code.is_empty() {
            continue;
        }
        // W1's example style: `N170 $TC_CARR15[1] = 0  ; comment`.
        loose.push_str(&format!(
            "N{} {} ; c\n",
            10 * (k + 1),
            code.replacen('=', " = ", 1)
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("loose.mpf");
    std::fs::write(&path, loose).unwrap();
    assert_eq!(read_carr(&path).unwrap().offsets_mm, sample().offsets_mm);
    let joined = text.replace("\n$TC_CARR2[", " $TC_CARR2[");
    let joined = joined.replace(" ; I1 X mm $TC_CARR2[", " $TC_CARR2[");
    std::fs::write(&path, joined).unwrap();
    assert_eq!(read_carr(&path).unwrap().offsets_mm, sample().offsets_mm);
}
