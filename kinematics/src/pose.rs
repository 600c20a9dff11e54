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

/// The error model flattened per axis for the hot paths: coefficient offsets instead of
/// parameter lookups, one shared Legendre evaluation per axis, and flags that let the nominal
/// chain skip work (a pure-translation joint origin needs no rotation product).
#[derive(Clone, Debug)]
struct Plan {
    axes: Vec<AxisPlan>,
    tool: [Option<usize>; 3],
    workpiece: [Option<usize>; 6],
    /// Longest shared Legendre recurrence of any axis (scratch size).
    max_legendre: usize,
    /// The branch ends carry no rotation (the first-order walk skips the product).
    tool_end_is_translation: bool,
    wp_end_is_translation: bool,
}

#[derive(Clone, Debug)]
struct AxisPlan {
    linear: bool,
    /// Some component error or own-direction location error is configured: the axis has
    /// component-twist Jacobian columns (a reduced model, e.g. location errors only, has none).
    has_component_columns: bool,
    tool_side: bool,
    r0t: Matrix3<f64>,
    /// The joint frame is aligned with the machine frame at the zero pose (`r0t = I`).
    r0t_is_identity: bool,
    origin_is_translation: bool,
    /// The axis direction is exactly `±e_k`, as `(k, ±1)`: rotations mix two coordinates.
    along_basis: Option<(usize, f64)>,
    /// `(lo, hi)` of the stroke the axis' shared Legendre components use.
    legendre_stroke: (f64, f64),
    /// Highest Legendre degree evaluated for the axis (`None`: no shared Legendre component).
    legendre_max: Option<usize>,
    /// Shared Fourier functions `1, cos q, sin q, cos 2q, …` the axis' Fourier components use
    /// (0: none).
    fourier_terms: usize,
    comp: [Slot; 6],
    /// Coefficient offsets of the location errors that go into the location factor.
    loc: [Option<usize>; 6],
    /// Coefficient offsets of a rotary axis' own-direction location errors (added to the
    /// component values: they are their constants).
    own_loc: [Option<usize>; 6],
}

/// Highest Legendre degree + 1 the packed fast path handles; axes beyond it use the general one.
const PACKED_TERMS: usize = 8;

/// Shared Fourier functions the packed fast path handles (harmonics up to 16); axes beyond it
/// use the general one.
const FOURIER_TERMS: usize = 33;

/// An axis' error values in local coordinates (`r0t` applied) as dense polynomials in the
/// shared Legendre basis: `[δ; ε](q) = Σ_k comp[k]·P_k(u)`, location `[lt; lw] = loc`.
#[derive(Clone, Copy, Debug)]
struct PackedAxis {
    /// Monomial coefficients in the normalised position `u ∈ [−1, 1]` (converted from the
    /// Legendre ones when packing): Horner's rule then evaluates all six directions with a
    /// short dependency chain, where the Legendre recurrence is a long serial one.
    mono: [[f64; 6]; PACKED_TERMS],
    terms: usize,
    loc: [f64; 6],
    /// The location factor `L = (exp([lw]×), lt)` and its inverse, and a linear axis' actual
    /// direction of motion `R_L·a`: constant for one set of coefficients, so the chain walk
    /// does not recompute them at every pose.
    l_factor: Rigid,
    l_inverse: Rigid,
    motion_dir: Vector3<f64>,
    /// Some component is neither a shared-stroke Legendre polynomial nor a Fourier series:
    /// use the general path.
    general: bool,
    fourier_terms: usize,
    /// Coefficients of the shared Fourier functions (`1, cos q, sin q, cos 2q, …`), local
    /// directions: one sine and cosine per sample serve all six directions. Last: most axes
    /// never read it, and the fields above stay on a few cache lines.
    fourier: [[f64; 6]; FOURIER_TERMS],
}

impl Default for PackedAxis {
    fn default() -> Self {
        Self {
            mono: [[0.0; 6]; PACKED_TERMS],
            terms: 0,
            fourier: [[0.0; 6]; FOURIER_TERMS],
            fourier_terms: 0,
            loc: [0.0; 6],
            l_factor: Rigid::IDENTITY,
            l_inverse: Rigid::IDENTITY,
            motion_dir: Vector3::zeros(),
            general: false,
        }
    }
}

/// A component error slot of an axis.
#[derive(Clone, Copy, Debug)]
enum Slot {
    Empty,
    /// Legendre over the axis' shared stroke: coefficients `offset..offset+len` multiply
    /// `P_min .. P_(min+len-1)`.
    Legendre {
        offset: usize,
        len: usize,
        min: usize,
    },
    /// Fourier series: coefficients `offset..offset+len` multiply the axis' shared Fourier
    /// functions `first..first+len` (`param` for the general path).
    Fourier {
        offset: usize,
        len: usize,
        first: usize,
        param: usize,
    },
    /// Any other basis, evaluated through [`crate::Basis`] (index into the parameters).
    General {
        offset: usize,
        len: usize,
        param: usize,
    },
}

