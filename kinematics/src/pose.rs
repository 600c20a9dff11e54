//! Pose error of the tool relative to the workpiece, exact and first-order, and its analytic
//! Jacobians.
//!
//! # The error model (see ARCHITECTURE.md, "Conventions")
//! Each branch is `origin · joint · … · end`. Into every joint enter:
//! - **component errors** `E(q)`: a small rigid motion (three translations, three rotations
//!   about the body's reference point) given in machine directions at the zero pose. They are
//!   *functional*: the motion of the tool relative to the workpiece that the axis causes, so an
//!   axis carrying the workpiece moves its body by `E⁻¹`. Linear axis: `Trans(q·a) · E`;
//!   rotary axis: `E · L·Rot(a, q)·L⁻¹` (error motions of a rotary axis do not turn with it).
//! - **location errors** `L`: where a rotary axis line really is (position and tilt across its
//!   own direction), and for a linear axis the tilt of its direction of motion (squareness): the
//!   axis moves along `R_L·a`. A rotary axis' own-direction location errors (`EZ0C`, `EC0C`) are
//!   the constants of its own-direction component errors.
//! - **set-up**: the tool point offset in the tool frame (`TOOL_D*`) and the actual workpiece
//!   pose in the nominal one (`WP_D*`).
//!
//! The pose error is `[p − p₀; log(R·R₀ᵀ)]` where `(R, p)` is the tool's pose in the (actual)
//! workpiece frame and `(R₀, p₀)` the nominal one: translations in m, rotations in rad, both in
//! the workpiece frame.

use crate::machine::{AxisKind, Machine, Side};
use crate::model::{ErrorModel, ModelError, ParamConfig, Role};
use crate::rigid::{Rigid, axis_rotation, exp_so3, left_jacobian, left_jacobian_inverse, log_so3};
use nalgebra::{Matrix3, Vector3};

/// Tool pose error in the workpiece frame: translation (m) and rotation vector (rad).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseError {
    pub translation: Vector3<f64>,
    pub rotation: Vector3<f64>,
}

impl PoseError {
    pub fn translation_um(&self) -> Vector3<f64> {
        self.translation * 1e6
    }
    pub fn rotation_urad(&self) -> Vector3<f64> {
        self.rotation * 1e6
    }
    /// `[dx, dy, dz, ea, eb, ec]` in m and rad.
    pub fn to_array(&self) -> [f64; 6] {
        let (t, r) = (self.translation, self.rotation);
        [t.x, t.y, t.z, r.x, r.y, r.z]
    }
}

/// A machine and its configured error parameters: everything needed to evaluate pose errors.
/// Immutable; per-thread scratch lives in [`Workspace`].
#[derive(Clone, Debug)]
pub struct MachineModel {
    machine: Machine,
    errors: ErrorModel,
}

/// Per-joint quantities of the last chain evaluation, in the joint's local frame.
#[derive(Clone, Copy, Debug, Default)]
struct JointState {
    /// Frame before the first error factor of the joint (`f_T_·`).
    before_a: Rigid,
    /// Linear: frame before `E` (after the motion). Rotary: frame before `L` (after `E`).
    before_b: Rigid,
    /// Rotary: frame before `Rot(q)` (after `L`).
    before_r: Rigid,
    /// Rotary: `L·Rot(q)·L⁻¹`.
    lrl: Rigid,
    /// The body's error factor (`E` or `E⁻¹`).
    e_body: Rigid,
    e_trans: Vector3<f64>,
    e_rot: Vector3<f64>,
    l_trans: Vector3<f64>,
    l_rot: Vector3<f64>,
    /// Linear: actual direction of motion `R_L·a`.
    motion_dir: Vector3<f64>,
    q: f64,
}

