//! What the final model keeps ([`keep_what_holds`]): every step was judged on the model of its
//! own moment; once the search ends, each added effect must still be a determined, physical
//! effect of the final fit, and the final model must predict held-out data — the blocks and
//! the forecasts — no worse than the fit before the search. What fails is withdrawn (reported, never a discovery). Uses the
//! cross-validation, the fit helpers and the steps; the loop calls it before the discoveries
//! are written.

use super::curves;
use super::fitted::{Fitted, carry_over, fit};
use super::settings::SearchOptions;
use super::step::{AddedChange, Addition, Stage, at_edge, forecasts_worse, real_gain};
use crate::findings::{SearchReport, Withdrawn};
use crate::ids::ParamId;
use crate::study::{Changes, Study};
use crate::{IdentifyError, K95, param_specs};
use mtcal_effects::{Candidate, Effect};
use mtcal_solve::Solution;
use std::sync::Arc;

/// Withdraws, latest first, every stage whose parameters the final fit does not determine
/// ([`undetermined`]), then every one the model predicts held-out data as well without
/// (latest first, the step's test the other way round), then — while the model predicts
/// held-out data (blocks, forecasts: [`worse`]) worse than the model before the search,
/// refitted on the same noise — the latest stage; then, on the noise the final model's
/// residuals show, every stage that noise leaves undetermined. Returns the model that remains.
pub(super) fn keep_what_holds(
    current: Fitted,
    stages: &mut Vec<Stage>,
    initial_changes: &Changes,
    options: &SearchOptions,
    report: &mut SearchReport,
) -> Result<Fitted, IdentifyError> {
    let (current, changed) = withdraw_undetermined(current, stages, options, report)?;
    keep_what_earns_its_place(current, changed, stages, initial_changes, options, report)
}

/// Withdraws, latest first, every stage whose parameters `current`'s fit does not determine
/// (holding a shape it does not determine first, or replacing a shape pinned at the edge where
/// it is a simpler effect); returns the model that remains and whether it changed.
fn withdraw_undetermined(
    mut current: Fitted,
    stages: &mut Vec<Stage>,
    options: &SearchOptions,
    report: &mut SearchReport,
) -> Result<(Fitted, bool), IdentifyError> {
    let mut changed = false;
    let mut tried_holding: Vec<usize> = Vec::new();
    while let Some((k, verdict)) = stages.iter().enumerate().rev().find_map(|(k, s)| {
        undetermined(&current.study, &current.solution, &s.addition.params)
            .or_else(|| implausible_order(&current, &s.addition))
            .map(Verdict::Fails)
            .or_else(|| needless_amplitude(&current, &s.addition.params).map(Verdict::Lesser))
            .map(|w| (k, w))
    }) {
        // A refinement (a change along the stroke) within its interval of zero: the effect
        // without it is what the data show.
        let failure = match verdict {
            Verdict::Lesser(Lesser { old, simpler, why }) => {
                current = simplified(current, &mut stages[k], &old, simpler, &why, options)?;
                changed = true;
                continue;
            }
            Verdict::Fails(failure) => failure,
        };
        // A shape (τ, a pitch) the data do not determine, while the effect's size is: the
        // effect stays with its shape held where the fit left it — a stated assumption, not a
        // fitted number — if its amplitudes are then determined.
        // A shape pinned at an edge of its box found no optimum inside it (a stick-slip
        // "decaying" over a tenth of a micrometre is a step on single samples): not a shape
        // to hold.
        let pin = pinned(&current, &stages[k].addition.params);
        // Pinned at the edge where its family makes it a simpler effect (a lateral play taken
        // up over no travel), the fit found that effect: the stage holds it instead.
        if let Some(p) = &pin
            && let Some((old, simpler)) = simpler_form(&current, p)
        {
            current = simplified(current, &mut stages[k], &old, simpler, &p.why, options)?;
            changed = true;
            continue;
        }
        let failure = match (failure, pin) {
            (Failure::Shape(_), Some(pin)) => Failure::Other(pin.why),
            (f, _) => f,
        };
        if let Failure::Shape(_) = &failure
            && !tried_holding.contains(&k)
        {
            tried_holding.push(k);
            current = holding_shapes(current, &stages[k].addition, options)?;
            changed = true;
            continue;
        }
        let stage = stages.remove(k);
        tried_holding.retain(|&j| j != k);
        for j in &mut tried_holding {
            if *j > k {
                *j -= 1;
            }
        }
        report.withdrawn.push(withdrawn(&stage, failure.why()));
        current = without(current, &stage.addition, options)?;
        changed = true;
    }
    Ok((current, changed))
}

