//! Step 1, rank: every registered family's candidates ([`candidates`]) scored against the
//! current fit without refitting ([`rank`]: the fit's rows with each candidate's columns, a
//! Lagrange-multiplier test, Holm's correction) into [`Ranked`] candidates. Uses no other part of
//! the search; the step, the discoveries and the loop use its ranking.

use crate::fit::{FitProblem, Row, RowTarget, SampleEval};
use crate::study::{Study, raise_order};
use crate::{IdentifyError, param_specs};
use mtcal_effects::{Candidate, Effect, Entry, PreparedEffects, SampleEffects};
use mtcal_kinematics::{MachineModel, Workspace};
use mtcal_solve::{EvalError, Problem, Score, ScoreSink, ScoredProblem, Solution};
use std::collections::HashMap;
use std::sync::Arc;

/// The share of a candidate's score the fitted parameters absorb above which these data can
/// hardly tell it from them: listed as concealed, and added only if it predicts the held-out
/// data clearly better ([`super::step`]).
pub(super) const CONCEALED: f64 = 0.99;

/// A candidate and its test.
#[derive(Debug, Clone)]
pub struct Ranked {
    pub candidate: Candidate,
    pub score: Score,
    /// Fitted parameters the candidate would move by more than one of their standard
    /// deviations, largest first: name and shift in σ.
    pub biased: Vec<(String, f64)>,
    /// Fitted parameters the candidate hides behind, largest share first (see
    /// [`Score::mimicked_by`]).
    pub mimics: Vec<(String, f64)>,
    /// Among how many independent shapes its starting shape was chosen (a cycle's pitch
    /// scanned over a quarter of its value: the peaks of the score along the scan); 1 without
    /// a scan. The best of many looks is owed the larger drop in χ² the largest of that many
    /// chances would bring ([`Ranked::look_elsewhere_dof`]).
    pub looked_among: usize,
}

impl Ranked {
    /// The parameters' worth of information criterion owed to the scan that chose the
    /// starting shape ([`Ranked::looked_among`]), for a fit of `n_rows` rows: the largest of
    /// `K` independent χ² statistics exceeds a level about `2 ln K` higher than one does at the
    /// same odds, and a parameter costs `ln n`.
    pub fn look_elsewhere_dof(&self, n_rows: usize) -> f64 {
        2.0 * (self.looked_among.max(1) as f64).ln() / (n_rows.max(2) as f64).ln()
    }

    /// The candidate's name with its starting shape (`thermal-drift Z (t), τ₀ = 600 s`).
    pub fn name(&self) -> String {
        match &self.candidate {
            Candidate::Effect(e) => {
                let shapes: Vec<String> = e
                    .params()
                    .iter()
                    .filter(|p| p.kind == mtcal_effects::ParamKind::Shape && !p.nuisance)
                    .map(|p| format!("{} = {:.4} {}", p.name, p.initial * p.per_si, p.unit))
                    .collect();
                if shapes.is_empty() {
                    e.info().label.clone()
                } else {
                    format!("{}, from {}", e.info().label, shapes.join(", "))
                }
            }
            Candidate::Model(m) => format!("{} ({})", m.label(), m.class),
        }
    }

    /// One sentence for the report.
    pub fn describe(&self) -> String {
        let s = &self.score;
        let mut text = format!(
            "{}: χ² would drop by {:.1} ({} degrees of freedom, adjusted p = {:.2e}){}",
            self.name(),
            s.statistic,
            s.df,
            s.adjusted_p,
            if s.significant { ", significant" } else { "" }
        );
        if s.absorbed > CONCEALED && !self.mimics.is_empty() {
            // Concealed: only its sliver outside the fitted span is tested, and fitting it
            // would trade it against those parameters.
            let names: Vec<&str> = self.mimics.iter().map(|(n, _)| n.as_str()).collect();
            text += &format!(
                "; {:.1} % of it looks like {}: these data cannot tell it from them",
                100.0 * s.absorbed,
                names.join(", ")
            );
            return text;
        }
        if s.absorbed > 0.5 {
            text += &format!(
                "; {:.0} % of it looks like the fitted parameters",
                100.0 * s.absorbed
            );
        }
        if s.significant && !self.biased.is_empty() {
            let moved: Vec<String> = self
                .biased
                .iter()
                .map(|(n, z)| format!("{n} by {z:+.1} σ"))
                .collect();
            text += &format!("; fitting it moves {}", moved.join(", "));
        }
        text
    }
}

