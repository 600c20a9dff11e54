//! The identification problem: every fitted sample of every run, whitened by its channel's σ,
//! as a streaming least-squares problem over the estimated machine coefficients and the free
//! nuisance parameters; and the evaluation of any run at a parameter vector.
//!
//! Per sample the machine model gives the actual tool pose, the set-up predicts the readings
//! and their derivatives with respect to that pose and its nuisance parameters, and the chain
//! rule joins them: `∂r/∂c = ∂r/∂pose · ∂pose/∂c`, computed by the model on the projected rows
//! (`MachineModel::project_tool_jacobian`, cheaper than the full pose Jacobian). Rows of one
//! run share their columns (all estimated machine coefficients + the run's set-up's free
//! nuisance parameters), which is the structure the streaming solver exploits.

use crate::study::Study;
use crate::whiten::ArStep;
use mtcal_effects::prepared::shape_values;
use mtcal_effects::{PreparedEffects, SampleEffects};
use mtcal_instrument::At;
use mtcal_kinematics::Rigid;
use mtcal_kinematics::rigid::exp_so3;
use mtcal_solve::{EvalError, Problem, RowSink};
use std::sync::{Arc, Mutex};

/// Samples per block of parallel evaluation.
const BLOCK_SAMPLES: usize = 2048;

/// The least-squares problem of a [`Study`]'s fitted runs.
#[derive(Debug)]
pub struct FitProblem<'a> {
    study: &'a Study,
    /// (run, first sample, end sample).
    blocks: Vec<(usize, usize, usize)>,
    /// Samples left out (held-out validation): sample `i` of run `r` is skipped when
    /// `fold_of(r, i) == Some(k)` for the held-out fold `k`.
    held_out: Option<(FoldOf, usize)>,
    /// The effects prepared at the last shape parameters asked for (a pass evaluates every
    /// block at one `x`: the first block prepares, the others reuse).
    prepared: PreparedCache,
    /// Per set-up, its channels in groups that share their columns ([`channel_groups`]).
    groups: Vec<Vec<ChannelGroup>>,
    /// Per run, the run whose last sample its noise filter continues from
    /// ([`Study::continues`]).
    continues: Vec<Option<usize>>,
}

/// Channels of a set-up whose rows have the same columns, and those columns.
#[derive(Debug, Clone)]
struct ChannelGroup {
    channels: Vec<usize>,
    /// Per effect, whether it reaches these channels (the others need not be evaluated for
    /// their rows).
    effects: Vec<bool>,
    cols: Vec<usize>,
    /// Per column, its place in the set-up's full row (machine, set-up, every effect).
    place: Vec<usize>,
}

/// The channel groups of every set-up: an effect parameter is a column of a channel's rows only
/// if one of the effect's terms can reach that channel (a term on another channel, an axis for a
/// channel that does not read the pose, another set-up's parameter do not). A set-up whose
/// channels all see the same columns is one group, its rows in sample order; otherwise each
/// group's rows come group by group (a joint thermal model of five sensors: each sensor's rows
/// carry its own model's columns, not all five).
fn channel_groups(study: &Study) -> Vec<Vec<ChannelGroup>> {
    let m = study.layout().n_machine();
    let effects = study.effects();
    (0..study.setups.len())
        .map(|s| {
            let slot = &study.setups[s];
            let n_free = study.layout().free(s).len();
            let nch = slot.setup.channels().len();
            let full: Vec<usize> = study.layout().columns_of_setup(s).collect();
            let reaches = |c: usize, t: &mtcal_effects::Target| match t {
                mtcal_effects::Target::Axis(_)
                | mtcal_effects::Target::ToolShift(_)
                | mtcal_effects::Target::ToolTurn(_)
                | mtcal_effects::Target::Location(_) => slot.setup.reads_pose(c),
                mtcal_effects::Target::Nuisance { setup, .. } => *setup == s,
                mtcal_effects::Target::Channel { per_setup }
                | mtcal_effects::Target::Gain { per_setup } => {
                    per_setup.get(s).copied().flatten() == Some(c)
                }
            };
            let mut groups: Vec<ChannelGroup> = Vec::new();
            for c in 0..nch {
                let mut place = Vec::with_capacity(full.len());
                place.extend(0..m + n_free);
                let mut o = study.layout().effect_offset();
                let mut reached = Vec::with_capacity(effects.len());
                for e in effects {
                    let any = e.terms().iter().any(|t| reaches(c, &t.target));
                    reached.push(any);
                    for (j, p) in e.params().iter().enumerate() {
                        let used = match p.kind {
                            mtcal_effects::ParamKind::Amplitude => e
                                .terms()
                                .iter()
                                .any(|t| t.amplitude == j && reaches(c, &t.target)),
                            mtcal_effects::ParamKind::Shape => any,
                        };
                        if used {
                            place.push(m + n_free + (o + j - study.layout().effect_offset()));
                        }
                    }
                    o += e.params().len();
                }
                match groups.iter_mut().find(|g| g.place == place) {
                    Some(g) => {
                        g.channels.push(c);
                        for (a, b) in g.effects.iter_mut().zip(&reached) {
                            *a |= b;
                        }
                    }
                    None => groups.push(ChannelGroup {
                        channels: vec![c],
                        effects: reached,
                        cols: place.iter().map(|&k| full[k]).collect(),
                        place,
                    }),
                }
            }
            groups
        })
        .collect()
}

