//! LinuxCNC table-table pivots: with the pivot parameters mtcal exports, LinuxCNC's
//! `xyzac-trt-kins` forward kinematics (its equations, written out below from the kinematics'
//! geometry: undo the A tilt about its line, then the C turn about its line) reproduce the
//! identified model's tool point relative to the workpiece, when the machine's errors are the
//! ones those kinematics can hold (where the C and A lines pass).

use crate::common;
use crate::trt_control;

use common::load;
use mtcal_compensate::*;
use mtcal_kinematics::{MachineModel, ParamName};
use nalgebra::Vector3;
use trt_control::{xyzac_forward, xyzbc_forward};

/// A LinuxCNC trt forward kinematics: joints (mm, deg) → workpiece coordinates (mm).
type Forward = fn(&TrtPivots, [f64; 5]) -> Vector3<f64>;

/// The largest distance (mm) over 500 random poses between LinuxCNC's forward kinematics
/// `forward` with pivots `p` and the model's actual tool point (joint coordinates), for
/// `p` and for `nominal`. LinuxCNC's trt kinematics turn the rotary axes the other way from
/// the CNC (ISO 841) convention mtcal follows (its source says so): its angles are mtcal's
/// negated.
fn worst_against_model(
    model: &MachineModel,
    coeffs: &[f64],
    letters: [char; 5],
    forward: Forward,
    p: &TrtPivots,
    nominal: &TrtPivots,
    seed: u64,
) -> (f64, f64) {
    let m = model.machine();
    let idx = letters.map(|l| m.axis_index(l).unwrap());
    let origin = m.tool_in_workpiece(&vec![0.0; m.n_axes()]).t;
    let mut ws = model.workspace();
    let (mut worst, mut nominal_worst) = (0.0f64, 0.0f64);
    let mut lcg = mtcal_testkit::random::Lcg64(seed);
    for _ in 0..500 {
        let mut q = vec![0.0; m.n_axes()];
        for &i in &idx {
            let (lo, hi) = m.axes()[i]
                .limits()
                .unwrap_or((-std::f64::consts::PI, std::f64::consts::PI));
            q[i] = lo + (hi - lo) * lcg.unit();
        }
        let actual = (model.tool_pose(&q, coeffs, &mut ws).t - origin) * 1e3;
        let j = [
            q[idx[0]] * 1e3,
            q[idx[1]] * 1e3,
            q[idx[2]] * 1e3,
            -q[idx[3]].to_degrees(),
            -q[idx[4]].to_degrees(),
        ];
        worst = worst.max((forward(p, j) - actual).norm());
        nominal_worst = nominal_worst.max((forward(nominal, j) - actual).norm());
    }
    (worst, nominal_worst)
}

fn set(model: &MachineModel, coeffs: &mut [f64], name: &str, value: f64) {
    let n: ParamName = name.parse().unwrap();
    let p = model
        .errors()
        .find(&n)
        .unwrap_or_else(|| panic!("{name} not in the model"));
    coeffs[p.offset] = value;
}

#[test]
fn linuxcnc_xyzac_kinematics_with_mtcal_pivots_match_the_model() {
    let model = load("mcu630-cafyxz.urdf");
    let mut coeffs = vec![0.0; model.n_coeffs()];
    // Where the C and A lines pass: tens of µm off nominal.
    for (name, v) in [
        ("EX0C", 35e-6),
        ("EY0C", -22e-6),
        ("EY0A", 41e-6),
        ("EZ0A", -18e-6),
    ] {
        set(&model, &mut coeffs, name, v);
    }
    let p = trt_pivots_with_nominal(&model, &coeffs).unwrap();
    assert_eq!(p.kind, TrtKind::Xyzac);
    assert!(p.not_representable.is_empty(), "{:?}", p.not_representable);
    let n = p.nominal.as_ref().as_ref().unwrap();
    // The location errors move the pivots by their own size.
    assert!((p.x_rot_point_mm - n.x_rot_point_mm - 0.035).abs() < 1e-9);
    assert!((p.y_rot_point_mm - n.y_rot_point_mm + 0.022).abs() < 1e-9);
    assert!(
        (p.y_rot_point_mm + p.y_offset_mm - n.y_rot_point_mm - n.y_offset_mm - 0.041).abs() < 1e-9
    );
    assert!((p.z_rot_point_mm - n.z_rot_point_mm + 0.018).abs() < 1e-9);

    let (worst, nominal_worst) = worst_against_model(
        &model,
        &coeffs,
        ['X', 'Y', 'Z', 'A', 'C'],
        xyzac_forward,
        &p,
        n,
        7,
    );
    eprintln!(
        "LinuxCNC kinematics vs model: {worst:.1e} mm with mtcal's pivots, {nominal_worst:.4} mm with nominal ones"
    );
    assert!(worst < 1e-7, "{worst} mm");
    // Without the identified pivots LinuxCNC would be off by tens of µm: the test can fail.
    assert!(nominal_worst > 0.02, "{nominal_worst} mm");
}