/// Scratch buffers for evaluations; allocate once per thread with [`MachineModel::workspace`].
#[derive(Clone, Debug)]
pub struct Workspace {
    phi: Vec<f64>,
    dphi: Vec<f64>,
    comp: Vec<[f64; 6]>,
    dcomp: Vec<[f64; 6]>,
    loc: Vec<[f64; 6]>,
    joints: Vec<JointState>,
    tool_end: Rigid,
    wp_end: Rigid,
    wp_rot: Vector3<f64>,
    wp_trans: Vector3<f64>,
    tool_trans: Vector3<f64>,
    f_t_w: Rigid,
    w_t_t: Rigid,
}

/// What [`MachineModel::eval_values`] computes besides the component values.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fill {
    /// Values only (`Basis::value`, no buffer writes): the pose-error paths.
    Values,
    /// Also every basis function's value in `phi`: the parameter Jacobian.
    Basis,
    /// Also the derivatives with respect to the axis position: the axis Jacobian.
    Derivative,
}

/// Which chain to evaluate.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Chain {
    Nominal,
    Actual,
}

impl MachineModel {
    pub fn new(machine: Machine, config: &[ParamConfig]) -> Result<Self, ModelError> {
        let errors = ErrorModel::new(&machine, config)?;
        Ok(Self { machine, errors })
    }

    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    pub fn errors(&self) -> &ErrorModel {
        &self.errors
    }

    pub fn n_coeffs(&self) -> usize {
        self.errors.n_coeffs()
    }

    pub fn workspace(&self) -> Workspace {
        let n = self.machine.n_axes();
        let m = self.errors.n_coeffs();
        Workspace {
            phi: vec![0.0; m],
            dphi: vec![0.0; m],
            comp: vec![[0.0; 6]; n],
            dcomp: vec![[0.0; 6]; n],
            loc: vec![[0.0; 6]; n],
            joints: vec![JointState::default(); n],
            tool_end: Rigid::IDENTITY,
            wp_end: Rigid::IDENTITY,
            wp_rot: Vector3::zeros(),
            wp_trans: Vector3::zeros(),
            tool_trans: Vector3::zeros(),
            f_t_w: Rigid::IDENTITY,
            w_t_t: Rigid::IDENTITY,
        }
    }

    /// Exact pose error: full rigid transforms with every error inserted.
    pub fn pose_error(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace) -> PoseError {
        self.pose_error_filled(q, coeffs, ws, Fill::Values)
    }

    fn pose_error_filled(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
        fill: Fill,
    ) -> PoseError {
        self.check_sizes(q, coeffs);
        let nominal = self.machine.tool_in_workpiece(q);
        self.eval_values(q, coeffs, ws, fill);
        self.eval_chain(q, ws, Chain::Actual);
        let act = ws.w_t_t;
        PoseError {
            translation: act.t - nominal.t,
            rotation: log_so3(&(act.r * nominal.r.transpose())),
        }
    }

    /// First-order pose error: the error parameters' effects added linearly at the nominal
    /// pose. Agrees with [`Self::pose_error`] to second order in the error size.
    pub fn pose_error_first_order(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
    ) -> PoseError {
        self.check_sizes(q, coeffs);
        self.eval_values(q, coeffs, ws, Fill::Values);
        self.eval_chain(q, ws, Chain::Nominal);
        let p = ws.w_t_t.t;
        // Twists are summed in the machine frame and mapped to the workpiece frame once.
        let (mut v, mut w) = (Vector3::zeros(), Vector3::zeros());
        let mut add = |side: Side, frame: &Rigid, tv: Vector3<f64>, tw: Vector3<f64>| {
            let (tv, tw) = frame.adjoint(&tv, &tw);
            let s = sign(side);
            v += tv * s;
            w += tw * s;
        };
        for (i, ax) in self.machine.axes().iter().enumerate() {
            let js = &ws.joints[i];
            let r0t = ax.zero_rotation().transpose();
            let c = &ws.comp[i];
            let l = &ws.loc[i];
            // Functional component errors: the workpiece side's E⁻¹ and its negative sign cancel.
            let (de, ee) = (r0t * v3(c, 0), r0t * v3(c, 3));
            let e_frame = match ax.kind() {
                AxisKind::Linear => js.before_b,
                AxisKind::Rotary => js.before_a,
            };
            add(Side::Tool, &e_frame, de, ee);
            let (lt, lw) = (r0t * v3(l, 0), r0t * v3(l, 3));
            match ax.kind() {
                AxisKind::Linear => add(
                    ax.side(),
                    &js.before_a,
                    (lw * js.q).cross(ax.direction()),
                    Vector3::zeros(),
                ),
                AxisKind::Rotary => {
                    let (rv, rw) = js.lrl.adjoint(&lt, &lw);
                    add(ax.side(), &js.before_b, lt - rv, lw - rw);
                }
            }
        }
        add(Side::Tool, &ws.tool_end, ws.tool_trans, Vector3::zeros());
        add(Side::Workpiece, &ws.wp_end, ws.wp_trans, ws.wp_rot);
        let (v, w) = ws.f_t_w.inverse().adjoint(&v, &w);
        PoseError {
            translation: v + w.cross(&p),
            rotation: w,
        }
    }

