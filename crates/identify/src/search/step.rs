//! Step 2, fit and check: which ranked candidates to refit ([`choose_tries`]), a cycle's pitch
//! scanned first ([`scanned`]), each added and refitted and judged ([`try_candidate`]: physics,
//! information criterion, held-out prediction) into a [`Refitted`] model, and the accepted
//! step kept as a [`Stage`] with its look-alikes (step 3). Uses the ranking, the cross-validation
//! and the fit helpers; the loop drives it and the discoveries read its stages.

use super::curves;
use super::fitted::{Fitted, carry_over, solve};
use super::heldout::{choose_width, heldout};
use super::rank::{CONCEALED, Ranked, rank_with};
use super::settings::{LOOKALIKE_BIC, SearchOptions};
use crate::K95;
use crate::findings::{Heldout, LookAlike, Trial};
use crate::ids::ParamId;
use crate::relabel::unique;
use crate::report::Identification;
use crate::study::{Changes, Study};
use crate::{IdentifyError, param_specs};
use mtcal_effects::Candidate;
use mtcal_solve::Solution;
use std::collections::HashMap;
use std::sync::Arc;

/// One accepted step.
pub(super) struct Stage {
    /// Candidates that explained nearly as well ([`LOOKALIKE_BIC`]); those still significant
    /// once this one is in the model explained something else and are dropped
    /// ([`Stage::confirm_lookalikes`]).
    ///
    /// [`LOOKALIKE_BIC`]: super::LOOKALIKE_BIC
    pub(super) lookalikes: Vec<LookAlike>,
    /// Look-alikes dropped because they were still significant with this stage's effect in
    /// the model; restored by [`restore_lookalikes`] when a later stage names them again.
    pub(super) dropped: Vec<LookAlike>,
    pub(super) ranked: Ranked,
    pub(super) before_id: Identification,
    pub(super) before_solution: Solution,
    pub(super) before_heldout: Heldout,
    /// The machine parameters before the step, in reported units.
    pub(super) before_params: HashMap<ParamId, f64>,
    pub(super) after_heldout: Heldout,
    pub(super) after_id: Identification,
    pub(super) after_solution: Solution,
    /// What the step added to the model, and the parameters it added.
    pub(super) addition: Addition,
    /// Why the final model holds a simpler form of the effect the step added, if it does
    /// (the fit pinned a shape at the edge where its family makes it that form).
    pub(super) simplified: Option<String>,
}

/// What a step adds to the model: an effect (as it sits in the study's changes) or a change
/// of the error model; and the parameters it adds.
#[derive(Clone, Debug)]
pub(super) struct Addition {
    pub(super) change: AddedChange,
    pub(super) params: Vec<ParamId>,
}

#[derive(Clone, Debug)]
pub(super) enum AddedChange {
    Effect(std::sync::Arc<dyn mtcal_effects::Effect>),
    Model(mtcal_effects::ModelChange),
}

impl Addition {
    /// `changes` without this addition.
    pub(super) fn removed_from(&self, changes: &Changes) -> Changes {
        let mut out = changes.clone();
        match &self.change {
            AddedChange::Effect(e) => out.effects.retain(|f| !std::sync::Arc::ptr_eq(f, e)),
            AddedChange::Model(m) if m.extra_order == 0 => out.estimate.retain(|p| *p != m.param),
            AddedChange::Model(m) => {
                if let Some(k) = out
                    .raise
                    .iter()
                    .rposition(|(p, o)| *p == m.param && *o == m.extra_order)
                {
                    out.raise.remove(k);
                }
            }
        }
        out
    }
}

impl Stage {
    /// Keeps the look-alikes that `ranking` (with this stage's effect in the model) no longer
    /// finds significant: they explained the same thing.
    pub(super) fn confirm_lookalikes(&mut self, ranking: &[Ranked]) {
        let (kept, dropped) = std::mem::take(&mut self.lookalikes)
            .into_iter()
            .partition(|l| {
                !ranking
                    .iter()
                    .any(|r| r.score.significant && r.candidate.label() == l.label)
            });
        self.lookalikes = kept;
        self.dropped.extend(dropped);
    }
}

/// The class and target of a look-alike, `thermal-drift Z` of `thermal-drift Z (t), from
/// tau_s = 120 s`: what stays when the driver and the starting shape are left out.
fn class_and_target(label: &str) -> &str {
    label.split(" (").next().unwrap_or(label)
}

/// Whether `a` and `b` are one explanation in two forms (a reversal and a reversal that
/// changes along the stroke, a drift in time through one thermal node or several): the same
/// class on the same target following the same driver. Such a pair is not a look-alike: the
/// data telling them apart or not, the answer is the same.
pub(super) fn same_explanation(a: &Candidate, b: &Candidate) -> bool {
    match (a, b) {
        (Candidate::Effect(x), Candidate::Effect(y)) => {
            let (x, y) = (x.info(), y.info());
            x.class == y.class
                && x.axis == y.axis
                && x.component == y.component
                && x.driver == y.driver
        }
        _ => a.label() == b.label(),
    }
}

