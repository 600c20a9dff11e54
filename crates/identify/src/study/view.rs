//! The session as the effects see it (`SessionView`): built on first use from the runs, the
//! set-ups, the model's parameters, the tool's travel and which set-up parameters look like
//! the machine's field.

use super::*;

/// Samples of one set-up looked at by `Study::field_like_nuisance` (an even stride through
/// more).
pub(super) const FIELD_LIKE_SAMPLES: usize = 4000;

impl Study {
    /// The session as the effects see it (built once).
    pub fn view(&self) -> &Arc<SessionView> {
        self.view.get_or_init(|| Arc::new(self.build_view()))
    }

    /// Per run, the fitted run it continues, if any: one recording cut into files (the
    /// cycles of a thermal test at one position written one file each) is one recording —
    /// the same set-up, no axis moving in either, and the run starting within
    /// [`CONTINUES_INTERVALS`] sample intervals of where the other ended. The noise filter
    /// runs on across such a boundary and the search divides the recording into blocks of
    /// its own, so a user's choice of file boundaries decides nothing.
    pub fn continues(&self) -> Vec<Option<usize>> {
        let view = self.view();
        let gap = CONTINUES_INTERVALS * view.median_interval();
        let held = |r: usize| (0..view.axes.len()).all(|a| !view.motion(r, a).moves);
        let mut out = vec![None; self.runs.len()];
        let mut previous: Option<usize> = None;
        for &r in view.runs_in_time_order() {
            if !self.runs[r].fit || self.runs[r].is_empty() {
                continue;
            }
            if let Some(p) = previous
                && view.runs[p].setup == view.runs[r].setup
                && held(p)
                && held(r)
                && let (Some(end), Some(start)) =
                    (view.runs[p].last_time(), view.runs[r].first_time())
                && start > end
                && start - end <= gap
            {
                out[r] = Some(p);
            }
            previous = Some(r);
        }
        out
    }

    /// Drops the series the view keeps over the whole timeline ([`SessionView::clear_caches`]),
    /// if it was built: a study kept for later need not hold them meanwhile.
    pub fn clear_view_caches(&self) {
        if let Some(view) = self.view.get() {
            view.clear_caches();
        }
    }

