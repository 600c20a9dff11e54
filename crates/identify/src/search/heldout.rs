//! Cross-validation, the held-out check of step 2: [`heldout`] (every fold's refit from the
//! session's rows evaluated once, reduced fold by fold) and [`choose_width`] (a joint model's
//! prior width by leaving each fitted run out). Uses the settings; gives [`Heldout`] to the fit helpers
//! (`fitted`) and the step.

use super::settings::{CrossValidation, SearchOptions};
use crate::IdentifyError;
use crate::findings::Heldout;
use crate::fit::{FitProblem, FoldOf, Row, RowTarget, SampleEval};
use crate::param_specs_from;
use crate::study::Study;
use mtcal_effects::Effect;
use mtcal_solve::{ParamSpec, Problem, Solution};
use std::sync::Arc;

/// Cross-validation: each fold of the fitted data ([`CrossValidation`]) is left out, the model
/// refitted on the rest and the left-out samples predicted.
///
/// The refit is the Gauss–Newton step from the full fit `x` (where the model is linear to the
/// accuracy that matters here), `δ_k = −R_k⁺z_k` from the streaming QR factor of the other
/// folds' rows ([`mtcal_solve::linearize`], with the solver's column scaling and rank rule: the
/// normal equations would square the condition number, and a direction the data barely see
/// would move by metres on their rounding). The session's rows are streamed once at `x` and
/// reduced, fold by fold and per column set, to their own QR factors ([`FoldFactors`]): a
/// fold's training rows are the other folds' factors, a few hundred rows instead of the
/// session's tens of thousands, and the same least-squares problem. A second pass predicts the
/// left-out rows as they are, `r_k + J_k·δ_k`. Two passes over the data and one small
/// factorisation per fold, instead of a fit per fold; nothing held grows with the session.
pub fn heldout(
    study: &Study,
    x: &[f64],
    options: &SearchOptions,
) -> Result<Heldout, IdentifyError> {
    let tolerance = options.solver.rank_tolerance;
    let (folds, assign) = fold_assignment(study, options);
    let forecasting = forecast_assignment(study);
    let mut assignments = vec![(&assign, folds)];
    if let Some((cuts, forecast)) = &forecasting {
        assignments.push((forecast, cuts + 1));
    }
    let factors = FoldFactors::stream(study, x, &assignments)?;
    let mut steps = vec![fold_steps(
        study,
        x,
        tolerance,
        &factors[0],
        &assign,
        0..folds,
        Refit::Everything,
    )?];
    if let Some((cuts, forecast)) = &forecasting {
        steps.push(fold_steps(
            study,
            x,
            tolerance,
            &factors[1],
            forecast,
            1..cuts + 1,
            Refit::EffectsOnly,
        )?);
    }
    let predicted = fold_predictions(study, x, &assignments, &steps)?;
    let inner = &predicted[0];
    let (w, u, c) = inner.iter().fold((0.0, 0.0, 0usize), |(w, u, c), f| {
        (w + f.whitened, u + f.units, c + f.count)
    });
    let forecast = predicted.get(1).map_or(&[][..], Vec::as_slice);
    let mean = |f: &FoldPrediction| f.whitened / f.count as f64;
    let (fw, fc) = forecast
        .iter()
        .fold((0.0, 0usize), |(w, c), f| (w + f.whitened, c + f.count));
    let c = c.max(1) as f64;
    Ok(Heldout {
        mean_square: w / c,
        rms_um: (u / c).sqrt() * 1e6,
        samples: c as usize,
        folds: inner.iter().map(mean).collect(),
        forecast_folds: forecast.iter().map(mean).collect(),
        forecast_mean_square: (fc > 0).then(|| fw / fc as f64),
    })
}

/// What a fold's refit moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Refit {
    /// Every parameter: the model fitted on the other folds.
    Everything,
    /// Only the effects' parameters, the machine and the set-ups kept at the full fit. A
    /// forecast asks whether the effects' course in time carries on into the later part of the
    /// session; the geometry it cannot ask about: the earlier part may not see the runs that
    /// determine some directions at all, and a step along the ones it barely sees would move
    /// parameters by millimetres.
    EffectsOnly,
}

/// One held-out fold's prediction: the sums of squares of its whitened residuals and of its
/// residuals in the channels' units (SI), and its rows.
struct FoldPrediction {
    whitened: f64,
    units: f64,
    count: usize,
}

/// Share of the fitted timeline before the first forecasting cut, and the cuts after it: the
/// model fitted on the first half predicts the next fifth, on 70 % the next 15 %, on 85 % the
/// rest.
const FORECAST_CUTS: [f64; 3] = [0.5, 0.7, 0.85];

