//! Jacobians: the parameter columns of the last chain evaluation (full or projected), the
//! location columns, the tool Jacobian and the tool-side motions.

use super::*;

impl MachineModel {
    /// Columns of the parameter Jacobian from the last actual chain evaluation (with `phi`
    /// filled). `rot_map` maps the rotation rows (the pose error's `J_l⁻¹`); `None` leaves the
    /// left-perturbation rotation.
    ///
    /// An axis' error twists are translations and rotations about one point, so each set of
    /// six columns is a few 3 × 3 products ([`twist_columns`]) rather than six adjoints.
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn fill_param_jacobian(
        &self,
        ws: &Workspace,
        jac: &mut [f64],
        rot_map: Option<&Matrix3<f64>>,
    ) {
        self.param_columns(ws, &mut FullColumns(jac), rot_map);
    }

    /// Hands every parameter Jacobian column of the last actual chain evaluation to `out`: one
    /// by one, or as a unit column times a component's basis values (see
    /// [`Self::fill_param_jacobian`]).
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn param_columns<C: ColumnSink>(
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
    pub(super) fn location_columns(
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
}

/// `dE·E⁻¹` for a unit change of machine-direction component `d` of `E = (exp(ε), δ)`, given
/// in local coordinates through `r0t` (machine → local); `jl` is the left Jacobian of `ε`.
#[inline]
pub(super) fn e_twist(
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
pub(super) trait ColumnSink {
    /// Column of coefficient `o`.
    fn column(&mut self, o: usize, col: &[f64; 6]);
    /// Columns `offset + k` = `basis[k] · unit`.
    fn scaled_columns(&mut self, offset: usize, unit: &[f64; 6], basis: &[f64]);
}

/// Writes the full `6 × n` Jacobian, column-major.
pub(super) struct FullColumns<'a>(pub(super) &'a mut [f64]);

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
pub(super) struct ProjectedColumns<'a> {
    pub(super) proj: &'a [[f64; 6]],
    pub(super) out: &'a mut [f64],
    pub(super) n: usize,
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

pub(super) fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    // Two independent partial sums: half the dependent-add latency of a running sum.
    (a[0] * b[0] + a[2] * b[2] + a[4] * b[4]) + (a[1] * b[1] + a[3] * b[3] + a[5] * b[5])
}

/// The Jacobian column `[δp; δθ]` of a twist `(tv, tw)` given in the frame `w_T_m = m`, times
/// `s`: the tool point `p` moves by `v + ω × p` and the tool turns by `ω` (mapped by
/// `rot_map`), where `(v, ω)` is the twist in workpiece coordinates.
#[inline(always)]
pub(super) fn twist_column(
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
pub(super) fn twist_columns(
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