    /// Exact pose error and its Jacobian with respect to every coefficient.
    ///
    /// `jac` is column-major 6 × `n_coeffs`: `jac[6·k + r]` is ∂(pose error row r)/∂(coefficient
    /// k), rows as in [`PoseError::to_array`]. No allocation.
    pub fn pose_error_jacobian(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
        jac: &mut [f64],
    ) -> PoseError {
        assert_eq!(jac.len(), 6 * self.n_coeffs(), "jacobian buffer size");
        let err = self.pose_error_filled(q, coeffs, ws, Fill::Basis);
        let p = ws.w_t_t.t;
        let jl_inv = left_jacobian_inverse(&err.rotation);
        let w_t_f = ws.f_t_w.inverse();
        let to_column = |side: Side, frame: &Rigid, tv: Vector3<f64>, tw: Vector3<f64>| {
            let (v, w) = w_t_f.compose(frame).adjoint(&tv, &tw);
            let s = sign(side);
            let (v, w) = (v * s, w * s);
            let dp = v + w.cross(&p);
            let dr = jl_inv * w;
            [dp.x, dp.y, dp.z, dr.x, dr.y, dr.z]
        };
        for (i, ax) in self.machine.axes().iter().enumerate() {
            let units = self.component_twists(i, ws);
            let e_frame = self.e_frame(i, ws);
            let cols: [[f64; 6]; 6] =
                std::array::from_fn(|d| to_column(ax.side(), &e_frame, units[d].0, units[d].1));
            for (d, unit_col) in cols.iter().enumerate() {
                if let Some(par) = self.errors.component(i, d) {
                    for k in 0..par.len {
                        let f = ws.phi[par.offset + k];
                        let col = &mut jac[6 * (par.offset + k)..6 * (par.offset + k + 1)];
                        col.iter_mut().zip(unit_col).for_each(|(o, c)| *o = f * c);
                    }
                }
                if let Some(par) = self.errors.location(i, d) {
                    let col = if ax.kind() == AxisKind::Rotary && d % 3 == ax.own_cartesian() {
                        *unit_col
                    } else {
                        let (tv, tw, frame) = self.location_twist(i, d, ws);
                        to_column(ax.side(), &frame, tv, tw)
                    };
                    jac[6 * par.offset..6 * par.offset + 6].copy_from_slice(&col);
                }
            }
        }
        for d in 0..3 {
            if let Some(par) = self.errors.tool_offset(d) {
                let col = to_column(Side::Tool, &ws.tool_end, unit(d), Vector3::zeros());
                jac[6 * par.offset..6 * par.offset + 6].copy_from_slice(&col);
            }
        }
        for d in 0..6 {
            if let Some(par) = self.errors.workpiece_offset(d) {
                let (tv, tw) = e_twist(d, &Matrix3::identity(), &ws.wp_trans, &ws.wp_rot);
                let col = to_column(Side::Workpiece, &ws.wp_end, tv, tw);
                jac[6 * par.offset..6 * par.offset + 6].copy_from_slice(&col);
            }
        }
        err
    }