/// Every registered family's candidates for `study` (only `families`, if given).
pub fn candidates(study: &Study, families: Option<&[String]>) -> Vec<Candidate> {
    let view = study.view();
    mtcal_effects::families()
        .into_iter()
        .filter(|f| families.is_none_or(|names| names.iter().any(|n| n == f.name)))
        .flat_map(|f| (f.candidates)(view))
        .collect()
}

/// Scores `candidates` against `solution` (the fit of `study`), Holm's correction at
/// family-wise level `alpha` over all of them; strongest first.
pub fn rank(
    study: &Study,
    solution: &Solution,
    candidates: Vec<Candidate>,
    alpha: f64,
) -> Result<Vec<Ranked>, IdentifyError> {
    rank_with(study, solution, candidates, alpha, 256 << 20)
}

pub(super) fn rank_with(
    study: &Study,
    solution: &Solution,
    candidates: Vec<Candidate>,
    alpha: f64,
    cache_bytes: usize,
) -> Result<Vec<Ranked>, IdentifyError> {
    if candidates.is_empty() {
        return Ok(Vec::new());
    }
    let specs = param_specs(study);
    let samples: usize = study.runs.iter().map(|r| r.len()).sum();
    // Candidates go in passes: every model change and the effects whose cached series fit
    // the budget together.
    let per_series = (samples.max(1) * 16).max(1);
    let budget = (cache_bytes / per_series).max(1);
    let mut passes: Vec<Vec<usize>> = vec![Vec::new()];
    let mut keys: Vec<String> = Vec::new();
    for (i, c) in candidates.iter().enumerate() {
        if let Candidate::Effect(e) = c {
            let new: Vec<String> = e
                .cached_series()
                .into_iter()
                .filter(|k| !keys.contains(k))
                .collect();
            if !new.is_empty() && keys.len() + new.len() > budget && !keys.is_empty() {
                passes.push(Vec::new());
                keys.clear();
                study.view().clear_caches();
            }
            keys.extend(new);
        }
        passes.last_mut().expect("one pass at least").push(i);
    }
    let mut scores: Vec<Option<Score>> = vec![None; candidates.len()];
    for pass in &passes {
        let chosen: Vec<&Candidate> = pass.iter().map(|&i| &candidates[i]).collect();
        let problem = Scoring::new(study, &chosen, solution)?;
        let s = mtcal_solve::score_candidates(&problem, &specs, solution, alpha, 0)?;
        for (&i, score) in pass.iter().zip(s) {
            scores[i] = Some(score);
        }
        study.view().clear_caches();
    }
    let mut scores: Vec<Score> = scores
        .into_iter()
        .map(|s| s.expect("every candidate scored"))
        .collect();
    mtcal_solve::holm(&mut scores, alpha);
    let mut ranked: Vec<Ranked> = candidates
        .into_iter()
        .zip(scores)
        .map(|(candidate, score)| {
            let named = |values: &[f64], scale: &dyn Fn(usize) -> Option<f64>, floor: f64| {
                let mut out: Vec<(String, f64)> = values
                    .iter()
                    .enumerate()
                    .filter_map(|(i, d)| {
                        let z = d / scale(i)?;
                        (z.abs() > floor).then(|| (study.param_info(i).name, z))
                    })
                    .collect();
                out.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
                out.truncate(3);
                out
            };
            let biased = named(&score.shift, &|i| solution.sigma[i], 1.0);
            // Only identified parameters: the members of an unidentifiable combination trade
            // large opposite amounts along it, which says nothing about this candidate.
            let mimics = named(
                &score.mimicked_by,
                &|i| solution.identified[i].then_some(1.0),
                0.2,
            );
            Ranked {
                candidate,
                score,
                biased,
                mimics,
                looked_among: 1,
            }
        })
        .collect();
    ranked.sort_by(|a, b| b.score.statistic.total_cmp(&a.score.statistic));
    Ok(ranked)
}

// ---------------------------------------------------------------------------------------------
// Scoring: the fit's rows with the candidates' columns

/// The model with the model-change candidates' parameters added.
struct Augmented {
    model: MachineModel,
    /// The fit's coefficients in the augmented model's layout.
    coeffs: Vec<f64>,
}