/// The forecasting folds of `study` ([`FoldOf::Forecast`]): their number and the assignment;
/// `None` when the fitted timeline is too short to cut (fewer than 40 samples).
fn forecast_assignment(study: &Study) -> Option<(usize, FoldOf)> {
    let mut offsets = vec![0; study.runs.len()];
    let mut total = 0;
    for &r in study.view().runs_in_time_order() {
        if study.runs[r].fit {
            offsets[r] = total;
            total += study.runs[r].len();
        }
    }
    if total < 40 {
        return None;
    }
    let cuts: Vec<usize> = FORECAST_CUTS
        .iter()
        .map(|&c| (c * total as f64).round() as usize)
        .collect();
    Some((cuts.len(), FoldOf::Forecast { offsets, cuts }))
}

/// Each fold `k` of `wanted` (of `factors`' assignment `assign`) left out
/// ([`FoldOf::held`]) and the model refitted on the rest by one Gauss–Newton step from `x`
/// (what `refit` says): the step per fold, `None` for folds without rows or not wanted.
fn fold_steps(
    study: &Study,
    x: &[f64],
    rank_tolerance: f64,
    factors: &FoldFactors,
    assign: &FoldOf,
    wanted: std::ops::Range<usize>,
    refit: Refit,
) -> Result<Vec<Option<Vec<f64>>>, IdentifyError> {
    let mut specs = param_specs_from(study, x);
    let n = study.layout().n_x();
    if refit == Refit::EffectsOnly {
        for spec in &mut specs[..study.layout().effect_offset()] {
            spec.fixed = true;
        }
        // An effect without a course over the session (a bump, a backlash) is judged by the
        // blocked folds, as a change of the error model is: refitted from the earlier part
        // alone, a bump crossed by one run there is a guess the forecast would blame on it.
        for i in study.layout().effects() {
            if study
                .effect_of_param(i)
                .is_some_and(|e| !e.follows_the_session())
            {
                specs[i].fixed = true;
            }
        }
    }
    // An axis' start state in a run (a nuisance shape boxed in ±1) keeps the full fit's
    // value: a fold that holds out its stretch leaves it without data, where a Gauss–Newton
    // step (which knows no box) would throw it far outside its box.
    for (i, spec) in specs.iter_mut().enumerate() {
        if study
            .effect_param(i)
            .is_some_and(|p| p.nuisance && p.kind == mtcal_effects::ParamKind::Shape)
        {
            spec.fixed = true;
        }
    }
    let information = match refit {
        Refit::EffectsOnly => factors.information(),
        Refit::Everything => Vec::new(),
    };
    let mut steps: Vec<Option<Vec<f64>>> = vec![None; factors.count.len()];
    for k in wanted.clone() {
        if factors.count[k] == 0 {
            continue;
        }
        let specs = match refit {
            Refit::EffectsOnly => barely_seen_held(&specs, &information, k),
            Refit::Everything => specs.clone(),
        };
        let delta = if specs.iter().any(|s| !s.fixed) {
            let training = factors.training(assign, k);
            let lin = mtcal_solve::linearize(&training, &specs, x, 0)?;
            let delta = lin.step(rank_tolerance)?;
            // A shape (a bump's centre, a time constant) the training part barely sees can be
            // thrown out of its box by the step, which knows no box: no fit would go there.
            // Such shapes keep the full fit's values, and the rest is stepped again.
            let outside: Vec<usize> = (0..n)
                .filter(|&i| {
                    !specs[i].fixed
                        && specs[i]
                            .bounds
                            .is_some_and(|(lo, hi)| !(lo..=hi).contains(&(x[i] + delta[i])))
                })
                .collect();
            if outside.is_empty() {
                delta
            } else if specs
                .iter()
                .enumerate()
                .all(|(i, s)| s.fixed || outside.contains(&i))
            {
                vec![0.0; n]
            } else {
                let mut held = specs.clone();
                for &i in &outside {
                    held[i].fixed = true;
                }
                mtcal_solve::linearize(&training, &held, x, 0)?.step(rank_tolerance)?
            }
        } else {
            vec![0.0; n]
        };
        steps[k] = Some(delta);
    }
    Ok(steps)
}

/// `study`'s rows at `x`, every block of its fit walked into one of the lane targets `fresh`
/// makes (`mtcal_solve::run_lanes`: lane `l` takes blocks `l, l + L, …` in order), returned in
/// lane order: the caller merges them in that order, the same sums on any number of cores.
fn walk_lanes<T: RowTarget + Send>(
    study: &Study,
    x: &[f64],
    fresh: impl Fn() -> T,
) -> Result<Vec<T>, IdentifyError> {
    let problem = FitProblem::new(study);
    let blocks = problem.n_blocks();
    let mut lanes: Vec<T> = (0..mtcal_solve::lane_count(blocks))
        .map(|_| fresh())
        .collect();
    mtcal_solve::run_lanes(blocks, &mut lanes, 0, |b, target| {
        problem
            .walk_rows(b, x, target)
            .map_err(|source| mtcal_solve::SolveError::Eval {
                block: b,
                cause: source,
            })
    })?;
    Ok(lanes)
}