/// [`keep_what_holds`] after the stages are settled: what the final model keeps.
fn keep_what_earns_its_place(
    mut current: Fitted,
    mut changed: bool,
    stages: &mut Vec<Stage>,
    initial_changes: &Changes,
    options: &SearchOptions,
    report: &mut SearchReport,
) -> Result<Fitted, IdentifyError> {
    // Each effect must earn its place in the final model, not only at its step: one that a
    // later step made redundant (the same structure explained again), or that only predicts
    // better beside another, is withdrawn when the model without it predicts held-out data as
    // well (the step's own test, the other way round).
    if stages.len() >= 2 {
        let mut k = stages.len();
        while k > 0 {
            k -= 1;
            let reduced = refit_without(&current, &stages[k].addition, options)?;
            if let Err(why) = real_gain(&reduced.heldout, &current.heldout, options.gain_level) {
                let stage = stages.remove(k);
                report.withdrawn.push(withdrawn(
                    &stage,
                    format!("in the final model {why}: the others explain what it did"),
                ));
                current = reduced;
                changed = true;
                k = k.min(stages.len());
            }
        }
    }
    if !stages.is_empty() {
        let before = before_the_search(&current, initial_changes, options)?;
        while !stages.is_empty()
            && let Some(why) = worse(&current, &before)
        {
            let stage = stages.pop().expect("a stage to withdraw");
            report.withdrawn.push(withdrawn(&stage, why));
            current = without(current, &stage.addition, options)?;
            changed = true;
        }
        if stages.is_empty() {
            current = before;
        }
    }
    // The final model on the noise its own residuals show; an effect that noise leaves
    // undetermined (a withdrawal left structure that raises the noise) is withdrawn too, until
    // the noise and the stages agree.
    while changed {
        current = super::fitted::with_noise(current, options)?;
        (current, changed) = withdraw_undetermined(current, stages, options, report)?;
    }
    Ok(current)
}

fn withdrawn(stage: &Stage, why: String) -> Withdrawn {
    Withdrawn {
        candidate: stage.ranked.name(),
        effect: stage.ranked.candidate.class().to_string(),
        why,
    }
}

/// `current` with the shape parameters of `addition` held at their fitted values, refitted
/// on the same noise.
fn holding_shapes(
    current: Fitted,
    addition: &Addition,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let specs = param_specs(&current.study);
    let mut changes = current.study.changes().clone();
    for (i, spec) in specs.iter().enumerate() {
        if spec.bounds.is_some() && addition.params.contains(&current.study.param_id(i)) {
            changes.hold.push(current.study.param_id(i));
        }
    }
    let study = current.study.rebuild(changes)?;
    let x0 = carry_over(&current.study, &current.solution.x, &study);
    fit(study, Some(x0), options)
}

/// `current` without `addition`, refitted on the same noise.
fn without(
    current: Fitted,
    addition: &Addition,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    refit_without(&current, addition, options)
}

/// [`without`], `current` kept.
fn refit_without(
    current: &Fitted,
    addition: &Addition,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let study = current
        .study
        .rebuild(addition.removed_from(current.study.changes()))?;
    let x0 = carry_over(&current.study, &current.solution.x, &study);
    fit(study, Some(x0), options)
}

/// The model before the search (`initial_changes`) refitted on `current`'s noise, so that the
/// two predict held-out data on one metric.
fn before_the_search(
    current: &Fitted,
    initial_changes: &Changes,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let mut changes = initial_changes.clone();
    changes.noise = current.study.changes().noise.clone();
    let study = current.study.rebuild(changes)?;
    let x0 = carry_over(&current.study, &current.solution.x, &study);
    fit(study, Some(x0), options)
}