    /// `f` on run `r` as its instrument's own evaluations see it (whole vectors, expanded for
    /// this run only); `None` for a run without readings.
    pub fn with_evaluation<T>(
        &self,
        r: usize,
        f: impl FnOnce(&mtcal_instrument::Evaluation<'_>) -> T,
    ) -> Option<T> {
        let run = &self.runs[r];
        let readings = run.readings.as_ref()?;
        Some(f(&mtcal_instrument::Evaluation {
            machine: self.model.machine(),
            setup: self.setups[run.setup].setup.as_ref(),
            q: &run.q.to_row_major(),
            readings: &readings.to_row_major(),
            t: &run.t.to_vec(),
            labels: &run.labels,
        }))
    }

    pub(super) fn build_view(&self) -> SessionView {
        let (lo, hi) = self.tool_travel_m();
        let machine = self.model.machine();
        let axes = AxisView::of_machine(machine);
        let field_like = self.field_like_nuisance();
        let setups = self
            .setups
            .iter()
            .zip(field_like)
            .map(|(s, field_like)| SetupView {
                field_like,
                ..SetupView::of(&s.name, s.plugin.name, s.setup.as_ref())
            })
            .collect();
        // The study's columns, shared (not copied): the positions convert to SI as they are
        // read, bit for bit what the fit reads.
        let runs = self
            .runs
            .iter()
            .map(|r| RunView {
                name: r.name.clone(),
                setup: r.setup,
                fit: r.fit,
                t: r.t.clone(),
                q: r.q.clone(),
                context: r.context.clone(),
            })
            .collect();
        let mut is_estimated = vec![false; self.model.n_coeffs()];
        for &k in self.layout.estimated() {
            is_estimated[k] = true;
        }
        let model = self
            .model
            .errors()
            .params()
            .iter()
            .map(|p| ModelParamView {
                name: p.name,
                estimated: (p.offset..p.offset + p.len).any(|k| is_estimated[k]),
                held: (p.offset..p.offset + p.len).any(|k| self.is_held(k)),
                order: match &p.role {
                    mtcal_kinematics::model::Role::Component { basis, .. } => match basis {
                        Basis::Legendre { max_degree, .. } => BasisOrder::Legendre(*max_degree),
                        Basis::Fourier { max_harmonic, .. } => BasisOrder::Fourier(*max_harmonic),
                        _ => BasisOrder::Other,
                    },
                    _ => BasisOrder::Other,
                },
            })
            .collect();
        SessionView::new(axes, setups, runs, model)
            .with_locations(self.locations().iter().map(|&(n, _)| n).collect())
            .with_series_cache(Arc::clone(&self.series))
            .with_current(self.effects().iter().map(|e| e.info().clone()).collect())
            .with_tool_travel(lo, hi)
    }

    /// Per set-up and nuisance parameter: whether, at every fitted sample of the set-up, the
    /// parameter moves the readings as one fixed shift of the tool in the machine frame does —
    /// the least-squares fit of its derivative columns by the three machine-frame shift columns
    /// ([`mtcal_kinematics::MachineModel::tool_motion_columns`]) leaves nothing. A ball visited
    /// at one place, or whose height only a table turning about Z carries elsewhere: its drift
    /// there and the machine's own field move the readings alike
    /// ([`mtcal_effects::SetupView::field_like`]). A set-up without analytic derivatives says
    /// no for every parameter.
    pub(super) fn field_like_nuisance(&self) -> Vec<Vec<bool>> {
        let x = self.initial_x();
        let coeffs = self.fit_coeffs_from(&x);
        let model = &self.fit_model;
        let na = model.machine().n_axes();
        let mut ws = model.workspace();
        let mut scratch = self.axis_jacobian_scratch();
        let mut jac = vec![0.0; 6 * mtcal_effects::axis_slots(na)];
        let mut q = vec![0.0; na];
        (0..self.setups.len())
            .map(|s| {
                let setup = self.setups[s].setup.as_ref();
                let (nn, nch) = (setup.nuisance().len(), setup.channels().len());
                let nuis = self.nuisance_from(s, &x);
                let (mut d_pose, mut d_nuis) = (vec![0.0; 6 * nch], vec![0.0; nch * nn]);
                let runs: Vec<usize> = (0..self.runs.len())
                    .filter(|&r| self.runs[r].setup == s && self.runs[r].fit)
                    .collect();
                let total: usize = runs.iter().map(|&r| self.runs[r].len()).sum();
                if nn == 0 || total == 0 {
                    return vec![false; nn];
                }
                // Normal equations of each parameter's column on the three shift columns.
                let mut ata = nalgebra::Matrix3::<f64>::zeros();
                let mut atb = vec![nalgebra::Vector3::<f64>::zeros(); nn];
                let mut btb = vec![0.0; nn];
                let stride = total.div_ceil(FIELD_LIKE_SAMPLES).max(1);
                let mut k = 0usize;
                for &r in &runs {
                    let run = &self.runs[r];
                    for i in 0..run.len() {
                        k += 1;
                        if k % stride != 0 {
                            continue;
                        }
                        run.q.row_into(i, &mut q);
                        let pose = model.tool_pose(&q, &coeffs, &mut ws);
                        let at = At {
                            q: &q,
                            t: run.t.get(i),
                            w_t_t: &pose,
                            label: run.label(i),
                        };
                        if !setup.derivatives(&at, &nuis, &mut d_pose, &mut d_nuis) {
                            return vec![false; nn];
                        }
                        self.axis_jacobian(r, i, &mut scratch, &mut jac);
                        let shifts = &jac[6 * na..6 * na + 18];
                        for (c, dp) in d_pose.chunks_exact(6).enumerate() {
                            let a = nalgebra::Vector3::from_fn(|m, _| {
                                (0..6).map(|p| dp[p] * shifts[6 * m + p]).sum::<f64>()
                            });
                            ata += a * a.transpose();
                            for j in 0..nn {
                                let b = d_nuis[c * nn + j];
                                atb[j] += a * b;
                                btb[j] += b * b;
                            }
                        }
                    }
                }
                let pinv = ata
                    .pseudo_inverse(1e-12 * ata.norm().max(f64::MIN_POSITIVE))
                    .unwrap_or_else(|_| nalgebra::Matrix3::zeros());
                (0..nn)
                    .map(|j| btb[j] - atb[j].dot(&(pinv * atb[j])) <= 1e-8 * btb[j])
                    .collect()
            })
            .collect()
    }

    /// The least and greatest coordinates of the nominal tool point in the machine frame over
    /// the fitted samples (m).
    pub(super) fn tool_travel_m(&self) -> ([f64; 3], [f64; 3]) {
        let model = &self.model;
        let zeros = vec![0.0; model.n_coeffs()];
        let mut ws = model.workspace();
        let mut q = vec![0.0; model.machine().n_axes()];
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for run in self.runs.iter().filter(|r| r.fit) {
            for i in 0..run.len() {
                run.q.row_into(i, &mut q);
                model.tool_pose(&q, &zeros, &mut ws);
                let p = model.machine_tool_point(&ws);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        (lo, hi)
    }
}