/// Effects prepared at some shape parameters, and those parameters.
type PreparedCache = Mutex<Option<(Vec<f64>, Arc<PreparedEffects>)>>;

/// Contiguous time blocks of every fitted run, for blocked cross-validation: sample `i` of a
/// run of `n` samples is in fold `⌊k·i/n⌋` of `k`. Every run (and so every set-up) keeps
/// samples in every training set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Folds {
    pub count: usize,
    /// The fold left out.
    pub held: usize,
}

impl Folds {
    /// The fold of sample `i` of a run of `n` samples.
    pub fn fold_of(count: usize, i: usize, n: usize) -> usize {
        (count * i) / n.max(1)
    }
}

/// Which fold a sample of a fitted run is in, for cross-validation.
#[derive(Clone, Debug, PartialEq)]
pub enum FoldOf {
    /// Per run: `count` blocks of its own samples ([`Folds::fold_of`]).
    BlocksPerRun { count: usize, lengths: Vec<usize> },
    /// Per run: one fold.
    Run(Vec<usize>),
    /// Per run: where it starts in the fitted timeline; the timeline's length; the blocks.
    Timeline {
        offsets: Vec<usize>,
        total: usize,
        count: usize,
    },
    /// Forecasting: per run where it starts in the fitted timeline, and cuts of the timeline
    /// (increasing). Fold `k ≥ 1` is the stretch from cut `k − 1` to cut `k` (or the end), and
    /// leaving it out leaves out everything after it too: the model is fitted on the earlier
    /// part of the session and predicts the next stretch. Fold 0 (before the first cut) is
    /// always trained on.
    Forecast {
        offsets: Vec<usize>,
        cuts: Vec<usize>,
    },
}

impl FoldOf {
    /// The fold of sample `sample` of run `run`.
    pub fn of(&self, run: usize, sample: usize) -> usize {
        match self {
            FoldOf::BlocksPerRun { count, lengths } => Folds::fold_of(*count, sample, lengths[run]),
            FoldOf::Run(fold) => fold[run],
            FoldOf::Timeline {
                offsets,
                total,
                count,
            } => Folds::fold_of(*count, offsets[run] + sample, *total),
            FoldOf::Forecast { offsets, cuts } => {
                cuts.partition_point(|&c| c <= offsets[run] + sample)
            }
        }
    }

    /// Whether sample `sample` of run `run` is left out when fold `k` is held out: the fold
    /// itself, and for a forecast everything after it as well.
    pub fn held(&self, run: usize, sample: usize, k: usize) -> bool {
        self.holds(self.of(run, sample), k)
    }

    /// Whether fold `j`'s samples are left out when fold `k` is held out.
    pub fn holds(&self, j: usize, k: usize) -> bool {
        match self {
            FoldOf::Forecast { .. } => j >= k,
            _ => j == k,
        }
    }
}

impl<'a> FitProblem<'a> {
    pub fn new(study: &'a Study) -> Self {
        Self::with_folds(study, None)
    }

    /// The problem without the samples of fold `folds.held` (blocked cross-validation).
    pub fn with_folds(study: &'a Study, held_out: Option<Folds>) -> Self {
        let assign = held_out.map(|f| {
            (
                FoldOf::BlocksPerRun {
                    count: f.count,
                    lengths: study.runs.iter().map(|r| r.len()).collect(),
                },
                f.held,
            )
        });
        Self::without_fold(study, assign)
    }

    /// The problem without the samples of fold `held.1` of the assignment `held.0`.
    pub fn without_fold(study: &'a Study, held_out: Option<(FoldOf, usize)>) -> Self {
        let mut blocks = Vec::new();
        for (r, run) in study.runs.iter().enumerate() {
            if !run.fit {
                continue;
            }
            let n = run.len();
            let mut s = 0;
            while s < n {
                let e = (s + BLOCK_SAMPLES).min(n);
                blocks.push((r, s, e));
                s = e;
            }
        }
        Self {
            study,
            blocks,
            held_out,
            prepared: Mutex::new(None),
            groups: channel_groups(study),
            continues: study.continues(),
        }
    }