    /// Jacobian of the actual tool pose in the workpiece frame with respect to the axis
    /// positions, `w_J_t`: column-major 6 × n_axes; rows 0..3 are ∂p/∂q (m per m or rad), rows
    /// 3..6 the tool's angular velocity in the workpiece frame per unit axis velocity.
    /// Returns the tool pose `w_T_t`.
    pub fn tool_jacobian(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
        jac: &mut [f64],
    ) -> Rigid {
        self.check_sizes(q, coeffs);
        assert_eq!(jac.len(), 6 * self.machine.n_axes(), "jacobian buffer size");
        self.eval_values(q, coeffs, ws, Fill::Derivative);
        self.eval_chain(q, ws, Chain::Actual);
        let p = ws.w_t_t.t;
        let w_t_f = ws.f_t_w.inverse();
        for (i, ax) in self.machine.axes().iter().enumerate() {
            let s = sign(ax.side());
            let acc = |frame: &Rigid, tv: Vector3<f64>, tw: Vector3<f64>, col: &mut [f64]| {
                let (v, w) = w_t_f.compose(frame).adjoint(&tv, &tw);
                let dp = (v + w.cross(&p)) * s;
                let w = w * s;
                for r in 0..3 {
                    col[r] += dp[r];
                    col[3 + r] += w[r];
                }
            };
            let col = &mut jac[6 * i..6 * i + 6];
            col.fill(0.0);
            let js = ws.joints[i];
            match ax.kind() {
                AxisKind::Linear => acc(&js.before_a, js.motion_dir, Vector3::zeros(), col),
                AxisKind::Rotary => acc(&js.before_r, Vector3::zeros(), *ax.direction(), col),
            }
            let units = self.component_twists(i, ws);
            let e_frame = self.e_frame(i, ws);
            for (d, (tv, tw)) in units.iter().enumerate() {
                let rate = ws.dcomp[i][d];
                if rate != 0.0 {
                    acc(&e_frame, tv * rate, tw * rate, col);
                }
            }
        }
        ws.w_t_t
    }

    fn check_sizes(&self, q: &[f64], coeffs: &[f64]) {
        assert_eq!(q.len(), self.machine.n_axes(), "one position per axis");
        assert_eq!(coeffs.len(), self.n_coeffs(), "one value per coefficient");
    }

    /// Component and location values per axis (machine directions) from the coefficients.
    fn eval_values(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace, fill: Fill) {
        for (i, ax) in self.machine.axes().iter().enumerate() {
            let mut c = [0.0; 6];
            let mut dc = [0.0; 6];
            let mut l = [0.0; 6];
            for d in 0..6 {
                if let Some(p) = self.errors.component(i, d) {
                    let Role::Component { basis, .. } = &p.role else {
                        unreachable!("component slot holds a component")
                    };
                    let range = p.offset..p.offset + p.len;
                    match fill {
                        Fill::Values => {
                            c[d] = basis.value(q[i], &coeffs[range]);
                            continue_location(
                                &mut c,
                                &mut l,
                                ax,
                                d,
                                self.errors.location(i, d),
                                coeffs,
                            );
                            continue;
                        }
                        Fill::Basis => basis.eval(q[i], &mut ws.phi[range.clone()]),
                        Fill::Derivative => {
                            basis.eval_with_derivative(
                                q[i],
                                &mut ws.phi[range.clone()],
                                &mut ws.dphi[range.clone()],
                            );
                            dc[d] = dot(&ws.dphi[range.clone()], &coeffs[range.clone()]);
                        }
                    }
                    c[d] = dot(&ws.phi[range.clone()], &coeffs[range]);
                }
                continue_location(&mut c, &mut l, ax, d, self.errors.location(i, d), coeffs);
            }
            ws.comp[i] = c;
            ws.dcomp[i] = dc;
            ws.loc[i] = l;
        }
        ws.wp_trans = Vector3::from_fn(|r, _| value_of(self.errors.workpiece_offset(r), coeffs));
        ws.wp_rot = Vector3::from_fn(|r, _| value_of(self.errors.workpiece_offset(3 + r), coeffs));
        ws.tool_trans = Vector3::from_fn(|r, _| value_of(self.errors.tool_offset(r), coeffs));
    }