/// One assignment's rows reduced, per fold and per column set of the rows, to the triangular
/// factor of their QR decomposition `[R | z]` (`RᵀR = JᵀJ`, `Rᵀz = Jᵀr`, by the solver's own
/// streaming QR): a fold's training rows are then the other folds' factors — a few hundred
/// rows where the session has tens of thousands — and the same least-squares problem. Rows
/// whose noise filter continues from a sample of another fold are kept apart in both forms.
struct FoldFactors {
    n: usize,
    /// The distinct column sets of the rows.
    keys: Vec<Vec<usize>>,
    /// Per key, per fold: its factor.
    factors: Vec<Vec<Factor>>,
    /// Per key: the rows that continue a sample of another fold.
    boundaries: Vec<Vec<BoundaryRow>>,
    /// Per fold: its rows.
    count: Vec<usize>,
}

/// A QR factor's rows, `w + 1` values each (the row of `R`, then `z`).
#[derive(Default)]
struct Factor {
    rows: Vec<f64>,
}

/// A row whose noise filter continues from a sample of another fold: prewhitened and as it
/// stands (the filter starting again), `w + 1` values each.
struct BoundaryRow {
    fold: usize,
    from_fold: usize,
    chained: Vec<f64>,
    alone: Vec<f64>,
}

impl FoldFactors {
    /// The training problem of fold `k` of the assignment the factors were made for.
    fn training<'a>(&'a self, assign: &'a FoldOf, k: usize) -> Training<'a> {
        Training {
            factors: self,
            assign,
            k,
        }
    }

    /// Each fold's rows of `[J | r]` (its factor's and its boundary rows prewhitened) with
    /// `f(fold, cols, row, residual)`.
    fn for_each_row(&self, mut f: impl FnMut(usize, &[usize], &[f64], f64)) {
        for (key, cols) in self.keys.iter().enumerate() {
            let w = cols.len();
            for (fold, factor) in self.factors[key].iter().enumerate() {
                for row in factor.rows.chunks_exact(w + 1) {
                    f(fold, cols, &row[..w], row[w]);
                }
            }
            for b in &self.boundaries[key] {
                f(b.fold, cols, &b.chained[..w], b.chained[w]);
            }
        }
    }

    /// Every fold's information on each parameter: the diagonal of its normal equations.
    fn information(&self) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; self.n]; self.count.len()];
        self.for_each_row(|fold, cols, jac, _| {
            for (&c, &j) in cols.iter().zip(jac) {
                out[fold][c] += j * j;
            }
        });
        out
    }
}

/// Rows gathered per fold and column set before they are reduced into its running factor: the
/// factors grow by blocks of rows (the solver's QR is fast on blocks), and what is held stays
/// bounded whatever the session's length.
const REDUCE_ROWS: usize = 256;

/// One fold's factor for one column set as the rows stream in: the factor of the rows so far
/// and the rows not yet reduced into it (`w + 1` values each).
#[derive(Default)]
struct Running {
    factor: Vec<f64>,
    buffer: Vec<f64>,
}

impl Running {
    fn push(&mut self, w: usize, jac: &[f64], res: f64) -> Result<(), IdentifyError> {
        self.buffer.extend_from_slice(jac);
        self.buffer.push(res);
        if self.buffer.len() >= REDUCE_ROWS * (w + 1) {
            self.reduce(w)?;
        }
        Ok(())
    }

    fn reduce(&mut self, w: usize) -> Result<(), IdentifyError> {
        if self.buffer.is_empty() {
            return Ok(());
        }
        let mut rows = std::mem::take(&mut self.factor);
        rows.append(&mut self.buffer);
        self.factor = reduced(w, rows)?.rows;
        Ok(())
    }
}

/// One lane's share of an assignment's [`FoldFactors`] as its blocks stream by.
#[derive(Default)]
struct LaneFactors {
    keys: Vec<Vec<usize>>,
    /// Per key, per fold.
    running: Vec<Vec<Running>>,
    boundaries: Vec<Vec<BoundaryRow>>,
    count: Vec<usize>,
    /// The current group's key.
    key: usize,
}

impl LaneFactors {
    fn columns(&mut self, cols: &[usize], folds: usize) {
        self.key = match self.keys.iter().position(|k| k == cols) {
            Some(key) => key,
            None => {
                self.keys.push(cols.to_vec());
                self.running
                    .push((0..folds).map(|_| Running::default()).collect());
                self.boundaries.push(Vec::new());
                self.keys.len() - 1
            }
        };
    }
}