    /// The problem of the runs in `runs` alone (validation runs included if named; a run
    /// without readings adds nothing), for per-run information.
    pub fn for_runs(study: &'a Study, runs: &[usize]) -> Self {
        let mut blocks = Vec::new();
        for &r in runs {
            if study.runs[r].readings.is_none() {
                continue;
            }
            let n = study.runs[r].len();
            let mut s = 0;
            while s < n {
                let e = (s + BLOCK_SAMPLES).min(n);
                blocks.push((r, s, e));
                s = e;
            }
        }
        Self {
            study,
            blocks,
            held_out: None,
            prepared: Mutex::new(None),
            groups: channel_groups(study),
            // A run's own information: its filter starts with it.
            continues: vec![None; study.runs.len()],
        }
    }

    /// The study's effects prepared at the shape parameters of `x` (`None` without effects).
    pub(crate) fn effects_at(&self, x: &[f64]) -> Option<Arc<PreparedEffects>> {
        prepared_at(self.study, x, Some(&self.prepared))
    }
}

/// `study`'s effects prepared at `x`, reusing `cache` when the shape parameters are the same.
fn prepared_at(
    study: &Study,
    x: &[f64],
    cache: Option<&PreparedCache>,
) -> Option<Arc<PreparedEffects>> {
    if study.effects().is_empty() {
        return None;
    }
    let params = study.effect_params(x);
    let shapes = shape_values(study.effects(), params);
    let build = || Arc::new(PreparedEffects::new(study.effects(), study.view(), params));
    let Some(cache) = cache else {
        return Some(build());
    };
    let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((s, p)) = guard.as_ref()
        && *s == shapes
    {
        return Some(Arc::clone(p));
    }
    let p = build();
    *guard = Some((shapes, Arc::clone(&p)));
    Some(p)
}

impl Problem for FitProblem<'_> {
    fn n_params(&self) -> usize {
        self.study.layout().n_x()
    }

    fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        self.walk_rows(b, x, sink)
    }
}

/// Where [`FitProblem::walk_rows`] sends a block's rows.
pub(crate) trait RowTarget {
    /// The block's column set (estimated coefficients, then the set-up's free nuisance).
    fn columns(&mut self, cols: &[usize]);
    /// One residual and Jacobian row ([`Row`]), with the sample's evaluation, the sample index
    /// and the channel (the channels of one sample come in order).
    fn row(&mut self, row: &Row<'_>, eval: &SampleEval<'_>, sample: usize, channel: usize);
}

/// One row of the fit: whitened by the channel's σ and, with a coloured noise model,
/// prewhitened (`res`, `jac`: what the solver sees), and as it was before the prewhitening
/// (`raw_res`, `raw_jac`: the residual in units of σ). `step` is the filter that made the one
/// from the other: a target with columns of its own (candidates) applies it to them.
pub(crate) struct Row<'r> {
    pub res: f64,
    pub jac: &'r [f64],
    pub raw_res: f64,
    pub raw_jac: &'r [f64],
    pub step: ArStep,
    /// The sample before a block that starts inside a run: given only so that a target can
    /// prime its own filter, not a row of the block.
    pub seed: bool,
    /// The sample (run, index) the noise filter continues from, when it does
    /// (`step.continued`).
    pub from: Option<(usize, usize)>,
}

impl RowTarget for RowSink<'_> {
    fn columns(&mut self, cols: &[usize]) {
        RowSink::columns(self, cols);
    }
    fn row(&mut self, row: &Row<'_>, _: &SampleEval<'_>, _: usize, _: usize) {
        if !row.seed {
            RowSink::row(self, row.res, row.jac);
        }
    }
}