impl Plan {
    fn new(machine: &Machine, errors: &ErrorModel) -> Plan {
        let axes: Vec<AxisPlan> = machine
            .axes()
            .iter()
            .enumerate()
            .map(|(i, ax)| AxisPlan::new(i, ax, errors))
            .collect();
        let max_legendre = axes
            .iter()
            .filter_map(|a| a.legendre_max)
            .map(|m| m + 1)
            .max()
            .unwrap_or(0);
        Plan {
            axes,
            tool: std::array::from_fn(|d| errors.tool_offset(d).map(|p| p.offset)),
            workpiece: std::array::from_fn(|d| errors.workpiece_offset(d).map(|p| p.offset)),
            max_legendre,
            tool_end_is_translation: machine.branch(Side::Tool).end().r == Matrix3::identity(),
            wp_end_is_translation: machine.branch(Side::Workpiece).end().r == Matrix3::identity(),
        }
    }
}

impl AxisPlan {
    fn new(i: usize, ax: &crate::machine::Axis, errors: &ErrorModel) -> AxisPlan {
        let linear = ax.kind() == AxisKind::Linear;
        // The first Legendre component fixes the shared stroke; others on another stroke fall
        // back to the general path.
        let mut stroke = None;
        let mut legendre_max = None;
        let mut fourier_terms = 0;
        let mut comp = [Slot::Empty; 6];
        for (d, slot) in comp.iter_mut().enumerate() {
            let Some(p) = errors.component(i, d) else {
                continue;
            };
            let param = errors
                .params()
                .iter()
                .position(|q| std::ptr::eq(q, p))
                .expect("parameter of this model");
            *slot = Slot::General {
                offset: p.offset,
                len: p.len,
                param,
            };
            if let Role::Component {
                basis:
                    crate::Basis::Legendre {
                        lo,
                        hi,
                        min_degree,
                        max_degree,
                    },
                ..
            } = &p.role
            {
                let s = *stroke.get_or_insert((*lo, *hi));
                if s == (*lo, *hi) {
                    *slot = Slot::Legendre {
                        offset: p.offset,
                        len: p.len,
                        min: *min_degree,
                    };
                    legendre_max = Some(legendre_max.unwrap_or(0).max(*max_degree));
                }
            }
            if let Role::Component {
                basis:
                    crate::Basis::Fourier {
                        min_harmonic,
                        max_harmonic,
                    },
                ..
            } = &p.role
            {
                // Function order 1, cos q, sin q, cos 2q, …: harmonic k ≥ 1 starts at 2k − 1.
                let first = if *min_harmonic == 0 {
                    0
                } else {
                    2 * min_harmonic - 1
                };
                *slot = Slot::Fourier {
                    offset: p.offset,
                    len: p.len,
                    first,
                    param,
                };
                fourier_terms = fourier_terms.max(2 * max_harmonic + 1);
            }
        }
        let own = ax.own_cartesian();
        let mut loc = [None; 6];
        let mut own_loc = [None; 6];
        for d in 0..6 {
            if let Some(p) = errors.location(i, d) {
                if !linear && d % 3 == own {
                    own_loc[d] = Some(p.offset);
                } else {
                    loc[d] = Some(p.offset);
                }
            }
        }
        AxisPlan {
            linear,
            has_component_columns: comp.iter().any(|s| !matches!(s, Slot::Empty))
                || own_loc.iter().any(Option::is_some),
            tool_side: ax.side() == Side::Tool,
            r0t: ax.zero_rotation().transpose(),
            r0t_is_identity: *ax.zero_rotation() == Matrix3::identity(),
            origin_is_translation: ax.origin().r == Matrix3::identity(),
            along_basis: (0..3).find_map(|k| {
                let d = ax.direction();
                if *d == unit(k) {
                    Some((k, 1.0))
                } else if *d == -unit(k) {
                    Some((k, -1.0))
                } else {
                    None
                }
            }),
            legendre_stroke: stroke.unwrap_or((0.0, 1.0)),
            legendre_max,
            fourier_terms,
            comp,
            loc,
            own_loc,
        }
    }

    /// `m · r0t` (machine directions to local ones, then `m`), without the product when the
    /// joint frame is aligned with the machine's.
    #[inline(always)]
    fn times_r0t(&self, m: &Matrix3<f64>) -> Matrix3<f64> {
        if self.r0t_is_identity {
            *m
        } else {
            mm(m, &self.r0t)
        }
    }
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
    /// The body frame after the joint (`before_b · L·Rot(q)·L⁻¹` for a rotary axis).
    after: Rigid,
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