/// Where [`FoldFactors::stream`] sends a block's rows: every assignment's lane factors.
struct FactorTarget<'a> {
    assignments: &'a [(&'a FoldOf, usize)],
    /// Per assignment.
    lanes: Vec<LaneFactors>,
    fault: Option<IdentifyError>,
}

impl RowTarget for FactorTarget<'_> {
    fn columns(&mut self, cols: &[usize]) {
        for (lane, &(_, folds)) in self.lanes.iter_mut().zip(self.assignments) {
            lane.columns(cols, folds);
        }
    }

    fn row(&mut self, out: &Row<'_>, eval: &SampleEval<'_>, sample: usize, _: usize) {
        if out.seed || self.fault.is_some() {
            return;
        }
        for (lane, &(assign, _)) in self.lanes.iter_mut().zip(self.assignments) {
            let key = lane.key;
            let w = lane.keys[key].len();
            let fold = assign.of(eval.run, sample);
            lane.count[fold] += 1;
            match out.from.map(|(r, i)| assign.of(r, i)) {
                Some(from_fold) if from_fold != fold => {
                    let with = |jac: &[f64], res: f64| {
                        let mut v = jac.to_vec();
                        v.push(res);
                        v
                    };
                    lane.boundaries[key].push(BoundaryRow {
                        fold,
                        from_fold,
                        chained: with(out.jac, out.res),
                        alone: with(out.raw_jac, out.raw_res),
                    });
                }
                _ => {
                    if let Err(e) = lane.running[key][fold].push(w, out.jac, out.res) {
                        self.fault = Some(e);
                        return;
                    }
                }
            }
        }
    }
}

impl FoldFactors {
    /// The factors of `study`'s rows at `x` for each assignment `(assign, folds)`, in one pass
    /// over the data (lanes merged in order: the same factors on any number of cores).
    fn stream(
        study: &Study,
        x: &[f64],
        assignments: &[(&FoldOf, usize)],
    ) -> Result<Vec<FoldFactors>, IdentifyError> {
        let mut parts = walk_lanes(study, x, || FactorTarget {
            assignments,
            lanes: assignments
                .iter()
                .map(|&(_, folds)| LaneFactors {
                    count: vec![0; folds],
                    ..LaneFactors::default()
                })
                .collect(),
            fault: None,
        })?;
        if let Some(fault) = parts.iter_mut().find_map(|t| t.fault.take()) {
            return Err(fault);
        }
        let mut out = Vec::with_capacity(assignments.len());
        for (a, &(_, folds)) in assignments.iter().enumerate() {
            let mut keys: Vec<Vec<usize>> = Vec::new();
            let mut stacked: Vec<Vec<Vec<f64>>> = Vec::new();
            let mut boundaries: Vec<Vec<BoundaryRow>> = Vec::new();
            let mut count = vec![0; folds];
            for part in &mut parts {
                let lane = std::mem::take(&mut part.lanes[a]);
                for (c, n) in count.iter_mut().zip(&lane.count) {
                    *c += n;
                }
                for ((cols, running), bounds) in
                    lane.keys.into_iter().zip(lane.running).zip(lane.boundaries)
                {
                    let key = match keys.iter().position(|k| *k == cols) {
                        Some(key) => key,
                        None => {
                            keys.push(cols);
                            stacked.push(vec![Vec::new(); folds]);
                            boundaries.push(Vec::new());
                            keys.len() - 1
                        }
                    };
                    let w = keys[key].len();
                    for (fold, mut r) in running.into_iter().enumerate() {
                        r.reduce(w)?;
                        stacked[key][fold].append(&mut r.factor);
                    }
                    boundaries[key].extend(bounds);
                }
            }
            let mut factors = Vec::with_capacity(keys.len());
            for (cols, per_fold) in keys.iter().zip(stacked) {
                let mut f = Vec::with_capacity(folds);
                for rows in per_fold {
                    f.push(reduced(cols.len(), rows)?);
                }
                factors.push(f);
            }
            out.push(FoldFactors {
                n: study.layout().n_x(),
                keys,
                factors,
                boundaries,
                count,
            });
        }
        Ok(out)
    }
}