    /// Walks both branches, recording every joint's frames; leaves `f_t_w` and `w_t_t`.
    fn eval_chain(&self, q: &[f64], ws: &mut Workspace, chain: Chain) {
        let actual = chain == Chain::Actual;
        for side in [Side::Workpiece, Side::Tool] {
            let branch = self.machine.branch(side);
            let mut t = Rigid::IDENTITY;
            for &i in branch.joints() {
                t = self.eval_joint(i, q[i], t, ws, actual);
            }
            t = t.compose(branch.end());
            match side {
                Side::Workpiece => {
                    ws.wp_end = t;
                    if actual {
                        t = t.compose(&Rigid::new(exp_so3(&ws.wp_rot), ws.wp_trans));
                    }
                    ws.f_t_w = t;
                }
                Side::Tool => {
                    ws.tool_end = t;
                    if actual {
                        t = t.compose(&Rigid::translation(ws.tool_trans));
                    }
                    ws.w_t_t = ws.f_t_w.inverse().compose(&t);
                }
            }
        }
    }

    fn eval_joint(&self, i: usize, q: f64, t: Rigid, ws: &mut Workspace, actual: bool) -> Rigid {
        let ax = &self.machine.axes()[i];
        if !actual {
            return self.eval_nominal_joint(i, q, t, ws);
        }
        let r0t = ax.zero_rotation().transpose();
        let (c, l) = (ws.comp[i], ws.loc[i]);
        let js = &mut ws.joints[i];
        js.q = q;
        js.e_trans = r0t * v3(&c, 0);
        js.e_rot = r0t * v3(&c, 3);
        js.l_trans = r0t * v3(&l, 0);
        js.l_rot = r0t * v3(&l, 3);
        let e = Rigid::new(exp_so3(&js.e_rot), js.e_trans);
        js.e_body = match ax.side() {
            Side::Tool => e,
            Side::Workpiece => e.inverse(),
        };
        let t = t.compose(ax.origin());
        js.before_a = t;
        match ax.kind() {
            AxisKind::Linear => {
                js.motion_dir = exp_so3(&js.l_rot) * ax.direction();
                js.before_b = t.compose(&Rigid::translation(js.motion_dir * q));
                js.before_b.compose(&js.e_body)
            }
            AxisKind::Rotary => {
                let lr = Rigid::new(exp_so3(&js.l_rot), js.l_trans);
                js.before_b = t.compose(&js.e_body);
                js.before_r = js.before_b.compose(&lr);
                let rot = Rigid::rotation(axis_rotation(ax.direction(), q));
                js.lrl = lr.compose(&rot).compose(&lr.inverse());
                js.before_b.compose(&js.lrl)
            }
        }
    }

    /// The nominal joint: no error factor, so every error frame is a plain chain frame.
    fn eval_nominal_joint(&self, i: usize, q: f64, t: Rigid, ws: &mut Workspace) -> Rigid {
        let ax = &self.machine.axes()[i];
        let js = &mut ws.joints[i];
        js.q = q;
        let t = t.compose(ax.origin());
        js.before_a = t;
        match ax.kind() {
            AxisKind::Linear => {
                js.motion_dir = *ax.direction();
                js.before_b = Rigid::new(t.r, t.r * (js.motion_dir * q) + t.t);
                js.before_b
            }
            AxisKind::Rotary => {
                js.before_b = t;
                js.before_r = t;
                js.lrl = Rigid::rotation(axis_rotation(ax.direction(), q));
                t.compose(&js.lrl)
            }
        }
    }