    /// Rebuilds the packed polynomials if `coeffs` differ from the last ones packed.
    #[inline(always)]
    fn ensure_packed(&self, coeffs: &[f64], ws: &mut Workspace) {
        // The check inline (it runs on every evaluation), the rebuild out of line.
        if !ws.packed_once || !bitwise_equal(&ws.packed_from, coeffs) {
            self.pack(coeffs, ws);
        }
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

    /// Columns of the parameter Jacobian from the last actual chain evaluation (with `phi`
    /// filled). `rot_map` maps the rotation rows (the pose error's `J_l⁻¹`); `None` leaves the
    /// left-perturbation rotation.
    ///
    /// An axis' error twists are translations and rotations about one point, so each set of
    /// six columns is a few 3 × 3 products ([`twist_columns`]) rather than six adjoints.
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    fn fill_param_jacobian(&self, ws: &Workspace, jac: &mut [f64], rot_map: Option<&Matrix3<f64>>) {
        self.param_columns(ws, &mut FullColumns(jac), rot_map);
    }

    /// Hands every parameter Jacobian column of the last actual chain evaluation to `out`: one
    /// by one, or as a unit column times a component's basis values (see
    /// [`Self::fill_param_jacobian`]).
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    fn param_columns<C: ColumnSink>(
        &self,
        ws: &Workspace,
        out: &mut C,
        rot_map: Option<&Matrix3<f64>>,
    ) {
        let p = ws.w_t_t.t;
        let w_t_f = ws.f_t_w.inverse();
        for (i, ap) in self.plan.axes.iter().enumerate() {
            if ap.loc.iter().any(Option::is_some) {
                let cols = self.location_columns(i, ws, &w_t_f, &p, rot_map);
                for d in 0..6 {
                    if let Some(o) = ap.loc[d] {
                        out.column(o, &cols[d]);
                    }
                }
            }
            if !ap.has_component_columns {
                continue;
            }
            let js = &ws.joints[i];
            // Component errors: dE·E⁻¹ is a translation along `u` or a rotation `J_l·u` about
            // `δ`, in the frame before E. A workpiece-side body moves by E⁻¹, and
            // d(E⁻¹)·E = −Ad(E⁻¹)·(dE·E⁻¹): the same twists in the frame after E⁻¹, negated,
            // which cancels the branch sign.
            let e_frame = if ap.linear {
                &js.before_b
            } else {
                &js.before_a
            };
            let mut m = w_t_f.compose(e_frame);
            if !ap.tool_side {
                m = m.compose(&js.e_body);
            }
            let rot_dirs = ap.times_r0t(&left_jacobian(&js.e_rot));
            let unit_cols = twist_columns(&m, ap, &rot_dirs, &js.e_trans, &p, rot_map);
            // A packed axis' basis values are its shared Legendre and Fourier values (not copied
            // to `phi`).
            let packed = !ws.packed[i].general;
            let mut legendre = [0.0; PACKED_TERMS];
            if let (true, Some(max)) = (packed, ap.legendre_max) {
                legendre_values(ap.legendre_stroke, js.q, &mut legendre[..=max]);
            }
            // Only axes with Fourier components pay for the buffer.
            let fourier_buf;
            let fourier: &[f64] = if packed && ap.fourier_terms > 0 {
                let mut f = [0.0; FOURIER_TERMS];
                fourier_values(js.q, &mut f[..ap.fourier_terms]);
                fourier_buf = f;
                &fourier_buf[..ap.fourier_terms]
            } else {
                &[]
            };
            for (d, unit_col) in unit_cols.iter().enumerate() {
                let (offset, len, basis) = match ap.comp[d] {
                    Slot::Empty => (0, 0, &ws.phi[..0]),
                    Slot::Legendre { offset, len, min } if packed => {
                        (offset, len, &legendre[min..min + len])
                    }
                    Slot::Fourier {
                        offset, len, first, ..
                    } if packed => (offset, len, &fourier[first..first + len]),
                    Slot::Legendre { offset, len, .. }
                    | Slot::Fourier { offset, len, .. }
                    | Slot::General { offset, len, .. } => {
                        (offset, len, &ws.phi[offset..offset + len])
                    }
                };
                out.scaled_columns(offset, unit_col, &basis[..len]);
                if let Some(o) = ap.own_loc[d] {
                    out.column(o, unit_col);
                }
            }
        }
        if self.plan.tool.iter().any(Option::is_some) {
            let m = w_t_f.compose(&ws.tool_end);
            for d in 0..3 {
                if let Some(o) = self.plan.tool[d] {
                    let col = twist_column(&m, 1.0, &unit(d), &Vector3::zeros(), &p, rot_map);
                    out.column(o, &col);
                }
            }
        }
        if self.plan.workpiece.iter().any(Option::is_some) {
            let m = w_t_f.compose(&ws.wp_end);
            let jl = left_jacobian(&ws.wp_rot);
            for d in 0..6 {
                if let Some(o) = self.plan.workpiece[d] {
                    let (tv, tw) = e_twist(d, &Matrix3::identity(), &jl, &ws.wp_trans);
                    let col = twist_column(&m, -1.0, &tv, &tw, &p, rot_map);
                    out.column(o, &col);
                }
            }
        }
    }

    /// Jacobian columns of every location-error direction of axis `i` (the caller uses the
    /// configured ones), branch sign applied.
    // Index loops over parallel fixed-size arrays (directions 0..6, rows) read best here.
    #[allow(clippy::needless_range_loop)]
    fn location_columns(
        &self,
        i: usize,
        ws: &Workspace,
        w_t_f: &Rigid,
        p: &Vector3<f64>,
        rot_map: Option<&Matrix3<f64>>,
    ) -> [[f64; 6]; 6] {
        let ap = &self.plan.axes[i];
        let js = &ws.joints[i];
        let s = if ap.tool_side { 1.0 } else { -1.0 };
        let rot_dirs = ap.times_r0t(&left_jacobian(&js.l_rot));
        let mut cols = [[0.0; 6]; 6];
        if ap.linear {
            // Squareness tilts the direction of motion: the body moves by (J_l·u × a')·q, a
            // translation in the frame before the motion. Translations do not apply.
            let r = mm(&w_t_f.r, &js.before_a.r);
            for d in 3..6 {
                let tv = column(&rot_dirs, d - 3).cross(&js.motion_dir) * (s * js.q);
                cols[d][..3].copy_from_slice(mv(&r, &tv).as_slice());
            }
        } else {
            // A location twist τ moves L·Rot·L⁻¹ by τ − Ad(L·Rot·L⁻¹)·τ: τ in the frame before
            // L minus τ in the frame after the joint. Rotations are about `l_t`.
            let before_b = w_t_f.compose(&js.before_b);
            let before = twist_columns(&before_b, ap, &rot_dirs, &js.l_trans, p, rot_map);
            let after = w_t_f.compose(&js.after);
            let after = twist_columns(&after, ap, &rot_dirs, &js.l_trans, p, rot_map);
            for d in 0..6 {
                for r in 0..6 {
                    cols[d][r] = s * (before[d][r] - after[d][r]);
                }
            }
        }
        cols
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
        self.eval_chain(q, ws);
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
            // The component errors' rates of change along the axis (none on the nominal
            // machine: then their twists are not needed).
            if ws.dcomp[i].iter().any(|&rate| rate != 0.0) {
                let units = self.component_twists(i, ws);
                let e_frame = self.e_frame(i, ws);
                for (d, (tv, tw)) in units.iter().enumerate() {
                    let rate = ws.dcomp[i][d];
                    if rate != 0.0 {
                        acc(&e_frame, tv * rate, tw * rate, col);
                    }
                }
            }
        }
        ws.w_t_t
    }

