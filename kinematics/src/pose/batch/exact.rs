//! The batched exact pose error as one walk along the chain carrying the error transform, the
//! way [`MachineModel::pose_error_first_order`] carries its first-order error.
//!
//! `pose_error` builds the actual and the nominal pose of both branches and relates them: four
//! chains of full transforms and an inverse, each joint a few 3 × 3 products. Here, walking
//! from the tool to the workpiece, the state is the nominal tool point `p` in the current
//! frame, the actual tool point's displacement from it `v = t − t₀`, and the rotation error
//! `R·R₀ᵀ` kept as its difference `A` from the identity. A frame change that actual and
//! nominal share (a joint origin, a turn, a nominal slide) only moves `p`, turns `v` and
//! conjugates `A` (nothing at all for a pure translation, two planar turns for a rotary axis);
//! an error factor `F = (I + B, f)` that only the actual chain has costs one small product:
//! `v ← B·(p + v) + v + f`, `A ← A + B + B·A`. At the workpiece `v` is `p − p₀` and
//! `log(I + A)` is `log(R·R₀ᵀ)`: the same definition as `pose_error`, and `v` and `A`, never
//! formed as differences of metre-sized numbers, carry the error to full relative precision.

use super::*;
use crate::pose::lanes::{exp_minus_identity, log_near_identity, mm_const_left};

/// A rigid factor near the identity, `x ↦ (I + b)·x + t`, shared by all lanes; `b` kept apart
/// from the identity for the precision of the small rotation.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct NearIdentity {
    b: Matrix3<f64>,
    t: Vector3<f64>,
}

impl NearIdentity {
    /// The rigid motion `(exp([w]×), t)`.
    fn new(w: &Vector3<f64>, t: Vector3<f64>) -> Self {
        Self {
            b: exp_minus_identity(V3::splat(w)).lane(0),
            t,
        }
    }

    /// The inverse of `(exp([w]×), t)`: `(exp(−[w]×), −exp(−[w]×)·t)`.
    fn inverse_of(w: &Vector3<f64>, t: &Vector3<f64>) -> Self {
        let inv = Self::new(&-w, Vector3::zeros());
        Self {
            t: -(mv(&inv.b, t) + t),
            ..inv
        }
    }
}

/// What the walk needs of one axis beyond the per-pose values; depends only on the
/// coefficients, so it is derived once per coefficient set (with the packing), not per chunk.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ExactAxis {
    /// Some location error is set: without one, `L` and the squareness are the identity and
    /// the walk skips them.
    located: bool,
    /// A rotary axis' location factor `L` and its inverse.
    l: NearIdentity,
    l_inverse: NearIdentity,
    /// A linear axis' change of the direction of motion by its squareness, `R_L·a − a`.
    slide: Vector3<f64>,
}

/// The per-coefficient-set constants of the walk (see [`ExactAxis`]).
#[derive(Clone, Debug, Default)]
pub(super) struct ExactConstants {
    pub(super) axes: Vec<ExactAxis>,
    /// The inverse of the workpiece set-up error, the walk's last factor.
    wp_inverse: NearIdentity,
}

impl ExactConstants {
    /// Derives the constants from the packing of `sw` (call after every repacking).
    pub(super) fn build(&mut self, model: &MachineModel, sw: &Workspace) {
        self.axes.clear();
        for (pa, ax) in sw.packed.iter().zip(model.machine.axes()) {
            let (lt, lw) = (v3(&pa.loc, 0), v3(&pa.loc, 3));
            let l = NearIdentity::new(&lw, lt);
            self.axes.push(ExactAxis {
                located: pa.loc.iter().any(|&x| x != 0.0),
                l,
                l_inverse: NearIdentity::inverse_of(&lw, &lt),
                slide: mv(&l.b, ax.direction()),
            });
        }
        self.wp_inverse = NearIdentity::inverse_of(&sw.packed_wp.1, &sw.packed_wp.0);
    }
}

/// The carried error, per lane (see the module notes).
struct ErrorL {
    /// Nominal tool point, current frame.
    p: V3,
    /// Actual minus nominal tool point, current frame.
    v: V3,
    /// Rotation error `R·R₀ᵀ − I`, current frame.
    a: M3,
}

impl ErrorL {
    /// In the tool frame, where the actual pose is the tool offset `Trans(t)`.
    #[inline(always)]
    fn at_tool(t: V3) -> Self {
        let zero = V3::default();
        Self {
            p: zero,
            v: t,
            a: M3 { c: [zero; 3] },
        }
    }

    /// An error factor `(I + b, t)` of the actual chain only, per lane.
    #[inline(always)]
    fn actual(&mut self, b: &M3, t: V3) {
        self.v = b.mv(self.p + self.v) + self.v + t;
        self.a = self.a + *b + b.mm(&self.a);
    }