#[test]
fn errors_the_pivots_cannot_hold_are_reported_and_written() {
    let model = load("mcu630-cafyxz.urdf");
    let mut coeffs = vec![0.0; model.n_coeffs()];
    set(&model, &mut coeffs, "EA0C", 12e-6);
    set(&model, &mut coeffs, "EC0Y", -8e-6);
    let p = trt_pivots_with_nominal(&model, &coeffs).unwrap();
    let names: Vec<&str> = p
        .not_representable
        .iter()
        .map(|(n, _)| n.as_str())
        .collect();
    assert_eq!(
        names,
        ["EC0Y", "EA0C"]
            .iter()
            .filter(|n| names.contains(n))
            .copied()
            .collect::<Vec<_>>()
    );
    assert!(
        names.contains(&"EA0C") && names.contains(&"EC0Y"),
        "{names:?}"
    );
    let text = trt_hal_text(&p, "mcu630");
    assert!(text.contains("setp xyzac-trt-kins.x-rot-point "));
    assert!(text.contains("setp xyzac-trt-kins.y-offset "));
    assert!(text.contains("not held by these kinematics"));
    assert!(text.contains("EA0C (12.000)"), "{text}");
}

#[test]
fn machines_without_a_table_table_pair_are_refused() {
    for (name, want) in [
        ("mcv754-zfyx.urdf", "the machine has none"),
        ("headhead-xyzca.urdf", "on the table"),
    ] {
        let model = load(name);
        let e = trt_pivots(&model, &vec![0.0; model.n_coeffs()])
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{name}: {e}");
    }
}

#[test]
fn linuxcnc_xyzbc_kinematics_with_mtcal_pivots_match_the_model() {
    let model = load("mcv1000-5ax220-bc.urdf");
    let mut coeffs = vec![0.0; model.n_coeffs()];
    for (name, v) in [
        ("EX0C", -28e-6),
        ("EY0C", 17e-6),
        ("EX0B", 33e-6),
        ("EZ0B", 21e-6),
    ] {
        set(&model, &mut coeffs, name, v);
    }
    let p = trt_pivots_with_nominal(&model, &coeffs).unwrap();
    assert_eq!(p.kind, TrtKind::Xyzbc);
    assert!(p.not_representable.is_empty(), "{:?}", p.not_representable);
    let n = p.nominal.as_ref().as_ref().unwrap();
    assert!((p.x_rot_point_mm - n.x_rot_point_mm + 0.028).abs() < 1e-9);
    assert!(
        (p.x_rot_point_mm + p.x_offset_mm - n.x_rot_point_mm - n.x_offset_mm - 0.033).abs() < 1e-9
    );
    assert!((p.z_rot_point_mm - n.z_rot_point_mm - 0.021).abs() < 1e-9);

    let (worst, nominal_worst) = worst_against_model(
        &model,
        &coeffs,
        ['X', 'Y', 'Z', 'B', 'C'],
        xyzbc_forward,
        &p,
        n,
        11,
    );
    eprintln!("xyzbc: {worst:.1e} mm with mtcal's pivots, {nominal_worst:.4} mm with nominal ones");
    assert!(worst < 1e-7, "{worst} mm");
    assert!(nominal_worst > 0.02, "{nominal_worst} mm");
}
