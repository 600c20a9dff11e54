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
use crate::rigid::{
    Rigid, axis_rotation, exp_so3, left_jacobian, left_jacobian_inverse, log_so3, mm, mv,
};
use nalgebra::{Matrix3, Vector3};

mod batch;
mod eval;
mod frames;
mod jacobian;
mod lanes;
mod plan;
#[cfg(test)]
mod tests;
mod values;

pub use batch::{BatchKernel, BatchWorkspace};
use frames::*;
use jacobian::*;
use plan::*;
use values::*;

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
    plan: Plan,
}

/// Number of [`MachineModel::tool_motion_columns`]: shifts along the machine's X, Y and Z,
/// turns about them.
pub const TOOL_MOTIONS: usize = 6;

/// Scratch buffers for evaluations; allocate once per thread with [`MachineModel::workspace`].
#[derive(Clone, Debug)]
pub struct Workspace {
    /// Shared Legendre values `P_0 ..` of the axis being evaluated.
    legendre: Vec<f64>,
    /// The coefficients [`Self::packed`] was built from (NaN before the first build).
    packed_from: Vec<f64>,
    /// Whether [`Self::packed`] was built at all: a model without coefficients has an empty
    /// `packed_from`, equal to every (empty) coefficient set, yet must be packed once.
    packed_once: bool,
    /// Per axis: the component and location values as dense local-frame polynomials, rebuilt
    /// only when the coefficients change (a map or a fit evaluates one set at many poses).
    packed: Vec<PackedAxis>,
    packed_tool: Vector3<f64>,
    packed_wp: (Vector3<f64>, Vector3<f64>),
    /// The workpiece set-up error as a transform, `(exp([wp_rot]×), wp_trans)`.
    wp_error: Rigid,
    phi: Vec<f64>,
    dphi: Vec<f64>,
    comp: Vec<[f64; 6]>,
    dcomp: Vec<[f64; 6]>,
    loc: Vec<[f64; 6]>,
    joints: Vec<JointState>,
    /// Per rotary axis: its rotation at the last chain evaluation's position.
    turns: Vec<Turn>,
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

impl MachineModel {
    pub fn new(machine: Machine, config: &[ParamConfig]) -> Result<Self, ModelError> {
        let errors = ErrorModel::new(&machine, config)?;
        let plan = Plan::new(&machine, &errors);
        Ok(Self {
            machine,
            errors,
            plan,
        })
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
            legendre: vec![0.0; self.plan.max_legendre],
            packed_from: vec![f64::NAN; m],
            packed_once: false,
            packed: vec![PackedAxis::default(); n],
            packed_tool: Vector3::zeros(),
            packed_wp: (Vector3::zeros(), Vector3::zeros()),
            wp_error: Rigid::IDENTITY,
            phi: vec![0.0; m],
            dphi: vec![0.0; m],
            comp: vec![[0.0; 6]; n],
            dcomp: vec![[0.0; 6]; n],
            loc: vec![[0.0; 6]; n],
            joints: vec![JointState::default(); n],
            turns: vec![Turn::About(0, 0.0, 1.0); n],
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
        self.eval_values(q, coeffs, ws, fill);
        self.eval_chain(q, ws);
        let nominal = self.nominal_tool_in_workpiece(q, &ws.turns);
        let act = ws.w_t_t;
        PoseError {
            translation: act.t - nominal.t,
            rotation: log_so3(&mm(&act.r, &nominal.r.transpose())),
        }
    }