/// A look-alike dropped at one stage (it still explained something once the stage's effect was
/// in) is restored when a later stage adds one of its class and target or names one among its
/// look-alikes: what it went on to explain was taken by the same kind of explanation, so the
/// data did not tell the stage's effect apart from it. Not when a later stage added the
/// look-alike itself: both are then in the model, each an effect of its own.
pub(super) fn restore_lookalikes(stages: &mut [Stage]) {
    for i in 0..stages.len() {
        let later: Vec<String> = stages[i + 1..]
            .iter()
            .flat_map(|s| {
                std::iter::once(s.ranked.candidate.label())
                    .chain(s.lookalikes.iter().map(|l| l.label.clone()))
            })
            .map(|label| class_and_target(&label).to_string())
            .collect();
        // A look-alike a later stage added itself is an effect of its own, told apart.
        let added: Vec<String> = stages[i + 1..]
            .iter()
            .map(|s| s.ranked.candidate.label())
            .collect();
        let stage = &mut stages[i];
        let (restored, still): (Vec<LookAlike>, Vec<LookAlike>) =
            std::mem::take(&mut stage.dropped)
                .into_iter()
                .partition(|l| {
                    !added.contains(&l.label)
                        && later.iter().any(|t| t == class_and_target(&l.label))
                });
        stage.lookalikes.extend(restored);
        stage.dropped = still;
    }
}