    /// The frame in which the component-error twists of axis `i` are given.
    fn e_frame(&self, i: usize, ws: &Workspace) -> Rigid {
        let js = &ws.joints[i];
        match self.machine.axes()[i].kind() {
            AxisKind::Linear => js.before_b,
            AxisKind::Rotary => js.before_a,
        }
    }

    /// Twists of the body per unit of each machine-direction component value, in the frame
    /// before the error factor (exact, at the current error values).
    fn component_twists(&self, i: usize, ws: &Workspace) -> [(Vector3<f64>, Vector3<f64>); 6] {
        let ax = &self.machine.axes()[i];
        let js = &ws.joints[i];
        let r0t = ax.zero_rotation().transpose();
        std::array::from_fn(|d| {
            let (tv, tw) = e_twist(d, &r0t, &js.e_trans, &js.e_rot);
            match ax.side() {
                Side::Tool => (tv, tw),
                // d(E⁻¹)·E = −Ad(E⁻¹)·(dE·E⁻¹); the branch sign is applied later.
                Side::Workpiece => {
                    let (v, w) = js.e_body.adjoint(&tv, &tw);
                    (-v, -w)
                }
            }
        })
    }

    /// Twist of a (non-own-direction) location error of axis `i` and the frame it is given in.
    fn location_twist(
        &self,
        i: usize,
        d: usize,
        ws: &Workspace,
    ) -> (Vector3<f64>, Vector3<f64>, Rigid) {
        let ax = &self.machine.axes()[i];
        let js = &ws.joints[i];
        let u = ax.zero_rotation().transpose() * unit(d % 3);
        match ax.kind() {
            AxisKind::Linear => {
                let w = left_jacobian(&js.l_rot) * u;
                (
                    w.cross(&js.motion_dir) * js.q,
                    Vector3::zeros(),
                    js.before_a,
                )
            }
            AxisKind::Rotary => {
                let (tv, tw) = if d < 3 {
                    (u, Vector3::zeros())
                } else {
                    let w = left_jacobian(&js.l_rot) * u;
                    (js.l_trans.cross(&w), w)
                };
                let (rv, rw) = js.lrl.adjoint(&tv, &tw);
                (tv - rv, tw - rw, js.before_b)
            }
        }
    }
}

/// `dE·E⁻¹` for a unit change of machine-direction component `d` of `E = (exp(ε), δ)`, given
/// in local coordinates through `r0t` (machine → local).
fn e_twist(
    d: usize,
    r0t: &Matrix3<f64>,
    delta: &Vector3<f64>,
    eps: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let u = r0t * unit(d % 3);
    if d < 3 {
        (u, Vector3::zeros())
    } else {
        let w = left_jacobian(eps) * u;
        (delta.cross(&w), w)
    }
}

/// Adds location error `d` of an axis: a rotary axis' own-direction location errors are the
/// constants of its component errors, the others go to the location factor.
#[inline]
fn continue_location(
    c: &mut [f64; 6],
    l: &mut [f64; 6],
    ax: &crate::machine::Axis,
    d: usize,
    param: Option<&crate::model::Param>,
    coeffs: &[f64],
) {
    if let Some(p) = param {
        let v = coeffs[p.offset];
        if ax.kind() == AxisKind::Rotary && d % 3 == ax.own_cartesian() {
            c[d] += v;
        } else {
            l[d] = v;
        }
    }
}

fn sign(side: Side) -> f64 {
    match side {
        Side::Tool => 1.0,
        Side::Workpiece => -1.0,
    }
}

fn unit(i: usize) -> Vector3<f64> {
    let mut v = Vector3::zeros();
    v[i] = 1.0;
    v
}

fn v3(a: &[f64; 6], start: usize) -> Vector3<f64> {
    Vector3::new(a[start], a[start + 1], a[start + 2])
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn value_of(p: Option<&crate::model::Param>, coeffs: &[f64]) -> f64 {
    match p {
        Some(p) => coeffs[p.offset],
        None => 0.0,
    }
}