    /// The tool point in the machine frame, `f_T_t`'s translation, at the pose `ws` was last
    /// evaluated at.
    pub fn machine_tool_point(&self, ws: &Workspace) -> Vector3<f64> {
        ws.f_t_w.compose(&ws.w_t_t).t
    }

    /// Columns of the tool branch moving as a whole in the machine frame: shifting along the
    /// machine's X, Y and Z, then turning about them through the origin,
    /// `w_T_t = f_T_w⁻¹ · Δ · f_T_t` (a cross-beam or a column twisting as a drive on one
    /// side of it warms): column-major 6 × [`TOOL_MOTIONS`] as [`Self::tool_jacobian`]'s, at
    /// the pose `ws` was last evaluated at ([`Self::tool_jacobian`], [`Self::tool_pose`]).
    pub fn tool_motion_columns(&self, ws: &Workspace, out: &mut [f64]) {
        assert_eq!(out.len(), 6 * TOOL_MOTIONS, "tool motion buffer size");
        let p = ws.w_t_t.t;
        let w_t_f = ws.f_t_w.inverse();
        for (k, col) in out.chunks_exact_mut(6).enumerate() {
            let unit = Vector3::ith(k % 3, 1.0);
            let (v, w) = if k < 3 {
                w_t_f.adjoint(&unit, &Vector3::zeros())
            } else {
                w_t_f.adjoint(&Vector3::zeros(), &unit)
            };
            let dp = v + w.cross(&p);
            col[..3].copy_from_slice(dp.as_slice());
            col[3..].copy_from_slice(w.as_slice());
        }
    }

    fn check_sizes(&self, q: &[f64], coeffs: &[f64]) {
        assert_eq!(q.len(), self.machine.n_axes(), "one position per axis");
        assert_eq!(coeffs.len(), self.n_coeffs(), "one value per coefficient");
    }

    /// Component and location values per axis (local joint directions) from the coefficients;
    /// with [`Fill::Basis`] also every basis function's value in `phi`.
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    fn eval_values(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace, fill: Fill) {
        if fill == Fill::Derivative {
            return self.eval_values_generic(q, coeffs, ws, fill);
        }
        self.ensure_packed(coeffs, ws);
        for i in 0..self.plan.axes.len() {
            let (c, l) = self.local_values(i, q[i], coeffs, ws);
            ws.comp[i] = c;
            ws.loc[i] = l;
            // Packed axes' basis values are the shared Legendre ones, which the parameter
            // Jacobian evaluates itself.
            if fill == Fill::Basis && ws.packed[i].general {
                self.fill_phi(i, q[i], ws);
            }
        }
        ws.wp_trans = ws.packed_wp.0;
        ws.wp_rot = ws.packed_wp.1;
        ws.tool_trans = ws.packed_tool;
    }

    /// Every basis function of axis `i`'s components at `q` into `phi`.
    fn fill_phi(&self, i: usize, q: f64, ws: &mut Workspace) {
        let ap = &self.plan.axes[i];
        if let Some(max) = ap.legendre_max {
            legendre_values(ap.legendre_stroke, q, &mut ws.legendre[..=max]);
        }
        for slot in ap.comp {
            match slot {
                Slot::Empty => {}
                Slot::Legendre { offset, len, min } => {
                    ws.phi[offset..offset + len].copy_from_slice(&ws.legendre[min..min + len]);
                }
                Slot::General { offset, len, param }
                | Slot::Fourier {
                    offset, len, param, ..
                } => {
                    let Role::Component { basis, .. } = &self.errors.params()[param].role else {
                        unreachable!("component slot holds a component")
                    };
                    basis.eval(q, &mut ws.phi[offset..offset + len]);
                }
            }
        }
    }