struct Scoring<'a> {
    fit: FitProblem<'a>,
    study: &'a Study,
    aug: Option<Augmented>,
    effects: Option<Arc<PreparedEffects>>,
    /// Extra columns from the augmented model: (extra column, coefficient).
    model_columns: Vec<(usize, usize)>,
    /// Per parameter of the prepared effect candidates: its extra column (amplitudes only).
    effect_columns: Vec<Option<usize>>,
    widths: Vec<usize>,
}

impl<'a> Scoring<'a> {
    fn new(
        study: &'a Study,
        candidates: &[&Candidate],
        solution: &Solution,
    ) -> Result<Self, IdentifyError> {
        let model_changes: Vec<&mtcal_effects::ModelChange> = candidates
            .iter()
            .filter_map(|c| match c {
                Candidate::Model(m) => Some(m),
                Candidate::Effect(_) => None,
            })
            .collect();
        let aug = if model_changes.is_empty() {
            None
        } else {
            Some(augmented(study, &model_changes, &solution.x)?)
        };
        let effects: Vec<Arc<dyn Effect>> = candidates
            .iter()
            .filter_map(|c| match c {
                Candidate::Effect(e) => Some(Arc::clone(e)),
                Candidate::Model(_) => None,
            })
            .collect();
        let mut effect_params = Vec::new();
        for e in &effects {
            effect_params.extend(e.params().iter().map(|p| p.initial));
        }
        let prepared = (!effects.is_empty())
            .then(|| Arc::new(PreparedEffects::new(&effects, study.view(), &effect_params)));
        let mut model_columns = Vec::new();
        let mut effect_columns = vec![None; effect_params.len()];
        let mut widths = Vec::new();
        let mut column = 0;
        let mut effect_offset = 0;
        for c in candidates {
            match c {
                Candidate::Model(m) => {
                    let aug = aug.as_ref().expect("built for model changes");
                    let cols = model_change_columns(study, &aug.model, m);
                    widths.push(cols.len());
                    for k in cols {
                        model_columns.push((column, k));
                        column += 1;
                    }
                }
                Candidate::Effect(e) => {
                    let mut width = 0;
                    for (j, p) in e.params().iter().enumerate() {
                        if p.kind == mtcal_effects::ParamKind::Amplitude {
                            effect_columns[effect_offset + j] = Some(column);
                            column += 1;
                            width += 1;
                        }
                    }
                    widths.push(width);
                    effect_offset += e.params().len();
                }
            }
        }
        Ok(Self {
            fit: FitProblem::new(study),
            study,
            aug,
            effects: prepared,
            model_columns,
            effect_columns,
            widths,
        })
    }
}

/// The study's full model with every model change applied at once, and the fit's coefficients
/// in its layout (by coefficient label; the added ones zero).
fn augmented(
    study: &Study,
    changes: &[&mtcal_effects::ModelChange],
    x: &[f64],
) -> Result<Augmented, IdentifyError> {
    let mut config = study.machine.config.clone();
    for &(name, extra) in &study.changes().raise {
        // Already in `study.model`'s configuration? The machine's config is the session's:
        // apply the study's own raises first.
        raise_leniently(&mut config, &name, extra);
    }
    for m in changes.iter().filter(|m| m.extra_order > 0) {
        raise_leniently(&mut config, &m.param, m.extra_order);
    }
    let model = MachineModel::new(study.machine.machine.clone(), &config).map_err(|e| {
        IdentifyError::Model {
            source_name: study.machine.config_source.clone(),
            message: e.to_string(),
        }
    })?;
    let current = study.coeffs_from(x);
    let index: HashMap<&str, usize> = study
        .coeff_labels
        .iter()
        .enumerate()
        .map(|(k, l)| (l.as_str(), k))
        .collect();
    let coeffs = model
        .errors()
        .coefficient_labels()
        .iter()
        .map(|l| index.get(l.as_str()).map_or(0.0, |&k| current[k]))
        .collect();
    Ok(Augmented { model, coeffs })
}

/// [`raise_order`] for scoring: a parameter the configuration lacks, or a basis without an
/// order, is scored as the model has it rather than refused.
fn raise_leniently(
    config: &mut [mtcal_kinematics::ParamConfig],
    name: &mtcal_kinematics::ParamName,
    extra: usize,
) {
    let _ = raise_order(config, name, extra);
}

