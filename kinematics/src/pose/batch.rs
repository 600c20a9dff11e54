//! Pose errors of many poses at once: the same definitions as
//! [`MachineModel::pose_error_first_order`] and [`MachineModel::pose_error`], evaluated on
//! [`LANES`] poses together so that every operation is a vector instruction across poses.
//!
//! Per chunk of poses: the axis positions transposed into lanes, each axis' error values from
//! the packed polynomials (Horner in the normalised position, the shared Fourier functions),
//! the rotary axes' turns from a vectorised sine and cosine, then one walk along the chain,
//! lane by lane: the first-order one of the per-pose path, or for the exact error a walk that
//! carries the error transform instead of building and relating full poses (`exact`).
//! Everything that depends only on the coefficients (the packed polynomials, location factors,
//! set-up errors) is the per-pose [`Workspace`]'s packing, built once per coefficient set, and
//! the exact walk's constants derived from it at the same time. Components in other bases
//! (tables, B-splines, Legendre on another stroke) are evaluated pose by pose into the lanes;
//! the chain stays vectorised.
//!
//! The kernel is compiled twice, for AVX2 + FMA (`x86-64-v3`) and for the baseline, and chosen
//! at run time by `pulp` (safe code: the crate forbids `unsafe`). Both compile the same
//! operations in the same order (no fused multiply-add), so they give the same bits (the
//! property tests compare them bit for bit); the results differ from the per-pose path's only
//! by rounding (vectorised sine and cosine, products grouped differently, and the exact error
//! carried rather than formed as a difference of poses, which is the more precise).

// Index loops over lanes and directions: the shape the vectoriser turns into one instruction.
#![allow(clippy::needless_range_loop)]

use super::lanes::{self, L, LANES, M3, V3, mv_const, scaled_const, sin_cos};
use super::*;

mod exact;
use exact::ExactConstants;

/// Scratch of the batched evaluations; allocate once per thread with
/// [`MachineModel::batch_workspace`] (no allocation per call).
#[derive(Clone, Debug)]
pub struct BatchWorkspace {
    /// The per-pose workspace, for its packed polynomials (shared with the per-pose path's
    /// packing, rebuilt only when the coefficients change) and the general bases' scratch.
    scalar: Workspace,
    /// Per axis: the chunk's positions.
    q: Vec<L>,
    /// Per axis: the chunk's component values `[δ; ε]` in local directions.
    comp: Vec<[L; 6]>,
    /// Per axis: a rotary axis' turn at the chunk's positions.
    turns: Vec<TurnL>,
    /// The exact walk's per-axis constants, rebuilt with the packing.
    exact: ExactConstants,
    dispatch: BatchKernel,
}

/// Which compiled kernel the batched evaluations run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BatchKernel {
    /// The best the processor supports (AVX2 + FMA on x86_64 when present), detected at run
    /// time.
    #[default]
    Detect,
    /// The portable kernel only (for tests of the fallback, and comparisons).
    Portable,
}

impl BatchWorkspace {
    /// Chooses the kernel; [`BatchKernel::Detect`] unless set.
    pub fn set_kernel(&mut self, kernel: BatchKernel) {
        self.dispatch = kernel;
    }
}

/// A rotary axis' rotation per lane (see `frames::Turn`).
// One per axis in the workspace, read by value on the hot path: no box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
enum TurnL {
    /// About `e_k`, with `(sin q, cos q)` per lane.
    About(usize, L, L),
    General(M3),
}

impl TurnL {
    #[inline(always)]
    fn apply(&self, v: V3) -> V3 {
        match *self {
            TurnL::About(k, s, c) => planar(k, s, c, v),
            TurnL::General(r) => r.mv(v),
        }
    }

    #[inline(always)]
    fn apply_inverse(&self, v: V3) -> V3 {
        match *self {
            TurnL::About(k, s, c) => planar(k, -s, c, v),
            TurnL::General(r) => r.tmv(v),
        }
    }

    #[inline(always)]
    fn inverse(&self) -> TurnL {
        match *self {
            TurnL::About(k, s, c) => TurnL::About(k, -s, c),
            TurnL::General(r) => TurnL::General(r.transpose()),
        }
    }

    /// `Rot · m · Rotᵀ`: `m` re-expressed in the turned frame. About `e_k`, two planar turns
    /// of two rows and two columns.
    #[inline(always)]
    fn conjugate(&self, m: &M3) -> M3 {
        let left = M3 {
            c: [self.apply(m.c[0]), self.apply(m.c[1]), self.apply(m.c[2])],
        };
        self.inverse().right_of(&left)
    }