    /// Component and location values per axis through [`crate::Basis`] one component at a time:
    /// the derivative fill (axis Jacobian), which is not on the identification hot path.
    fn eval_values_generic(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace, fill: Fill) {
        // The chain walk takes the location factors from the packed coefficients.
        self.ensure_packed(coeffs, ws);
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
            let r0t = &self.plan.axes[i].r0t;
            ws.comp[i] = to_local(r0t, &c);
            ws.dcomp[i] = dc;
            ws.loc[i] = to_local(r0t, &l);
        }
        ws.wp_trans = Vector3::from_fn(|r, _| value_of(self.errors.workpiece_offset(r), coeffs));
        ws.wp_rot = Vector3::from_fn(|r, _| value_of(self.errors.workpiece_offset(3 + r), coeffs));
        ws.tool_trans = Vector3::from_fn(|r, _| value_of(self.errors.tool_offset(r), coeffs));
    }

    /// Walks both branches, recording every joint's frames; leaves `f_t_w`, `w_t_t` and the
    /// rotary axes' turns.
    fn eval_chain(&self, q: &[f64], ws: &mut Workspace) {
        for (i, (ap, ax)) in self.plan.axes.iter().zip(self.machine.axes()).enumerate() {
            if !ap.linear {
                ws.turns[i] = Turn::new(ap.along_basis, ax.direction(), q[i]);
            }
        }
        for side in [Side::Workpiece, Side::Tool] {
            let branch = self.machine.branch(side);
            let mut t = Rigid::IDENTITY;
            for &i in branch.joints() {
                t = self.eval_joint(i, q[i], t, ws);
            }
            t = t.compose(branch.end());
            match side {
                Side::Workpiece => {
                    ws.wp_end = t;
                    t = t.compose(&ws.wp_error);
                    ws.f_t_w = t;
                }
                Side::Tool => {
                    ws.tool_end = t;
                    t = t.translated(&ws.tool_trans);
                    ws.w_t_t = ws.f_t_w.inverse().compose(&t);
                }
            }
        }
    }

    fn eval_joint(&self, i: usize, q: f64, t: Rigid, ws: &mut Workspace) -> Rigid {
        let ax = &self.machine.axes()[i];
        let (c, l) = (ws.comp[i], ws.loc[i]);
        let js = &mut ws.joints[i];
        js.q = q;
        js.e_trans = v3(&c, 0);
        js.e_rot = v3(&c, 3);
        js.l_trans = v3(&l, 0);
        js.l_rot = v3(&l, 3);
        let e = Rigid::new(exp_so3(&js.e_rot), js.e_trans);
        js.e_body = match ax.side() {
            Side::Tool => e,
            Side::Workpiece => e.inverse(),
        };
        let t = self.after_origin(i, &t);
        js.before_a = t;
        let pa = &ws.packed[i];
        match ax.kind() {
            AxisKind::Linear => {
                js.motion_dir = pa.motion_dir;
                js.before_b = t.translated(&(js.motion_dir * q));
                js.after = js.before_b.compose(&js.e_body);
                js.after
            }
            AxisKind::Rotary => {
                js.before_b = t.compose(&js.e_body);
                js.before_r = js.before_b.compose(&pa.l_factor);
                // before_r · Rot(q) · L⁻¹, with Rot(q) applied to the columns.
                let turned = Rigid::new(ws.turns[i].right_of(&js.before_r.r), js.before_r.t);
                js.after = turned.compose(&pa.l_inverse);
                js.after
            }
        }
    }

    /// `t · origin` of axis `i`, without the rotation product when the origin is a translation.
    #[inline(always)]
    fn after_origin(&self, i: usize, t: &Rigid) -> Rigid {
        let origin = self.machine.axes()[i].origin();
        if self.plan.axes[i].origin_is_translation {
            Rigid::new(t.r, mv(&t.r, &origin.t) + t.t)
        } else {
            t.compose(origin)
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
        let ap = &self.plan.axes[i];
        let js = &ws.joints[i];
        let jl = left_jacobian(&js.e_rot);
        let mut out = [(Vector3::zeros(), Vector3::zeros()); 6];
        for (d, o) in out.iter_mut().enumerate() {
            let (tv, tw) = e_twist(d, &ap.r0t, &jl, &js.e_trans);
            *o = if ap.tool_side {
                (tv, tw)
            } else {
                // d(E⁻¹)·E = −Ad(E⁻¹)·(dE·E⁻¹); the branch sign is applied later.
                let (v, w) = js.e_body.adjoint(&tv, &tw);
                (-v, -w)
            };
        }
        out
    }

    /// Nominal `w_T_t` (no errors), as [`Machine::tool_in_workpiece`] but with the plan's
    /// shortcuts and the rotary axes' turns of the last chain evaluation (at `q`).
    fn nominal_tool_in_workpiece(&self, q: &[f64], turns: &[Turn]) -> Rigid {
        let branch_pose = |side: Side| {
            let branch = self.machine.branch(side);
            let mut t = Rigid::IDENTITY;
            for &i in branch.joints() {
                let ax = &self.machine.axes()[i];
                t = self.after_origin(i, &t);
                t = match ax.kind() {
                    AxisKind::Linear => Rigid::new(t.r, mv(&t.r, &(ax.direction() * q[i])) + t.t),
                    AxisKind::Rotary => Rigid::new(turns[i].right_of(&t.r), t.t),
                };
            }
            t.compose(branch.end())
        };
        branch_pose(Side::Workpiece)
            .inverse()
            .compose(&branch_pose(Side::Tool))
    }
}