/// Why `after` predicts new data worse than `before`, if it does: the held-out blocks' mean
/// square larger, or the forecasts' by more than their tolerance ([`forecasts_worse`]).
///
/// The session's validation runs are not used: their readings carry their own noise, and on a
/// run of a few dozen samples the difference of two models' mean squares against them moves by
/// tens of per cent with the noise alone (a test that refused on it withdrew real effects in
/// 11 of 74 independent sessions).
fn worse(after: &Fitted, before: &Fitted) -> Option<String> {
    let (a, b) = (&after.heldout, &before.heldout);
    if a.mean_square > b.mean_square {
        return Some(format!(
            "the final model predicts held-out data worse than the fit before the search \
             (mean square {:.4} against {:.4}, RMS {:.3} against {:.3} µm)",
            a.mean_square, b.mean_square, a.rms_um, b.rms_um
        ));
    }
    forecasts_worse(b, a).map(|why| format!("with the final model {why} than before the search"))
}

/// Why the parameters `params` (one effect's or model change's) are not a determined, physical
/// effect of the fit `solution` of `study`, if they are not: a parameter the fit cannot
/// separate; a shape (τ, pitch, decay) whose 95 % interval is as wide as its value; an
/// amplitude beyond its plausible range or with an interval wider than it; or every amplitude
/// within its 95 % interval of zero (a joint model whose columns each are: nothing is shown).
pub(super) fn undetermined(
    study: &Study,
    solution: &Solution,
    params: &[ParamId],
) -> Option<Failure> {
    let specs = param_specs(study);
    let index = study.param_indices();
    let mut amplitudes = Vec::new();
    let held = &study.changes().hold;
    for id in params {
        let Some(&i) = index.get(id) else { continue };
        let info = study.param_info(i);
        let name = &info.name;
        let nuisance = study.effect_param(i).is_some_and(|p| p.nuisance);
        if nuisance || (specs[i].bounds.is_some() && held.contains(id)) {
            continue;
        }
        let show = |v: f64| format!("{:.4} {}", v * info.per_si, info.unit);
        let value = solution.x[i];
        let Some(sigma) = solution.sigma[i].filter(|_| solution.identified[i]) else {
            let why = format!("the final fit cannot separate {name} from the other parameters");
            return Some(if specs[i].bounds.is_some() {
                Failure::Shape(why)
            } else {
                Failure::Other(why)
            });
        };
        let u95 = K95 * sigma;
        if specs[i].bounds.is_some() {
            if u95 >= value.abs() {
                return Some(Failure::Shape(format!(
                    "the final fit does not determine {name} = {} ± {}",
                    show(value),
                    show(u95)
                )));
            }
            continue;
        }
        amplitudes.push(i);
        if let Some(range) = specs[i].scale {
            if value.abs() > range {
                return Some(Failure::Other(format!(
                    "the final fit puts {name} at {}, beyond its plausible range of ±{}",
                    show(value),
                    show(range)
                )));
            }
            if u95 > range {
                return Some(Failure::Other(format!(
                    "{name} = {} ± {} in the final fit: an interval wider than its plausible \
                     range of ±{}",
                    show(value),
                    show(u95),
                    show(range)
                )));
            }
        }
    }
    let (statistic, limit) = wald(solution, &amplitudes)?;
    (statistic <= limit).then(|| {
        Failure::Other(if amplitudes.len() == 1 {
            "its amplitude is within its 95 % interval of zero in the final fit".to_string()
        } else {
            format!(
                "its {} amplitudes together are within their 95 % region of zero in the final \
                 fit (Wald χ² {statistic:.1}, {limit:.1} needed)",
                amplitudes.len()
            )
        })
    })
}

