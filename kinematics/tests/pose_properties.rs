//! Ground truth for the pose-error model: properties over random machines and random error
//! models, analytic Jacobians against central finite differences, and an independent slow
//! formulation (plain 4×4 homogeneous matrices) against the fast path.

mod support;

use mtcal_kinematics::model::Role;
use mtcal_kinematics::{
    AxisKind, BranchSpec, Direction, JointSpec, Machine, MachineModel, MachineSpec, ParamConfig,
    ParamName, Side,
};
use nalgebra::{Isometry3, Matrix4, Rotation3, Translation3, Vector3};
use proptest::prelude::*;
use support::{Mix, case};

fn mixes() -> impl Strategy<Value = Mix> {
    prop_oneof![Just(Mix::Prismatic), Just(Mix::Rotary), Just(Mix::Mixed)]
}

fn any_case() -> impl Strategy<Value = (MachineModel, Vec<f64>, Vec<f64>)> {
    mixes().prop_flat_map(case)
}

fn config() -> ProptestConfig {
    ProptestConfig::with_cases(96)
}

// ---------------------------------------------------------------------------------------------
// The independent slow formulation: every factor a 4×4 matrix, rotations from nalgebra's own
// axis-angle constructors, component values from the bases one by one.

fn h(r: Rotation3<f64>, t: Vector3<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(r.matrix());
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
    m
}

fn iso(i: &Isometry3<f64>) -> Matrix4<f64> {
    i.to_homogeneous()
}

/// Value of every named parameter at axis positions `q` (SI).
fn values(model: &MachineModel, q: &[f64], coeffs: &[f64]) -> Vec<(ParamName, f64)> {
    model
        .errors()
        .params()
        .iter()
        .map(|p| {
            let c = &coeffs[p.offset..p.offset + p.len];
            let v = match &p.role {
                Role::Component { axis, basis, .. } => basis.value(q[*axis], c),
                _ => c[0],
            };
            (p.name, v)
        })
        .collect()
}

fn get(vals: &[(ParamName, f64)], name: &str) -> f64 {
    let n: ParamName = name.parse().unwrap();
    vals.iter().filter(|(m, _)| *m == n).map(|(_, v)| v).sum()
}

/// `frame_T_end` of one branch, with every error inserted, as a product of 4×4 matrices.
fn slow_branch(m: &Machine, side: Side, q: &[f64], vals: &[(ParamName, f64)]) -> Matrix4<f64> {
    let spec = m.to_spec();
    let b = match side {
        Side::Workpiece => &spec.workpiece,
        Side::Tool => &spec.tool,
    };
    let mut t: Matrix4<f64> = Matrix4::identity();
    let mut r0: Rotation3<f64> = Rotation3::identity();
    for j in &b.joints {
        let letter = j.letter;
        let ax = &m.axes()[m.axis_index(letter).unwrap()];
        t *= iso(&j.origin);
        r0 *= j.origin.rotation.to_rotation_matrix();
        // Machine-direction values → local vectors.
        let mv = |kind: &str, rot: bool| {
            let f = |c: char| {
                let d = Direction::from_parts(rot, "XYZ".find(c).unwrap());
                get(vals, &format!("E{}{}{}", d.letter(), kind, letter))
            };
            r0.inverse() * Vector3::new(f('X'), f('Y'), f('Z'))
        };
        let (mut de, mut ee) = (mv("", false), mv("", true));
        let (mut lt, mut lr) = (mv("0", false), mv("0", true));
        if ax.kind() == AxisKind::Rotary {
            // Own-direction location errors are constants of the component errors.
            let own = ax.own_cartesian();
            let own_local = r0.inverse() * Vector3::ith(own, 1.0);
            let (a, b) = (
                get(
                    vals,
                    &format!("E{}0{}", "XYZ".as_bytes()[own] as char, letter),
                ),
                get(
                    vals,
                    &format!("E{}0{}", "ABC".as_bytes()[own] as char, letter),
                ),
            );
            de += own_local * a;
            ee += own_local * b;
            lt -= own_local * a;
            lr -= own_local * b;
        }
        let e = h(Rotation3::from_scaled_axis(ee), de);
        let e_body = match side {
            Side::Tool => e,
            Side::Workpiece => e.try_inverse().unwrap(),
        };
        let axis = nalgebra::Unit::new_normalize(j.axis);
        match ax.kind() {
            AxisKind::Linear => {
                let dir = Rotation3::from_scaled_axis(lr) * axis.into_inner();
                t *= h(
                    Rotation3::identity(),
                    dir * q[m.axis_index(letter).unwrap()],
                );
                t *= e_body;
            }
            AxisKind::Rotary => {
                let l = h(Rotation3::from_scaled_axis(lr), lt);
                let rot = h(
                    Rotation3::from_axis_angle(&axis, q[m.axis_index(letter).unwrap()]),
                    Vector3::zeros(),
                );
                t *= e_body;
                t = t * l * rot * l.try_inverse().unwrap();
            }
        }
    }
    t *= iso(&b.end);
    match side {
        Side::Tool => {
            let off = Vector3::new(
                get(vals, "TOOL_DX"),
                get(vals, "TOOL_DY"),
                get(vals, "TOOL_DZ"),
            );
            t * h(Rotation3::identity(), off)
        }
        Side::Workpiece => {
            let d = Vector3::new(get(vals, "WP_DX"), get(vals, "WP_DY"), get(vals, "WP_DZ"));
            let e = Vector3::new(get(vals, "WP_DA"), get(vals, "WP_DB"), get(vals, "WP_DC"));
            t * h(Rotation3::from_scaled_axis(e), d)
        }
    }
}

