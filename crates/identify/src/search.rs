//! The physics search: when the identified model and the recordings disagree, find which
//! physics the model left out, add it, and show the fit improve on data it did not train on.
//!
//! # The loop
//! 0. **Noise.** Every decision below is a χ² statistic, and real recordings are neither white
//!    nor of the σ their manifest states: the fit's residuals give each instrument channel's
//!    real σ and AR(1) coefficient ([`crate::noise`]), and every fit of the search is then the
//!    generalised least-squares fit for that noise (rows prewhitened). Estimated again after
//!    every accepted step (a large effect left out reads partly as noise); within a step every
//!    candidate is judged on one metric.
//! 1. **Rank.** Every registered effect family ([`mtcal_effects::families`]) proposes its
//!    candidates for the session (thermal drifts at a grid of time constants, reversal of each
//!    axis that reverses, cyclic errors at screw pitches, joint thermal models, the model's
//!    left-out parameters…). Each is scored against the current fit without refitting
//!    ([`mtcal_solve::score_candidates`], a Lagrange-multiplier test): the predicted drop in χ²,
//!    Holm's correction over all candidates, the share of it the fitted parameters absorb, the
//!    fitted parameters it would move.
//! 2. **Fit and check.** The strongest significant candidates (at most [`SearchOptions::tries`],
//!    one per label and three per class, so that every kind of explanation the scores point at
//!    is refitted) are each added to the model and refitted — in two stages, the shape
//!    parameters (τ, pitch…) held first and then refined with everything else; a cycle's pitch
//!    is first scanned on a grid fine enough for every phase ([`Effect::shape_scan`]), a joint
//!    model's prior width chosen by leaving each fitted run out ([`Effect::prior_ladder`]). A
//!    candidate passes if its refit is physics (no parameter driven beyond its plausible range,
//!    no new one whose interval is wider than it), the information criterion agrees
//!    (`Δχ²/max(1, χ²_red) > Δk·ln n`, a parameter under a prior counting for the share the data
//!    decide) **and** it predicts held-out data better: cross-validation ([`CrossValidation`]:
//!    contiguous time blocks of every fitted run by default, whole runs, or blocks of the whole
//!    timeline for a long recording; `[identify] heldout`), its whitened mean square lower by
//!    more than [`SearchOptions::min_heldout_gain`]. The cross-validation is the Gauss–Newton
//!    refit of each fold from the full fit, computed from every fold's normal equations in one
//!    pass ([`heldout`]). Of those that pass, the lowest BIC wins: scores at grid starting
//!    values cannot tell a drift in time from a lagged temperature that follows it, their
//!    refits can; and of two that fit alike the one with fewer parameters.
//! 3. **Look-alikes.** Others that passed within [`LOOKALIKE_BIC`] of the winner, and that are
//!    no longer significant once it is in the model (they explained the same thing), are its
//!    look-alikes: the discovery names them and the measurement that would tell them apart,
//!    and claims neither as the answer (machine drift or set-up drift, a drift in time or a
//!    temperature that follows it).
//! 4. **Repeat** with the accepted effect in the model, until no candidate is significant or
//!    none that is passes.
//!
//! # What it reports
//! Each accepted step is a [`Discovery`] (FORMATS.md `discoveries`): the effect, its
//! parameters with 95 % intervals from the final fit, the fit and held-out RMS before and
//! after, the share of the excess χ² it explains, the machine parameters it had biased (before
//! and after), where the residuals showed it, its look-alikes, and a sentence. Candidates the
//! data cannot tell from the fitted parameters (almost wholly absorbed) are listed as
//! [`Concealed`], with the parameters they hide behind and the measurement that would separate
//! them.
//!
//! # Columns of a candidate
//! Effects give their columns through [`mtcal_effects::PreparedEffects`] (axis perturbations
//! through the machine's axis Jacobian, set-up parameters through the instrument's nuisance
//! derivatives, readings directly); model changes through the projected Jacobian of the
//! machine model with the candidate parameters added (held-out parameters are zero at the
//! solution, so the pose is the fit's).

use crate::K95;
pub use crate::findings::{
    Concealed, Correction, Discovery, DiscoveryParameter, Heldout, LookAlike, SearchReport,
    SearchStop, Trial,
};
use crate::fit::{FitProblem, FoldOf, Row, RowTarget, SampleEval};
use crate::options::SearchKeys;
use crate::relabel::unique;
use crate::report::Identification;
use crate::study::{Changes, Study};
use crate::{IdentifyError, param_specs, param_specs_from};
use mtcal_effects::{Candidate, Effect, EffectInfo, Entry, PreparedEffects, SampleEffects};
use mtcal_kinematics::{MachineModel, Workspace};
use mtcal_solve::{EvalError, Options, Problem, Score, ScoreSink, ScoredProblem, Silent, Solution};
use std::collections::HashMap;
use std::sync::Arc;

/// Settings of [`search`].
#[derive(Debug, Clone)]
pub struct SearchOptions {
    /// Family-wise level of the score tests (Holm).
    pub alpha: f64,
    /// Effects added at most.
    pub max_steps: usize,
    /// Significant candidates refitted per step, strongest first, before giving up.
    pub tries: usize,
    /// How the held-out check divides the fitted data.
    pub cross_validation: CrossValidation,
    /// Number of blocks (per run, or of the timeline).
    pub folds: usize,
    /// Relative drop of the held-out mean square a candidate must bring (0: any drop; the score
    /// test and the information criterion already ask for evidence).
    pub min_heldout_gain: f64,
    /// Only candidates of these families (`None`: every registered family).
    pub families: Option<Vec<String>>,
    /// Solver settings of every fit.
    pub solver: Options,
    /// Memory for candidates' cached series (bytes) per scoring pass: more candidates are
    /// scored in several passes.
    pub cache_bytes: usize,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self {
            alpha: 0.05,
            max_steps: 10,
            tries: 8,
            folds: 5,
            cross_validation: CrossValidation::BlocksPerRun,
            min_heldout_gain: 0.0,
            families: None,
            solver: Options::default(),
            cache_bytes: 256 << 20,
        }
    }
}

/// How the held-out check divides the fitted data (`[identify] heldout` in a session).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CrossValidation {
    /// `"blocks"`: every fitted run cut into [`SearchOptions::folds`] contiguous blocks; fold
    /// `k` is the `k`-th block of every run (every set-up stays in every training set: right
    /// for sessions of different runs, each telling something of its own).
    BlocksPerRun,
    /// `"runs"`: one fitted run at a time (leave-one-run-out): when runs repeat one experiment
    /// and a model must carry over to a run it never saw.
    Runs,
    /// `"timeline"`: the fitted samples in time order cut into [`SearchOptions::folds`]
    /// contiguous blocks: a long recording (a thermal test) where a model must predict hours it
    /// did not see.
    Timeline,
}

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
}