/// Each assignment's folds predicted with their own refit's step (`steps`, per assignment and
/// fold: [`fold_steps`]): the rows of `study` at `x` streamed once more, `r + J·δ` prewhitened
/// (the decision's statistic) and as they stand in the channels' units (the RMS the user
/// reads). Folds without a step are left out.
fn fold_predictions(
    study: &Study,
    x: &[f64],
    assignments: &[(&FoldOf, usize)],
    steps: &[Vec<Option<Vec<f64>>>],
) -> Result<Vec<Vec<FoldPrediction>>, IdentifyError> {
    let zeros = || -> Vec<Vec<(f64, f64, usize)>> {
        assignments
            .iter()
            .map(|&(_, folds)| vec![(0.0, 0.0, 0); folds])
            .collect()
    };
    let parts = walk_lanes(study, x, || PredictTarget {
        assignments,
        steps,
        sums: zeros(),
        cols: Vec::new(),
    })?;
    let mut total = zeros();
    for part in &parts {
        for (t, p) in total.iter_mut().zip(&part.sums) {
            for (a, b) in t.iter_mut().zip(p) {
                a.0 += b.0;
                a.1 += b.1;
                a.2 += b.2;
            }
        }
    }
    Ok(total
        .into_iter()
        .zip(steps)
        .map(|(sums, steps)| {
            sums.into_iter()
                .zip(steps)
                .filter(|(_, step)| step.is_some())
                .map(|((whitened, units, count), _)| FoldPrediction {
                    whitened,
                    units,
                    count,
                })
                .collect()
        })
        .collect())
}

/// Where [`fold_predictions`] sends a block's rows: per assignment and fold, the sums of
/// squares of the stepped residuals, whitened and in the channels' units, and the rows.
struct PredictTarget<'a> {
    assignments: &'a [(&'a FoldOf, usize)],
    steps: &'a [Vec<Option<Vec<f64>>>],
    sums: Vec<Vec<(f64, f64, usize)>>,
    cols: Vec<usize>,
}

impl RowTarget for PredictTarget<'_> {
    fn columns(&mut self, cols: &[usize]) {
        self.cols.clear();
        self.cols.extend_from_slice(cols);
    }

    fn row(&mut self, out: &Row<'_>, eval: &SampleEval<'_>, sample: usize, channel: usize) {
        if out.seed {
            return;
        }
        let sigma = 1.0 / eval.inv_sigma[channel];
        for ((&(assign, _), steps), sums) in self
            .assignments
            .iter()
            .zip(self.steps)
            .zip(self.sums.iter_mut())
        {
            let k = assign.of(eval.run, sample);
            let Some(delta) = &steps[k] else { continue };
            let moved = |jac: &[f64], res: f64| {
                res + self
                    .cols
                    .iter()
                    .zip(jac)
                    .map(|(&c, &j)| j * delta[c])
                    .sum::<f64>()
            };
            let s = &mut sums[k];
            s.0 += moved(out.jac, out.res).powi(2);
            s.1 += (moved(out.raw_jac, out.raw_res) * sigma).powi(2);
            s.2 += 1;
        }
    }
}

/// `rows` (`w + 1` values each: a row of `w` columns, then its residual) reduced to their QR
/// factor by the solver's own streaming QR.
fn reduced(w: usize, rows: Vec<f64>) -> Result<Factor, IdentifyError> {
    if rows.is_empty() || w == 0 {
        return Ok(Factor::default());
    }
    let free: Vec<ParamSpec> = (0..w)
        .map(|i| ParamSpec {
            name: format!("c{i}"),
            initial: 0.0,
            fixed: false,
            prior: None,
            bounds: None,
            group: None,
            scale: None,
        })
        .collect();
    let lin = mtcal_solve::linearize(&StackedRows { w, rows }, &free, &vec![0.0; w], 1)?;
    let mut out = Vec::with_capacity(w * (w + 1));
    for i in 0..w {
        let row = &lin.r[i * w..(i + 1) * w];
        if row.iter().any(|&v| v != 0.0) || lin.z[i] != 0.0 {
            out.extend_from_slice(row);
            out.push(lin.z[i]);
        }
    }
    Ok(Factor { rows: out })
}

/// Rows given as they are, `w + 1` values each ([`reduced`]).
struct StackedRows {
    w: usize,
    rows: Vec<f64>,
}

impl Problem for StackedRows {
    fn n_params(&self) -> usize {
        self.w
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(
        &self,
        _: usize,
        _: &[f64],
        sink: &mut mtcal_solve::RowSink<'_>,
    ) -> Result<(), mtcal_solve::EvalError> {
        let cols: Vec<usize> = (0..self.w).collect();
        sink.columns(&cols);
        for row in self.rows.chunks_exact(self.w + 1) {
            sink.row(row[self.w], &row[..self.w]);
        }
        Ok(())
    }
}

/// The training rows of one fold's refit ([`FoldFactors`]): the other folds' factors, and the
/// rows at a fold's boundary in the form the left-out fold leaves them.
struct Training<'a> {
    factors: &'a FoldFactors,
    assign: &'a FoldOf,
    k: usize,
}

