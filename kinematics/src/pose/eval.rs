//! Evaluation: the error values per axis from the coefficients, the actual chain, the
//! nominal tool pose.

use super::*;

impl MachineModel {
    pub(super) fn check_sizes(&self, q: &[f64], coeffs: &[f64]) {
        assert_eq!(q.len(), self.machine.n_axes(), "one position per axis");
        assert_eq!(coeffs.len(), self.n_coeffs(), "one value per coefficient");
    }

    /// Component and location values per axis (local joint directions) from the coefficients;
    /// with [`Fill::Basis`] also every basis function's value in `phi`.
    // Index loops over parallel fixed-size arrays (directions 0..6, axes) read best here.
    #[allow(clippy::needless_range_loop)]
    pub(super) fn eval_values(&self, q: &[f64], coeffs: &[f64], ws: &mut Workspace, fill: Fill) {
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
    pub(super) fn fill_phi(&self, i: usize, q: f64, ws: &mut Workspace) {
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
    pub(super) fn eval_values_generic(
        &self,
        q: &[f64],
        coeffs: &[f64],
        ws: &mut Workspace,
        fill: Fill,
    ) {
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
    pub(super) fn eval_chain(&self, q: &[f64], ws: &mut Workspace) {
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

    pub(super) fn eval_joint(&self, i: usize, q: f64, t: Rigid, ws: &mut Workspace) -> Rigid {
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
    pub(super) fn after_origin(&self, i: usize, t: &Rigid) -> Rigid {
        let origin = self.machine.axes()[i].origin();
        if self.plan.axes[i].origin_is_translation {
            Rigid::new(t.r, mv(&t.r, &origin.t) + t.t)
        } else {
            t.compose(origin)
        }
    }

    /// The frame in which the component-error twists of axis `i` are given.
    pub(super) fn e_frame(&self, i: usize, ws: &Workspace) -> Rigid {
        let js = &ws.joints[i];
        match self.machine.axes()[i].kind() {
            AxisKind::Linear => js.before_b,
            AxisKind::Rotary => js.before_a,
        }
    }

    /// Twists of the body per unit of each machine-direction component value, in the frame
    /// before the error factor (exact, at the current error values).
    pub(super) fn component_twists(
        &self,
        i: usize,
        ws: &Workspace,
    ) -> [(Vector3<f64>, Vector3<f64>); 6] {
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
    pub(super) fn nominal_tool_in_workpiece(&self, q: &[f64], turns: &[Turn]) -> Rigid {
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