/// The candidates to refit at a step: the strongest significant ones, at most three targets or
/// drivers of one class (a drift of Z or of the tool length, a thermal expansion in time or
/// with a temperature) and one starting shape per label, `tries` in all, so that every kind of
/// explanation the scores point at is refitted and the look-alikes of the winner are seen.
pub(super) fn choose_tries(ranked: &[Ranked], tries: usize) -> Vec<Ranked> {
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

/// One refitted candidate: where its refit started (after the shape scan), the trial as
/// reported, and the refit if it passed.
pub(super) type Tried = (Ranked, Trial, Option<Refitted>);

/// Scans and refits each of `tries` against `current` ([`scanned`], [`try_candidate`]), side by
/// side on the solver's threads. Each try reads only `current` and computes alone, so the
/// outcomes — in the order of `tries` — are the same on any number of threads; the error of
/// the first failing try in that order is returned.
pub(super) fn try_all(
    current: &Fitted,
    tries: Vec<Ranked>,
    options: &SearchOptions,
) -> Result<Vec<Tried>, IdentifyError> {
    let one = |r: Ranked| -> Result<Tried, IdentifyError> {
        let r = scanned(current, r, options)?;
        let (trial, fitted) = try_candidate(current, &r, options)?;
        Ok((r, trial, fitted))
    };
    mtcal_solve::map_in_order(tries, options.solver.threads, one)
}

/// `r` from the best of its shape scan ([`Effect::shape_scan`]: a cycle's pitch on a grid
/// fine enough that no phase is off by more than an eighth of a turn), scored against the
/// current fit; `r` itself if it has none or none scores higher. The scan picks where the
/// refit starts; whether the candidate is kept is decided as for any other.
///
/// [`Effect::shape_scan`]: mtcal_effects::Effect::shape_scan
fn scanned(current: &Fitted, r: Ranked, options: &SearchOptions) -> Result<Ranked, IdentifyError> {
    let Candidate::Effect(e) = &r.candidate else {
        return Ok(r);
    };
    let shapes = e.shape_scan(current.study.view());
    if shapes.is_empty() {
        return Ok(r);
    }
    let variants: Vec<Arc<dyn mtcal_effects::Effect>> =
        shapes.iter().filter_map(|s| e.with_shape(s)).collect();
    let ranked = rank_with(
        &current.study,
        &current.solution,
        variants.iter().cloned().map(Candidate::Effect).collect(),
        options.alpha,
        options.cache_bytes,
    )?;
    // The score along the scan, in the scan's order: its peaks are the independent looks.
    let along: Vec<f64> = variants
        .iter()
        .map(|v| {
            ranked
                .iter()
                .find(|r| matches!(&r.candidate, Candidate::Effect(x) if Arc::ptr_eq(x, v)))
                .map_or(0.0, |r| r.score.statistic)
        })
        .collect();
    Ok(match ranked.into_iter().next() {
        Some(mut best) if best.score.statistic > r.score.statistic => {
            best.score.adjusted_p = r.score.adjusted_p;
            best.score.significant = r.score.significant;
            best.looked_among = peaks(&along);
            best
        }
        _ => r,
    })
}

/// The local maxima of `s` along its order (at least one): how many independent shapes a
/// scan finer than the shapes' resolution looked at.
fn peaks(s: &[f64]) -> usize {
    let n = s.len();
    let count = (0..n)
        .filter(|&i| (i == 0 || s[i] > s[i - 1]) && (i + 1 == n || s[i] >= s[i + 1]))
        .count();
    count.max(1)
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
    if let Candidate::Effect(e) = &ranked.candidate
        && let Some(old) = bank_in_model(&changes, e)
    {
        return widen(current, ranked, &old, trial, options);
    }
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
        let first = match solve(&study, &x0, options, &[]) {
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
    match converged_refit(&study, &x0, options) {
        Ok(solution) => judge(current, ranked, study, solution, &x0, trial, None, options),
        Err(why) => {
            trial.why = why;
            Ok((trial, None))
        }
    }
}

/// The refit of `study` from `x0` if it converged; else why not. Nothing is claimed on a fit
/// that did not converge: its numbers are a last iterate.
fn converged_refit(study: &Study, x0: &[f64], options: &SearchOptions) -> Result<Solution, String> {
    match solve(study, x0, options, &[]) {
        Ok(s) if s.converged => Ok(s),
        Ok(s) => Err(format!(
            "the refit did not converge ({:?} after {} iterations)",
            s.termination, s.iterations
        )),
        Err(e) => Err(format!("the refit failed: {e}")),
    }
}

/// The bank in the model that `e` proposes again (the same label, a prior ladder).
fn bank_in_model(
    changes: &Changes,
    e: &Arc<dyn mtcal_effects::Effect>,
) -> Option<Arc<dyn mtcal_effects::Effect>> {
    if e.prior_ladder().is_empty() {
        return None;
    }
    changes
        .effects
        .iter()
        .find(|f| f.info().label == e.info().label && !f.prior_ladder().is_empty())
        .cloned()
}

/// The width of a bank's prior (its first column's prior standard deviation).
fn prior_width(e: &dyn mtcal_effects::Effect) -> f64 {
    e.params().first().and_then(|p| p.prior).unwrap_or(0.0)
}

/// A joint model proposed again while it is in the model (`old`): a second bank of the same
/// columns beside the first would be the first at a wider prior (two Gaussian priors on one
/// column add their variances), found piecemeal and withdrawn piece by piece, each piece's
/// amplitudes alone within their interval of zero. The proposal is the bank in the model at a
/// wider prior instead: the width chosen by the cross-validation among the present one and
/// the wider ones ([`choose_width`]), judged as any candidate is, the information criterion
/// counting the effective parameters the wider prior frees.
fn widen(
    current: &Fitted,
    ranked: &Ranked,
    old: &Arc<dyn mtcal_effects::Effect>,
    mut trial: Trial,
    options: &SearchOptions,
) -> Result<(Trial, Option<Refitted>), IdentifyError> {
    let now = prior_width(old.as_ref());
    let mut ladder = vec![Arc::clone(old)];
    ladder.extend(
        old.prior_ladder()
            .into_iter()
            .filter(|e| prior_width(e.as_ref()) > now * (1.0 + 1e-9)),
    );
    if ladder.len() == 1 {
        trial.why = "in the model already, at its widest prior".to_string();
        return Ok((trial, None));
    }
    // The model as it is, the bank last (as `choose_width` reads it).
    let mut changes = current.study.changes().clone();
    changes.effects.retain(|f| !Arc::ptr_eq(f, old));
    changes.effects.push(Arc::clone(old));
    let reordered = current.study.rebuild(changes)?;
    let at = Solution {
        x: carry_over(&current.study, &current.solution.x, &reordered),
        ..current.solution.clone()
    };
    let k = choose_width(&reordered, &at, &ladder, options)?;
    if k == 0 {
        trial.why = format!(
            "in the model already; the cross-validation keeps its prior of {}",
            width_words(old.as_ref())
        );
        return Ok((trial, None));
    }
    let mut changes = reordered.changes().clone();
    changes.effects.pop();
    changes.effects.push(Arc::clone(&ladder[k]));
    let study = reordered.rebuild(changes)?;
    let solution = match converged_refit(&study, &at.x, options) {
        Ok(s) => s,
        Err(why) => {
            trial.why = why;
            return Ok((trial, None));
        }
    };
    let (trial, refitted) = judge(
        current,
        ranked,
        study,
        solution,
        &at.x,
        trial,
        Some(old),
        options,
    )?;
    let mut trial = trial;
    if trial.accepted {
        trial.why = format!(
            "its prior widened from {} to {}: {}",
            width_words(old.as_ref()),
            width_words(ladder[k].as_ref()),
            trial.why
        );
    }
    Ok((trial, refitted))
}

/// A bank's prior width in words.
fn width_words(e: &dyn mtcal_effects::Effect) -> String {
    e.prior_words().unwrap_or_else(|| "its width".to_string())
}

/// Judges a converged refit of `current` with `ranked`'s candidate (`widens`: the bank in
/// the model it widens): physics, information criterion, held-out prediction.
#[allow(clippy::too_many_arguments)]
fn judge(
    current: &Fitted,
    ranked: &Ranked,
    study: Study,
    solution: Solution,
    x0: &[f64],
    mut trial: Trial,
    widens: Option<&Arc<dyn mtcal_effects::Effect>>,
    options: &SearchOptions,
) -> Result<(Trial, Option<Refitted>), IdentifyError> {
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
            match solve(&study, x0, options, &earlier) {
                Ok(held) if implausible(current, &study, &held).is_none() => held,
                _ => solution,
            }
        }
        _ => solution,
    };
    let before = &current.solution;
    let drop = before.chi2 - solution.chi2;
    let added = match widens {
        Some(old) => widened_dof(current, old, &study, &solution),
        None => added_dof(current, &study, &solution),
    } + ranked.look_elsewhere_dof(solution.n_rows);
    let scale = solution.chi2_reduced.max(1.0);
    let penalty = added * (solution.n_rows.max(2) as f64).ln();
    if drop / scale <= penalty {
        let scan = match ranked.looked_among {
            k if k > 1 => format!(", its shape the best of {k} the scan looked at"),
            _ => String::new(),
        };
        trial.why = format!(
            "χ² dropped by {drop:.1}; scaled by the noise estimate ({scale:.2}) that is {:.1}, below the information criterion's {penalty:.1} for {added:.1} parameters{scan}",
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
    if let Err(why) = real_gain(&current.heldout, &held, options.gain_level) {
        trial.why = format!(
            "held-out RMS {:.3} → {:.3} µm, but {why}",
            current.heldout.rms_um, held.rms_um
        );
        return Ok((trial, None));
    }
    // A candidate the fitted parameters absorb almost wholly (concealed: its score is the
    // sliver of it they cannot take) gains a per cent or two of held-out prediction from any
    // shape the truth has and the model lacks — a set-up "settling" that is 99 % a location
    // error, on a machine whose errors are not the model's. It is a claim only if it predicts
    // clearly better.
    if ranked.score.absorbed > CONCEALED && !clearly_better(&held, &current.heldout) {
        trial.why = format!(
            "held-out RMS {:.3} → {:.3} µm, but {:.1} % of it looks like the fitted parameters: \
             a candidate these data can hardly tell from them must predict clearly better \
             ({:.0} % lower mean square)",
            current.heldout.rms_um,
            held.rms_um,
            100.0 * ranked.score.absorbed,
            100.0 * CLEARLY_BETTER_SHARE
        );
        return Ok((trial, None));
    }
    if let Some((effect, shared)) = re_expresses(&study, &solution, current.study.effects().len())
        && !clearly_better(&held, &current.heldout)
    {
        trial.why = format!(
            "held-out RMS {:.3} → {:.3} µm, but {:.0} % of what it adds beside the geometry \
             {effect} (added before) explains as well: a second law for that effect must \
             predict clearly better ({:.0} % lower mean square)",
            current.heldout.rms_um,
            held.rms_um,
            100.0 * shared,
            100.0 * CLEARLY_BETTER_SHARE
        );
        return Ok((trial, None));
    }
    trial.accepted = true;
    let addition = match widens {
        Some(_) => Addition {
            change: AddedChange::Effect(Arc::clone(
                study.changes().effects.last().expect("the widened bank"),
            )),
            params: Vec::new(),
        },
        None => addition_of(current, &study, &ranked.candidate),
    };
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
            added_dof: added,
            addition,
            widens: widens.cloned(),
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
    let before: HashMap<ParamId, f64> = current
        .study
        .param_indices()
        .into_iter()
        .map(|(id, k)| (id, current.solution.x[k]))
        .collect();
    // A component's whole curve, where each coefficient alone is in range.
    if let Some(curve) = curves::newly_implausible(
        &curves::component_curves(&current.study, &current.solution),
        &curves::component_curves(study, solution),
    ) {
        return Some(format!("not physics: in the refit, {}", curve.describe()));
    }
    for (i, spec) in specs.iter().enumerate() {
        let Some(range) = spec.scale else { continue };
        // An axis' state where its approach is unknown is not a claim: the data need not
        // determine it.
        if !solution.identified[i] || study.effect_param(i).is_some_and(|p| p.nuisance) {
            continue;
        }
        if let Some((lo, hi)) = spec.bounds {
            // A shape parameter (τ, pitch): its box says what is plausible, and a candidate's
            // shape pinned at an edge of it found no optimum inside (a settling "faster" than
            // its 1 s floor is a step on the first samples, not a time constant).
            let info = study.param_info(i);
            let value = solution.x[i];
            if !before.contains_key(&study.param_id(i)) && at_edge(value, (lo, hi)) {
                return Some(format!(
                    "not physics: the refit pins {} at the edge of its range, {:.4} {}",
                    info.name,
                    value * info.per_si,
                    info.unit
                ));
            }
            continue;
        }
        if solution.sigma[i].is_none() {
            // In the null space: the fit's value along it is arbitrary, not a claim.
            continue;
        }
        let info = study.param_info(i);
        let value = solution.x[i];
        let was = before.get(&study.param_id(i)).copied();
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
/// The effective parameters a wider prior frees: over the bank's amplitudes (the study's
/// last effect), `1 − (posterior σ / prior σ)²` now less the same in `current`.
fn widened_dof(
    current: &Fitted,
    old: &Arc<dyn mtcal_effects::Effect>,
    study: &Study,
    solution: &Solution,
) -> f64 {
    let effective = |prior: Option<f64>, post: Option<f64>| match (prior, post) {
        (Some(prior), Some(post)) => (1.0 - (post / prior).powi(2)).clamp(0.0, 1.0),
        _ => 0.0,
    };
    let before: HashMap<ParamId, f64> = (0..current.study.layout().n_x())
        .filter_map(|i| {
            let prior = current.study.effect_param(i)?.prior;
            let post = current.solution.sigma[i];
            Some((current.study.param_id(i), effective(prior, post)))
        })
        .collect();
    let n = study.layout().n_x();
    let mut dof = 0.0;
    for i in n - old.params().len()..n {
        let now = effective(
            study.effect_param(i).and_then(|d| d.prior),
            solution.sigma[i],
        );
        dof += now - before.get(&study.param_id(i)).copied().unwrap_or(0.0);
    }
    dof.max(0.0)
}

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

/// Whether the held-out gain of `after` over `before` is real: the folds that predict better
/// outweigh, beyond chance, those that predict worse (a one-sided Wilcoxon signed-rank test at
/// `level` on the per-fold changes of the mean square), the held-out RMS in the channels' units
/// does not grow, and the later part of the session is forecast no worse ([`forecasts_worse`]). A candidate fitted to the noise of
/// the training folds gains a few nanometres on average and loses as much on some folds; a
/// drift that does not extrapolate forecasts the stretches after its training worse. A real
/// effect may gain much more in the folds that hold the runs it shows in than in the others:
/// the signed ranks ask that the gain is consistent, not that it is even.
pub(super) fn real_gain(before: &Heldout, after: &Heldout, level: f64) -> Result<(), String> {
    if let Some(why) = forecasts_worse(before, after) {
        return Err(why);
    }
    // The statistic is the whitened mean square (channels weighed by their noise); but a
    // model whose held-out error in the channels' own units grows predicts no better for the
    // user, whatever the weights say.
    if after.rms_um > before.rms_um {
        return Err(format!(
            "the held-out error in the channels' units grows (RMS {:.3} → {:.3} µm)",
            before.rms_um, after.rms_um
        ));
    }
    // The forecasts are judged above on their own: their refit moves the effects alone, so
    // the model before a candidate forecasts with geometry fitted to those very samples.
    let d: Vec<f64> = before
        .folds
        .iter()
        .zip(&after.folds)
        .map(|(b, a)| b - a)
        .collect();
    if std::env::var_os("MTCAL_DEBUG_FOLDS").is_some() {
        eprintln!("fold gains {d:?}");
    }
    if d.len() < 3 {
        return Ok(());
    }
    let p = signed_rank_p(&d);
    if p <= level {
        return Ok(());
    }
    let worse = d.iter().filter(|&&x| x < 0.0).count();
    Err(format!(
        "the gain is not consistent over the folds ({worse} of {} predicted worse; signed-rank \
         p = {p:.3}, {level} needed)",
        d.len()
    ))
}

/// The share of a new effect's amplitude the effects added before explain beside the
/// geometry at which it re-expresses them ([`re_expresses`]).
const RE_EXPRESSES_SHARE: f64 = 0.5;

/// The effect added before that the newest effect of `study` (its last) mostly re-expresses,
/// and the share: the squared multiple correlation, in `solution`'s covariance (the geometry
/// profiled out), of one of the new amplitudes with the earlier effects' parameters; `None`
/// below [`RE_EXPRESSES_SHARE`]. A linear drift of a tool length beside the head's warm-up
/// along Z, a spindle growth beside it: a second law for what an effect already explains, and
/// a few per cent of held-out gain then says the first law is not quite the truth's, not that
/// a second effect is there. `earlier` is how many effects came before.
fn re_expresses(study: &Study, solution: &Solution, earlier: usize) -> Option<(String, f64)> {
    let effects = study.effects();
    if earlier == 0 || effects.len() != earlier + 1 {
        return None;
    }
    let n = solution.x.len();
    if solution.covariance.len() != n * n {
        return None;
    }
    let range = study.layout().effects();
    let new_first = range.end - effects[earlier].params().len();
    let kind = |i: usize| study.effect_param(i).map(|p| (p.kind, p.nuisance));
    let old: Vec<usize> = (range.start..new_first)
        .filter(|&i| kind(i).is_some_and(|(_, nuisance)| !nuisance))
        .collect();
    let shared = SharedWith::new(&solution.covariance, n, &old);
    let mut best: Option<(usize, f64)> = None;
    for k in new_first..range.end {
        if kind(k) != Some((mtcal_effects::ParamKind::Amplitude, false)) {
            continue;
        }
        let share = shared.share(&solution.covariance, n, k);
        if share >= RE_EXPRESSES_SHARE && best.is_none_or(|(_, b)| share > b) {
            best = Some((k, share));
        }
    }
    let (k, share) = best?;
    // Name the earlier effect whose parameter correlates most with the new amplitude.
    let c = |i: usize, j: usize| solution.covariance[i * n + j];
    let closest = old.iter().copied().max_by(|&a, &b| {
        let r = |i: usize| c(k, i).abs() / (c(k, k) * c(i, i)).sqrt().max(f64::MIN_POSITIVE);
        r(a).total_cmp(&r(b))
    })?;
    let label = study.effect_of_param(closest)?.info().label.clone();
    Some((label, share))
}

/// The regression of estimates on a fixed set `others` under a covariance (`n × n`,
/// row-major), factored once: for each estimate `k`, the squared multiple correlation
/// `c_kᵀS⁻¹c_k / C_kk` (`S` the covariance of `others`, `c_k` theirs with `k`), the share of
/// `k`'s variance they explain; 0 where `S` is singular. One factorisation for all of a joint
/// model's amplitudes, instead of a matrix inverse per amplitude.
struct SharedWith {
    others: Vec<usize>,
    lu: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
}

impl SharedWith {
    fn new(cov: &[f64], n: usize, others: &[usize]) -> Self {
        let m = others.len();
        let s = nalgebra::DMatrix::from_fn(m, m, |a, b| cov[others[a] * n + others[b]]);
        let lu = s.lu();
        Self {
            others: others.to_vec(),
            lu: (m > 0 && lu.is_invertible()).then_some(lu),
        }
    }

    fn share(&self, cov: &[f64], n: usize, k: usize) -> f64 {
        let (Some(lu), ckk) = (&self.lu, cov[k * n + k]) else {
            return 0.0;
        };
        if ckk <= 0.0 {
            return 0.0;
        }
        let c = nalgebra::DVector::from_fn(self.others.len(), |a, _| cov[self.others[a] * n + k]);
        match lu.solve(&c) {
            Some(w) => (c.dot(&w) / ckk).clamp(0.0, 1.0),
            None => 0.0,
        }
    }
}

/// Whether a shape's `value` sits at an edge of its box `bounds` (within 0.1 % of it): the fit
/// found no optimum inside.
pub(super) fn at_edge(value: f64, (lo, hi): (f64, f64)) -> bool {
    let at = |edge: f64| (value - edge).abs() <= 1e-3 * edge.abs();
    at(lo) || at(hi)
}

/// Of the candidates that passed, the one added: the lowest information criterion — unless
/// another predicts the held-out data clearly better ([`clearly_better`]), or, within
/// [`LOOKALIKE_BIC`] of it (where the criterion's evidence is not strong: `scale` is the noise
/// estimate it is measured in), consistently better ([`consistently_better`]); then the best
/// predictor among those. A fit's χ² counts what the candidate and the refitted geometry
/// together absorb of the training data; where the two disagree, the prediction of data the
/// fit did not see is what the model is for (a reversal error fits a decaying spike as well as
/// the spike does, but predicts the blocks it did not see worse).
pub(super) fn winner<'a>(
    passed: impl Iterator<Item = &'a Refitted> + Clone,
    scale: f64,
) -> Option<usize> {
    let by_criterion = passed
        .clone()
        .enumerate()
        .min_by(|a, b| a.1.criterion().total_cmp(&b.1.criterion()))?;
    let best = by_criterion.1;
    let better = passed
        .enumerate()
        .filter(|(_, r)| {
            clearly_better(&r.heldout, &best.heldout)
                || (r.criterion() - best.criterion()) / scale < LOOKALIKE_BIC
                    && consistently_better(&r.heldout, &best.heldout)
        })
        .min_by(|a, b| a.1.heldout.mean_square.total_cmp(&b.1.heldout.mean_square));
    Some(better.map_or(by_criterion.0, |b| b.0))
}

/// A held-out mean square lower by at least this share before it decides over the
/// information criterion.
pub(super) const CLEARLY_BETTER_SHARE: f64 = 0.05;
/// The one-sided level of the signed-rank test over the folds it must pass as well.
const CLEARLY_BETTER_LEVEL: f64 = 0.1;

/// Whether `a` predicts the held-out data clearly better than `b`: a mean square lower by
/// [`CLEARLY_BETTER_SHARE`] and lower fold by fold beyond chance (signed-rank test at
/// [`CLEARLY_BETTER_LEVEL`]).
pub(super) fn clearly_better(a: &Heldout, b: &Heldout) -> bool {
    a.mean_square <= (1.0 - CLEARLY_BETTER_SHARE) * b.mean_square && consistently_better(a, b)
}

/// Whether `a` predicts the held-out data better than `b` fold by fold beyond chance
/// (signed-rank test at [`CLEARLY_BETTER_LEVEL`]), and on the whole.
fn consistently_better(a: &Heldout, b: &Heldout) -> bool {
    if a.mean_square >= b.mean_square || a.folds.len() != b.folds.len() || a.folds.len() < 3 {
        return false;
    }
    let d: Vec<f64> = b.folds.iter().zip(&a.folds).map(|(b, a)| b - a).collect();
    signed_rank_p(&d) <= CLEARLY_BETTER_LEVEL
}

/// How much worse (relative mean square) a forecast may get before a model is said not to
/// carry on into the later part of the session: a drift that does not extrapolate gets it
/// worse by several per cent; a model that merely shifts what the earlier part taught it
/// within the noise, by a fraction of one.
pub(super) const FORECAST_TOLERANCE: f64 = 0.01;

/// Why `after` forecasts the later part of the session worse than `before`, if it does by
/// more than [`FORECAST_TOLERANCE`].
pub(super) fn forecasts_worse(before: &Heldout, after: &Heldout) -> Option<String> {
    match (before.forecast_mean_square, after.forecast_mean_square) {
        (Some(b), Some(a)) if a > b * (1.0 + FORECAST_TOLERANCE) => Some(format!(
            "it forecasts the later part of the session worse (mean square {b:.4} → {a:.4})"
        )),
        _ => None,
    }
}

/// One-sided p-value of the Wilcoxon signed-rank test that the values `d` tend to be positive:
/// the chance that random signs on the same ranks give a positive rank sum at least as large.
/// Exact (the rank sums of every sign pattern counted, ties given their mean rank); zeros count
/// as neither.
pub(super) fn signed_rank_p(d: &[f64]) -> f64 {
    let mut order: Vec<usize> = (0..d.len()).filter(|&i| d[i] != 0.0).collect();
    let n = order.len();
    if n == 0 {
        return 1.0;
    }
    order.sort_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()));
    // Twice the ranks, so that mean ranks of ties stay whole numbers.
    let mut rank2 = vec![0usize; n];
    let mut k = 0;
    while k < n {
        let mut e = k + 1;
        while e < n && d[order[e]].abs() == d[order[k]].abs() {
            e += 1;
        }
        for r in &mut rank2[k..e] {
            *r = k + e + 1;
        }
        k = e;
    }
    let observed: usize = (0..n)
        .filter(|&r| d[order[r]] > 0.0)
        .map(|r| rank2[r])
        .sum();
    let total: usize = rank2.iter().sum();
    // ways[s]: sign patterns whose positive ranks sum to s (counts as f64: 2^n may be large).
    let mut ways = vec![0.0f64; total + 1];
    ways[0] = 1.0;
    for &r in &rank2 {
        for s in (r..=total).rev() {
            ways[s] += ways[s - r];
        }
    }
    let at_least: f64 = ways[observed..].iter().sum();
    at_least / 2f64.powi(n as i32)
}

/// A candidate's refit that passed the checks (its report is built only if it wins).
pub(super) struct Refitted {
    pub(super) study: Study,
    pub(super) solution: Solution,
    pub(super) heldout: Heldout,
    /// The parameters the candidate added, as the information criterion counts them.
    pub(super) added_dof: f64,
    pub(super) addition: Addition,
    /// The bank in the model this refit widens ([`widen`]): the step changes that stage's
    /// effect instead of adding one.
    pub(super) widens: Option<Arc<dyn mtcal_effects::Effect>>,
}

/// What `candidate` added to `current`'s model to make `study`.
fn addition_of(current: &Fitted, study: &Study, candidate: &Candidate) -> Addition {
    let before = current.study.param_indices();
    let params = (0..study.layout().n_x())
        .map(|i| study.param_id(i))
        .filter(|id| !before.contains_key(id))
        .collect();
    let change = match candidate {
        Candidate::Effect(_) => AddedChange::Effect(std::sync::Arc::clone(
            study
                .changes()
                .effects
                .last()
                .expect("an effect candidate adds an effect"),
        )),
        Candidate::Model(m) => AddedChange::Model(m.clone()),
    };
    Addition { change, params }
}

impl Refitted {
    /// The information criterion the candidates of a step are compared by: χ² plus the
    /// parameters each added (its own, a prior's share discounted) times ln n. Not the refit's
    /// numerical rank: in a model with null directions, a candidate that leans on them would
    /// get a parameter for free and win over an equal fit.
    pub(super) fn criterion(&self) -> f64 {
        self.solution.chi2 + self.added_dof * (self.solution.n_rows.max(2) as f64).ln()
    }
}

#[cfg(test)]
mod tests {
    use super::{SharedWith, peaks, prior_width, signed_rank_p, try_candidate};
    use crate::search::fitted::fit;
    use crate::search::rank::{candidates, rank_with};
    use crate::search::settings::SearchOptions;
    use mtcal_effects::Candidate;
    use nalgebra::DMatrix;

    use std::fmt::Write as _;
    use std::sync::Arc;

    #[test]
    fn a_scan_counts_the_peaks_of_its_score() {
        assert_eq!(peaks(&[1.0, 3.0, 2.0, 5.0, 4.0]), 2);
        assert_eq!(peaks(&[1.0, 2.0, 3.0]), 1);
        assert_eq!(peaks(&[3.0, 2.0, 1.0, 2.0]), 2);
        assert_eq!(peaks(&[2.0, 2.0, 2.0]), 1);
        assert_eq!(peaks(&[]), 1);
        // A cycle's score along its pitch, sampled eight times per independent pitch: one
        // look per period of the score's oscillation.
        // Eleven crests from pitch 0 to 80 steps, both ends on one.
        let s: Vec<f64> = (0..=80)
            .map(|k| (std::f64::consts::TAU * k as f64 / 8.0).cos() + 2.0)
            .collect();
        assert_eq!(peaks(&s), 11);
        // Stopped on the way down from its tenth crest: no more looks.
        assert_eq!(peaks(&s[..76]), 10);
    }

    /// A displacement sensor following a heated node through a 20-minute lag (5 µm/K, the
    /// node 10 K warm when loaded) beside a room sensor: 12 h at 30 s, loaded 3 h on, 3 h off.
    fn heated_session(dir: &std::path::Path) {
        let lag = |x: &[f64], dt: f64, tau: f64| {
            let a = (-dt / tau).exp();
            let mut y = 0.0;
            x.iter()
                .map(|&v| {
                    y = a * y + (1.0 - a) * v;
                    y
                })
                .collect::<Vec<f64>>()
        };
        let dt = 30.0;
        let t: Vec<f64> = (0..1440).map(|i| i as f64 * dt).collect();
        let power: Vec<f64> = t
            .iter()
            .map(|&s| f64::from(u8::from((s / 10_800.0) as u64 % 2 == 0)))
            .collect();
        let heat = lag(&power, dt, 1800.0);
        let reading = lag(&heat, dt, 1200.0);
        let mut csv = String::from("t,X,Y,Z,T_heat,T_room,d_ch1\n");
        for i in 0..t.len() {
            let noise = 0.2 * ((i as f64 * 12.9898).sin() * 43_758.545).fract();
            let _ = writeln!(
                csv,
                "{},0,0,0,{},{},{}",
                t[i],
                20.0 + 10.0 * heat[i],
                20.0 + 0.3 * (t[i] / 20_000.0).sin(),
                50.0 * reading[i] + noise
            );
        }
        std::fs::write(dir.join("run.csv"), csv).unwrap();
        std::fs::write(
            dir.join("session.toml"),
            "machine = \"ZFYX\"\n\n[setup.probe]\nsigma_um = 0.2\n[setup.probe.sensors]\n\
             ch1 = {}\n\n[[run]]\nname = \"run\"\ninstrument = \"displacement\"\n\
             file = \"run.csv\"\nuse = \"fit\"\nsetup = \"probe\"\n",
        )
        .unwrap();
    }

    /// The joint thermal model the search proposes for `study`.
    fn joint_model(study: &crate::Study) -> Arc<dyn mtcal_effects::Effect> {
        candidates(study, Some(&["thermal-model".to_string()]))
            .into_iter()
            .find_map(|c| match c {
                Candidate::Effect(e) => Some(e),
                Candidate::Model(_) => None,
            })
            .expect("a joint thermal model is proposed")
    }

    /// A joint model in the model at far too narrow a prior (its narrowest rung: 0.03 µm per
    /// column against a 50 µm response), proposed again, is widened: the refit holds one bank of
    /// that label at a wider width, replacing the stage's — not a second bank beside it (which
    /// the final check would withdraw piece by piece, leaving the narrow one).
    #[test]
    fn a_joint_model_proposed_again_is_widened_not_stacked() {
        let dir = tempfile::tempdir().unwrap();
        heated_session(dir.path());
        let study = crate::Study::load(dir.path()).unwrap();
        let options = SearchOptions::default();
        let family = ["thermal-model".to_string()];
        let bank = joint_model(&study);
        let narrow = Arc::clone(&bank.prior_ladder()[0]);
        let mut changes = study.changes().clone();
        changes.effects.push(Arc::clone(&narrow));
        let current = fit(study.rebuild(changes).unwrap(), None, &options).unwrap();
        let ranked = rank_with(
            &current.study,
            &current.solution,
            candidates(&current.study, Some(&family)),
            options.alpha,
            options.cache_bytes,
        )
        .unwrap();
        let again = ranked
            .iter()
            .find(|r| r.candidate.label() == narrow.info().label)
            .expect("the bank proposed again");
        let (trial, refit) = try_candidate(&current, again, &options).unwrap();
        assert!(trial.accepted, "{}", trial.why);
        assert!(
            trial
                .why
                .starts_with("its prior widened from 0.03 um per column to"),
            "{}",
            trial.why
        );
        let refit = refit.unwrap();
        assert!(
            refit
                .widens
                .as_ref()
                .is_some_and(|w| Arc::ptr_eq(w, &narrow))
        );
        let banks: Vec<_> = refit
            .study
            .changes()
            .effects
            .iter()
            .filter(|e| e.info().label.starts_with(&narrow.info().label))
            .collect();
        assert_eq!(banks.len(), 1, "one bank of the label");
        assert!(prior_width(banks[0].as_ref()) > 10.0 * prior_width(narrow.as_ref()));
    }

    /// A joint model's prior measures each column from the reference state (a temperature's
    /// first reading): the heated temperature and the room's both wander away from their
    /// start, by different shapes, so their priors per kelvin stand in the inverse ratio of
    /// their RMS departures from the start — not of their wiggles about their means, which
    /// would let a steadily drifting column's gain carry the whole drift more freely.
    #[test]
    fn a_joint_models_prior_measures_each_column_from_the_reference_state() {
        let dir = tempfile::tempdir().unwrap();
        heated_session(dir.path());
        let study = crate::Study::load(dir.path()).unwrap();
        let bank = joint_model(&study);
        // The recorded temperatures, read back from the file the session holds: RMS from the
        // first reading, and about the mean.
        let text = std::fs::read_to_string(dir.path().join("run.csv")).unwrap();
        let sizes = |column: usize| {
            let v: Vec<f64> = text
                .lines()
                .skip(1)
                .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
                .collect();
            let n = v.len() as f64;
            let rms = |c: f64| (v.iter().map(|x| (x - c).powi(2)).sum::<f64>() / n).sqrt();
            (rms(v[0]), rms(v.iter().sum::<f64>() / n))
        };
        let (heat, room) = (sizes(4), sizes(5));
        let prior = |name: &str| {
            bank.params()
                .iter()
                .find(|p| p.name == name)
                .and_then(|p| p.prior)
                .unwrap_or_else(|| panic!("the static column {name}"))
        };
        let ratio = prior("T_heat_um_per_K") / prior("T_room_um_per_K");
        let from_start = room.0 / heat.0;
        let about_mean = room.1 / heat.1;
        assert!(
            (about_mean / from_start - 1.0).abs() > 0.2,
            "{from_start} {about_mean}"
        );
        assert!(
            (ratio / from_start - 1.0).abs() < 0.01,
            "priors in the ratio {ratio}: from the start {from_start}, about the means \
             {about_mean}"
        );
    }

    /// The squared multiple correlation of the estimate `0` with the others equals the share
    /// of its variance a regression on them explains, `c_kᵀ·S⁻¹·c_k / C_kk` (the regression
    /// formulation, not the inverse's corner element); and 0 and 1 at the ends.
    #[test]
    fn multiple_correlation_is_the_regression_share() {
        // An SPD covariance from a random 5 × 8 design.
        let a = DMatrix::from_fn(5, 8, |i, j| {
            ((i * 7 + j * 3) as f64 * 0.37).sin() + 0.1 * i as f64
        });
        let cov = &a * a.transpose();
        let n = 5;
        let flat: Vec<f64> = (0..n * n).map(|k| cov[(k / n, k % n)]).collect();
        let others = [1, 3, 4];
        let s = DMatrix::from_fn(3, 3, |i, j| cov[(others[i], others[j])]);
        let c = nalgebra::DVector::from_fn(3, |i, _| cov[(0, others[i])]);
        let regression = (c.transpose() * s.try_inverse().unwrap() * &c)[(0, 0)] / cov[(0, 0)];
        let r2 = SharedWith::new(&flat, n, &others).share(&flat, n, 0);
        assert!((r2 - regression).abs() < 1e-9, "{r2} vs {regression}");
        // Uncorrelated: nothing shared; a copy of another estimate: everything.
        let diag = [1.0, 0.0, 0.0, 2.0];
        assert_eq!(SharedWith::new(&diag, 2, &[1]).share(&diag, 2, 0), 0.0);
        let twin = [1.0, 1.0 - 1e-12, 1.0 - 1e-12, 1.0];
        assert!(SharedWith::new(&twin, 2, &[1]).share(&twin, 2, 0) > 0.999);
    }

    #[test]
    fn signed_rank_p_values_are_exact() {
        // Every one of n values positive: only one pattern of 2^n is as extreme.
        assert!((signed_rank_p(&[1.0, 2.0, 3.0, 4.0, 5.0]) - 1.0 / 32.0).abs() < 1e-15);
        // All negative: every pattern is at least as large.
        assert!((signed_rank_p(&[-1.0, -2.0, -3.0]) - 1.0).abs() < 1e-15);
        // Ranks 1..4, the smallest negative: W+ = 9 of 10; patterns with W+ ≥ 9 are {2,3,4}
        // and {1,2,3,4}: 2 of 16.
        assert!((signed_rank_p(&[-0.1, 0.2, 0.3, 0.4]) - 2.0 / 16.0).abs() < 1e-15);
        // Ties share their mean rank: |d| = 1, 1 → ranks 1.5, 1.5; W+ = 1.5 of 3: patterns
        // {a}, {b}, {a, b} reach it: 3 of 4.
        assert!((signed_rank_p(&[1.0, -1.0]) - 0.75).abs() < 1e-15);
    }
}