/// `dE·E⁻¹` for a unit change of machine-direction component `d` of `E = (exp(ε), δ)`, given
/// in local coordinates through `r0t` (machine → local); `jl` is the left Jacobian of `ε`.
#[inline]
fn e_twist(
    d: usize,
    r0t: &Matrix3<f64>,
    jl: &Matrix3<f64>,
    delta: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let u = column(r0t, d % 3);
    if d < 3 {
        (u, Vector3::zeros())
    } else {
        let w = mv(jl, &u);
        (delta.cross(&w), w)
    }
}

/// Receives parameter Jacobian columns (six pose rows each).
trait ColumnSink {
    /// Column of coefficient `o`.
    fn column(&mut self, o: usize, col: &[f64; 6]);
    /// Columns `offset + k` = `basis[k] · unit`.
    fn scaled_columns(&mut self, offset: usize, unit: &[f64; 6], basis: &[f64]);
}

/// Writes the full `6 × n` Jacobian, column-major.
struct FullColumns<'a>(&'a mut [f64]);

impl ColumnSink for FullColumns<'_> {
    fn column(&mut self, o: usize, col: &[f64; 6]) {
        self.0[6 * o..6 * o + 6].copy_from_slice(col);
    }

    fn scaled_columns(&mut self, offset: usize, unit: &[f64; 6], basis: &[f64]) {
        let block = &mut self.0[6 * offset..6 * (offset + basis.len())];
        for (k, f) in basis.iter().enumerate() {
            // As a fixed-size array: six straight-line products, no per-row loop.
            let col: &mut [f64; 6] = (&mut block[6 * k..6 * k + 6]).try_into().expect("six rows");
            *col = unit.map(|c| f * c);
        }
    }
}

/// Writes `proj · J` (`proj.len()` rows of `n`, row-major).
struct ProjectedColumns<'a> {
    proj: &'a [[f64; 6]],
    out: &'a mut [f64],
    n: usize,
}

impl ColumnSink for ProjectedColumns<'_> {
    fn column(&mut self, o: usize, col: &[f64; 6]) {
        for (c, p) in self.proj.iter().enumerate() {
            self.out[c * self.n + o] = dot6(p, col);
        }
    }

    fn scaled_columns(&mut self, offset: usize, unit: &[f64; 6], basis: &[f64]) {
        for (c, p) in self.proj.iter().enumerate() {
            let v = dot6(p, unit);
            let row = &mut self.out[c * self.n + offset..c * self.n + offset + basis.len()];
            for (o, f) in row.iter_mut().zip(basis) {
                *o = v * f;
            }
        }
    }
}

fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    // Two independent partial sums: half the dependent-add latency of a running sum.
    (a[0] * b[0] + a[2] * b[2] + a[4] * b[4]) + (a[1] * b[1] + a[3] * b[3] + a[5] * b[5])
}

/// The Jacobian column `[δp; δθ]` of a twist `(tv, tw)` given in the frame `w_T_m = m`, times
/// `s`: the tool point `p` moves by `v + ω × p` and the tool turns by `ω` (mapped by
/// `rot_map`), where `(v, ω)` is the twist in workpiece coordinates.
#[inline(always)]
fn twist_column(
    m: &Rigid,
    s: f64,
    tv: &Vector3<f64>,
    tw: &Vector3<f64>,
    p: &Vector3<f64>,
    rot_map: Option<&Matrix3<f64>>,
) -> [f64; 6] {
    let (v, w) = m.adjoint(tv, tw);
    let (v, w) = (v * s, w * s);
    let dp = v + w.cross(p);
    let dr = match rot_map {
        Some(map) => mv(map, &w),
        None => w,
    };
    [dp.x, dp.y, dp.z, dr.x, dr.y, dr.z]
}

/// Jacobian columns (as [`twist_column`], sign +1) of six twists given in the frame
/// `w_T_m = (R, t)`: translations along the machine directions (`ap.r0t` maps them to local
/// ones), then rotations about the columns of `rot_dirs` (local) through the point `o`. A
/// rotation `ω` about `o` moves the tool point by `(R·ω) × (p − t − R·o)`, so the six columns
/// are a few 3 × 3 products and three cross products instead of six adjoints.
#[inline(always)]
fn twist_columns(
    m: &Rigid,
    ap: &AxisPlan,
    rot_dirs: &Matrix3<f64>,
    o: &Vector3<f64>,
    p: &Vector3<f64>,
    rot_map: Option<&Matrix3<f64>>,
) -> [[f64; 6]; 6] {
    let tr = ap.times_r0t(&m.r);
    let rw = mm(&m.r, rot_dirs);
    let arm = p - m.t - mv(&m.r, o);
    let turn = match rot_map {
        Some(map) => mm(map, &rw),
        None => rw,
    };
    let mut cols = [[0.0; 6]; 6];
    for k in 0..3 {
        let (t, w, dr) = (column(&tr, k), column(&rw, k), column(&turn, k));
        let dp = w.cross(&arm);
        cols[k] = [t.x, t.y, t.z, 0.0, 0.0, 0.0];
        cols[3 + k] = [dp.x, dp.y, dp.z, dr.x, dr.y, dr.z];
    }
    cols
}