/// Why a component given more orders (`addition`) is no curve a machine could have in
/// `current`'s fit, or no determined one, if it is not ([`curves`]).
fn implausible_order(current: &Fitted, addition: &Addition) -> Option<Failure> {
    let AddedChange::Model(m) = &addition.change else {
        return None;
    };
    if m.extra_order == 0 {
        return None;
    }
    let component = m.param.to_string();
    let curve = curves::component_curves(&current.study, &current.solution)
        .into_iter()
        .find(|c| c.component == component)?;
    if curve.implausible() {
        return Some(Failure::Other(format!(
            "in the final fit {}",
            curve.describe()
        )));
    }
    curve.undetermined().then(|| {
        Failure::Other(format!(
            "the final fit does not determine {}'s curve: ±{:.1} {} somewhere over its axis' \
             stroke, wider than its plausible range of ±{:.1} {}",
            curve.component,
            curve.widest_u95 * curve.per_si,
            curve.unit,
            curve.range * curve.per_si,
            curve.unit
        ))
    })
}

/// Why a shape (not a nuisance) among the parameters `params` is no shape of `current`'s
/// fit, if one is: its value at an edge of its box.
fn pinned(current: &Fitted, params: &[ParamId]) -> Option<Pinned> {
    let study = &current.study;
    let specs = param_specs(study);
    (0..study.layout().n_x()).find_map(|i| {
        let (lo, hi) = specs[i].bounds?;
        let p = study.effect_param(i)?;
        let info = study.param_info(i);
        if p.nuisance || !params.contains(&study.param_id(i)) {
            return None;
        }
        let value = current.solution.x[i];
        at_edge(value, (lo, hi)).then(|| Pinned {
            index: i,
            low: (value - lo).abs() <= (hi - value).abs(),
            why: format!(
                "the final fit pins {} at the edge of its range, {:.4} {}",
                info.name,
                value * info.per_si,
                info.unit
            ),
        })
    })
}

/// What [`withdraw_undetermined`] finds of a stage: a failure, or an amplitude to drop.
enum Verdict {
    Fails(Failure),
    Lesser(Lesser),
}

/// A stage's effect `old`, the simpler effect `simpler` it is without an amplitude the final
/// fit leaves within its interval of zero ([`mtcal_effects::Effect::without`]), and why.
struct Lesser {
    old: Arc<dyn Effect>,
    simpler: Arc<dyn Effect>,
    why: String,
}

/// The first amplitude among `params` whose effect is a simpler one without it and which the
/// final fit leaves within its 95 % interval of zero (or cannot separate): the effect is then
/// judged as a whole ([`undetermined`]: jointly determined), but this part of its claim is
/// not. `None` where the simpler effect's label is in the model already.
fn needless_amplitude(current: &Fitted, params: &[ParamId]) -> Option<Lesser> {
    let study = &current.study;
    let sol = &current.solution;
    (0..study.layout().n_x()).find_map(|i| {
        if !params.contains(&study.param_id(i)) {
            return None;
        }
        let (effect, param) = effect_and_param(study, i)?;
        let u95 = sol.sigma[i].filter(|_| sol.identified[i]).map(|s| K95 * s);
        let value = sol.x[i];
        if u95.is_some_and(|u| u < value.abs()) {
            return None;
        }
        let simpler = effect.without(param).filter(|e| !in_model(study, e))?;
        let info = study.param_info(i);
        let why = match u95 {
            Some(u) => format!(
                "the final fit puts {} at {:.4} ± {:.4} {}, within its interval of zero",
                info.name,
                value * info.per_si,
                u * info.per_si,
                info.unit
            ),
            None => format!(
                "the final fit cannot separate {} from the other parameters",
                info.name
            ),
        };
        Some(Lesser {
            old: Arc::clone(effect),
            simpler,
            why,
        })
    })
}

/// A shape parameter the final fit pins at an edge of its box ([`pinned`]).
struct Pinned {
    /// Its index in the fit's parameter vector.
    index: usize,
    /// At the lower edge (else the upper one).
    low: bool,
    why: String,
}