impl Problem for Training<'_> {
    fn n_params(&self) -> usize {
        self.factors.n
    }

    fn n_blocks(&self) -> usize {
        self.factors.keys.len()
    }

    fn eval_block(
        &self,
        key: usize,
        _: &[f64],
        sink: &mut mtcal_solve::RowSink<'_>,
    ) -> Result<(), mtcal_solve::EvalError> {
        let f = self.factors;
        let cols = &f.keys[key];
        let w = cols.len();
        sink.columns(cols);
        let held = |fold: usize| self.assign.holds(fold, self.k);
        for (fold, factor) in f.factors[key].iter().enumerate() {
            if held(fold) {
                continue;
            }
            for row in factor.rows.chunks_exact(w + 1) {
                sink.row(row[w], &row[..w]);
            }
        }
        for b in &f.boundaries[key] {
            if held(b.fold) {
                continue;
            }
            // The filter's sample is left out: it starts again here.
            let row = if held(b.from_fold) {
                &b.alone
            } else {
                &b.chained
            };
            sink.row(row[w], &row[..w]);
        }
        Ok(())
    }
}

/// The least share of the session's information on an effect's parameter a forecast's
/// earlier part must carry to refit it. A bump of a guideway that the earlier runs cross only
/// at its tail (a few thousandths of the information) is stepped by tens of micrometres along
/// a direction they barely see, and the linear prediction of the later part from there is no
/// forecast of the effect but of the step; a drift's rate, seen by the first half of a session
/// with an eighth of its lever arm, carries several per cent.
const FORECAST_MIN_INFORMATION: f64 = 0.02;

/// `specs` with the free parameters that the forecast training part before cut `k` barely sees
/// ([`FORECAST_MIN_INFORMATION`] of the whole session's information, the diagonal of the
/// whitened normal equations) held at the full fit: a forecast judges what the earlier part
/// can refit, and says nothing about the rest.
fn barely_seen_held(specs: &[ParamSpec], info: &[Vec<f64>], k: usize) -> Vec<ParamSpec> {
    let information = |i: usize, upto: usize| -> f64 { info[..upto].iter().map(|f| f[i]).sum() };
    let folds = info.len();
    let mut out = specs.to_vec();
    for (i, spec) in out.iter_mut().enumerate() {
        let full = information(i, folds);
        if !spec.fixed && full > 0.0 && information(i, k) < FORECAST_MIN_INFORMATION * full {
            spec.fixed = true;
        }
    }
    out
}

/// Per fold: the normal equations of its prewhitened rows (`a`, `n × n`; `g`; `rr`, the sum of
/// squared residuals) and its number of rows ([`fold_sums`]).
struct FoldSums {
    n: usize,
    a: Vec<f64>,
    g: Vec<f64>,
    rr: Vec<f64>,
    count: Vec<usize>,
}

impl FoldSums {
    fn new(folds: usize, n: usize) -> Self {
        Self {
            n,
            a: vec![0.0; folds * n * n],
            g: vec![0.0; folds * n],
            rr: vec![0.0; folds],
            count: vec![0; folds],
        }
    }

    /// Fills each fold's lower triangle from the upper one the rows were added to.
    fn mirror(&mut self) {
        let n = self.n;
        for m in self.a.chunks_mut(n * n) {
            for i in 0..n {
                for j in i + 1..n {
                    m[j * n + i] = m[i * n + j];
                }
            }
        }
    }

    fn add(&mut self, other: &FoldSums) {
        for (a, b) in [
            (&mut self.a, &other.a),
            (&mut self.g, &other.g),
            (&mut self.rr, &other.rr),
        ] {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        for (x, y) in self.count.iter_mut().zip(&other.count) {
            *x += y;
        }
    }
}

/// Sends a block's rows into their fold's sums.
struct FoldTarget<'a> {
    sums: FoldSums,
    cols: Vec<usize>,
    assign: &'a FoldOf,
    /// The current row's non-zero entries `(parameter, value)`: a channel's row touches only
    /// its own effects' columns (a joint thermal model per channel is 88 of them), so the
    /// outer products run over these.
    nz: Vec<(usize, f64)>,
}

impl RowTarget for FoldTarget<'_> {
    fn columns(&mut self, cols: &[usize]) {
        self.cols.clear();
        self.cols.extend_from_slice(cols);
    }

    fn row(&mut self, out: &Row<'_>, eval: &SampleEval<'_>, sample: usize, _: usize) {
        if out.seed {
            return;
        }
        let n = self.sums.n;
        let k = self.assign.of(eval.run, sample);
        self.nz.clear();
        for (p, &i) in self.cols.iter().enumerate() {
            if out.jac[p] != 0.0 {
                self.nz.push((i, out.jac[p]));
            }
        }
        let sums = &mut self.sums;
        let (a, g) = (
            &mut sums.a[k * n * n..(k + 1) * n * n],
            &mut sums.g[k * n..(k + 1) * n],
        );
        // The upper triangle (entry `(min, max)`; `mirror` fills the lower one).
        for (p, &(i, ri)) in self.nz.iter().enumerate() {
            g[i] += ri * out.res;
            for &(j, rj) in &self.nz[p..] {
                let (lo, hi) = if i <= j { (i, j) } else { (j, i) };
                a[lo * n + hi] += ri * rj;
            }
        }
        sums.rr[k] += out.res * out.res;
        sums.count[k] += 1;
    }
}