/// `1/n` (a table for the small `n` of the Legendre recurrence keeps division off the hot path;
/// the values are the correctly rounded quotients, as `1.0 / n as f64`).
#[inline]
fn recip(n: usize) -> f64 {
    const TABLE: [f64; 9] = [
        f64::INFINITY,
        1.0,
        1.0 / 2.0,
        1.0 / 3.0,
        1.0 / 4.0,
        1.0 / 5.0,
        1.0 / 6.0,
        1.0 / 7.0,
        1.0 / 8.0,
    ];
    if n < TABLE.len() {
        TABLE[n]
    } else {
        1.0 / n as f64
    }
}

/// `P_0 … P_(len−1)` at `q` on the stroke `(lo, hi)`, held at the ends outside it: the same
/// recurrence and rounding as [`crate::Basis`]'s Legendre evaluation.
#[inline]
fn legendre_values(stroke: (f64, f64), q: f64, out: &mut [f64]) {
    let u = normalised(stroke, q);
    let (mut p_prev, mut p) = (0.0, 1.0);
    let n = out.len();
    for (k, o) in out.iter_mut().enumerate() {
        *o = p;
        if k + 1 < n {
            let p_next = ((2 * k + 1) as f64 * u * p - k as f64 * p_prev) * recip(k + 1);
            (p_prev, p) = (p, p_next);
        }
    }
}