/// The augmented model's coefficients a model change adds: all of an omitted parameter's, or
/// the ones a higher order adds (labels the study's model does not have).
fn model_change_columns(
    study: &Study,
    model: &MachineModel,
    change: &mtcal_effects::ModelChange,
) -> Vec<usize> {
    let Some(p) = model.errors().find(&change.param) else {
        return Vec::new();
    };
    let labels = model.errors().coefficient_labels();
    (p.offset..p.offset + p.len)
        .filter(|&k| change.extra_order == 0 || !study.coeff_labels.contains(&labels[k]))
        .collect()
}

impl ScoredProblem for Scoring<'_> {
    fn n_params(&self) -> usize {
        self.study.layout().n_x()
    }
    fn candidate_widths(&self) -> Vec<usize> {
        self.widths.clone()
    }
    fn n_blocks(&self) -> usize {
        self.fit.n_blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        let na = self.study.model.machine().n_axes();
        let max_ch = self
            .study
            .setups
            .iter()
            .map(|s| s.setup.channels().len())
            .max()
            .unwrap_or(0);
        let effects = self.effects.as_ref().map(|prepared| CandidateEffects {
            scratch: prepared.scratch(na, 0, 0),
            prepared: Arc::clone(prepared),
            entries: Vec::new(),
            placed: Vec::new(),
            pose_axis: vec![0.0; max_ch * mtcal_effects::axis_slots(na)],
            axis_jac: vec![0.0; 6 * mtcal_effects::axis_slots(na)],
            pose_location: vec![0.0; max_ch * self.study.locations().len()],
            location_jac: vec![0.0; 6 * self.study.locations().len()],
            axis_scratch: self.study.axis_jacobian_scratch(),
        });
        let mut target = Target {
            sink,
            study: self.study,
            aug: self.aug.as_ref().map(|a| (a, a.model.workspace())),
            jac: Vec::new(),
            q: vec![0.0; self.study.model.machine().n_axes()],
            effects,
            model_columns: &self.model_columns,
            effect_columns: &self.effect_columns,
            at: None,
            extra_raw: vec![0.0; self.widths.iter().sum()],
            extra_prev: vec![0.0; max_ch * self.widths.iter().sum::<usize>()],
        };
        self.fit.walk_rows(b, x, &mut target)
    }
}

/// Effect candidates at one sample.
struct CandidateEffects {
    prepared: Arc<PreparedEffects>,
    /// Feature buffers.
    scratch: SampleEffects,
    /// The sample's amplitude columns, sparse.
    entries: Vec<Entry>,
    /// The same with their extra column, those that have one (built once per sample, used by
    /// every channel).
    placed: Vec<(usize, Entry)>,
    /// `∂reading_c/∂pose · ∂pose/∂q_a` (whitened), channels × axes: what displacing axis `a`
    /// does to reading `c` at this sample.
    pose_axis: Vec<f64>,
    /// The nominal axis Jacobian at this sample, and its scratch.
    axis_jac: Vec<f64>,
    /// The same for the location errors an effect can act on: channels × locations, and
    /// their columns at this sample.
    pose_location: Vec<f64>,
    location_jac: Vec<f64>,
    axis_scratch: crate::study::AxisJacobianScratch,
}

/// Adds the candidate columns to the fit's rows.
struct Target<'a, 's> {
    sink: &'a mut ScoreSink<'s>,
    study: &'a Study,
    aug: Option<(&'a Augmented, Workspace)>,
    /// The sample's readings' derivatives by every augmented-model coefficient (channels × n).
    jac: Vec<f64>,
    /// The sample's commanded positions (SI).
    q: Vec<f64>,
    effects: Option<CandidateEffects>,
    model_columns: &'a [(usize, usize)],
    effect_columns: &'a [Option<usize>],
    /// The row's candidate columns before the noise model's prewhitening, and per channel the
    /// previous sample's (the filter's memory).
    extra_raw: Vec<f64>,
    extra_prev: Vec<f64>,
    /// The (run, sample) the per-sample columns were computed for.
    at: Option<(usize, usize)>,
}

impl RowTarget for Target<'_, '_> {
    fn columns(&mut self, cols: &[usize]) {
        self.sink.columns(cols);
    }