fn slow_pose(model: &MachineModel, q: &[f64], coeffs: &[f64]) -> Matrix4<f64> {
    let vals = values(model, q, coeffs);
    let m = model.machine();
    let w = slow_branch(m, Side::Workpiece, q, &vals);
    let t = slow_branch(m, Side::Tool, q, &vals);
    w.try_inverse().unwrap() * t
}

/// Rotation vector of a small rotation, written independently of the crate's `log_so3`:
/// `vee(R − Rᵀ)/2 = sin θ · axis`, so scale by θ / sin θ.
fn small_log(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    let v = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5;
    let s = v.norm();
    if s == 0.0 { v } else { v * (s.asin() / s) }
}

fn slow_pose_error(model: &MachineModel, q: &[f64], coeffs: &[f64]) -> [f64; 6] {
    let act = slow_pose(model, q, coeffs);
    let nom = slow_pose(model, q, &vec![0.0; coeffs.len()]);
    let dp = act.fixed_view::<3, 1>(0, 3) - nom.fixed_view::<3, 1>(0, 3);
    let ra = Rotation3::from_matrix_unchecked(act.fixed_view::<3, 3>(0, 0).into_owned());
    let rn = Rotation3::from_matrix_unchecked(nom.fixed_view::<3, 3>(0, 0).into_owned());
    let dr = small_log(&(ra * rn.inverse()));
    [dp[0], dp[1], dp[2], dr[0], dr[1], dr[2]]
}

/// Sum of all lever lengths in the chain, at least 1 m.
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

// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(config())]

    /// An independent slow 4×4-product formulation equals the fast exact path to 1e-8 µm.
    #[test]
    fn slow_formulation_equals_fast_path((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let fast = model.pose_error(&q, &c, &mut ws).to_array();
        let slow = slow_pose_error(&model, &q, &c);
        // 1e-8 µm = 1e-14 m for a machine of 1 m: rounding is about 1e-16 per metre of lever
        // per operation, and the two paths take a few dozen different operations along a chain
        // of four axes (a bound of 1e-15 failed at 1.3e-15 on one random machine on CI); any
        // formulation error shows at the errors' own scale, 1e-5 m, far above it.
        let size = machine_size(model.machine());
        for r in 0..6 {
            prop_assert!((fast[r] - slow[r]).abs() < 1e-14 * size, "row {r}: fast {} slow {}", fast[r], slow[r]);
        }
    }

    /// Zero parameters give the nominal kinematics exactly.
    #[test]
    fn zero_parameters_give_nominal((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let zero = vec![0.0; c.len()];
        prop_assert_eq!(model.pose_error(&q, &zero, &mut ws).to_array(), [0.0; 6]);
        prop_assert_eq!(model.pose_error_first_order(&q, &zero, &mut ws).to_array(), [0.0; 6]);
    }

    /// The first-order model agrees with the exact one to second order in the error size.
    #[test]
    fn first_order_agrees_to_second_order((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let gap = |s: f64, ws: &mut _| {
            let cs: Vec<f64> = c.iter().map(|v| v * s).collect();
            let e = model.pose_error(&q, &cs, ws).to_array();
            let f = model.pose_error_first_order(&q, &cs, ws).to_array();
            e.iter().zip(&f).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
        };
        let (big, small) = (gap(10.0, &mut ws), gap(1.0, &mut ws));
        // Ten times smaller errors → about a hundred times smaller gap (and never first order).
        prop_assert!(small <= big / 40.0 + 1e-16, "gap {small:e} at 1x vs {big:e} at 10x");
        // The second-order gap grows with the lever arms (the machine's size).
        let size = machine_size(model.machine());
        prop_assert!(small < 1e-8 * size, "gap {small:e} m for ~20 µm errors (size {size})");
    }

    /// The analytic Jacobian of the exact pose error equals central finite differences.
    #[test]
    fn parameter_jacobian_matches_finite_differences((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let n = model.n_coeffs();
        let mut jac = vec![0.0; 6 * n];
        model.pose_error_jacobian(&q, &c, &mut ws, &mut jac);
        let step = 1e-6;
        let mut cp = c.clone();
        for k in 0..n {
            cp[k] = c[k] + step;
            let plus = model.pose_error(&q, &cp, &mut ws).to_array();
            cp[k] = c[k] - step;
            let minus = model.pose_error(&q, &cp, &mut ws).to_array();
            cp[k] = c[k];
            for r in 0..6 {
                let fd = (plus[r] - minus[r]) / (2.0 * step);
                let an = jac[6 * k + r];
                prop_assert!((fd - an).abs() < 1e-8 * (1.0 + an.abs()),
                    "coefficient {} row {r}: analytic {an} fd {fd}", model.errors().coefficient_labels()[k]);
            }
        }
    }

    /// The projected tool-pose Jacobian (what identification uses: the readings' derivatives
    /// with respect to the pose times the pose Jacobian, formed per component and scaled by its
    /// basis values) equals the product of the rows with the full Jacobian, at the same pose.
    #[test]
    fn projected_tool_jacobian_is_the_product_with_the_full_one(
        (model, q, c) in any_case(),
        rows in proptest::collection::vec(proptest::array::uniform6(-2.0..2.0f64), 1..4),
    ) {
        let mut ws = model.workspace();
        let n = model.n_coeffs();
        // NaN-filled: every column must be written (neither path clears its output first).
        let mut jac = vec![f64::NAN; 6 * n];
        let pose = model.tool_pose_jacobian(&q, &c, &mut ws, &mut jac);
        let mut projected = vec![f64::NAN; rows.len() * n];
        prop_assert_eq!(model.tool_pose_for_jacobian(&q, &c, &mut ws), pose);
        model.project_tool_jacobian(&ws, &rows, &mut projected);
        for (i, row) in rows.iter().enumerate() {
            for k in 0..n {
                let full: f64 = (0..6).map(|r| row[r] * jac[6 * k + r]).sum();
                let got = projected[i * n + k];
                let scale = 1.0 + (0..6).map(|r| (row[r] * jac[6 * k + r]).abs()).sum::<f64>();
                prop_assert!((got - full).abs() <= 1e-13 * scale,
                    "row {i} coefficient {}: projected {got} full {full}", model.errors().coefficient_labels()[k]);
            }
        }
    }

    /// The tool-pose Jacobian (left perturbation, for instrument models) equals central finite
    /// differences of the actual tool pose, and the pose is the nominal one plus the exact error.
    #[test]
    fn tool_pose_jacobian_matches_finite_differences((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let n = model.n_coeffs();
        let mut jac = vec![0.0; 6 * n];
        let pose = model.tool_pose_jacobian(&q, &c, &mut ws, &mut jac);
        prop_assert_eq!(pose, model.tool_pose(&q, &c, &mut ws));
        let nominal = model.machine().tool_in_workpiece(&q);
        let err = model.pose_error(&q, &c, &mut ws);
        prop_assert!(((pose.t - nominal.t) - err.translation).norm() < 1e-15 * machine_size(model.machine()));
        let step = 1e-6;
        let mut cp = c.clone();
        for k in 0..n {
            cp[k] = c[k] + step;
            let plus = model.tool_pose(&q, &cp, &mut ws);
            cp[k] = c[k] - step;
            let minus = model.tool_pose(&q, &cp, &mut ws);
            cp[k] = c[k];
            let dt = (plus.t - minus.t) / (2.0 * step);
            // δθ from R₊·R₋ᵀ = exp(2h·[δθ]×) to first order.
            let m = plus.r * minus.r.transpose();
            let dth = Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]) / (4.0 * step);
            let fd = [dt.x, dt.y, dt.z, dth.x, dth.y, dth.z];
            for r in 0..6 {
                let an = jac[6 * k + r];
                prop_assert!((fd[r] - an).abs() < 1e-8 * (1.0 + an.abs()),
                    "coefficient {} row {r}: analytic {an} fd {}", model.errors().coefficient_labels()[k], fd[r]);
            }
        }
    }

    /// At zero errors the exact Jacobian times the coefficients is the first-order error.
    #[test]
    fn first_order_is_jacobian_at_zero((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let n = model.n_coeffs();
        let mut jac = vec![0.0; 6 * n];
        model.pose_error_jacobian(&q, &vec![0.0; n], &mut ws, &mut jac);
        let fo = model.pose_error_first_order(&q, &c, &mut ws).to_array();
        for r in 0..6 {
            let lin: f64 = (0..n).map(|k| jac[6 * k + r] * c[k]).sum();
            prop_assert!((lin - fo[r]).abs() < 1e-15 + 1e-12 * fo[r].abs());
        }
    }

    /// The tool-pose Jacobian with respect to the axis positions equals central finite
    /// differences of the exact model (with errors).
    #[test]
    fn axis_jacobian_matches_finite_differences((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let na = q.len();
        let mut jac = vec![0.0; 6 * na];
        model.tool_jacobian(&q, &c, &mut ws, &mut jac);
        let step = 1e-6;
        let pose = |qq: &[f64], ws: &mut _| {
            let mut j = vec![0.0; 6 * na];
            model.tool_jacobian(qq, &c, ws, &mut j)
        };
        for i in 0..na {
            let mut qp = q.clone();
            qp[i] += step;
            let plus = pose(&qp, &mut ws);
            qp[i] -= 2.0 * step;
            let minus = pose(&qp, &mut ws);
            let dp = (plus.t - minus.t) / (2.0 * step);
            let w = small_log(&Rotation3::from_matrix_unchecked(plus.r * minus.r.transpose())) / (2.0 * step);
            for r in 0..3 {
                prop_assert!((dp[r] - jac[6 * i + r]).abs() < 1e-7, "axis {i} dp[{r}] {} vs {}", dp[r], jac[6 * i + r]);
                prop_assert!((w[r] - jac[6 * i + 3 + r]).abs() < 1e-7, "axis {i} w[{r}] {} vs {}", w[r], jac[6 * i + 3 + r]);
            }
        }
    }

    /// The tool branch shifting along and turning about the machine's X, Y, Z (through its
    /// origin), against the slow formulation with the motion multiplied in:
    /// `w_T_t = f_T_w⁻¹ · Δ · f_T_t`.
    #[test]
    fn tool_motion_columns_match_the_slow_formulation((model, q, c) in any_case()) {
        let mut ws = model.workspace();
        let mut jac = vec![0.0; 6 * q.len()];
        model.tool_jacobian(&q, &c, &mut ws, &mut jac);
        let mut turns = vec![0.0; 6 * mtcal_kinematics::TOOL_MOTIONS];
        model.tool_motion_columns(&ws, &mut turns);
        let vals = values(&model, &q, &c);
        let m = model.machine();
        let w = slow_branch(m, Side::Workpiece, &q, &vals);
        let t = slow_branch(m, Side::Tool, &q, &vals);
        let step = 1e-6;
        let turned = |d: f64, k: usize| {
            let motion = if k < 3 {
                h(Rotation3::identity(), Vector3::ith(k, d))
            } else {
                h(Rotation3::from_scaled_axis(Vector3::ith(k - 3, d)), Vector3::zeros())
            };
            w.try_inverse().unwrap() * motion * t
        };
        for k in 0..6 {
            let (plus, minus) = (turned(step, k), turned(-step, k));
            let dp = (plus.fixed_view::<3, 1>(0, 3) - minus.fixed_view::<3, 1>(0, 3)) / (2.0 * step);
            let rp = Rotation3::from_matrix_unchecked(plus.fixed_view::<3, 3>(0, 0).into_owned());
            let rm = Rotation3::from_matrix_unchecked(minus.fixed_view::<3, 3>(0, 0).into_owned());
            let dw = small_log(&(rp * rm.inverse())) / (2.0 * step);
            for r in 0..3 {
                prop_assert!((dp[r] - turns[6 * k + r]).abs() < 1e-7, "turn {k} dp[{r}] {} vs {}", dp[r], turns[6 * k + r]);
                prop_assert!((dw[r] - turns[6 * k + 3 + r]).abs() < 1e-7, "turn {k} w[{r}] {} vs {}", dw[r], turns[6 * k + 3 + r]);
            }
        }
    }

    /// Reordering the parameters of the configuration changes nothing.
    #[test]
    fn reordering_parameters_changes_nothing((model, q, c) in any_case(), seed in any::<u64>()) {
        let params = model.errors().params().to_vec();
        let mut order: Vec<usize> = (0..params.len()).collect();
        let mut s = seed | 1;
        for i in (1..order.len()).rev() {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            order.swap(i, (s % (i as u64 + 1)) as usize);
        }
        let cfg: Vec<ParamConfig> = order.iter().map(|&i| {
            let p = &params[i];
            ParamConfig { name: p.name, basis: match &p.role { Role::Component { basis, .. } => Some(basis.clone()), _ => None } }
        }).collect();
        let shuffled = MachineModel::new(model.machine().clone(), &cfg).unwrap();
        let mut c2 = vec![0.0; c.len()];
        for p in &params {
            let p2 = shuffled.errors().find(&p.name).unwrap();
            c2[p2.offset..p2.offset + p2.len].copy_from_slice(&c[p.offset..p.offset + p.len]);
        }
        let mut ws = model.workspace();
        let mut ws2 = shuffled.workspace();
        let a = model.pose_error(&q, &c, &mut ws).to_array();
        let b = shuffled.pose_error(&q, &c2, &mut ws2).to_array();
        prop_assert_eq!(a, b);
    }
}

// ---------------------------------------------------------------------------------------------
// Hand-checkable cases.

fn lin(letter: char, axis: [f64; 3]) -> JointSpec {
    JointSpec {
        letter,
        kind: AxisKind::Linear,
        origin: Isometry3::identity(),
        axis: Vector3::from(axis),
        limits: Some((-0.5, 0.5)),
    }
}

fn rot(letter: char, axis: [f64; 3], at: [f64; 3]) -> JointSpec {
    JointSpec {
        letter,
        kind: AxisKind::Rotary,
        origin: Isometry3::from_parts(Translation3::from(Vector3::from(at)), Default::default()),
        axis: Vector3::from(axis),
        limits: None,
    }
}

fn machine(wp: Vec<JointSpec>, tool: Vec<JointSpec>) -> Machine {
    let b = |joints| BranchSpec {
        joints,
        end: Isometry3::identity(),
    };
    Machine::try_new(&MachineSpec {
        name: "hand".into(),
        workpiece: b(wp),
        tool: b(tool),
    })
    .unwrap()
}

fn single(m: Machine, name: &str) -> MachineModel {
    let name: ParamName = name.parse().unwrap();
    MachineModel::new(m, &[ParamConfig { name, basis: None }]).unwrap()
}

/// A squareness error gives the expected shear: EC0Y tilts Y's motion about +Z, so moving Y by
/// y moves the tool by −EC0Y·y in X relative to the workpiece, whichever branch Y is in.
#[test]
fn squareness_gives_expected_shear() {
    for y_in_tool in [false, true] {
        let y_axis = if y_in_tool {
            [0., 1., 0.]
        } else {
            [0., -1., 0.]
        };
        let (wp, tool) = if y_in_tool {
            (
                vec![lin('X', [-1., 0., 0.])],
                vec![lin('Y', y_axis), lin('Z', [0., 0., 1.])],
            )
        } else {
            (
                vec![lin('X', [-1., 0., 0.]), lin('Y', y_axis)],
                vec![lin('Z', [0., 0., 1.])],
            )
        };
        let model = single(machine(wp, tool), "EC0Y");
        let mut ws = model.workspace();
        let eps = 20e-6;
        let (x, y, z) = (0.3, 0.4, -0.2);
        let e = model.pose_error(&[x, y, z], &[eps], &mut ws);
        let expect = Vector3::new(-eps * y, 0.0, 0.0);
        // Exact to first order; the second-order cosine term is y·ε²/2.
        assert!(
            (e.translation - expect).norm() < 1e-10,
            "y in tool {y_in_tool}: {:?}",
            e.translation
        );
        assert!(
            e.rotation.norm() < 1e-15,
            "squareness changes no orientation"
        );
    }
}

/// A rotary location error moves a table point by the rotated offset: with the C axis line at
/// d instead of the origin, the tool relative to the workpiece is off by (I − R(C))·d.
#[test]
fn rotary_location_error_moves_table_point_by_rotated_offset() {
    let m = machine(
        vec![
            lin('X', [-1., 0., 0.]),
            lin('Y', [0., -1., 0.]),
            rot('C', [0., 0., -1.], [0., 0., 0.]),
        ],
        vec![lin('Z', [0., 0., 1.])],
    );
    let cfg: Vec<ParamConfig> = ["EX0C", "EY0C"]
        .iter()
        .map(|n| ParamConfig {
            name: n.parse().unwrap(),
            basis: None,
        })
        .collect();
    let model = MachineModel::new(m, &cfg).unwrap();
    let mut ws = model.workspace();
    let d = Vector3::new(12e-6, -7e-6, 0.0);
    for c in [0.0, 0.7, 2.0, -2.5] {
        let q = [0.1, -0.2, 0.05, c];
        let e = model.pose_error(&q, &[d.x, d.y], &mut ws);
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), c);
        let expect = d - r * d;
        assert!(
            (e.translation - expect).norm() < 1e-15,
            "C={c}: {:?} vs {:?}",
            e.translation,
            expect
        );
    }
}

/// Component errors are functional (tool relative to workpiece): EXX = +5 µm puts the tool 5 µm
/// further along +X relative to the workpiece, whether X moves the table or the tool.
#[test]
fn component_errors_are_tool_relative_to_workpiece() {
    for x_in_tool in [false, true] {
        let (wp, tool) = if x_in_tool {
            (vec![], vec![lin('X', [1., 0., 0.])])
        } else {
            (vec![lin('X', [-1., 0., 0.])], vec![])
        };
        let m = machine(wp, tool);
        let basis = mtcal_kinematics::Basis::legendre(-0.5, 0.5, 0, 0).unwrap();
        let model = MachineModel::new(
            m,
            &[ParamConfig {
                name: "EXX".parse().unwrap(),
                basis: Some(basis),
            }],
        )
        .unwrap();
        let mut ws = model.workspace();
        let e = model.pose_error(&[0.2], &[5e-6], &mut ws);
        assert!(
            (e.translation - Vector3::new(5e-6, 0.0, 0.0)).norm() < 1e-15,
            "x in tool: {x_in_tool}"
        );
    }
}

/// A model without any error parameter (a session that estimates nothing of the machine, e.g. a
/// thermal test of fixed sensors) evaluates to the nominal machine on every path, including the
/// Jacobian ones, instead of indexing an empty packed polynomial.
#[test]
fn a_model_without_parameters_is_the_nominal_machine() {
    let m = machine(
        vec![
            lin('X', [-1.0, 0.0, 0.0]),
            rot('C', [0.0, 0.0, -1.0], [0.1, 0.0, 0.0]),
        ],
        vec![lin('Y', [0.0, 1.0, 0.0]), lin('Z', [0.0, 0.0, 1.0])],
    );
    let model = MachineModel::new(m.clone(), &[]).unwrap();
    assert_eq!(model.n_coeffs(), 0);
    let mut ws = model.workspace();
    for q in [[0.0, 0.0, 0.0, 0.0], [0.1, -0.2, 0.05, 1.3]] {
        let nominal = m.tool_in_workpiece(&q);
        let a = model.tool_pose(&q, &[], &mut ws);
        let b = model.tool_pose_for_jacobian(&q, &[], &mut ws);
        for pose in [a, b] {
            assert!(
                (pose.t - nominal.t).norm() < 1e-12,
                "{:?} vs {:?}",
                pose.t,
                nominal.t
            );
            assert!((pose.r - nominal.r).norm() < 1e-15);
        }
        let e = model.pose_error(&q, &[], &mut ws).to_array();
        assert!(e.iter().all(|v| v.abs() < 1e-15), "{e:?}");
        let mut jac = vec![0.0; 6 * 4];
        model.tool_jacobian(&q, &[], &mut ws, &mut jac);
        assert!(jac.iter().all(|v| v.is_finite()));
    }
}