/// The shared Fourier functions `1, cos q, sin q, cos 2q, sin 2q, …` at `q` into `out`: the
/// same angle-addition recurrence and rounding as [`crate::Basis`]'s Fourier evaluation.
#[inline]
fn fourier_values(q: f64, out: &mut [f64]) {
    let Some((one, harmonics)) = out.split_first_mut() else {
        return;
    };
    *one = 1.0;
    let (s1, c1) = q.sin_cos();
    let (mut c, mut s) = (1.0, 0.0);
    for pair in harmonics.chunks_exact_mut(2) {
        (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
        pair[0] = c;
        pair[1] = s;
    }
}

/// `a == b` bit for bit (so NaN never matches a number), four lanes at a time without early
/// exit: this runs on every evaluation, and the usual answer is "equal".
#[inline]
fn bitwise_equal(a: &[f64], b: &[f64]) -> bool {
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .fold(0u64, |acc, (x, y)| acc | (x.to_bits() ^ y.to_bits()));
    let lanes = ca.zip(cb).fold([0u64; 4], |mut acc, (x, y)| {
        for k in 0..4 {
            acc[k] |= x[k].to_bits() ^ y[k].to_bits();
        }
        acc
    });
    a.len() == b.len() && (tail | lanes[0] | lanes[1] | lanes[2] | lanes[3]) == 0
}

/// `q` mapped from the stroke `(lo, hi)` to `[−1, 1]`, held at the ends outside it.
#[inline(always)]
fn normalised((lo, hi): (f64, f64), q: f64) -> f64 {
    let x = if q < lo {
        lo
    } else if q > hi {
        hi
    } else {
        q
    };
    (x - lo) * (2.0 / (hi - lo)) - 1.0
}

/// `P_k(u) = Σ_j L[k][j]·u^j` for `k < PACKED_TERMS` (Bonnet's recurrence on the monomial
/// coefficients; all entries are small exact-enough rationals).
fn legendre_monomials() -> [[f64; PACKED_TERMS]; PACKED_TERMS] {
    let mut l = [[0.0; PACKED_TERMS]; PACKED_TERMS];
    l[0][0] = 1.0;
    l[1][1] = 1.0;
    for k in 1..PACKED_TERMS - 1 {
        // (k+1)·P_(k+1) = (2k+1)·u·P_k − k·P_(k−1)
        let (a, b, c) = ((2 * k + 1) as f64, k as f64, (k + 1) as f64);
        for j in 0..PACKED_TERMS {
            let up = if j > 0 { l[k][j - 1] } else { 0.0 };
            l[k + 1][j] = (a * up - b * l[k - 1][j]) / c;
        }
    }
    l
}

/// A rotary axis' rotation by `q`: about a coordinate axis only two coordinates mix (four
/// products instead of a 3 × 3 product, and no matrix to build).
#[derive(Clone, Copy, Debug)]
enum Turn {
    /// About `e_k`, with `(sin q, cos q)` (an axis along `−e_k` turns by `−q`).
    About(usize, f64, f64),
    General(Matrix3<f64>),
}

impl Turn {
    #[inline(always)]
    fn new(along_basis: Option<(usize, f64)>, direction: &Vector3<f64>, q: f64) -> Turn {
        match along_basis {
            Some((k, sign)) => {
                let (s, c) = q.sin_cos();
                Turn::About(k, sign * s, c)
            }
            None => Turn::General(axis_rotation(direction, q)),
        }
    }

    #[inline(always)]
    fn apply(&self, v: &Vector3<f64>) -> Vector3<f64> {
        match *self {
            Turn::About(k, s, c) => planar(k, s, c, v),
            Turn::General(r) => mv(&r, v),
        }
    }

    #[inline(always)]
    fn apply_inverse(&self, v: &Vector3<f64>) -> Vector3<f64> {
        match *self {
            Turn::About(k, s, c) => planar(k, -s, c, v),
            Turn::General(r) => mv(&r.transpose(), v),
        }
    }

    /// `m · Rot`: about `e_k` only two columns mix.
    #[inline(always)]
    fn right_of(&self, m: &Matrix3<f64>) -> Matrix3<f64> {
        match *self {
            Turn::About(k, s, c) => {
                // Columns i = k+1, j = k+2 (cyclic) become c·m_i + s·m_j and c·m_j − s·m_i.
                let (m0, m1, m2) = (column(m, 0), column(m, 1), column(m, 2));
                let cols = match k {
                    0 => [m0, m1 * c + m2 * s, m2 * c - m1 * s],
                    1 => [m0 * c - m2 * s, m1, m2 * c + m0 * s],
                    _ => [m0 * c + m1 * s, m1 * c - m0 * s, m2],
                };
                Matrix3::from_columns(&cols)
            }
            Turn::General(r) => mm(m, &r),
        }
    }
}

/// `v` rotated about `e_k` by the angle with sine `s` and cosine `c`.
#[inline(always)]
fn planar(k: usize, s: f64, c: f64, v: &Vector3<f64>) -> Vector3<f64> {
    // Written out per axis: no run-time indexing into the vector.
    let (x, y, z) = (v.x, v.y, v.z);
    match k {
        0 => Vector3::new(x, c * y - s * z, s * y + c * z),
        1 => Vector3::new(s * z + c * x, y, c * z - s * x),
        _ => Vector3::new(c * x - s * y, s * x + c * y, z),
    }
}

/// The first-order error carried along the chain: the tool point `p`, the displacement of the
/// tool point `v` (µm) and the rotation `w` (µrad), all in the current frame's coordinates.
#[derive(Clone, Copy, Default)]
struct AtToolPoint {
    p: Vector3<f64>,
    v: Vector3<f64>,
    w: Vector3<f64>,
}

impl AtToolPoint {
    /// Adds a twist `(tv, tw)` given at the current frame's origin.
    #[inline(always)]
    fn add(&mut self, tv: Vector3<f64>, tw: Vector3<f64>) {
        self.v += tv + tw.cross(&self.p);
        self.w += tw;
    }

    /// Re-expresses in the frame before the rotation `r` (current = before · r).
    #[inline(always)]
    fn rotate(&mut self, r: &Matrix3<f64>) {
        self.p = mv(r, &self.p);
        self.v = mv(r, &self.v);
        self.w = mv(r, &self.w);
    }

    /// Re-expresses in the frame after the rotation `r` (current · r = next).
    #[inline(always)]
    fn rotate_back(&mut self, r: &Matrix3<f64>) {
        let rt = r.transpose();
        self.rotate(&rt);
    }

    /// From a child frame to its parent, `parent_T_child = t`.
    #[inline(always)]
    fn move_to_parent(&mut self, t: &Rigid, translation_only: bool) {
        if !translation_only {
            self.rotate(&t.r);
        }
        self.p += t.t;
    }

    /// From a parent frame to its child, `parent_T_child = t`.
    #[inline(always)]
    fn move_to_child(&mut self, t: &Rigid, translation_only: bool) {
        self.p -= t.t;
        if !translation_only {
            self.rotate_back(&t.r);
        }
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

/// `[r0t·a[0..3]; r0t·a[3..6]]`: machine directions to a joint's local ones.
#[inline]
fn to_local(r0t: &Matrix3<f64>, a: &[f64; 6]) -> [f64; 6] {
    let (t, r) = (mv(r0t, &v3(a, 0)), mv(r0t, &v3(a, 3)));
    [t.x, t.y, t.z, r.x, r.y, r.z]
}

/// Column `j` of `m`.
#[inline(always)]
fn column(m: &Matrix3<f64>, j: usize) -> Vector3<f64> {
    let c = &m.data.0[j];
    Vector3::new(c[0], c[1], c[2])
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

fn opt(offset: Option<usize>, coeffs: &[f64]) -> f64 {
    offset.map_or(0.0, |o| coeffs[o])
}

/// Workpiece set-up translation (`start` 0) or rotation (`start` 3) from the coefficients.
fn ws_wp(plan: &Plan, coeffs: &[f64], start: usize) -> Vector3<f64> {
    let wp = &plan.workpiece;
    Vector3::new(
        opt(wp[start], coeffs),
        opt(wp[start + 1], coeffs),
        opt(wp[start + 2], coeffs),
    )
}

fn value_of(p: Option<&crate::model::Param>, coeffs: &[f64]) -> f64 {
    match p {
        Some(p) => coeffs[p.offset],
        None => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::{BranchSpec, JointSpec, MachineSpec};
    use crate::model::{BasisChoice, iso_full_config};
    use nalgebra::{Isometry3, Translation3};

    fn joint(letter: char, kind: AxisKind, axis: [f64; 3], at: [f64; 3]) -> JointSpec {
        JointSpec {
            letter,
            kind,
            origin: Isometry3::from_parts(
                Translation3::from(Vector3::from(at)),
                Default::default(),
            ),
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
}