    /// An error factor shared by all lanes.
    #[inline(always)]
    fn actual_const(&mut self, f: &NearIdentity) {
        self.v = mv_const(&f.b, self.p + self.v) + self.v + V3::splat(&f.t);
        self.a = self.a + M3::splat(&f.b) + mm_const_left(&f.b, &self.a);
    }

    /// A linear axis' motion: nominal along `dir`, actual along `dir + slide`.
    #[inline(always)]
    fn slide(&mut self, dir: &Vector3<f64>, slide: &Vector3<f64>, q: L) {
        self.p += scaled_const(dir, q);
        self.v += scaled_const(slide, q);
    }

    /// From a child frame to its parent through `parent_T_child = t`, shared by actual and
    /// nominal chains.
    #[inline(always)]
    fn move_to_parent(&mut self, t: &Rigid, translation_only: bool) {
        if !translation_only {
            self.p = mv_const(&t.r, self.p);
            self.v = mv_const(&t.r, self.v);
            self.a = mm_const_left(&t.r, &self.a).mm_const(&t.r.transpose());
        }
        self.p += V3::splat(&t.t);
    }

    /// From a parent frame to its child through `parent_T_child = t`.
    #[inline(always)]
    fn move_to_child(&mut self, t: &Rigid, translation_only: bool) {
        self.p -= V3::splat(&t.t);
        if !translation_only {
            let rt = t.r.transpose();
            self.p = mv_const(&rt, self.p);
            self.v = mv_const(&rt, self.v);
            self.a = mm_const_left(&rt, &self.a).mm_const(&t.r);
        }
    }

    /// Through a rotary axis' turn `Rot` (current = Rot · before).
    #[inline(always)]
    fn turn(&mut self, t: &TurnL) {
        self.p = t.apply(self.p);
        self.v = t.apply(self.v);
        self.a = t.conjugate(&self.a);
    }

    /// Through the inverse of a turn.
    #[inline(always)]
    fn turn_back(&mut self, t: &TurnL) {
        let inv = t.inverse();
        self.p = inv.apply(self.p);
        self.v = inv.apply(self.v);
        self.a = inv.conjugate(&self.a);
    }
}

impl MachineModel {
    /// Exact error per lane: `pose_error`'s definition, as one walk carrying the error (see the
    /// module notes). Tool branch from the tool down to the machine frame, then the workpiece
    /// branch up to the workpiece, each joint's factors in the order they act on the tool.
    #[inline(always)]
    pub(super) fn chunk_exact(&self, ws: &BatchWorkspace) -> (V3, V3) {
        let axes = self.machine.axes();
        let consts = &ws.exact;
        let mut acc = ErrorL::at_tool(V3::splat(&ws.scalar.packed_tool));
        let tool = self.machine.branch(Side::Tool);
        acc.move_to_parent(tool.end(), self.plan.tool_end_is_translation);
        // parent_T_child = origin · Trans(R_L·a·q) · E (linear), origin · E · L·Rot·L⁻¹ (rotary).
        for &i in tool.joints().iter().rev() {
            let (ap, ax, k) = (&self.plan.axes[i], &axes[i], &consts.axes[i]);
            let (b, t) = component_factor(&ws.comp[i]);
            if ap.linear {
                acc.actual(&b, t);
                acc.slide(ax.direction(), &k.slide, ws.q[i]);
            } else {
                if k.located {
                    acc.actual_const(&k.l_inverse);
                }
                acc.turn(&ws.turns[i]);
                if k.located {
                    acc.actual_const(&k.l);
                }
                acc.actual(&b, t);
            }
            acc.move_to_parent(ax.origin(), ap.origin_is_translation);
        }
        // The workpiece body moves by E⁻¹: child_T_parent = E · Trans(−R_L·a·q) · origin⁻¹
        // (linear), L·Rot⁻¹·L⁻¹ · E · origin⁻¹ (rotary).
        let wp = self.machine.branch(Side::Workpiece);
        for &i in wp.joints() {
            let (ap, ax, k) = (&self.plan.axes[i], &axes[i], &consts.axes[i]);
            let (b, t) = component_factor(&ws.comp[i]);
            acc.move_to_child(ax.origin(), ap.origin_is_translation);
            if ap.linear {
                acc.slide(&-ax.direction(), &-k.slide, ws.q[i]);
                acc.actual(&b, t);
            } else {
                acc.actual(&b, t);
                if k.located {
                    acc.actual_const(&k.l_inverse);
                }
                acc.turn_back(&ws.turns[i]);
                if k.located {
                    acc.actual_const(&k.l);
                }
            }
        }
        acc.move_to_child(wp.end(), self.plan.wp_end_is_translation);
        acc.actual_const(&consts.wp_inverse);
        (acc.v, log_near_identity(&acc.a))
    }
}

/// The component error factor `E = (exp([ε]×), δ)` of the values `[δ; ε]`, as `(E_r − I, δ)`.
#[inline(always)]
fn component_factor(c: &[L; 6]) -> (M3, V3) {
    (exp_minus_identity(V3::of(c, 3)), V3::of(c, 0))
}