/// Every fold's normal equations of `study`'s rows at `x` (one pass, lanes merged in order:
/// the same sums on any number of cores).
fn fold_sums(
    study: &Study,
    x: &[f64],
    folds: usize,
    assign: &FoldOf,
) -> Result<FoldSums, IdentifyError> {
    let n = study.layout().n_x();
    let parts = walk_lanes(study, x, || FoldTarget {
        sums: FoldSums::new(folds, n),
        cols: Vec::new(),
        assign,
        nz: Vec::new(),
    })?;
    let mut total = FoldSums::new(folds, n);
    for part in &parts {
        total.add(&part.sums);
    }
    total.mirror();
    Ok(total)
}

/// The folds of `options`' cross-validation on `study`: their number and the assignment.
fn fold_assignment(study: &Study, options: &SearchOptions) -> (usize, FoldOf) {
    let fitted = study.runs.iter().filter(|r| r.fit).count();
    match options.cross_validation {
        CrossValidation::BlocksPerRun => (
            options.folds.max(2),
            FoldOf::BlocksPerRun {
                count: options.folds.max(2),
                lengths: study.runs.iter().map(|r| r.len()).collect(),
            },
        ),
        CrossValidation::Runs => {
            let mut k = 0;
            let fold = study
                .runs
                .iter()
                .map(|r| {
                    let f = k;
                    k += usize::from(r.fit);
                    f
                })
                .collect();
            (fitted.max(2), FoldOf::Run(fold))
        }
        CrossValidation::Timeline => {
            let mut offsets = vec![0; study.runs.len()];
            let mut total = 0;
            for &r in study.view().runs_in_time_order() {
                if study.runs[r].fit {
                    offsets[r] = total;
                    total += study.runs[r].len();
                }
            }
            let count = options.folds.max(2);
            (
                count,
                FoldOf::Timeline {
                    offsets,
                    total,
                    count,
                },
            )
        }
    }
}

/// The prior width of `ladder` (the same effect at every width, the study's last) whose fit
/// predicts held-out runs best: each fitted run left out in turn (three or more, unless they
/// are one recording cut into runs; otherwise the search's folds), the others' normal equations at `solution` with the ladder's priors
/// solved for the Gauss–Newton step (the model is linear in the effect's amplitudes), the
/// left-out rows predicted. One pass over the data for every width and fold.
pub(super) fn choose_width(
    study: &Study,
    solution: &Solution,
    ladder: &[Arc<dyn Effect>],
    options: &SearchOptions,
) -> Result<usize, IdentifyError> {
    let fitted = study.runs.iter().filter(|r| r.fit).count();
    // Runs that each tell something of their own: leave each out. A recording's blocks
    // (`Timeline`) are its own whatever the files it was cut into.
    let (folds, assign) = if fitted >= 3 && options.cross_validation != CrossValidation::Timeline {
        let mut k = 0;
        let fold = study
            .runs
            .iter()
            .map(|r| {
                let f = k;
                k += usize::from(r.fit);
                f
            })
            .collect();
        (fitted, FoldOf::Run(fold))
    } else {
        fold_assignment(study, options)
    };
    let x = &solution.x;
    let n = study.layout().n_x();
    let sums = fold_sums(study, x, folds, &assign)?;
    let specs = param_specs_from(study, x);
    let first = n - ladder[0].params().len();
    // A run left out may be the one that determines some directions of the machine or its own
    // set-up (a ball of a volumetric test): refitted on the others, a step along a direction
    // they barely see moves parameters by millimetres and the run's prediction with them,
    // whatever the prior. Then, as in a forecast ([`Refit::EffectsOnly`]), only the effects
    // move; the machine and the set-ups keep the full fit's values.
    let effects = study.layout().effects();
    let effects_only = matches!(assign, FoldOf::Run(_));
    // Only the parameters that share rows with the effect's take part in the refit of a fold
    // (the rest, another sensor's model, keep their fitted values: what they do does not
    // depend on this effect's prior).
    let coupled: Vec<usize> = (0..n)
        .filter(|&i| !effects_only || effects.contains(&i))
        .filter(|&i| {
            i >= first
                || (first..n).any(|j| (0..folds).any(|k| sums.a[k * n * n + i * n + j] != 0.0))
        })
        .collect();
    let m = coupled.len();
    let mut totals = Vec::with_capacity(ladder.len());
    for effect in ladder {
        // Prior precision and gradient of every coupled parameter at x (the effect's at this
        // width).
        let mut precision = vec![0.0; m];
        let mut prior_grad = vec![0.0; m];
        for (p, &i) in coupled.iter().enumerate() {
            let prior = if i >= first {
                effect.params()[i - first].prior.map(|s| (0.0, s))
            } else {
                specs[i].prior
            };
            if let Some((mu, sigma)) = prior {
                precision[p] = 1.0 / (sigma * sigma);
                prior_grad[p] = (x[i] - mu) / (sigma * sigma);
            }
        }
        let mut total = 0.0;
        for k in 0..folds {
            if sums.count[k] == 0 {
                continue;
            }
            let mut a = vec![0.0; m * m];
            let mut g = prior_grad.clone();
            for j in (0..folds).filter(|&j| j != k) {
                let (aj, gj) = (
                    &sums.a[j * n * n..(j + 1) * n * n],
                    &sums.g[j * n..(j + 1) * n],
                );
                for (p, &i) in coupled.iter().enumerate() {
                    g[p] += gj[i];
                    for (q, &l) in coupled.iter().enumerate() {
                        a[p * m + q] += aj[i * n + l];
                    }
                }
            }
            for p in 0..m {
                a[p * m + p] += precision[p];
            }
            let delta = solve_psd(&a, &g, m);
            let (ak, gk) = (
                &sums.a[k * n * n..(k + 1) * n * n],
                &sums.g[k * n..(k + 1) * n],
            );
            let mut q = sums.rr[k];
            for (p, &i) in coupled.iter().enumerate() {
                q += 2.0 * delta[p] * gk[i];
                for (r, &l) in coupled.iter().enumerate() {
                    q += delta[p] * ak[i * n + l] * delta[r];
                }
            }
            total += q.max(0.0);
        }
        totals.push(total);
    }
    Ok(flattest_minimum(&totals))
}