impl FitProblem<'_> {
    /// The rows of block `b` at `x` into `target`.
    pub(crate) fn walk_rows(
        &self,
        b: usize,
        x: &[f64],
        target: &mut impl RowTarget,
    ) -> Result<(), EvalError> {
        let (r, start, end) = self.blocks[b];
        let study = self.study;
        let run = &study.runs[r];
        let readings = run
            .readings
            .as_ref()
            .expect("fitted runs have readings (checked when loading)");
        let mut eval = SampleEval::new(study, r, x, self.effects_at(x));
        let nch = eval.n_channels();
        let phi: Vec<f64> = (0..nch).map(|c| study.noise(r, c).phi).collect();
        let coloured = phi.iter().any(|&p| p != 0.0);
        let held_in = |run: usize, i: usize| {
            self.held_out
                .as_ref()
                .is_some_and(|(assign, k)| assign.held(run, i, *k))
        };
        let held = |i: usize| held_in(r, i);
        // A run that continues another one's recording continues its filter from that run's
        // last sample (unless it is held out).
        let mut previous = match self.continues[r] {
            Some(p) if coloured && start == 0 && !held_in(p, study.runs[p].len() - 1) => {
                Some((p, SampleEval::new(study, p, x, self.effects_at(x))))
            }
            _ => None,
        };
        // A block that starts inside a run continues the filter from the sample before it.
        let first = if coloured && start > 0 && !held(start - 1) {
            start - 1
        } else {
            start
        };
        for group in &self.groups[run.setup] {
            target.columns(&group.cols);
            eval.only_effects(&group.effects);
            let w = group.cols.len();
            // Per channel the previous sample's raw residual and row (the filter's memory).
            let mut prev_res = vec![0.0; nch];
            let mut prev_jac = vec![0.0; nch * w];
            let (mut raw, mut out) = (vec![0.0; w], vec![0.0; w]);
            let mut last: Option<usize> = None;
            let mut from_previous = false;
            if let Some((p, peval)) = &mut previous {
                peval.only_effects(&group.effects);
                from_previous =
                    seed_from(peval, &study.runs[*p], group, &mut prev_res, &mut prev_jac);
            }
            for i in first..end {
                if held(i) {
                    continue;
                }
                eval.at(i, true);
                let continued =
                    coloured && ((i > 0 && last == Some(i - 1)) || (i == 0 && from_previous));
                for &c in &group.channels {
                    let raw_res = (eval.pred[c] - readings.get(i, c)) * eval.inv_sigma[c];
                    if !raw_res.is_finite() {
                        return Err(EvalError::new(format!(
                            "run {}: sample {} (CSV line {}) channel {}: the model gives no \
                             finite prediction",
                            run.name,
                            i + 1,
                            mtcal_session::row_line(&run.file.path, i).unwrap_or(i + 2),
                            study.channels(r)[c].name
                        )));
                    }
                    eval.whitened_row(c, &group.place, &mut raw);
                    let step = ArStep {
                        phi: phi[c],
                        continued,
                    };
                    let prev = &mut prev_jac[c * w..(c + 1) * w];
                    let res = step.apply(raw_res, prev_res[c]);
                    if step.active() {
                        for ((o, &v), &p) in out.iter_mut().zip(&raw).zip(prev.iter()) {
                            *o = step.apply(v, p);
                        }
                    } else {
                        out.copy_from_slice(&raw);
                    }
                    let from = continued.then(|| match (i, &previous) {
                        (0, Some((p, _))) => (*p, study.runs[*p].len() - 1),
                        _ => (r, i - 1),
                    });
                    let row = Row {
                        res,
                        jac: &out,
                        raw_res,
                        raw_jac: &raw,
                        step,
                        seed: i < start,
                        from,
                    };
                    target.row(&row, &eval, i, c);
                    if coloured {
                        prev_res[c] = raw_res;
                        prev.copy_from_slice(&raw);
                    }
                }
                last = Some(i);
            }
        }
        Ok(())
    }
}

/// Primes the noise filter of `group`'s channels with the last sample of `run` (evaluated by
/// `eval`, the run's own): its raw residual and row. `false` (nothing primed) where the model
/// gives no finite residual there: the chain then starts again.
fn seed_from(
    eval: &mut SampleEval<'_>,
    run: &crate::study::RunSlot,
    group: &ChannelGroup,
    prev_res: &mut [f64],
    prev_jac: &mut [f64],
) -> bool {
    let Some(readings) = run.readings.as_ref() else {
        return false;
    };
    let i = run.len() - 1;
    eval.at(i, true);
    let w = group.cols.len();
    for &c in &group.channels {
        let raw_res = (eval.pred[c] - readings.get(i, c)) * eval.inv_sigma[c];
        if !raw_res.is_finite() {
            return false;
        }
        eval.whitened_row(c, &group.place, &mut prev_jac[c * w..(c + 1) * w]);
        prev_res[c] = raw_res;
    }
    true
}