impl Ranked {
    /// The candidate's name with its starting shape (`thermal-drift Z (t), τ₀ = 600 s`).
    pub fn name(&self) -> String {
        match &self.candidate {
            Candidate::Effect(e) => {
                let shapes: Vec<String> = e
                    .params()
                    .iter()
                    .filter(|p| p.kind == mtcal_effects::ParamKind::Shape)
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
        if s.absorbed > 0.99 && !self.mimics.is_empty() {
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

/// The `omitted-parameter` candidates of `study`: parameters of the full error model the fit
/// holds.
pub fn omitted_parameters(study: &Study) -> Vec<Candidate> {
    candidates(study, Some(&["omitted-parameter".to_string()]))
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

fn rank_with(
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
        raise(&mut config, &name, extra)?;
    }
    for m in changes.iter().filter(|m| m.extra_order > 0) {
        raise(&mut config, &m.param, m.extra_order)?;
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

fn raise(
    config: &mut [mtcal_kinematics::ParamConfig],
    name: &mtcal_kinematics::ParamName,
    extra: usize,
) -> Result<(), IdentifyError> {
    use mtcal_kinematics::Basis;
    let Some(entry) = config.iter_mut().find(|c| &c.name == name) else {
        return Ok(());
    };
    entry.basis = match entry.basis.take() {
        Some(Basis::Legendre {
            lo,
            hi,
            min_degree,
            max_degree,
        }) => Basis::legendre(lo, hi, min_degree, max_degree + extra).ok(),
        Some(Basis::Fourier {
            min_harmonic,
            max_harmonic,
        }) => Basis::fourier(min_harmonic, max_harmonic + extra).ok(),
        other => other,
    };
    Ok(())
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
            pose_axis: vec![0.0; max_ch * na],
            axis_jac: vec![0.0; 6 * na],
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
        let na = self.study.model.machine().n_axes();
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

// ---------------------------------------------------------------------------------------------
// The loop

/// One fitted model.
struct Fitted {
    study: Study,
    solution: Solution,
    id: Identification,
    heldout: Heldout,
}

/// What [`search`] returns: the final study (the session with the discoveries added), its
/// fit, and the report (with `discoveries` and `search` filled).
#[derive(Debug)]
pub struct SearchResult {
    pub study: Study,
    pub solution: Solution,
    pub identification: Identification,
    /// The fit before the search added anything.
    pub initial: Identification,
    /// Its solution, and the changes of its study (`study.rebuild(initial_changes)` gives it
    /// back: the parameter vector `initial_solution` belongs to).
    pub initial_solution: Solution,
    pub initial_changes: crate::study::Changes,
}

/// One accepted step.
struct Stage {
    /// Candidates that explained nearly as well ([`LOOKALIKE_BIC`]); those still significant
    /// once this one is in the model explained something else and are dropped
    /// ([`Stage::confirm_lookalikes`]).
    lookalikes: Vec<LookAlike>,
    ranked: Ranked,
    before_id: Identification,
    before_solution: Solution,
    before_heldout: Heldout,
    before_params: Vec<(String, f64, String)>,
    after_heldout: Heldout,
    after_id: Identification,
    after_solution: Solution,
}

/// Information criterion (in units of the noise estimate) within which another candidate is a
/// look-alike of the one added: below 10, the evidence for the one over the other is not
/// "very strong" (Kass & Raftery's scale for Bayes factors).
pub const LOOKALIKE_BIC: f64 = 10.0;

impl Stage {
    /// Keeps the look-alikes that `ranking` (with this stage's effect in the model) no longer
    /// finds significant: they explained the same thing.
    fn confirm_lookalikes(&mut self, ranking: &[Ranked]) {
        self.lookalikes.retain(|l| {
            !ranking
                .iter()
                .any(|r| r.score.significant && r.candidate.label() == l.label)
        });
    }
}

/// The candidates to refit at a step: the strongest significant ones, at most three targets or
/// drivers of one class (a drift of Z or of the tool length, a thermal expansion in time or
/// with a temperature) and one starting shape per label, `tries` in all, so that every kind of
/// explanation the scores point at is refitted and the look-alikes of the winner are seen.
fn choose_tries(ranked: &[Ranked], tries: usize) -> Vec<Ranked> {
    let mut out: Vec<Ranked> = Vec::new();
    for r in ranked
        .iter()
        .filter(|r| r.score.significant && r.score.df > 0)
    {
        if out.len() == tries {
            break;
        }
        let class = r.candidate.class();
        let same_class = out.iter().filter(|t| t.candidate.class() == class).count();
        if same_class < 3
            && !out
                .iter()
                .any(|t| t.candidate.label() == r.candidate.label())
        {
            out.push(r.clone());
        }
    }
    out
}

/// `r` from the best of its shape scan ([`Effect::shape_scan`]: a cycle's pitch on a grid
/// fine enough that no phase is off by more than an eighth of a turn), scored against the
/// current fit; `r` itself if it has none or none scores higher. The scan picks where the
/// refit starts; whether the candidate is kept is decided as for any other.
fn scanned(current: &Fitted, r: Ranked, options: &SearchOptions) -> Result<Ranked, IdentifyError> {
    let Candidate::Effect(e) = &r.candidate else {
        return Ok(r);
    };
    let shapes = e.shape_scan(current.study.view());
    if shapes.is_empty() {
        return Ok(r);
    }
    let variants: Vec<Candidate> = shapes
        .iter()
        .filter_map(|s| e.with_shape(s))
        .map(Candidate::Effect)
        .collect();
    let ranked = rank_with(
        &current.study,
        &current.solution,
        variants,
        options.alpha,
        options.cache_bytes,
    )?;
    Ok(match ranked.into_iter().next() {
        Some(mut best) if best.score.statistic > r.score.statistic => {
            best.score.adjusted_p = r.score.adjusted_p;
            best.score.significant = r.score.significant;
            best
        }
        _ => r,
    })
}

/// What would tell candidate `b` from `a` (both explain the data alike).
fn telling_apart(a: &Candidate, b: &Candidate) -> String {
    let (ca, cb) = (a.class(), b.class());
    let driver = |c: &Candidate| match c {
        Candidate::Effect(e) => e.info().driver.clone().unwrap_or_default(),
        Candidate::Model(_) => String::new(),
    };
    let pair = |x: &str, y: &str| (ca == x && cb == y) || (ca == y && cb == x);
    let thermal = |c: &str| {
        matches!(
            c,
            "thermal-drift" | "temperature-coupling" | "thermal-expansion"
        )
    };
    if ca == cb && driver(a) != driver(b) {
        return format!(
            "a session in which {} and {} do not follow each other (a pause, a cool-down, a \
             change of spindle speed)",
            driver(a),
            driver(b)
        );
    }
    if (thermal(ca) && cb == "setup-drift") || (thermal(cb) && ca == "setup-drift") {
        return "re-measure the first run with a second set-up at the end (a set-up's drift \
                stays with its set-up, a machine's shows in every set-up)"
            .into();
    }
    if pair("reversal", "servo-lag") || pair("stick-slip", "servo-lag") {
        return "repeat a path at a second feed: a lag grows with the velocity, lost motion does \
                not"
        .into();
    }
    if pair("reversal", "stick-slip") {
        return "approach a reversal in steps finer than the decay: stick-slip fades with the \
                travel, lost motion does not"
            .into();
    }
    if pair("cyclic", "component-order") || pair("cyclic", "omitted-parameter") {
        return "step the axis finer than a quarter of the pitch over its whole stroke: a cycle \
                repeats, a higher order does not"
            .into();
    }
    if ca == cb {
        return "measure with the set-up or path changed so the two targets move differently \
                (another ball position, another height)"
            .into();
    }
    separating_measurement(b, &[])
}

/// Runs the physics search on `study` (see the module documentation).
pub fn search(study: Study, options: &SearchOptions) -> Result<SearchResult, IdentifyError> {
    let options = &with_session_options(&study, options)?;
    let mut current = with_noise(fit(study, None, options)?, options)?;
    let initial = current.id.clone();
    let initial_solution = current.solution.clone();
    let initial_changes = current.study.changes().clone();
    let mut report = SearchReport {
        candidates: 0,
        steps: Vec::new(),
        stopped: SearchStop::MostAllowed {
            steps: options.max_steps,
        },
        concealed: Vec::new(),
        ranking: Vec::new(),
    };
    let mut stages: Vec<Stage> = Vec::new();
    let mut last_ranking: Option<Vec<Ranked>> = None;
    for step in 0..options.max_steps {
        let cands = candidates(&current.study, options.families.as_deref());
        if step == 0 {
            report.candidates = cands.len();
        }
        let ranked = rank_with(
            &current.study,
            &current.solution,
            cands,
            options.alpha,
            options.cache_bytes,
        )?;
        // What the last step added was told from its look-alikes only if they no longer
        // explain anything now that it is in the model.
        if let Some(stage) = stages.last_mut() {
            stage.confirm_lookalikes(&ranked);
        }
        let tries = choose_tries(&ranked, options.tries);
        if tries.is_empty() {
            report.stopped = if step == 0 {
                SearchStop::NothingSignificant
            } else {
                SearchStop::NothingFurther
            };
            last_ranking = Some(ranked);
            break;
        }
        let mut trials = Vec::new();
        let mut passed: Vec<(usize, Ranked, Refitted)> = Vec::new();
        for r in tries {
            let r = scanned(&current, r, options)?;
            let (trial, fitted) = try_candidate(&current, &r, options)?;
            if let Some(f) = fitted {
                passed.push((trials.len(), r, f));
            }
            trials.push(trial);
        }
        // Among those that pass, the information criterion decides: the better fit unless it
        // pays for it with parameters (stick-slip with an endless decay is a reversal error
        // with one parameter more). Those within a whisker of it are its look-alikes.
        let scale = current.solution.chi2_reduced.max(1.0);
        let winner = passed
            .iter()
            .enumerate()
            .min_by(|a, b| bic(&a.1.2.solution).total_cmp(&bic(&b.1.2.solution)))
            .map(|(k, _)| k);
        let mut lookalikes = Vec::new();
        if let Some(w) = winner {
            let (wk, wr, wf) = &passed[w];
            let best = bic(&wf.solution);
            for (k, r, f) in &passed {
                if k == wk {
                    continue;
                }
                let delta = (bic(&f.solution) - best) / scale;
                let t = &mut trials[*k];
                t.accepted = false;
                if delta < LOOKALIKE_BIC && r.candidate.label() != wr.candidate.label() {
                    t.why = format!(
                        "explains nearly as well as the one added (information criterion {delta:+.1}): \
                         a look-alike; {}",
                        t.why
                    );
                    lookalikes.push(LookAlike {
                        candidate: r.name(),
                        effect: r.candidate.class().to_string(),
                        label: r.candidate.label(),
                        delta_chi2: (f.solution.chi2 - wf.solution.chi2) / scale,
                        delta_bic: delta,
                        measurement: telling_apart(&wr.candidate, &r.candidate),
                    });
                } else {
                    t.why = format!("passed, but another candidate predicts better; {}", t.why);
                }
            }
        }
        report.steps.push(trials);
        let accepted = match winner {
            Some(w) => {
                let (_, r, f) = passed.swap_remove(w);
                let id = Identification::new(&f.study, &f.solution)?;
                Some((
                    r,
                    Fitted {
                        study: f.study,
                        solution: f.solution,
                        id,
                        heldout: f.heldout,
                    },
                ))
            }
            None => None,
        };
        let Some((ranked_ok, fitted)) = accepted else {
            report.stopped = SearchStop::NoneImproved;
            last_ranking = Some(ranked);
            break;
        };
        let before_params = machine_values(&current.study, &current.solution);
        let Fitted {
            study,
            solution,
            id,
            heldout,
        } = fitted;
        stages.push(Stage {
            lookalikes,
            ranked: ranked_ok,
            before_id: current.id,
            before_solution: current.solution,
            before_heldout: current.heldout,
            before_params,
            after_heldout: heldout,
            after_id: id.clone(),
            after_solution: solution.clone(),
        });
        current = with_noise(
            Fitted {
                study,
                solution,
                id,
                heldout,
            },
            options,
        )?;
    }
    let last_ranking = match last_ranking {
        Some(r) => r,
        None => rank_with(
            &current.study,
            &current.solution,
            candidates(&current.study, options.families.as_deref()),
            options.alpha,
            options.cache_bytes,
        )?,
    };
    if let Some(stage) = stages.last_mut() {
        stage.confirm_lookalikes(&last_ranking);
    }
    report.concealed = concealed(&last_ranking);
    report.ranking = last_ranking.iter().take(5).map(Ranked::describe).collect();
    let discoveries = stages.iter().map(|s| discovery(s, &current)).collect();
    let mut identification = current.id;
    identification.discoveries = discoveries;
    identification.search = Some(report);
    Ok(SearchResult {
        study: current.study,
        solution: current.solution,
        identification,
        initial,
        initial_solution,
        initial_changes,
    })
}

/// `options` with the session's `[identify] heldout` (`"blocks"`, the default; `"runs"`;
/// `"timeline"`) and `folds` (blocks: 5 per run, 16 of a timeline).
fn with_session_options(
    study: &Study,
    options: &SearchOptions,
) -> Result<SearchOptions, IdentifyError> {
    let mut out = options.clone();
    let bad = |key: &str, m: String| IdentifyError::Options {
        at: study.session.identify_location(key),
        key: key.into(),
        message: m,
    };
    let keys = SearchKeys::read(&study.session)?;
    match keys.heldout.as_deref() {
        None => {}
        Some("blocks") => out.cross_validation = CrossValidation::BlocksPerRun,
        Some("runs") => out.cross_validation = CrossValidation::Runs,
        Some("timeline") => {
            out.cross_validation = CrossValidation::Timeline;
            out.folds = 16;
        }
        Some(other) => {
            let found = toml::Value::from(other);
            return Err(bad(
                "heldout",
                format!("expected \"blocks\", \"runs\" or \"timeline\", found {found}"),
            ));
        }
    }
    match keys.folds {
        None => {}
        Some(k) if k >= 2 => out.folds = k as usize,
        Some(k) => {
            return Err(bad(
                "folds",
                format!("expected a whole number ≥ 2, found {k}"),
            ));
        }
    }
    if out.cross_validation == CrossValidation::Runs
        && study.runs.iter().filter(|r| r.fit).count() < 2
    {
        return Err(bad(
            "heldout",
            "leaving runs out needs two fitted runs at least".into(),
        ));
    }
    Ok(out)
}

/// `fitted` on the noise its residuals show ([`crate::noise`]): every decision of the search is
/// a χ² statistic, on the noise the recordings really carry rather than the σ the manifest
/// states. Estimated again after every step: a large effect left out inflates the estimate
/// (a cycle of a few samples reads as noise), and once it is in the model the smaller ones
/// need the noise it leaves. Within a step every candidate is compared on one metric.
fn with_noise(fitted: Fitted, options: &SearchOptions) -> Result<Fitted, IdentifyError> {
    let noise = crate::noise::estimate(&fitted.study, &fitted.solution.x);
    let now = fitted.study.changes().noise.as_deref();
    let same = match now {
        Some(n) => *n == noise,
        None => noise.is_stated(),
    };
    if same {
        return Ok(fitted);
    }
    let changes = Changes {
        noise: (!noise.is_stated()).then(|| Arc::new(noise)),
        ..fitted.study.changes().clone()
    };
    let study = fitted.study.rebuild(changes)?;
    fit(study, Some(fitted.solution.x), options)
}

/// Fits `study` (from `x0` or its own start) and cross-validates it.
fn fit(
    study: Study,
    x0: Option<Vec<f64>>,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let x0 = x0.unwrap_or_else(|| study.initial_x());
    let solution = crate::solve_from(&study, &x0, &options.solver, &mut Silent)?;
    let id = Identification::new(&study, &solution)?;
    let heldout = heldout(&study, &solution.x, options)?;
    Ok(Fitted {
        study,
        solution,
        id,
        heldout,
    })
}

/// Cross-validation: each fold of the fitted data ([`CrossValidation`]) is left out, the model
/// refitted on the rest and the left-out samples predicted.
///
/// The refit is the Gauss–Newton step from the full fit `x` (where the model is linear to the
/// accuracy that matters here), `δ_k = −R_k⁺z_k` from the streaming QR factor of the other
/// folds' rows ([`mtcal_solve::linearize`], with the solver's column scaling and rank rule: the
/// normal equations would square the condition number, and a direction the data barely see
/// would move by metres on their rounding). The left-out rows enter only through their normal
/// equations `A_k = J_kᵀJ_k`, `g_k = J_kᵀr_k`, summed for every fold in one pass: their
/// residuals become `r_k + J_k·δ_k`, whose sum of squares is `r_kᵀr_k + 2δ_kᵀg_k + δ_kᵀA_kδ_k`.
/// One factor per fold and no iteration, instead of a fit per fold.
pub fn heldout(
    study: &Study,
    x: &[f64],
    options: &SearchOptions,
) -> Result<Heldout, IdentifyError> {
    let (folds, assign) = fold_assignment(study, options);
    let specs = param_specs_from(study, x);
    let n = study.layout().n_x();
    let problem = FitProblem::new(study);
    let blocks = problem.n_blocks();
    // Lanes merged in order (see `mtcal_solve::run_lanes`): the same sums on any number of cores.
    // Each lane: its sums and a column-list buffer reused from block to block.
    let mut parts: Vec<(FoldSums, Vec<usize>)> = (0..mtcal_solve::lane_count(blocks))
        .map(|_| (FoldSums::new(folds, n), Vec::new()))
        .collect();
    mtcal_solve::run_lanes(blocks, &mut parts, 0, |b, (sums, cols)| {
        let mut target = FoldTarget {
            sums,
            cols: std::mem::take(cols),
            assign: &assign,
        };
        let res =
            problem
                .walk_rows(b, x, &mut target)
                .map_err(|source| mtcal_solve::SolveError::Eval {
                    block: b,
                    cause: source,
                });
        *cols = target.cols;
        res
    })?;
    let mut total = FoldSums::new(folds, n);
    for (part, _) in &parts {
        total.add(part);
    }
    let (mut sum_w, mut sum_u, mut count) = (0.0, 0.0, 0usize);
    for k in 0..folds {
        if total.count[k] == 0 {
            continue;
        }
        let training = FitProblem::without_fold(study, Some((assign.clone(), k)));
        let lin = mtcal_solve::linearize(&training, &specs, x, 0)?;
        let delta = lin.step(options.solver.rank_tolerance)?;
        let quad = |a: &[f64], g: &[f64], rr: f64| -> f64 {
            let mut q = rr;
            for i in 0..n {
                q += 2.0 * delta[i] * g[i];
                for j in 0..n {
                    q += delta[i] * a[i * n + j] * delta[j];
                }
            }
            q.max(0.0)
        };
        sum_w += quad(
            &total.a[k * n * n..(k + 1) * n * n],
            &total.g[k * n..(k + 1) * n],
            total.rr[k],
        );
        sum_u += quad(
            &total.au[k * n * n..(k + 1) * n * n],
            &total.gu[k * n..(k + 1) * n],
            total.rru[k],
        );
        count += total.count[k];
    }
    let c = count.max(1) as f64;
    Ok(Heldout {
        mean_square: sum_w / c,
        rms_um: (sum_u / c).sqrt() * 1e6,
        samples: count,
    })
}

/// Per fold: normal equations of the whitened rows (`a`, `g`, `rr`) and of the rows in the
/// channels' units (`au`, `gu`, `rru`, SI), and the number of rows.
struct FoldSums {
    n: usize,
    a: Vec<f64>,
    g: Vec<f64>,
    rr: Vec<f64>,
    au: Vec<f64>,
    gu: Vec<f64>,
    rru: Vec<f64>,
    count: Vec<usize>,
}

impl FoldSums {
    fn new(folds: usize, n: usize) -> Self {
        Self {
            n,
            a: vec![0.0; folds * n * n],
            g: vec![0.0; folds * n],
            rr: vec![0.0; folds],
            au: vec![0.0; folds * n * n],
            gu: vec![0.0; folds * n],
            rru: vec![0.0; folds],
            count: vec![0; folds],
        }
    }

    fn add(&mut self, other: &FoldSums) {
        for (a, b) in [
            (&mut self.a, &other.a),
            (&mut self.g, &other.g),
            (&mut self.rr, &other.rr),
            (&mut self.au, &other.au),
            (&mut self.gu, &other.gu),
            (&mut self.rru, &other.rru),
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
    sums: &'a mut FoldSums,
    cols: Vec<usize>,
    assign: &'a FoldOf,
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

impl RowTarget for FoldTarget<'_> {
    fn columns(&mut self, cols: &[usize]) {
        self.cols.clear();
        self.cols.extend_from_slice(cols);
    }

    fn row(&mut self, out: &Row<'_>, eval: &SampleEval<'_>, sample: usize, channel: usize) {
        if out.seed {
            return;
        }
        let n = self.sums.n;
        let k = self.assign.of(eval.run, sample);
        let sigma = 1.0 / eval.inv_sigma[channel];
        let s2 = sigma * sigma;
        let (a, au) = (
            &mut self.sums.a[k * n * n..(k + 1) * n * n],
            &mut self.sums.au[k * n * n..(k + 1) * n * n],
        );
        // The decision's sums from the prewhitened rows; the RMS in the channels' units from
        // the residuals as they are.
        let (row, res) = (out.jac, out.res);
        let (raw, raw_res) = (out.raw_jac, out.raw_res);
        for (p, &i) in self.cols.iter().enumerate() {
            let (ri, ui) = (row[p], raw[p]);
            if ri != 0.0 {
                for (q, &j) in self.cols.iter().enumerate() {
                    a[i * n + j] += ri * row[q];
                }
                self.sums.g[k * n + i] += ri * res;
            }
            if ui != 0.0 {
                for (q, &j) in self.cols.iter().enumerate() {
                    au[i * n + j] += ui * raw[q] * s2;
                }
                self.sums.gu[k * n + i] += ui * raw_res * s2;
            }
        }
        self.sums.rr[k] += res * res;
        self.sums.rru[k] += raw_res * raw_res * s2;
        self.sums.count[k] += 1;
    }
}

/// The Bayesian information criterion of a fit with known noise: `χ² + k·ln n`, `k` the
/// identified parameters.
fn bic(solution: &Solution) -> f64 {
    solution.chi2 + solution.rank as f64 * (solution.n_rows.max(2) as f64).ln()
}

/// Adds `ranked`'s candidate to the current model, refits, and decides.
fn try_candidate(
    current: &Fitted,
    ranked: &Ranked,
    options: &SearchOptions,
) -> Result<(Trial, Option<Refitted>), IdentifyError> {
    let mut changes: Changes = current.study.changes().clone();
    let mut trial = Trial {
        candidate: ranked.name(),
        effect: ranked.candidate.class().to_string(),
        statistic: ranked.score.statistic,
        adjusted_p: ranked.score.adjusted_p,
        absorbed: ranked.score.absorbed,
        accepted: false,
        why: String::new(),
    };
    match &ranked.candidate {
        Candidate::Model(m) if m.extra_order == 0 => changes.estimate.push(m.param),
        Candidate::Model(m) => changes.raise.push((m.param, m.extra_order)),
        Candidate::Effect(e) => changes.effects.push(unique(e, &changes.effects)),
    }
    let mut study = current.study.rebuild(changes)?;
    let mut x0 = carry_over(&current.study, &current.solution.x, &study);
    let ladder = match &ranked.candidate {
        Candidate::Effect(e) => e.prior_ladder(),
        Candidate::Model(_) => Vec::new(),
    };
    if !ladder.is_empty() {
        // A joint model with a ridge prior: fitted at its starting width, the width chosen by
        // cross-validation over whole runs, refitted at it.
        let first = match crate::solve_from(&study, &x0, &options.solver, &mut Silent) {
            Ok(s) => s,
            Err(e) => {
                trial.why = format!("the refit failed: {e}");
                return Ok((trial, None));
            }
        };
        let k = choose_width(&study, &first, &ladder, options)?;
        let mut changes = study.changes().clone();
        changes.effects.pop();
        changes.effects.push(unique(&ladder[k], &changes.effects));
        study = study.rebuild(changes)?;
        x0 = first.x;
    } else if let Candidate::Effect(e) = &ranked.candidate {
        // Start the new amplitudes where the score test put them.
        let offset = study.layout().n_x() - e.params().len();
        let mut a = ranked.score.amplitude.iter();
        for (j, p) in e.params().iter().enumerate() {
            if p.kind == mtcal_effects::ParamKind::Amplitude {
                x0[offset + j] = a.next().copied().unwrap_or(0.0);
            }
        }
    }
    let solution = match crate::solve_from(&study, &x0, &options.solver, &mut Silent) {
        Ok(s) => s,
        Err(e) => {
            trial.why = format!("the refit failed: {e}");
            return Ok((trial, None));
        }
    };
    // Refined together, a second thermal node's τ may slide onto the first one's, where the
    // two amplitudes grow without bound in opposite directions: then the earlier effects keep
    // the shapes they were found with and only the new one's is refined.
    let solution = match implausible(current, &study, &solution) {
        Some(_) if !current.study.layout().effects().is_empty() => {
            let earlier: Vec<usize> = current
                .study
                .layout()
                .effects()
                .filter(|&i| {
                    current
                        .study
                        .effect_param(i)
                        .is_some_and(|p| p.kind == mtcal_effects::ParamKind::Shape)
                })
                .collect();
            match crate::solve_holding(&study, &x0, &options.solver, &mut Silent, &earlier) {
                Ok(held) if implausible(current, &study, &held).is_none() => held,
                _ => solution,
            }
        }
        _ => solution,
    };
    let before = &current.solution;
    let drop = before.chi2 - solution.chi2;
    let added = added_dof(current, &study, &solution);
    let scale = solution.chi2_reduced.max(1.0);
    let penalty = added * (solution.n_rows.max(2) as f64).ln();
    if drop / scale <= penalty {
        trial.why = format!(
            "χ² dropped by {drop:.1}; scaled by the noise estimate ({scale:.2}) that is {:.1}, below the information criterion's {penalty:.1} for {added:.1} parameters",
            drop / scale
        );
        return Ok((trial, None));
    }
    if let Some(why) = implausible(current, &study, &solution) {
        trial.why = why;
        return Ok((trial, None));
    }
    let held = heldout(&study, &solution.x, options)?;
    let gain = 1.0 - held.mean_square / current.heldout.mean_square;
    if gain < options.min_heldout_gain {
        trial.why = format!(
            "held-out prediction did not improve enough: RMS {:.3} → {:.3} µm (mean square {:+.2} %)",
            current.heldout.rms_um,
            held.rms_um,
            -100.0 * gain
        );
        return Ok((trial, None));
    }
    trial.accepted = true;
    // Kept until the step's winner is chosen: without the lag series of its fit.
    study.clear_view_caches();
    trial.why = format!(
        "χ² {:.1} → {:.1}; held-out RMS {:.3} → {:.3} µm (mean square {:+.2} %)",
        before.chi2,
        solution.chi2,
        current.heldout.rms_um,
        held.rms_um,
        -100.0 * gain
    );
    Ok((
        trial,
        Some(Refitted {
            study,
            solution,
            heldout: held,
        }),
    ))
}

/// Why a refit is not physics, if it is not: a parameter beyond its plausible range (a
/// millimetre or milliradian of machine or set-up error, an effect's own: a metre per hour of
/// set-up drift or a 96 % gain error fit numbers, not a machine), or an added parameter whose
/// interval is wider than that range (not an identification). Parameters already beyond their
/// range before the candidate was added are not its doing, nor are those in the null space
/// (what the data cannot see has no value to judge).
fn implausible(current: &Fitted, study: &Study, solution: &Solution) -> Option<String> {
    let specs = param_specs(study);
    let before: HashMap<String, f64> = (0..current.study.layout().n_x())
        .map(|i| (current.study.param_info(i).name, current.solution.x[i]))
        .collect();
    for (i, spec) in specs.iter().enumerate() {
        let Some(range) = spec.scale else { continue };
        if !solution.identified[i] {
            continue;
        }
        if spec.bounds.is_some() {
            // A shape parameter (τ, pitch): its box says what is plausible.
            continue;
        }
        if solution.sigma[i].is_none() {
            // In the null space: the fit's value along it is arbitrary, not a claim.
            continue;
        }
        let info = study.param_info(i);
        let value = solution.x[i];
        let was = before.get(&info.name).copied();
        let show = |v: f64| format!("{:.4} {}", v * info.per_si, info.unit);
        // A parameter already in the model is blamed only when its whole interval lies
        // beyond the range (one the data barely see may wander along a near-null direction);
        // the candidate's own by its value.
        let margin = match (was, solution.sigma[i]) {
            (Some(_), Some(sigma)) => K95 * sigma,
            _ => 0.0,
        };
        if value.abs() - margin > range && was.is_none_or(|w| w.abs() <= range) {
            return Some(format!(
                "not physics: the refit puts {} at {}, beyond its plausible range of ±{}",
                info.name,
                show(value),
                show(range)
            ));
        }
        if was.is_none()
            && let Some(sigma) = solution.sigma[i]
            && K95 * sigma > range
        {
            return Some(format!(
                "not an identification: {} = {} ± {}, an interval wider than its plausible \
                 range of ±{}",
                info.name,
                show(value),
                show(K95 * sigma),
                show(range)
            ));
        }
    }
    None
}

/// The degrees of freedom `study` (the current model with a candidate added) spends beyond
/// `current`'s: one per new parameter, less for one under a prior (a ridge's column counts
/// `1 − σ²_fit/σ²_prior`, the share of it the data rather than the prior decide); at least 1.
fn added_dof(current: &Fitted, study: &Study, solution: &Solution) -> f64 {
    let mut dof = 0.0;
    for i in current.study.layout().n_x()..study.layout().n_x() {
        dof += match (
            study.effect_param(i).and_then(|d| d.prior),
            solution.sigma[i],
        ) {
            (Some(prior), Some(post)) => (1.0 - (post / prior).powi(2)).clamp(0.0, 1.0),
            (Some(_), None) => 0.0,
            (None, _) => 1.0,
        };
    }
    dof.max(1.0)
}

/// The prior width of `ladder` (the same effect at every width, the study's last) whose fit
/// predicts held-out runs best: each fitted run left out in turn (three or more; otherwise
/// the search's folds), the others' normal equations at `solution` with the ladder's priors
/// solved for the Gauss–Newton step (the model is linear in the effect's amplitudes), the
/// left-out rows predicted. One pass over the data for every width and fold.
fn choose_width(
    study: &Study,
    solution: &Solution,
    ladder: &[Arc<dyn Effect>],
    options: &SearchOptions,
) -> Result<usize, IdentifyError> {
    let fitted = study.runs.iter().filter(|r| r.fit).count();
    let (folds, assign) = if fitted >= 3 {
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
    // Only the parameters that share rows with the effect's take part in the refit of a fold
    // (the rest, another sensor's model, keep their fitted values: what they do does not
    // depend on this effect's prior).
    let coupled: Vec<usize> = (0..n)
        .filter(|&i| {
            i >= first
                || (first..n).any(|j| (0..folds).any(|k| sums.a[k * n * n + i * n + j] != 0.0))
        })
        .collect();
    let m = coupled.len();
    let mut best = (f64::INFINITY, 0);
    for (w, effect) in ladder.iter().enumerate() {
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
        if total < best.0 {
            best = (total, w);
        }
    }
    Ok(best.1)
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

/// Every fold's normal equations of `study`'s rows at `x` (one pass, lanes merged in order).
fn fold_sums(
    study: &Study,
    x: &[f64],
    folds: usize,
    assign: &FoldOf,
) -> Result<FoldSums, IdentifyError> {
    let n = study.layout().n_x();
    let problem = FitProblem::new(study);
    let blocks = problem.n_blocks();
    let mut parts: Vec<(FoldSums, Vec<usize>)> = (0..mtcal_solve::lane_count(blocks))
        .map(|_| (FoldSums::new(folds, n), Vec::new()))
        .collect();
    mtcal_solve::run_lanes(blocks, &mut parts, 0, |b, (sums, cols)| {
        let mut target = FoldTarget {
            sums,
            cols: std::mem::take(cols),
            assign,
        };
        let res =
            problem
                .walk_rows(b, x, &mut target)
                .map_err(|source| mtcal_solve::SolveError::Eval {
                    block: b,
                    cause: source,
                });
        *cols = target.cols;
        res
    })?;
    let mut total = FoldSums::new(folds, n);
    for (part, _) in &parts {
        total.add(part);
    }
    Ok(total)
}

/// A candidate's refit that passed the checks (its report is built only if it wins).
struct Refitted {
    study: Study,
    solution: Solution,
    heldout: Heldout,
}

/// `x` of `from` mapped into `to`'s parameter vector by parameter name; new parameters at
/// their starting values.
fn carry_over(from: &Study, x: &[f64], to: &Study) -> Vec<f64> {
    let known: HashMap<String, f64> = (0..from.layout().n_x())
        .map(|i| (from.param_info(i).name, x[i]))
        .collect();
    let start = to.initial_x();
    (0..to.layout().n_x())
        .map(|i| *known.get(&to.param_info(i).name).unwrap_or(&start[i]))
        .collect()
}

/// The machine parameters of a fit: name, value and unit (reported units).
fn machine_values(study: &Study, solution: &Solution) -> Vec<(String, f64, String)> {
    (0..study.layout().n_machine())
        .map(|i| {
            let info = study.param_info(i);
            (info.name, solution.x[i] * info.per_si, info.unit)
        })
        .collect()
}

/// The discovery of one accepted step, with its parameters from the final fit.
fn discovery(stage: &Stage, last: &Fitted) -> Discovery {
    let study = &last.study;
    let sol = &last.solution;
    let (info, parameters, words) = match &stage.ranked.candidate {
        Candidate::Effect(e) => {
            // Find the effect in the final study by its place: effects are only appended.
            let label = &e.info().label;
            let mut offset = study.layout().effect_offset();
            let mut found = None;
            for fx in study.effects() {
                let n = fx.params().len();
                if found.is_none()
                    && (fx.info().label == *label
                        || fx.info().label.starts_with(&format!("{label} #")))
                    && stage_effect_matches(stage, fx)
                {
                    found = Some((Arc::clone(fx), offset));
                }
                offset += n;
            }
            let (fx, offset) = found.unwrap_or((Arc::clone(e), study.layout().effect_offset()));
            let values: Vec<f64> = (0..fx.params().len()).map(|j| sol.x[offset + j]).collect();
            let u95: Vec<Option<f64>> = (0..fx.params().len())
                .map(|j| sol.sigma[offset + j].map(|s| K95 * s))
                .collect();
            let params = fx
                .params()
                .iter()
                .enumerate()
                .map(|(j, p)| DiscoveryParameter {
                    name: p.name.clone(),
                    value: values[j] * p.per_si,
                    unit: p.unit.clone(),
                    u95: u95[j].map(|u| u * p.per_si),
                })
                .collect();
            (fx.info().clone(), params, fx.describe(&values, &u95))
        }
        Candidate::Model(m) => {
            let prefix = format!("{}", m.param);
            let params: Vec<DiscoveryParameter> = (0..study.layout().n_machine())
                .filter_map(|i| {
                    let info = study.param_info(i);
                    let base = info.name.split('.').next().unwrap_or(&info.name);
                    (base == prefix).then(|| DiscoveryParameter {
                        name: info.name.clone(),
                        value: sol.x[i] * info.per_si,
                        unit: info.unit.clone(),
                        u95: sol.sigma[i].map(|s| K95 * s * info.per_si),
                    })
                })
                .collect();
            let list: Vec<String> = params
                .iter()
                .map(|p| match p.u95 {
                    Some(u) => format!("{} = {:.3} ± {:.3} {}", p.name, p.value, u, p.unit),
                    None => format!("{} (not separable)", p.name),
                })
                .collect();
            let words = if m.extra_order == 0 {
                format!(
                    "the error {} the model left out: {}",
                    m.param,
                    list.join(", ")
                )
            } else {
                format!(
                    "{} needs {} more orders: {}",
                    m.param,
                    m.extra_order,
                    list.join(", ")
                )
            };
            let axis = m.param.axis().map(|a| a.as_char());
            (
                EffectInfo {
                    class: m.class,
                    axis,
                    component: Some(m.param.to_string()),
                    driver: axis.map(|a| a.to_string()),
                    label: m.label(),
                },
                params,
                words,
            )
        }
    };
    let excess =
        (stage.before_solution.chi2 - stage.before_solution.dof as f64).max(f64::MIN_POSITIVE);
    let removed = stage.before_solution.chi2 - stage.after_solution.chi2;
    let share = (removed / excess).clamp(0.0, 1.0);
    let corrected = corrections(stage, study, sol);
    let location = locate(stage, &info);
    let validation = |id: &Identification| {
        let (mut ss, mut n) = (0.0, 0usize);
        for r in &id.validation {
            let k = r.channels.iter().map(|c| c.samples).sum::<usize>();
            ss += r.rms_um * r.rms_um * k as f64;
            n += k;
        }
        (n > 0).then(|| (ss / n as f64).sqrt())
    };
    let (val_before, val_after) = (validation(&stage.before_id), validation(&stage.after_id));
    let mut explanation = match &location {
        Some(loc) => where_words(loc, &stage.before_id),
        None => {
            "the residuals' structure tests did not show it (it hides below the noise or inside \
             the fitted parameters); the score test did"
                .to_string()
        }
    };
    explanation += &format!(
        "; {words} explains {:.0} % of the excess χ²; held-out RMS {:.3} → {:.3} µm",
        100.0 * share,
        stage.before_heldout.rms_um,
        stage.after_heldout.rms_um
    );
    if let (Some(a), Some(b)) = (val_before, val_after) {
        explanation += &format!(", validation RMS {a:.3} → {b:.3} µm");
    }
    if stage.ranked.score.absorbed > 0.5 {
        let like: Vec<&str> = stage
            .ranked
            .mimics
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        explanation += &format!(
            "; {:.0} % of it looked like the fitted parameters{} (to separate them better: {})",
            100.0 * stage.ranked.score.absorbed,
            if like.is_empty() {
                String::new()
            } else {
                format!(", chiefly {}", like.join(", "))
            },
            separating_measurement(
                &stage.ranked.candidate,
                &stage
                    .ranked
                    .mimics
                    .iter()
                    .map(|(n, _)| n.clone())
                    .collect::<Vec<_>>()
            )
        );
    }
    if !stage.lookalikes.is_empty() {
        let others: Vec<String> = stage
            .lookalikes
            .iter()
            .map(|l| {
                format!(
                    "{} ({} by {:.1} in χ²)",
                    l.candidate,
                    if l.delta_chi2 >= 0.0 {
                        "worse"
                    } else {
                        "better"
                    },
                    l.delta_chi2.abs()
                )
            })
            .collect();
        explanation += &format!(
            "; THESE DATA CANNOT TELL IT FROM {} — neither is the answer; to tell them apart: {}",
            others.join(" or "),
            stage.lookalikes[0].measurement
        );
    }
    if !corrected.is_empty() {
        let list: Vec<String> = corrected
            .iter()
            .take(4)
            .map(|c| {
                format!(
                    "{} was biased by {:+.3} {} and is now {:.3} ± {:.3} {}",
                    c.name,
                    c.before - c.after,
                    c.unit,
                    c.after,
                    c.u95,
                    c.unit
                )
            })
            .collect();
        explanation += &format!("; {}", list.join(", "));
    }
    Discovery {
        effect: info.class.to_string(),
        axis: info.axis.map(|a| a.to_string()),
        component: info.component.clone(),
        driver: info.driver.clone(),
        label: info.label.clone(),
        parameters,
        rms_before_um: stage.before_id.fit.rms_um,
        rms_after_um: stage.after_id.fit.rms_um,
        heldout_rms_before_um: stage.before_heldout.rms_um,
        heldout_rms_after_um: stage.after_heldout.rms_um,
        validation_rms_before_um: val_before,
        validation_rms_after_um: val_after,
        share_of_excess: share,
        statistic: stage.ranked.score.statistic,
        adjusted_p: stage.ranked.score.adjusted_p,
        absorbed: stage.ranked.score.absorbed,
        corrected,
        location,
        alternatives: stage.lookalikes.clone(),
        sentence: words,
        explanation,
    }
}

/// Whether `fx` (an effect of the final study) is the stage's effect: same label stem and
/// same starting shape.
fn stage_effect_matches(stage: &Stage, fx: &Arc<dyn Effect>) -> bool {
    let Candidate::Effect(e) = &stage.ranked.candidate else {
        return false;
    };
    e.params()
        .iter()
        .zip(fx.params())
        .all(|(a, b)| a.name == b.name && a.initial == b.initial)
}

/// Machine parameters that moved by more than two standard deviations (of the final fit) when
/// the stage's effect was added: before is the fit without it, after the final fit.
fn corrections(stage: &Stage, study: &Study, sol: &Solution) -> Vec<Correction> {
    let before: HashMap<&str, f64> = stage
        .before_params
        .iter()
        .map(|(n, v, _)| (n.as_str(), *v))
        .collect();
    let mut out: Vec<(f64, Correction)> = (0..study.layout().n_machine())
        .filter_map(|i| {
            let info = study.param_info(i);
            let sigma = sol.sigma[i]? * info.per_si;
            let b = *before.get(info.name.as_str())?;
            let a = sol.x[i] * info.per_si;
            let z = (b - a).abs() / sigma;
            (z > 2.0).then_some((
                z,
                Correction {
                    name: info.name,
                    unit: info.unit,
                    before: b,
                    after: a,
                    u95: K95 * sigma,
                },
            ))
        })
        .collect();
    out.sort_by(|a, b| b.0.total_cmp(&a.0));
    out.into_iter().map(|(_, c)| c).collect()
}

/// The mismatch location (before the step) that matches the effect's driver best.
fn locate(stage: &Stage, info: &EffectInfo) -> Option<mtcal_mismatch::Location> {
    let m = &stage.before_id.mismatch;
    if !m.detected {
        return None;
    }
    let driver = info.driver.clone().unwrap_or_default();
    let matches = |along: &str| {
        along == driver
            || (driver.len() == 1 && along == format!("{driver} direction"))
            || (driver == "S^2" && along == "S")
            || (driver.contains('*') && driver.split('*').any(|d| d == along))
    };
    m.locations
        .iter()
        .find(|l| l.along.as_deref().is_some_and(matches))
        .or(m.locations.first())
        .cloned()
}

/// "run X's residuals are structured along t (lag-1 autocorrelation 0.93)".
fn where_words(loc: &mtcal_mismatch::Location, id: &Identification) -> String {
    let Some(along) = &loc.along else {
        return format!(
            "run {}'s channel {} is off by more than the noise",
            loc.run, loc.channel
        );
    };
    let ac = id.tests.iter().find(|t| {
        t.run == loc.run
            && t.channel == loc.channel
            && t.along.as_deref() == Some(along)
            && t.test == mtcal_mismatch::TestKind::LjungBox
    });
    let span = match (loc.from, loc.to) {
        (Some(a), Some(b)) if a != b => format!(" between {along} = {} and {}", num(a), num(b)),
        _ => String::new(),
    };
    let detail = ac.map_or_else(String::new, |t| {
        format!(" (lag-1 autocorrelation {:.2})", t.detail)
    });
    format!(
        "run {}'s {} residuals are structured along {along}{detail}, {:.0} % of their excess{span}",
        loc.run,
        loc.channel,
        100.0 * loc.share
    )
}

/// `x` with at most four decimals, trailing zeros dropped.
fn num(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// Candidates the data cannot tell from the fitted parameters (more than 99 % absorbed), one per
/// effect class and target, most absorbed first. A candidate that hides behind an effect of its
/// own label already fitted (the same drift at another starting τ) is that effect, not a
/// concealed one.
fn concealed(ranking: &[Ranked]) -> Vec<Concealed> {
    let mut out: Vec<Concealed> = Vec::new();
    let mut seen: Vec<(String, Option<String>, Option<char>)> = Vec::new();
    let mut sorted: Vec<&Ranked> = ranking
        .iter()
        .filter(|r| r.score.absorbed > 0.99 && !r.mimics.is_empty())
        .filter(|r| {
            let own = r.candidate.label();
            !r.mimics.iter().any(|(n, _)| {
                n.starts_with(&format!("{own}.")) || n.starts_with(&format!("{own} #"))
            })
        })
        .collect();
    sorted.sort_by(|a, b| b.score.absorbed.total_cmp(&a.score.absorbed));
    for r in sorted {
        let key = match &r.candidate {
            Candidate::Effect(e) => (
                e.info().class.to_string(),
                e.info().component.clone(),
                e.info().axis,
            ),
            Candidate::Model(m) => (m.class.to_string(), Some(m.param.to_string()), None),
        };
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let names: Vec<String> = r.mimics.iter().map(|(n, _)| n.clone()).collect();
        out.push(Concealed {
            candidate: r.name(),
            effect: r.candidate.class().to_string(),
            absorbed: r.score.absorbed,
            measurement: separating_measurement(&r.candidate, &names),
            hides_behind: names,
        });
        if out.len() == 12 {
            break;
        }
    }
    out
}

/// The measurement that would separate a concealed candidate from the parameters it hides
/// behind.
pub fn separating_measurement(candidate: &Candidate, hides_behind: &[String]) -> String {
    let setup = hides_behind.iter().any(|n| {
        n.contains("tool_length")
            || n.contains("ball_")
            || n.contains("pivot")
            || n.contains("TOOL")
    });
    match candidate.class() {
        "thermal-drift" | "temperature-coupling" | "setup-drift" => {
            "repeat a reference point (or the first run) at the end of the session, or measure \
             the runs in random order: a drift in time then no longer follows the path"
                .into()
        }
        "reversal" | "stick-slip" => {
            "measure each path in both directions (CW and CCW, up and down): a reversal error \
             flips with the direction, geometry does not"
                .into()
        }
        "servo-lag" => {
            "repeat a path at a second feed: a lag grows with the velocity, geometry does not"
                .into()
        }
        "cyclic" => "step the axis finer than a quarter of the pitch over several pitches".into(),
        "cross-coupling" => "repeat the measurement at a second position of the other axes".into(),
        "instrument-scale" => {
            "measure the same motion with the instrument turned or at a second range (or \
             against a calibrated reference)"
                .into()
        }
        _ if setup => {
            "a second ball height (or a second tool length): set-up offsets then no longer \
             move with the axis like this error"
                .into()
        }
        _ => "a second ball position at another radius or height, and the axis over its whole \
             stroke"
            .into(),
    }
}

impl Identification {
    /// The physics search in words: what was added and why, what was tried and not kept,
    /// what the data cannot tell apart. Empty without a search.
    pub fn search_summary(&self) -> String {
        self.search_summary_with(true)
    }

    /// [`Self::search_summary`]; without `verbose` only what a person reads first: how the
    /// search ended, each discovery with its values, its evidence, the parameters it had
    /// biased and its look-alikes, and a few of what the data cannot tell apart (every trial,
    /// every concealed candidate and the remaining candidates' tests are in the JSON and with
    /// `verbose`).
    pub fn search_summary_with(&self, verbose: bool) -> String {
        use std::fmt::Write as _;
        let Some(report) = &self.search else {
            return String::new();
        };
        let mut s = String::new();
        let _ = writeln!(
            s,
            "physics search: {} candidates scored (family-wise α = 5 %); {}",
            report.candidates, report.stopped
        );
        if verbose {
            for (k, trials) in report.steps.iter().enumerate() {
                for t in trials {
                    let _ = writeln!(
                        s,
                        "  step {}: {} [{}] {}: {}",
                        k + 1,
                        if t.accepted { "added" } else { "not kept" },
                        t.effect,
                        t.candidate,
                        t.why
                    );
                }
            }
        }
        if self.discoveries.is_empty() {
            let _ = writeln!(s, "discoveries: none");
        } else {
            let _ = writeln!(s, "discoveries:");
            for d in &self.discoveries {
                if verbose {
                    let _ = writeln!(s, "  {} — {}", d.label, d.explanation);
                } else {
                    s.push_str(&d.in_brief());
                }
            }
        }
        let shown = if verbose { report.concealed.len() } else { 3 };
        if !report.concealed.is_empty() {
            let _ = writeln!(
                s,
                "concealed (these data cannot tell them from the fitted parameters):"
            );
            for c in report.concealed.iter().take(shown) {
                let _ = writeln!(
                    s,
                    "  {} ({:.1} % like {}): {}",
                    c.candidate,
                    100.0 * c.absorbed,
                    c.hides_behind.join(", "),
                    c.measurement
                );
            }
            if report.concealed.len() > shown {
                let _ = writeln!(
                    s,
                    "  … {} more in the JSON (`search.concealed`) and with --verbose",
                    report.concealed.len() - shown
                );
            }
        }
        if verbose && !report.ranking.is_empty() {
            let _ = writeln!(s, "strongest remaining candidates:");
            for line in &report.ranking {
                let _ = writeln!(s, "  {line}");
            }
        }
        s
    }
}

impl SearchResult {
    /// Applies `base` to the reports before and after the search (each with its own study's
    /// parameter vector).
    pub fn apply_base(&mut self, base: &crate::base::BaseModel) -> Result<(), IdentifyError> {
        let initial_study = self.study.rebuild(self.initial_changes.clone())?;
        self.initial
            .apply_base(base, &initial_study, &self.initial_solution);
        self.identification
            .apply_base(base, &self.study, &self.solution);
        Ok(())
    }
}