    /// First-order pose error: the error parameters' effects added linearly at the nominal
    /// pose. Agrees with [`Self::pose_error`] to second order in the error size.
    ///
    /// One walk along the nominal chain from the tool to the workpiece, carrying the tool
    /// point in the current frame and the error accumulated so far as a point displacement at
    /// the tool point and a rotation, both in current-frame coordinates. Because the
    /// displacement is referred to the tool point, changing frames only rotates it (no
    /// adjoint cross products), and a joint whose origin is a pure translation only moves the
    /// point. No frame products and no per-joint state (volumetric maps run this millions of
    /// times).
    pub fn pose_error_first_order(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
    ) -> PoseError {
        self.check_sizes(q, coeffs);
        self.ensure_packed(coeffs, ws);
        let axes = self.machine.axes();
        let mut acc = AtToolPoint::default();
        // Tool branch, from the tool end down to the machine frame (branch sign +1).
        let tool = self.machine.branch(Side::Tool);
        acc.add(ws.packed_tool, Vector3::zeros());
        acc.move_to_parent(tool.end(), self.plan.tool_end_is_translation);
        for &i in tool.joints().iter().rev() {
            let (ap, ax) = (&self.plan.axes[i], &axes[i]);
            let (c, l) = self.local_values(i, q[i], coeffs, ws);
            let (de, ee) = (v3(&c, 0), v3(&c, 3));
            if ap.linear {
                // Errors sit after the motion; squareness moves the axis along R_L·a.
                let dir = ax.direction();
                acc.add(de + v3(&l, 3).cross(dir) * q[i], ee);
                acc.p += dir * q[i];
            } else {
                let turn = Turn::new(ap.along_basis, ax.direction(), q[i]);
                acc.p = turn.apply(&acc.p);
                acc.v = turn.apply(&acc.v);
                acc.w = turn.apply(&acc.w);
                let (lt, lw) = (v3(&l, 0), v3(&l, 3));
                acc.add(de + lt - turn.apply(&lt), ee + lw - turn.apply(&lw));
            }
            acc.move_to_parent(ax.origin(), ap.origin_is_translation);
        }
        // Workpiece branch, from the machine frame up to the workpiece (branch sign −1; the
        // functional component errors enter as E⁻¹, which cancels the sign).
        let wp = self.machine.branch(Side::Workpiece);
        for &i in wp.joints() {
            let (ap, ax) = (&self.plan.axes[i], &axes[i]);
            let (c, l) = self.local_values(i, q[i], coeffs, ws);
            let (de, ee) = (v3(&c, 0), v3(&c, 3));
            acc.move_to_child(ax.origin(), ap.origin_is_translation);
            if ap.linear {
                let dir = ax.direction();
                acc.p -= dir * q[i];
                acc.add(de - v3(&l, 3).cross(dir) * q[i], ee);
            } else {
                let turn = Turn::new(ap.along_basis, ax.direction(), q[i]);
                let (lt, lw) = (v3(&l, 0), v3(&l, 3));
                acc.add(de - lt + turn.apply(&lt), ee - lw + turn.apply(&lw));
                acc.p = turn.apply_inverse(&acc.p);
                acc.v = turn.apply_inverse(&acc.v);
                acc.w = turn.apply_inverse(&acc.w);
            }
        }
        acc.move_to_child(wp.end(), self.plan.wp_end_is_translation);
        acc.add(-ws.packed_wp.0, -ws.packed_wp.1);
        PoseError {
            translation: acc.v,
            rotation: acc.w,
        }
    }

    /// Rebuilds the packed polynomials if `coeffs` differ from the last ones packed; whether it
    /// did (the batched path derives its own constants from the packing).
    #[inline(always)]
    fn ensure_packed(&self, coeffs: &[f64], ws: &mut Workspace) -> bool {
        // The check inline (it runs on every evaluation), the rebuild out of line.
        let stale = !ws.packed_once || !bitwise_equal(&ws.packed_from, coeffs);
        if stale {
            self.pack(coeffs, ws);
        }
        stale
    }