/// Evaluates one run's samples at one parameter vector: predictions and, on request, the
/// Jacobian of the whitened predictions (divided by each channel's σ) with respect to the
/// estimated coefficients and the set-up's free nuisance parameters. Allocates once, per run.
pub(crate) struct SampleEval<'a> {
    study: &'a Study,
    pub(crate) run: usize,
    coeffs: Vec<f64>,
    nuis: Vec<f64>,
    ws: mtcal_kinematics::Workspace,
    /// `∂pose/∂coefficient` projected on each channel's `∂reading/∂pose / σ`: channels × fit
    /// coefficients, row-major.
    jac: Vec<f64>,
    /// The estimated coefficients are the fit model's, in its order: rows are plain copies.
    estimated_in_order: bool,
    /// Whether some channel reads the tool pose: without one (sensors on their own) the
    /// machine's columns stay zero and the pose needs no Jacobian.
    reads_pose: bool,
    pub pred: Vec<f64>,
    /// `∂reading/∂pose`, one row of six per channel (whitened after the set-up wrote it).
    pub(crate) d_pose: Vec<[f64; 6]>,
    pub(crate) d_nuis: Vec<f64>,
    pub inv_sigma: Vec<f64>,
    scratch: Vec<f64>,
    /// The commanded positions of the sample being evaluated (SI).
    q: Vec<f64>,
    effects: Option<EffectEval>,
}

/// What evaluating effects at a sample needs.
struct EffectEval {
    prepared: Arc<PreparedEffects>,
    /// The effects' parameters (SI).
    params: Vec<f64>,
    out: SampleEffects,
    /// The set-up's prediction before the effects' gain and direct changes.
    raw: Vec<f64>,
    /// `∂pose/∂q` at the nominal machine, 6 × axis slots column-major (the tool side's
    /// motions after the axes), and its scratch.
    axis_jac: Vec<f64>,
    axis_scratch: crate::study::AxisJacobianScratch,
    /// `∂pose/∂L` of the location errors an effect can act on, 6 × their count.
    location_jac: Vec<f64>,
    /// Nuisance values with the effects' perturbation.
    nuis: Vec<f64>,
    /// Per effect parameter, the twist its axis columns give (6 each).
    twists: Vec<[f64; 6]>,
    /// The effects evaluated (all when `None`): those that reach the channels read.
    only: Option<Vec<bool>>,
}

impl<'a> SampleEval<'a> {
    pub fn new(
        study: &'a Study,
        run: usize,
        x: &[f64],
        prepared: Option<Arc<PreparedEffects>>,
    ) -> Self {
        let setup = &study.setups[study.runs[run].setup].setup;
        let nch = setup.channels().len();
        let nn = setup.nuisance().len();
        let na = study.fit_model.machine().n_axes();
        let effects = prepared.map(|prepared| {
            let max_nuis = study
                .setups
                .iter()
                .map(|s| s.setup.nuisance().len())
                .max()
                .unwrap_or(0);
            let max_ch = study
                .setups
                .iter()
                .map(|s| s.setup.channels().len())
                .max()
                .unwrap_or(0);
            EffectEval {
                out: prepared.scratch(na, max_nuis, max_ch),
                params: study.effect_params(x).to_vec(),
                twists: vec![[0.0; 6]; prepared.n_params()],
                prepared,
                raw: vec![0.0; nch],
                axis_jac: vec![0.0; 6 * mtcal_effects::axis_slots(na)],
                axis_scratch: study.axis_jacobian_scratch(),
                location_jac: vec![0.0; 6 * study.locations().len()],
                nuis: vec![0.0; nn],
                only: None,
            }
        });
        Self {
            effects,
            study,
            run,
            coeffs: study.fit_coeffs_from(x),
            nuis: study.nuisance_from(study.runs[run].setup, x),
            ws: study.fit_model.workspace(),
            jac: vec![0.0; nch * study.fit_model.n_coeffs()],
            estimated_in_order: study.layout().estimated_in_order(),
            reads_pose: (0..nch).any(|c| setup.reads_pose(c)),
            pred: vec![0.0; nch],
            d_pose: vec![[0.0; 6]; nch],
            d_nuis: vec![0.0; nch * nn],
            inv_sigma: (0..nch).map(|c| 1.0 / study.sigma(run, c)).collect(),
            scratch: vec![0.0; 2 * nch],
            q: vec![0.0; na],
        }
    }

    pub fn n_channels(&self) -> usize {
        self.pred.len()
    }

    /// What the effects add to location error `j` ([`Study::locations`]) at the sample last
    /// evaluated (SI; zero without effects).
    pub(crate) fn location_change(&self, j: usize) -> f64 {
        self.effects.as_ref().map_or(0.0, |fx| fx.out.dl[j])
    }

    /// The whitened predictions' Jacobian by the fit model's coefficients at the sample last
    /// evaluated with derivatives: channels × coefficients, row-major.
    pub(crate) fn jacobian(&self) -> &[f64] {
        &self.jac
    }