/// The pinned parameter's effect and the simpler one it becomes at that edge
/// ([`mtcal_effects::Effect::at_edge`]), unless one of its label is in the model already.
fn simpler_form(current: &Fitted, pin: &Pinned) -> Option<(Arc<dyn Effect>, Arc<dyn Effect>)> {
    let study = &current.study;
    let (effect, param) = effect_and_param(study, pin.index)?;
    let simpler = effect.at_edge(param, pin.low)?;
    (!in_model(study, &simpler)).then(|| (Arc::clone(effect), simpler))
}

/// The effect parameter `i` of `study` belongs to, and its index among the effect's own.
fn effect_and_param(study: &Study, i: usize) -> Option<(&Arc<dyn Effect>, usize)> {
    let effect = study.effect_of_param(i)?;
    let k = study
        .effects()
        .iter()
        .position(|e| Arc::ptr_eq(e, effect))?;
    Some((effect, i - study.layout().effect_range(k).start))
}

/// Whether an effect of `effect`'s label is in `study`'s model already.
fn in_model(study: &Study, effect: &Arc<dyn Effect>) -> bool {
    let label = &effect.info().label;
    study.effects().iter().any(|e| e.info().label == *label)
}

/// `current` with `stage`'s effect `old` replaced by `simpler` (its form at the edge where the
/// fit pinned it, `pinned` saying so) and refitted on the same noise; the stage holds the
/// simpler effect from now on and says why.
fn simplified(
    current: Fitted,
    stage: &mut Stage,
    old: &Arc<dyn Effect>,
    simpler: Arc<dyn Effect>,
    pinned: &str,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let mut changes = current.study.changes().clone();
    for e in &mut changes.effects {
        if Arc::ptr_eq(e, old) {
            *e = Arc::clone(&simpler);
        }
    }
    changes
        .hold
        .retain(|id| !stage.addition.params.contains(id));
    let study = current.study.rebuild(changes)?;
    let x0 = carry_over(&current.study, &current.solution.x, &study);
    let refitted = fit(study, Some(x0), options)?;
    let params = (0..refitted.study.layout().n_x())
        .filter(|&i| {
            refitted
                .study
                .effect_of_param(i)
                .is_some_and(|e| Arc::ptr_eq(e, &simpler))
        })
        .map(|i| refitted.study.param_id(i))
        .collect();
    stage.simplified = Some(format!(
        "added as {}: {}, where it is this simpler form",
        old.info().label,
        pinned.trim_start_matches("the ")
    ));
    stage.addition = Addition {
        change: AddedChange::Effect(Arc::clone(&simpler)),
        params,
    };
    stage.ranked.candidate = Candidate::Effect(simpler);
    Ok(refitted)
}

/// Why an effect is not a determined, physical effect of a fit.
pub(super) enum Failure {
    /// A shape parameter (τ, a pitch, a decay) the fit does not determine.
    Shape(String),
    /// Anything else: an amplitude not separable, implausible or not shown.
    Other(String),
}

impl Failure {
    fn why(self) -> String {
        match self {
            Failure::Shape(w) | Failure::Other(w) => w,
        }
    }
}

/// The Wald statistic of the parameters `idx` against zero, `xᵀC⁺x` in the fit's covariance
/// (the columns of a joint model are correlated: each may be within its interval of zero
/// while together they are far from it), and its 95 % limit (χ² with the covariance's rank as
/// degrees of freedom). `None` without parameters.
fn wald(solution: &Solution, idx: &[usize]) -> Option<(f64, f64)> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    if idx.is_empty() {
        return None;
    }
    let k = idx.len();
    let c = nalgebra::DMatrix::from_fn(k, k, |a, b| solution.cov(idx[a], idx[b]));
    let x = nalgebra::DVector::from_iterator(k, idx.iter().map(|&i| solution.x[i]));
    let svd = c.svd(true, true);
    let top = svd.singular_values.max();
    let rank = svd
        .singular_values
        .iter()
        .filter(|&&s| s > 1e-12 * top)
        .count();
    let pinv = svd.pseudo_inverse(1e-12 * top).ok()?;
    let statistic = (x.transpose() * pinv * &x)[(0, 0)];
    let limit = ChiSquared::new(rank.max(1) as f64).ok()?.inverse_cdf(0.95);
    Some((statistic, limit))
}