    /// `m · Rot`: about `e_k` only two columns mix.
    #[inline(always)]
    fn right_of(&self, m: &M3) -> M3 {
        match *self {
            TurnL::About(k, s, c) => {
                let [m0, m1, m2] = m.c;
                let c = match k {
                    0 => [m0, m1.scale(c) + m2.scale(s), m2.scale(c) - m1.scale(s)],
                    1 => [m0.scale(c) - m2.scale(s), m1, m2.scale(c) + m0.scale(s)],
                    _ => [m0.scale(c) + m1.scale(s), m1.scale(c) - m0.scale(s), m2],
                };
                M3 { c }
            }
            TurnL::General(r) => m.mm(&r),
        }
    }
}

/// `v` rotated about `e_k` by the angle with sine `s` and cosine `c` (see `frames::planar`).
#[inline(always)]
fn planar(k: usize, s: L, c: L, v: V3) -> V3 {
    let (x, y, z) = (v.x, v.y, v.z);
    match k {
        0 => V3::new(x, c * y - s * z, s * y + c * z),
        1 => V3::new(s * z + c * x, y, c * z - s * x),
        _ => V3::new(c * x - s * y, s * x + c * y, z),
    }
}

/// The first-order error carried along the chain (see `frames::AtToolPoint`), per lane.
#[derive(Clone, Copy, Default)]
struct AtToolPointL {
    p: V3,
    v: V3,
    w: V3,
}

impl AtToolPointL {
    #[inline(always)]
    fn add(&mut self, tv: V3, tw: V3) {
        self.v += tv + tw.cross(self.p);
        self.w += tw;
    }

    #[inline(always)]
    fn turn(&mut self, t: &TurnL) {
        (self.p, self.v, self.w) = (t.apply(self.p), t.apply(self.v), t.apply(self.w));
    }

    #[inline(always)]
    fn turn_back(&mut self, t: &TurnL) {
        self.p = t.apply_inverse(self.p);
        self.v = t.apply_inverse(self.v);
        self.w = t.apply_inverse(self.w);
    }

    #[inline(always)]
    fn move_to_parent(&mut self, t: &Rigid, translation_only: bool) {
        if !translation_only {
            self.p = mv_const(&t.r, self.p);
            self.v = mv_const(&t.r, self.v);
            self.w = mv_const(&t.r, self.w);
        }
        self.p += V3::splat(&t.t);
    }

    #[inline(always)]
    fn move_to_child(&mut self, t: &Rigid, translation_only: bool) {
        self.p -= V3::splat(&t.t);
        if !translation_only {
            let rt = t.r.transpose();
            self.p = mv_const(&rt, self.p);
            self.v = mv_const(&rt, self.v);
            self.w = mv_const(&rt, self.w);
        }
    }
}

/// One batched evaluation, handed to `pulp` to run under the detected instruction set.
struct Kernel<'a, const EXACT: bool> {
    model: &'a MachineModel,
    q: &'a [f64],
    coeffs: &'a [f64],
    ws: &'a mut BatchWorkspace,
    out: &'a mut [[f64; 6]],
}

impl<const EXACT: bool> pulp::WithSimd for Kernel<'_, EXACT> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        self.model
            .run_batch::<EXACT>(self.q, self.coeffs, self.ws, self.out);
    }
}

impl MachineModel {
    /// Scratch for [`Self::pose_errors_first_order`] and [`Self::pose_errors`].
    pub fn batch_workspace(&self) -> BatchWorkspace {
        let n = self.machine.n_axes();
        BatchWorkspace {
            scalar: self.workspace(),
            q: vec![L::ZERO; n],
            comp: vec![[L::ZERO; 6]; n],
            turns: vec![TurnL::About(0, L::ZERO, L::ZERO); n],
            exact: ExactConstants::default(),
            dispatch: BatchKernel::Detect,
        }
    }

    /// First-order pose errors of many poses: `q` holds the poses one after another (one
    /// position per axis each, as [`Self::pose_error_first_order`] takes them), `out[k]` gets
    /// pose `k`'s error as [`PoseError::to_array`] orders it. Equal to the per-pose
    /// evaluation to rounding; no allocation.
    ///
    /// # Panics
    /// If `q.len() != out.len() · n_axes` or `coeffs.len() != n_coeffs()`.
    pub fn pose_errors_first_order(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut BatchWorkspace,
        out: &mut [[f64; 6]],
    ) {
        self.dispatch_batch::<false>(q, coeffs, ws, out);
    }