    /// From now on evaluates only the effects `only` marks (one flag per effect of the
    /// study): the rest cannot reach the channels read, whose predictions and rows are then
    /// the same; the other channels' are not.
    fn only_effects(&mut self, only: &[bool]) {
        if let Some(fx) = self.effects.as_mut() {
            let flags = fx.only.get_or_insert_with(Vec::new);
            flags.clear();
            flags.extend_from_slice(only);
        }
    }

    /// Predictions at sample `i` into `pred`; with `derivatives` also the pose Jacobian and the
    /// set-up's derivatives.
    pub fn at(&mut self, i: usize, derivatives: bool) {
        let study = self.study;
        let run = &study.runs[self.run];
        let setup = &study.setups[run.setup].setup;
        let model = &study.fit_model;
        // Taken out of `self` while `self` is borrowed mutably below; put back at the end.
        let mut q_buf = std::mem::take(&mut self.q);
        run.q.row_into(i, &mut q_buf);
        let q = q_buf.as_slice();
        // Readings that do not depend on the pose (sensors modelled on their own) need none.
        let mut pose = if !self.reads_pose {
            Rigid::IDENTITY
        } else if derivatives {
            model.tool_pose_for_jacobian(q, &self.coeffs, &mut self.ws)
        } else {
            model.tool_pose(q, &self.coeffs, &mut self.ws)
        };
        let t = run.t.get(i);
        let mut nuis = std::mem::take(&mut self.nuis);
        if let Some(fx) = self.effects.as_mut() {
            // The effects act on the axes (through the axis Jacobian, first order), on the
            // set-up's nuisance parameters and on the readings.
            fx.prepared.sample_only(
                self.run,
                run.setup,
                i,
                &fx.params,
                &mut fx.out,
                fx.only.as_deref(),
            );
            if fx.out.axes_touched {
                study.axis_jacobian(self.run, i, &mut fx.axis_scratch, &mut fx.axis_jac);
                let twist = axis_twist(&fx.axis_jac, &fx.out.dq);
                pose.t += nalgebra::Vector3::new(twist[0], twist[1], twist[2]);
                pose.r = exp_so3(&nalgebra::Vector3::new(twist[3], twist[4], twist[5])) * pose.r;
            }
            if fx.out.locations_touched {
                // A changed location error moves the tool as the parameter's own column
                // says (first order, as the axes').
                study.location_jacobian(self.run, i, &mut fx.axis_scratch, &mut fx.location_jac);
                let twist = axis_twist(&fx.location_jac, &fx.out.dl);
                pose.t += nalgebra::Vector3::new(twist[0], twist[1], twist[2]);
                pose.r = exp_so3(&nalgebra::Vector3::new(twist[3], twist[4], twist[5])) * pose.r;
            }
            fx.nuis.copy_from_slice(&nuis);
            for (v, d) in fx.nuis.iter_mut().zip(&fx.out.dn) {
                *v += d;
            }
            std::mem::swap(&mut nuis, &mut fx.nuis);
        }
        let label = run.label(i);
        let at = At {
            q,
            t,
            w_t_t: &pose,
            label,
        };
        setup.predict(&at, &nuis, &mut self.pred);
        if let Some(fx) = self.effects.as_mut() {
            // reading = (1 + gain)·prediction + direct change.
            fx.raw.copy_from_slice(&self.pred);
            for (c, p) in self.pred.iter_mut().enumerate() {
                *p = *p * (1.0 + fx.out.gain[c]) + fx.out.dr[c];
            }
        }
        if derivatives {
            if !setup.derivatives(&at, &nuis, self.d_pose.as_flattened_mut(), &mut self.d_nuis) {
                self.nuis = nuis;
                self.finite_differences(q, t, label, &pose);
                nuis = std::mem::take(&mut self.nuis);
            }
            // Whitening the pose rows whitens the projected Jacobian for free; a gain error
            // scales the reading's every derivative.
            let nn = nuis.len();
            for (c, &w) in self.inv_sigma.iter().enumerate() {
                let w = w * self.effects.as_ref().map_or(1.0, |fx| 1.0 + fx.out.gain[c]);
                self.d_pose[c].iter_mut().for_each(|v| *v *= w);
                self.d_nuis[c * nn..(c + 1) * nn]
                    .iter_mut()
                    .for_each(|v| *v *= w);
            }
            if self.reads_pose {
                model.project_tool_jacobian(&self.ws, &self.d_pose, &mut self.jac);
            }
            if let Some(fx) = self.effects.as_mut() {
                for (j, tw) in fx.twists.iter_mut().enumerate() {
                    *tw = if fx.out.axes_touched {
                        axis_twist(
                            &fx.axis_jac,
                            &fx.out.jq[j * fx.out.n_axes..][..fx.out.n_axes],
                        )
                    } else {
                        [0.0; 6]
                    };
                    if fx.out.locations_touched {
                        let nl = fx.out.n_loc;
                        let more = axis_twist(&fx.location_jac, &fx.out.jl[j * nl..][..nl]);
                        for (t, m) in tw.iter_mut().zip(more) {
                            *t += m;
                        }
                    }
                }
            }
        }
        // Put the unperturbed nuisance values back.
        if let Some(fx) = self.effects.as_mut() {
            std::mem::swap(&mut nuis, &mut fx.nuis);
        }
        self.nuis = nuis;
        self.q = q_buf;
    }