    fn row(&mut self, row: &Row<'_>, eval: &SampleEval<'_>, sample: usize, channel: usize) {
        let run = &self.study.runs[eval.run];
        let na = mtcal_effects::axis_slots(self.study.model.machine().n_axes());
        // Once per sample (rows come channel after channel, or group after group).
        if self.at != Some((eval.run, sample)) {
            self.at = Some((eval.run, sample));
            if let Some((aug, ws)) = self.aug.as_mut() {
                run.q.row_into(sample, &mut self.q);
                let n = aug.model.n_coeffs();
                aug.model.tool_pose_for_jacobian(&self.q, &aug.coeffs, ws);
                self.jac.resize(eval.d_pose.len() * n, 0.0);
                // The pose rows are whitened already: so are these columns.
                aug.model
                    .project_tool_jacobian(ws, &eval.d_pose, &mut self.jac);
            }
            if let Some(fx) = self.effects.as_mut() {
                fx.prepared.amplitude_entries(
                    eval.run,
                    run.setup,
                    sample,
                    &mut fx.scratch,
                    &mut fx.entries,
                );
                fx.placed.clear();
                let columns = self.effect_columns;
                fx.placed.extend(
                    fx.entries
                        .iter()
                        .filter_map(|e| columns[e.param].map(|col| (col, *e))),
                );
                if fx
                    .entries
                    .iter()
                    .any(|e| matches!(e.slot, mtcal_effects::Slot::Axis(_)))
                {
                    let jq = &mut fx.axis_jac;
                    self.study
                        .axis_jacobian(eval.run, sample, &mut fx.axis_scratch, jq);
                    for (c, dp) in eval.d_pose.iter().enumerate() {
                        for a in 0..na {
                            fx.pose_axis[c * na + a] = (0..6).map(|k| dp[k] * jq[6 * a + k]).sum();
                        }
                    }
                }
                if fx
                    .entries
                    .iter()
                    .any(|e| matches!(e.slot, mtcal_effects::Slot::Location(_)))
                {
                    let nl = self.study.locations().len();
                    let jl = &mut fx.location_jac;
                    self.study
                        .location_jacobian(eval.run, sample, &mut fx.axis_scratch, jl);
                    for (c, dp) in eval.d_pose.iter().enumerate() {
                        for j in 0..nl {
                            fx.pose_location[c * nl + j] =
                                (0..6).map(|k| dp[k] * jl[6 * j + k]).sum();
                        }
                    }
                }
            }
        }
        let extra = &mut self.extra_raw;
        extra.fill(0.0);
        if let Some((aug, _)) = &self.aug {
            let n_aug = aug.model.n_coeffs();
            for &(col, k) in self.model_columns {
                extra[col] = self.jac[channel * n_aug + k];
            }
        }
        if let Some(fx) = &self.effects {
            let nn = eval.d_nuis.len() / eval.n_channels().max(1);
            let w = eval.inv_sigma[channel];
            for &(col, e) in &fx.placed {
                let through = match e.slot {
                    mtcal_effects::Slot::Axis(a) => fx.pose_axis[channel * na + a],
                    mtcal_effects::Slot::Location(j) => {
                        fx.pose_location[channel * self.study.locations().len() + j]
                    }
                    mtcal_effects::Slot::Nuisance(j) => eval.d_nuis[channel * nn + j],
                    mtcal_effects::Slot::Channel(c) if c == channel => w,
                    mtcal_effects::Slot::Gain(c) if c == channel => eval.pred[channel] * w,
                    _ => 0.0,
                };
                extra[col] += e.value * through;
            }
        }
        // The candidates' columns go through the same prewhitening as the fit's.
        let e = extra.len();
        let prev = &mut self.extra_prev[channel * e..(channel + 1) * e];
        if !row.seed {
            let step = row.step;
            self.sink.row_with(row.res, row.jac, |out| {
                if step.active() {
                    for ((o, &v), &p) in out.iter_mut().zip(extra.iter()).zip(prev.iter()) {
                        *o = step.apply(v, p);
                    }
                } else {
                    out.copy_from_slice(extra);
                }
            });
        }
        if row.step.phi != 0.0 {
            prev.copy_from_slice(extra);
        }
    }
}