/// The rung of a ladder of cross-validation errors whose neighbourhood predicts best: each
/// error averaged with its neighbours' (weights ¼ ½ ¼, an end rung's missing neighbour
/// counting as itself). Where the curve is flat, the folds' noise decides which rung dips
/// lowest — a few parts in a thousand that a different cut of the same recording turns
/// the other way —, and the rungs either side of a flat minimum predict new conditions
/// very differently; the middle of the flat stretch does not depend on that noise.
fn flattest_minimum(totals: &[f64]) -> usize {
    let at = |i: usize| totals[i];
    let mut best = (f64::INFINITY, 0);
    for i in 0..totals.len() {
        let lo = at(i.saturating_sub(1));
        let hi = at((i + 1).min(totals.len() - 1));
        let smooth = 0.25 * lo + 0.5 * at(i) + 0.25 * hi;
        if smooth < best.0 {
            best = (smooth, i);
        }
    }
    best.1
}

/// `−A⁺g` for a symmetric positive semi-definite `A` (`n × n`): through the eigenvectors of the
/// diagonally scaled matrix, directions below 1e-12 of the largest left out.
fn solve_psd(a: &[f64], g: &[f64], n: usize) -> Vec<f64> {
    let d: Vec<f64> = (0..n)
        .map(|i| {
            let v = a[i * n + i];
            if v > 0.0 { v.sqrt() } else { 1.0 }
        })
        .collect();
    let scaled = nalgebra::DMatrix::from_fn(n, n, |i, j| {
        0.5 * (a[i * n + j] + a[j * n + i]) / (d[i] * d[j])
    });
    let eig = scaled.symmetric_eigen();
    let top = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    let gs: Vec<f64> = (0..n).map(|i| g[i] / d[i]).collect();
    let mut out = vec![0.0; n];
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        if l.is_nan() || l <= 1e-12 * top {
            continue;
        }
        let v = eig.eigenvectors.column(k);
        let proj: f64 = (0..n).map(|i| v[i] * gs[i]).sum::<f64>() / l;
        for i in 0..n {
            out[i] -= v[i] * proj;
        }
    }
    for i in 0..n {
        out[i] /= d[i];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::flattest_minimum;

    #[test]
    fn the_middle_of_a_flat_minimum_not_the_rung_that_dips() {
        // Rungs 3 and 4 within a few parts in a thousand (the folds' noise), rung 3 a hair
        // lower; rung 4's neighbours predict better than rung 3's: 4 either way the hair goes.
        let a = [
            8854.0, 3920.0, 3035.0, 2607.0, 2608.0, 2916.0, 2974.0, 3217.0,
        ];
        let mut b = a;
        b[3] = 2609.0;
        assert_eq!(flattest_minimum(&a), 4);
        assert_eq!(flattest_minimum(&b), 4);
        // A clear minimum stays where it is, at an end too.
        assert_eq!(flattest_minimum(&[5.0, 4.0, 1.0, 4.0, 5.0]), 2);
        assert_eq!(flattest_minimum(&[1.0, 3.0, 5.0]), 0);
        assert_eq!(flattest_minimum(&[7.0]), 0);
    }
}