    /// Central differences of the set-up's predictions, for plugins without analytic
    /// derivatives.
    fn finite_differences(&mut self, q: &[f64], t: f64, label: u32, pose: &Rigid) {
        let setup = &self.study.setups[self.study.runs[self.run].setup].setup;
        let nch = self.pred.len();
        let h = 1e-7;
        let (plus, minus) = self.scratch.split_at_mut(nch);
        for k in 0..6 {
            let shifted = |sgn: f64| {
                let mut p = *pose;
                if k < 3 {
                    p.t[k] += sgn * h;
                } else {
                    let mut w = nalgebra::Vector3::zeros();
                    w[k - 3] = sgn * h;
                    p.r = exp_so3(&w) * p.r;
                }
                p
            };
            let (pp, pm) = (shifted(1.0), shifted(-1.0));
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: &pp,
                    label,
                },
                &self.nuis,
                plus,
            );
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: &pm,
                    label,
                },
                &self.nuis,
                minus,
            );
            for c in 0..nch {
                self.d_pose[c][k] = (plus[c] - minus[c]) / (2.0 * h);
            }
        }
        let nn = self.nuis.len();
        for j in 0..nn {
            let v = self.nuis[j];
            self.nuis[j] = v + h;
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: pose,
                    label,
                },
                &self.nuis,
                plus,
            );
            self.nuis[j] = v - h;
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: pose,
                    label,
                },
                &self.nuis,
                minus,
            );
            self.nuis[j] = v;
            for c in 0..nch {
                self.d_nuis[c * nn + j] = (plus[c] - minus[c]) / (2.0 * h);
            }
        }
    }

    /// The whitened Jacobian row of channel `c` at the places `place` of the run's full row
    /// (estimated machine coefficients, then the set-up's free nuisance parameters, then every
    /// effect's parameters): only the entries a group of rows has (a joint thermal model of
    /// five sensors: one sensor's rows need its own model's columns, not all five).
    pub fn whitened_row(&self, c: usize, place: &[usize], row: &mut [f64]) {
        let study = self.study;
        let n = study.fit_model.n_coeffs();
        let jac = &self.jac[c * n..(c + 1) * n];
        let estimated = study.layout().estimated_in_fit();
        let free = study.layout().free(study.runs[self.run].setup);
        let nn = self.nuis.len();
        let m = study.layout().n_machine();
        let base = m + free.len();
        let d_nuis = &self.d_nuis[c * nn..(c + 1) * nn];
        for (o, &k) in row.iter_mut().zip(place) {
            *o = if k < m {
                jac[if self.estimated_in_order {
                    k
                } else {
                    estimated[k]
                }]
            } else if k < base {
                d_nuis[free[k - m]]
            } else {
                // Effect parameters: through the axes, the nuisance parameters and the reading.
                let fx = self
                    .effects
                    .as_ref()
                    .expect("a row's effect columns come with the effects");
                let j = k - base;
                let out = &fx.out;
                let tw = &fx.twists[j];
                let mut v: f64 = (0..6).map(|k| self.d_pose[c][k] * tw[k]).sum();
                let jn = &out.jn[j * out.n_nuis..][..nn];
                v += d_nuis.iter().zip(jn).map(|(a, b)| a * b).sum::<f64>();
                v += (out.jr[j * out.n_ch + c] + out.jg[j * out.n_ch + c] * fx.raw[c])
                    * self.inv_sigma[c];
                v
            };
        }
    }
}

/// Predicted readings (SI, row-major `samples × channels`) of run `r` at parameters `x`.
pub fn predict_run(study: &Study, r: usize, x: &[f64]) -> Vec<f64> {
    predict_runs(study, x, |i| i == r)
        .swap_remove(r)
        .expect("the wanted run is predicted")
}

/// Samples per task of [`predict_runs`].
const PREDICT_CHUNK: usize = 8192;

