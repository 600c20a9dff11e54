//! The nominal machine's axis and location Jacobians at every sample, kept for sessions
//! that fit in memory and shared by the studies rebuilt on the same reduced model.

use super::*;

/// The nominal axis Jacobians of every sample are kept when they take at most this (a session
/// of about 70,000 samples on a five-axis machine: every example and test session): computed
/// once per study rather than once per pass over the data, which makes a physics search on
/// such a session about a quarter faster. A larger session computes each when it is needed,
/// so that its memory does not grow by 48 bytes per axis and sample (README, "Scale").
pub const AXIS_JACOBIAN_CACHE_BYTES: usize = 16 << 20;

/// How one sample's nominal Jacobian columns are computed ([`Study::axis_jacobian`]'s,
/// [`Study::location_jacobian`]'s).
pub(super) type PerSample = fn(&Study, usize, usize, &mut AxisJacobianScratch, &mut [f64]);

/// Per-sample values kept for every sample, or computed when asked.
pub(super) struct KeptPerSample<'s> {
    pub(super) study: &'s Study,
    pub(super) kept: Option<&'s Vec<Vec<f64>>>,
    pub(super) compute: PerSample,
}

impl KeptPerSample<'_> {
    /// Sample `i` of run `r`'s values into `out`.
    pub(super) fn fill(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        match self.kept {
            Some(all) => out.copy_from_slice(&all[r][i * out.len()..(i + 1) * out.len()]),
            None => (self.compute)(self.study, r, i, scratch, out),
        }
    }
}

/// Scratch for [`Study::axis_jacobian`] (one per thread): the nominal machine's workspace,
/// its zero coefficients and one sample's positions.
#[derive(Debug)]
pub struct AxisJacobianScratch {
    pub(super) ws: mtcal_kinematics::Workspace,
    pub(super) zeros: Vec<f64>,
    pub(super) q: Vec<f64>,
    /// The full model's, for the location errors' columns (made on first use).
    pub(super) full: Option<FullScratch>,
}

/// The full model's workspace, zero coefficients and coefficient Jacobian.
#[derive(Debug)]
pub(super) struct FullScratch {
    pub(super) ws: mtcal_kinematics::Workspace,
    pub(super) zeros: Vec<f64>,
    pub(super) jac: Vec<f64>,
}

impl Study {
    /// Scratch for [`Self::axis_jacobian`].
    pub fn axis_jacobian_scratch(&self) -> AxisJacobianScratch {
        let model = &self.fit_model;
        AxisJacobianScratch {
            ws: model.workspace(),
            zeros: vec![0.0; model.n_coeffs()],
            q: vec![0.0; model.machine().n_axes()],
            full: None,
        }
    }

    /// The location errors (rotary axes' lines, linear axes' squareness) this study estimates,
    /// one coefficient each, with their coefficient in the full model: what an effect's
    /// [`mtcal_effects::Target::Location`] can act on, in slot order.
    pub fn locations(&self) -> &[(ParamName, usize)] {
        self.locations.get_or_init(|| {
            let estimated: std::collections::BTreeSet<usize> =
                self.layout.estimated().iter().copied().collect();
            self.model
                .errors()
                .params()
                .iter()
                .filter(|p| {
                    matches!(p.name, ParamName::Location { .. })
                        && p.len == 1
                        && estimated.contains(&p.offset)
                })
                .map(|p| (p.name, p.offset))
                .collect()
        })
    }

    /// `∂pose/∂L` of the nominal machine at sample `i` of run `r` into `out` (6 × the
    /// [`Self::locations`], column-major, as [`Self::axis_jacobian`]'s): how an effect that
    /// changes a location error moves the tool. Kept for every sample as the axis Jacobians
    /// are, computed on first use (only a search that proposes such a change needs them).
    pub fn location_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let width = 6 * self.locations().len();
        self.kept_per_sample(
            &self.location_jacobians,
            width,
            Self::nominal_location_jacobian,
        )
        .fill(r, i, scratch, out);
    }

    /// [`Self::location_jacobian`], computed: the full model's coefficient Jacobian at the
    /// nominal machine, the locations' columns.
    pub(super) fn nominal_location_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let model = &self.model;
        let full = scratch.full.get_or_insert_with(|| FullScratch {
            ws: model.workspace(),
            zeros: vec![0.0; model.n_coeffs()],
            jac: vec![0.0; 6 * model.n_coeffs()],
        });
        self.runs[r].q.row_into(i, &mut scratch.q);
        model.tool_pose_jacobian(&scratch.q, &full.zeros, &mut full.ws, &mut full.jac);
        for (col, &(_, k)) in out.chunks_exact_mut(6).zip(self.locations()) {
            col.copy_from_slice(&full.jac[6 * k..6 * k + 6]);
        }
    }

    /// `∂pose/∂q` of the nominal machine at sample `i` of run `r` into `out` (6 × axis slots,
    /// column-major: the axes, then the tool side shifting along and turning about the
    /// machine's X, Y and Z, [`mtcal_effects::axis_slots`]): how an effect that displaces an axis moves the tool. The commanded
    /// positions are fixed: a small session keeps every sample's, a large one computes it at
    /// every call ([`AXIS_JACOBIAN_CACHE_BYTES`]; the same numbers either way).
    pub fn axis_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let width = 6 * mtcal_effects::axis_slots(self.fit_model.machine().n_axes());
        self.kept_per_sample(&self.axis_jacobians, width, Self::nominal_axis_jacobian)
            .fill(r, i, scratch, out);
    }

    /// Every sample's `width` values from `compute`, per run, kept in `cell` on first use if
    /// they fit [`AXIS_JACOBIAN_CACHE_BYTES`] (otherwise each is computed when asked).
    pub(super) fn kept_per_sample<'s>(
        &'s self,
        cell: &'s OnceLock<Option<Vec<Vec<f64>>>>,
        width: usize,
        compute: PerSample,
    ) -> KeptPerSample<'s> {
        let kept = cell.get_or_init(|| {
            let samples: usize = self.runs.iter().map(RunSlot::len).sum();
            if width == 0
                || samples * width * std::mem::size_of::<f64>() > AXIS_JACOBIAN_CACHE_BYTES
            {
                return None;
            }
            let mut scratch = self.axis_jacobian_scratch();
            let all = (0..self.runs.len())
                .map(|r| {
                    let mut out = vec![0.0; self.runs[r].len() * width];
                    for (i, values) in out.chunks_exact_mut(width).enumerate() {
                        compute(self, r, i, &mut scratch, values);
                    }
                    out
                })
                .collect();
            Some(all)
        });
        KeptPerSample {
            study: self,
            kept: kept.as_ref(),
            compute,
        }
    }

    /// [`Self::axis_jacobian`], computed.
    pub(super) fn nominal_axis_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        self.runs[r].q.row_into(i, &mut scratch.q);
        let (axes, turns) = out.split_at_mut(6 * scratch.q.len());
        self.fit_model
            .tool_jacobian(&scratch.q, &scratch.zeros, &mut scratch.ws, axes);
        self.fit_model.tool_motion_columns(&scratch.ws, turns);
    }
}