    /// Exact pose errors of many poses, as [`Self::pose_errors_first_order`] lays them out;
    /// equal to [`Self::pose_error`] to rounding.
    ///
    /// # Panics
    /// As [`Self::pose_errors_first_order`].
    pub fn pose_errors(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut BatchWorkspace,
        out: &mut [[f64; 6]],
    ) {
        self.dispatch_batch::<true>(q, coeffs, ws, out);
    }

    fn dispatch_batch<const EXACT: bool>(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut BatchWorkspace,
        out: &mut [[f64; 6]],
    ) {
        assert_eq!(
            q.len(),
            out.len() * self.machine.n_axes(),
            "one position per axis and pose"
        );
        assert_eq!(coeffs.len(), self.n_coeffs(), "one value per coefficient");
        assert_eq!(ws.q.len(), self.machine.n_axes(), "workspace of this model");
        if self.ensure_packed(coeffs, &mut ws.scalar) {
            ws.exact.build(self, &ws.scalar);
        }
        let arch = match ws.dispatch {
            BatchKernel::Detect => pulp::Arch::new(),
            BatchKernel::Portable => pulp::Arch::Scalar,
        };
        arch.dispatch(Kernel::<EXACT> {
            model: self,
            q,
            coeffs,
            ws,
            out,
        });
    }

    /// The chunk loop: positions into lanes, values, the chain, results out of the lanes. A
    /// last partial chunk repeats its last pose in the spare lanes and writes only its own.
    #[inline(always)]
    fn run_batch<const EXACT: bool>(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut BatchWorkspace,
        out: &mut [[f64; 6]],
    ) {
        let n = self.machine.n_axes();
        for (c, out) in out.chunks_mut(LANES).enumerate() {
            let poses = &q[c * LANES * n..][..out.len() * n];
            let last = out.len() - 1;
            for (i, qi) in ws.q.iter_mut().enumerate() {
                for k in 0..LANES {
                    qi.0[k] = poses[k.min(last) * n + i];
                }
            }
            self.chunk_values(coeffs, ws);
            let (t, r) = if EXACT {
                self.chunk_exact(ws)
            } else {
                self.chunk_first_order(ws)
            };
            for (k, o) in out.iter_mut().enumerate() {
                *o = [t.x.0[k], t.y.0[k], t.z.0[k], r.x.0[k], r.y.0[k], r.z.0[k]];
            }
        }
    }

    /// Every axis' component values and every rotary axis' turn at the chunk's positions.
    #[inline(always)]
    fn chunk_values(&self, coeffs: &[f64], ws: &mut BatchWorkspace) {
        for (i, (ap, ax)) in self.plan.axes.iter().zip(self.machine.axes()).enumerate() {
            let q = ws.q[i];
            let pa = &ws.scalar.packed[i];
            let sin_cos = (!ap.linear || pa.fourier_terms > 0).then(|| sin_cos(q));
            ws.comp[i] = if pa.general {
                self.general_values(i, q, coeffs, &mut ws.scalar)
            } else {
                packed_values(self.plan.axes[i].legendre_stroke, pa, q, sin_cos)
            };
            if let Some((s, c)) = sin_cos
                && !ap.linear
            {
                ws.turns[i] = match ap.along_basis {
                    Some((k, sign)) => TurnL::About(k, s * sign, c),
                    None => TurnL::General(lanes::axis_rotation(ax.direction(), s, c)),
                };
            }
        }
    }

    /// Axis `i`'s local component values pose by pose through the general path.
    #[inline(always)]
    fn general_values(&self, i: usize, q: L, coeffs: &[f64], sw: &mut Workspace) -> [L; 6] {
        let mut out = [L::ZERO; 6];
        for k in 0..LANES {
            let (c, _) = self.axis_values(i, q.0[k], coeffs, &mut sw.legendre);
            for (o, v) in out.iter_mut().zip(to_local(&self.plan.axes[i].r0t, &c)) {
                o.0[k] = v;
            }
        }
        out
    }

