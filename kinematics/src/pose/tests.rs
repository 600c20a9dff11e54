use super::*;
use crate::machine::{BranchSpec, JointSpec, MachineSpec};
use crate::model::{BasisChoice, iso_full_config};
use nalgebra::{Isometry3, Translation3};

fn joint(letter: char, kind: AxisKind, axis: [f64; 3], at: [f64; 3]) -> JointSpec {
    JointSpec {
        letter,
        kind,
        origin: Isometry3::from_parts(Translation3::from(Vector3::from(at)), Default::default()),
        axis: Vector3::from(axis),
        limits: Some((-2.0, 2.0)),
    }
}

/// A trunnion with axes along `±e_k` and joint frames aligned with the machine's, so that
/// every shortcut of the plan applies, and the same model with the shortcuts switched off.
fn aligned_and_general() -> (MachineModel, MachineModel) {
    use AxisKind::{Linear, Rotary};
    let spec = MachineSpec {
        name: "aligned".into(),
        workpiece: BranchSpec {
            joints: vec![
                joint('A', Rotary, [-1.0, 0.0, 0.0], [0.0, 0.0, 0.125]),
                joint('C', Rotary, [0.0, 0.0, -1.0], [0.01, -0.02, -0.125]),
            ],
            end: Isometry3::translation(0.05, 0.0, 0.02),
        },
        tool: BranchSpec {
            joints: vec![
                joint('Y', Linear, [0.0, 1.0, 0.0], [0.0, 0.0, 1.2]),
                joint('X', Linear, [1.0, 0.0, 0.0], [0.0, 0.2, -0.1]),
                joint('Z', Linear, [0.0, 0.0, 1.0], [0.0, 0.15, -0.15]),
                joint('B', Rotary, [0.0, -1.0, 0.0], [0.0, 0.0, -0.3]),
            ],
            end: Isometry3::translation(0.0, 0.0, -0.2),
        },
    };
    let machine = Machine::try_new(&spec).expect("valid machine");
    let cubic = BasisChoice::Legendre { degree: 3 };
    let config = iso_full_config(&machine, &cubic, &cubic).expect("ISO model");
    let fast = MachineModel::new(machine, &config).expect("model");
    let mut general = fast.clone();
    for ap in &mut general.plan.axes {
        ap.along_basis = None;
        ap.r0t_is_identity = false;
        ap.origin_is_translation = false;
    }
    general.plan.tool_end_is_translation = false;
    general.plan.wp_end_is_translation = false;
    assert!(fast.plan.axes.iter().all(|a| a.r0t_is_identity));
    assert!(fast.plan.axes.iter().all(|a| a.along_basis.is_some()));
    (fast, general)
}

/// The plan's shortcuts for coordinate-aligned axes (planar turns, no `r0t` products) give
/// the general path's results to rounding, on every evaluation path.
#[test]
fn aligned_axis_shortcuts_change_nothing() {
    let (fast, general) = aligned_and_general();
    let n = fast.n_coeffs();
    let coeffs: Vec<f64> = (0..n)
        .map(|k| 1e-5 * (((k * 7919) % 41) as f64 - 20.0) / 20.0)
        .collect();
    let (mut wf, mut wg) = (fast.workspace(), general.workspace());
    let (mut jf, mut jg) = (vec![0.0; 6 * n], vec![0.0; 6 * n]);
    let na = fast.machine().n_axes();
    let (mut af, mut ag) = (vec![0.0; 6 * na], vec![0.0; 6 * na]);
    let close = |a: &[f64], b: &[f64], what: &str| {
        for (k, (x, y)) in a.iter().zip(b).enumerate() {
            assert!((x - y).abs() < 1e-15, "{what}[{k}]: {x:e} vs {y:e}");
        }
    };
    for s in 0..20 {
        let q: Vec<f64> = (0..na)
            .map(|a| -1.9 + 3.8 * (((s * (a + 3) * 37) % 101) as f64 / 100.0))
            .collect();
        let f = fast.pose_error_first_order(&q, &coeffs, &mut wf).to_array();
        let g = general
            .pose_error_first_order(&q, &coeffs, &mut wg)
            .to_array();
        close(&f, &g, "first order");
        let f = fast
            .pose_error_jacobian(&q, &coeffs, &mut wf, &mut jf)
            .to_array();
        let g = general
            .pose_error_jacobian(&q, &coeffs, &mut wg, &mut jg)
            .to_array();
        close(&f, &g, "exact");
        close(&jf, &jg, "parameter jacobian");
        let f = fast.tool_pose_jacobian(&q, &coeffs, &mut wf, &mut jf);
        let g = general.tool_pose_jacobian(&q, &coeffs, &mut wg, &mut jg);
        close(f.r.as_slice(), g.r.as_slice(), "tool pose rotation");
        close(f.t.as_slice(), g.t.as_slice(), "tool pose translation");
        close(&jf, &jg, "tool pose jacobian");
        fast.tool_jacobian(&q, &coeffs, &mut wf, &mut af);
        general.tool_jacobian(&q, &coeffs, &mut wg, &mut ag);
        close(&af, &ag, "axis jacobian");
    }
}