/// Predicted readings of every run `r` with `wanted(r)` at parameters `x` (as
/// [`predict_run`]; `None` for the others), the samples spread over the available cores.
pub fn predict_runs(
    study: &Study,
    x: &[f64],
    wanted: impl Fn(usize) -> bool,
) -> Vec<Option<Vec<f64>>> {
    predict_runs_with(study, x, wanted, prepared_at(study, x, None))
}

/// The study's effects prepared at `x`, for [`predict_run_with`] (`None` without effects).
pub(crate) fn prepared_effects(study: &Study, x: &[f64]) -> Option<Arc<PreparedEffects>> {
    prepared_at(study, x, None)
}

/// `∂reading/∂x[cols[k]]` of every reading of run `r` at `x` (column-major readings × `cols`,
/// readings in the order of [`predict_run`]; a matrix as nalgebra keeps it, without a copy):
/// the fit's own rows before the noise filter and the weights (analytic where the set-up and
/// the effects give derivatives), one pass over the run instead of two predictions per
/// parameter.
pub(crate) fn prediction_jacobian(study: &Study, r: usize, x: &[f64], cols: &[usize]) -> Vec<f64> {
    let mut of_param = vec![usize::MAX; x.len()];
    for (k, &i) in cols.iter().enumerate() {
        of_param[i] = k;
    }
    let n = study.runs[r].len();
    let nch = study.channels(r).len();
    let m = n * nch;
    let mut out = vec![0.0; m * cols.len()];
    let mut eval = SampleEval::new(study, r, x, prepared_effects(study, x));
    for group in &channel_groups(study)[study.runs[r].setup] {
        eval.only_effects(&group.effects);
        let to: Vec<usize> = group.cols.iter().map(|&i| of_param[i]).collect();
        let mut row = vec![0.0; group.cols.len()];
        for i in 0..n {
            eval.at(i, true);
            for &c in &group.channels {
                eval.whitened_row(c, &group.place, &mut row);
                let sigma = 1.0 / eval.inv_sigma[c];
                for (&k, &v) in to.iter().zip(&row) {
                    if k != usize::MAX {
                        out[k * m + i * nch + c] = v * sigma;
                    }
                }
            }
        }
    }
    out
}

/// [`predict_run`] with the effects already prepared at `x` ([`prepared_effects`]): a caller
/// that predicts run after run holds one run's predictions at a time.
pub(crate) fn predict_run_with(
    study: &Study,
    r: usize,
    x: &[f64],
    prepared: Option<Arc<PreparedEffects>>,
) -> Vec<f64> {
    predict_runs_with(study, x, |i| i == r, prepared)
        .swap_remove(r)
        .expect("the wanted run is predicted")
}

fn predict_runs_with(
    study: &Study,
    x: &[f64],
    wanted: impl Fn(usize) -> bool,
    prepared: Option<Arc<PreparedEffects>>,
) -> Vec<Option<Vec<f64>>> {
    let mut out: Vec<Option<Vec<f64>>> = (0..study.runs.len())
        .map(|r| wanted(r).then(|| vec![0.0; study.runs[r].len() * study.channels(r).len()]))
        .collect();
    // Tasks: (run, first sample, its output rows), disjoint slices of the outputs.
    let mut tasks = Vec::new();
    for (r, pred) in out.iter_mut().enumerate() {
        let Some(pred) = pred else { continue };
        let nch = study.channels(r).len();
        for (k, chunk) in pred.chunks_mut(PREDICT_CHUNK * nch).enumerate() {
            tasks.push((r, k * PREDICT_CHUNK, chunk));
        }
    }
    let predict = |(r, first, chunk): (usize, usize, &mut [f64])| {
        let mut eval = SampleEval::new(study, r, x, prepared.clone());
        let nch = eval.n_channels();
        for (j, row) in chunk.chunks_exact_mut(nch).enumerate() {
            eval.at(first + j, false);
            row.copy_from_slice(&eval.pred);
        }
        Ok::<(), std::convert::Infallible>(())
    };
    let Ok(_) = mtcal_solve::map_in_order(tasks, 0, predict);
    out
}

/// The pose twist (translation, rotation; workpiece frame) of axis perturbations `dq` through
/// the axis Jacobian `jac` (6 × axes, column-major).
fn axis_twist(jac: &[f64], dq: &[f64]) -> [f64; 6] {
    let mut tw = [0.0; 6];
    for (a, &d) in dq.iter().enumerate() {
        if d != 0.0 {
            for (k, t) in tw.iter_mut().enumerate() {
                *t += jac[6 * a + k] * d;
            }
        }
    }
    tw
}