    /// First-order error per lane: `pose_error_first_order`'s walk, line by line.
    #[inline(always)]
    fn chunk_first_order(&self, ws: &BatchWorkspace) -> (V3, V3) {
        let sw = &ws.scalar;
        let axes = self.machine.axes();
        let mut acc = AtToolPointL::default();
        let tool = self.machine.branch(Side::Tool);
        acc.add(V3::splat(&sw.packed_tool), V3::default());
        acc.move_to_parent(tool.end(), self.plan.tool_end_is_translation);
        for &i in tool.joints().iter().rev() {
            let (ap, ax, q) = (&self.plan.axes[i], &axes[i], ws.q[i]);
            let (c, l) = (&ws.comp[i], &sw.packed[i].loc);
            let (de, ee) = (V3::of(c, 0), V3::of(c, 3));
            if ap.linear {
                let dir = ax.direction();
                acc.add(de + scaled_const(&v3(l, 3).cross(dir), q), ee);
                acc.p += scaled_const(dir, q);
            } else {
                let turn = &ws.turns[i];
                acc.turn(turn);
                let (lt, lw) = (V3::splat(&v3(l, 0)), V3::splat(&v3(l, 3)));
                acc.add(de + lt - turn.apply(lt), ee + lw - turn.apply(lw));
            }
            acc.move_to_parent(ax.origin(), ap.origin_is_translation);
        }
        let wp = self.machine.branch(Side::Workpiece);
        for &i in wp.joints() {
            let (ap, ax, q) = (&self.plan.axes[i], &axes[i], ws.q[i]);
            let (c, l) = (&ws.comp[i], &sw.packed[i].loc);
            let (de, ee) = (V3::of(c, 0), V3::of(c, 3));
            acc.move_to_child(ax.origin(), ap.origin_is_translation);
            if ap.linear {
                let dir = ax.direction();
                acc.p -= scaled_const(dir, q);
                acc.add(de - scaled_const(&v3(l, 3).cross(dir), q), ee);
            } else {
                let turn = &ws.turns[i];
                let (lt, lw) = (V3::splat(&v3(l, 0)), V3::splat(&v3(l, 3)));
                acc.add(de - lt + turn.apply(lt), ee - lw + turn.apply(lw));
                acc.turn_back(turn);
            }
        }
        acc.move_to_child(wp.end(), self.plan.wp_end_is_translation);
        acc.add(-V3::splat(&sw.packed_wp.0), -V3::splat(&sw.packed_wp.1));
        (acc.v, acc.w)
    }
}

/// Local component values per lane from the packed polynomials (see `local_values`).
#[inline(always)]
fn packed_values(stroke: (f64, f64), pa: &PackedAxis, q: L, sin_cos: Option<(L, L)>) -> [L; 6] {
    let u = q.map(|x| normalised(stroke, x));
    // Unrolled per degree (cubic is the common one), so that the six values stay in registers.
    let mut c = match pa.terms {
        0 => [L::ZERO; 6],
        1 => horner::<1>(&pa.mono, u),
        2 => horner::<2>(&pa.mono, u),
        3 => horner::<3>(&pa.mono, u),
        4 => horner::<4>(&pa.mono, u),
        5 => horner::<5>(&pa.mono, u),
        6 => horner::<6>(&pa.mono, u),
        7 => horner::<7>(&pa.mono, u),
        _ => horner::<PACKED_TERMS>(&pa.mono, u),
    };
    if let Some((s1, c1)) = sin_cos
        && pa.fourier_terms > 0
    {
        // 1, cos q, sin q, cos 2q, … by angle addition, as `fourier_values`.
        for d in 0..6 {
            c[d] += L::splat(pa.fourier[0][d]);
        }
        let (mut cj, mut sj) = (L::splat(1.0), L::ZERO);
        for pair in pa.fourier[1..pa.fourier_terms].chunks_exact(2) {
            (cj, sj) = (cj * c1 - sj * s1, sj * c1 + cj * s1);
            for d in 0..6 {
                c[d] += cj * pair[0][d] + sj * pair[1][d];
            }
        }
    }
    c
}

/// `Σ_{j<T} mono[j]·u^j` for the six directions, by Horner's rule.
#[inline(always)]
fn horner<const T: usize>(mono: &[[f64; 6]; PACKED_TERMS], u: L) -> [L; 6] {
    let mut c = [L::ZERO; 6];
    for d in 0..6 {
        c[d] = L::splat(mono[T - 1][d]);
    }
    for j in (0..T - 1).rev() {
        for d in 0..6 {
            c[d] = c[d] * u + L::splat(mono[j][d]);
        }
    }
    c
}