    /// Builds the packed polynomials from `coeffs`.
    #[inline(never)]
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    fn pack(&self, coeffs: &[f64], ws: &mut Workspace) {
        for (i, ap) in self.plan.axes.iter().enumerate() {
            let mut pa = PackedAxis::default();
            let terms = ap.legendre_max.map_or(1, |m| m + 1);
            pa.general = terms > PACKED_TERMS
                || ap.fourier_terms > FOURIER_TERMS
                || ap.comp.iter().any(|s| matches!(s, Slot::General { .. }));
            pa.terms = terms.min(PACKED_TERMS);
            if !pa.general {
                pa.fourier_terms = ap.fourier_terms;
                for j in 0..pa.fourier_terms {
                    let mut machine_dir = [0.0; 6];
                    for d in 0..6 {
                        if let Slot::Fourier {
                            offset, len, first, ..
                        } = ap.comp[d]
                            && (first..first + len).contains(&j)
                        {
                            machine_dir[d] = coeffs[offset + j - first];
                        }
                    }
                    pa.fourier[j] = to_local(&ap.r0t, &machine_dir);
                }
                let mut machine_dir = [[0.0; 6]; PACKED_TERMS];
                for d in 0..6 {
                    if let Slot::Legendre { offset, len, min } = ap.comp[d] {
                        for k in 0..len {
                            machine_dir[min + k][d] = coeffs[offset + k];
                        }
                    }
                    if let Some(o) = ap.own_loc[d] {
                        machine_dir[0][d] += coeffs[o];
                    }
                }
                let legendre = legendre_monomials();
                for k in 0..pa.terms {
                    let local = to_local(&ap.r0t, &machine_dir[k]);
                    for (j, m) in pa.mono[..=k].iter_mut().enumerate() {
                        for d in 0..6 {
                            m[d] += local[d] * legendre[k][j];
                        }
                    }
                }
            }
            let mut l = [0.0; 6];
            for d in 0..6 {
                if let Some(o) = ap.loc[d] {
                    l[d] = coeffs[o];
                }
            }
            pa.loc = to_local(&ap.r0t, &l);
            pa.l_factor = Rigid::new(exp_so3(&v3(&pa.loc, 3)), v3(&pa.loc, 0));
            pa.l_inverse = pa.l_factor.inverse();
            pa.motion_dir = mv(&pa.l_factor.r, self.machine.axes()[i].direction());
            ws.packed[i] = pa;
        }
        ws.packed_tool = Vector3::new(
            opt(self.plan.tool[0], coeffs),
            opt(self.plan.tool[1], coeffs),
            opt(self.plan.tool[2], coeffs),
        );
        ws.packed_wp = (ws_wp(&self.plan, coeffs, 0), ws_wp(&self.plan, coeffs, 3));
        ws.wp_error = Rigid::new(exp_so3(&ws.packed_wp.1), ws.packed_wp.0);
        ws.packed_from.copy_from_slice(coeffs);
        ws.packed_once = true;
    }

    /// Local-frame component values `[δ; ε]` and location values `[lt; lw]` of axis `i` at
    /// position `q`, from the packed polynomials (or the general path).
    #[inline(always)]
    fn local_values(
        &self,
        i: usize,
        q: f64,
        coeffs: &[f64],
        ws: &mut Workspace,
    ) -> ([f64; 6], [f64; 6]) {
        let pa = &ws.packed[i];
        if pa.general {
            let ap = &self.plan.axes[i];
            let (c, _) = self.axis_values(i, q, coeffs, &mut ws.legendre);
            return (to_local(&ap.r0t, &c), ws.packed[i].loc);
        }
        let terms = pa.terms;
        let u = normalised(self.plan.axes[i].legendre_stroke, q);
        // A model without coefficients (nothing estimated, nothing set) packs no terms.
        let mut c = if terms == 0 {
            [0.0; 6]
        } else {
            pa.mono[terms - 1]
        };
        for m in pa.mono[..terms.saturating_sub(1)].iter().rev() {
            for d in 0..6 {
                c[d] = c[d] * u + m[d];
            }
        }
        if pa.fourier_terms > 0 {
            let mut f = [0.0; FOURIER_TERMS];
            fourier_values(q, &mut f[..pa.fourier_terms]);
            for (fj, m) in f.iter().zip(&pa.fourier[..pa.fourier_terms]) {
                for d in 0..6 {
                    c[d] += fj * m[d];
                }
            }
        }
        (c, pa.loc)
    }

    /// Component values (with a rotary axis' own-direction location constants) and location
    /// values of axis `i` at position `q`, machine directions.
    #[inline]
    fn axis_values(
        &self,
        i: usize,
        q: f64,
        coeffs: &[f64],
        legendre: &mut [f64],
    ) -> ([f64; 6], [f64; 6]) {
        let ap = &self.plan.axes[i];
        if let Some(max) = ap.legendre_max {
            legendre_values(ap.legendre_stroke, q, &mut legendre[..=max]);
        }
        let mut c = [0.0; 6];
        let mut l = [0.0; 6];
        for d in 0..6 {
            match ap.comp[d] {
                Slot::Empty => {}
                Slot::Legendre { offset, len, min } => {
                    c[d] = dot(&coeffs[offset..offset + len], &legendre[min..min + len]);
                }
                Slot::General { offset, len, param }
                | Slot::Fourier {
                    offset, len, param, ..
                } => {
                    let Role::Component { basis, .. } = &self.errors.params()[param].role else {
                        unreachable!("component slot holds a component")
                    };
                    c[d] = basis.value(q, &coeffs[offset..offset + len]);
                }
            }
            if let Some(o) = ap.own_loc[d] {
                c[d] += coeffs[o];
            }
            if let Some(o) = ap.loc[d] {
                l[d] = coeffs[o];
            }
        }
        (c, l)
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
        let jl_inv = left_jacobian_inverse(&err.rotation);
        self.fill_param_jacobian(ws, jac, Some(&jl_inv));
        err
    }

    /// The actual tool pose in the workpiece frame `w_T_t` and its Jacobian with respect to every
    /// coefficient, for instrument models: `jac` is column-major 6 × `n_coeffs`, each column
    /// `[δt; δθ]` of the left perturbation `t ← t + δt`, `R ← exp([δθ]×)·R` (workpiece frame).
    /// No allocation.
    pub fn tool_pose_jacobian(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
        jac: &mut [f64],
    ) -> Rigid {
        self.check_sizes(q, coeffs);
        assert_eq!(jac.len(), 6 * self.n_coeffs(), "jacobian buffer size");
        self.eval_values(q, coeffs, ws, Fill::Basis);
        self.eval_chain(q, ws);
        self.fill_param_jacobian(ws, jac, None);
        ws.w_t_t
    }

    /// The actual tool pose, like [`Self::tool_pose`], leaving `ws` ready for
    /// [`Self::project_tool_jacobian`] at this pose (the caller needs the pose first to know
    /// how its readings depend on it).
    pub fn tool_pose_for_jacobian(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace) -> Rigid {
        self.check_sizes(q, coeffs);
        self.eval_values(q, coeffs, ws, Fill::Basis);
        self.eval_chain(q, ws);
        ws.w_t_t
    }

    /// `out[c·n + k] = Σ_r proj[c][r] · J[r][k]` for the tool-pose Jacobian `J` of
    /// [`Self::tool_pose_jacobian`] (`n` coefficients) at the pose of the last
    /// [`Self::tool_pose_for_jacobian`]: the Jacobian of readings that depend on the pose
    /// through the rows `proj`. A component error's columns are one unit column times its basis
    /// values, so each is projected once and scaled, which is much cheaper than the full
    /// Jacobian followed by the product.
    ///
    /// # Panics
    /// If `out.len() != proj.len() · n_coeffs()`.
    pub fn project_tool_jacobian(&self, ws: &Workspace, proj: &[[f64; 6]], out: &mut [f64]) {
        let n = self.n_coeffs();
        assert_eq!(out.len(), proj.len() * n, "projected jacobian buffer size");
        self.param_columns(ws, &mut ProjectedColumns { proj, out, n }, None);
    }

    /// The actual tool pose in the workpiece frame `w_T_t`, every error inserted.
    pub fn tool_pose(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace) -> Rigid {
        self.check_sizes(q, coeffs);
        self.eval_values(q, coeffs, ws, Fill::Values);
        self.eval_chain(q, ws);
        ws.w_t_t
    }
}
