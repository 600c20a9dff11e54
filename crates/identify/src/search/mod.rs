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
//!    is first scanned on a grid fine enough for every phase ([`Effect::shape_scan`]: the best
//!    of `K` independent pitches, the peaks of the score along the scan, owes the criterion
//!    `2 ln K` more — the largest of `K` chances), a joint
//!    model's prior width chosen by leaving each fitted run out (or each block of one
//!    recording), the rung whose neighbourhood predicts best ([`Effect::prior_ladder`]). A
//!    candidate passes if its refit is physics (no parameter driven beyond its plausible range,
//!    no new one whose interval is wider than it), the information criterion agrees
//!    (`Δχ²/max(1, χ²_red) > Δk·ln n`, a parameter under a prior counting for the share the data
//!    decide) **and** it predicts held-out data better: cross-validation ([`CrossValidation`]:
//!    contiguous time blocks of every fitted run by default, whole runs, or blocks of the whole
//!    timeline for a long recording — by default for one recording cut into runs, so that the
//!    files' boundaries decide nothing; `[identify] heldout`), its whitened mean square lower, the
//!    gain consistent over the folds (a one-sided Wilcoxon signed-rank test on the per-fold
//!    changes, [`SearchOptions::gain_level`]: a few nanometres gained on average and lost on
//!    some folds is the noise of the training folds, not physics), and the later part of the
//!    session forecast no worse (forecasting folds: the effects refitted on the first half,
//!    70 % and 85 % of the session predict the next stretch; a drift that does not extrapolate
//!    is not kept). The refit must have converged: a fit that creeps along a direction seen
//!    only to second order goes on until its χ² settles, and a fit that converges neither way
//!    decides nothing. The cross-validation is the Gauss–Newton refit of each fold from the
//!    full fit, from the session's rows evaluated once and each fold's QR factor ([`heldout`]). Of
//!    those that pass, the lowest BIC wins: scores at grid starting values cannot tell a drift
//!    in time from a lagged temperature that follows it, their refits can; and of two that fit
//!    alike the one with fewer parameters — unless another predicts the held-out data clearly
//!    better (a mean square 5 % lower, and lower fold by fold: `step::winner`), or, within
//!    [`LOOKALIKE_BIC`] of it (where the criterion's evidence is not strong), lower fold by
//!    fold, when the best predictor does (a reversal error fits a decaying spike as well as the
//!    spike, with the geometry's help, and predicts the blocks it did not see worse).
//!    A forecast (fit the earlier part, predict the later) refits the effects alone, and only
//!    those parameters the earlier part carries 2 % of the session's information on at least,
//!    of effects that have a course over the session at all (a drift, a lag of a temperature:
//!    `Effect::follows_the_session`); a bump, a backlash or a play is the same early and late
//!    and is judged by the blocked folds, as a change of the error model is.
//!    A candidate that mostly re-expresses an effect added before (half or more of a new
//!    amplitude explained by the earlier effects' parameters, the geometry profiled out: a
//!    linear tool-length drift beside the head's warm-up along Z) must predict clearly better
//!    (the 5 % above): a few per cent says the earlier law is not quite the truth's, not that a
//!    second effect is there. So must a candidate the fitted parameters absorb almost wholly
//!    (more than 99 % of its score, as the concealed ones): any shape the truth has and the
//!    model lacks lends such a column a per cent of held-out prediction (a set-up "settling"
//!    that is 99 % a location error, claimed in 10 of 60 sessions of one draw before).
//!    A refit is not physics if it drives a parameter beyond its plausible range or a
//!    component error's whole curve beyond what a guideway has (`curves`: 100 µm per metre of
//!    stroke, 500 µrad), coefficients each in range but traded off against each other.
//!    A `reversal` or `lateral-play` fits the axis' side of its play before its first motion in
//!    each run it moves in (the approach is not in the file: the previous run's side is only a
//!    guess), as nuisance shapes in ±1 that the held-out
//!    folds keep at the full fit's values and that no discovery reports as a number.
//! 3. **Look-alikes.** Others that passed within [`LOOKALIKE_BIC`] of the winner, and that are
//!    no longer significant once it is in the model (they explained the same thing), are its
//!    look-alikes: the discovery names them and the measurement that would tell them apart,
//!    and claims neither as the answer (machine drift or set-up drift, a drift in time or a
//!    temperature that follows it).
//! 4. **Repeat** with the accepted effect in the model, until no candidate is significant or
//!    none that is passes.
//! 5. **Keep what holds** (`keep`). Each step was judged on the model of its moment; in the
//!    final fit every added effect must still be determined and physical — each parameter
//!    separable, inside its plausible range with an interval narrower than it (a component
//!    given more orders: its whole curve plausible), its amplitudes
//!    together outside their 95 % region of zero (a Wald test: a joint model's columns are
//!    correlated) — and the final model must predict held-out data (blocks and forecasts) no
//!    worse than the fit before the search. A shape (τ, a pitch) the data do not determine is
//!    held where the fit left it and said to be; one pinned at the edge of its box where its
//!    family makes the effect a simpler one (`Effect::at_edge`: a lateral play taken up over
//!    no travel is the plain play) is replaced by that effect, and the discovery says so; so
//!    is one whose refinement the final fit leaves within its interval of zero
//!    (`Effect::without`: a backlash whose change along the stroke is not shown is the plain
//!    backlash);
//!    anything else that fails is withdrawn, the latest first, and reported as withdrawn,
//!    never as a discovery.
//!
//! Nothing is searched on a fit that did not converge: the report says so and what to do.
//!
//! # What it reports
//! Each accepted step is a [`Discovery`] (FORMATS.md `discoveries`): the effect, its
//! parameters with 95 % intervals from the final fit, the fit and held-out RMS before and
//! after, the share of the excess χ² it explains, the machine parameters it had biased (before
//! and after), where the residuals showed it, its look-alikes, and a sentence. Candidates the
//! data cannot tell from the fitted parameters (almost wholly absorbed) are listed as
//! [`Concealed`], with the parameters they hide behind and the measurement that would separate
//! them. Structure the final model leaves unexplained is reported as [`Remains`] — where (run,
//! channel, along which variable), its shape in words (a change in time, a local shape along an
//! axis, periodic, flipping with a direction) and the candidates that came closest with why
//! each was not kept — instead of stacking candidates onto it.
//!
//! # Columns of a candidate
//! Effects give their columns through [`mtcal_effects::PreparedEffects`] (axis perturbations
//! through the machine's axis Jacobian, set-up parameters through the instrument's nuisance
//! derivatives, readings directly); model changes through the projected Jacobian of the
//! machine model with the candidate parameters added (held-out parameters are zero at the
//! solution, so the pose is the fit's).
//!
//! # Where each phase lives
//! Each module uses only those listed above it; this one composes them.
//! - `settings`: [`SearchOptions`], [`CrossValidation`], [`LOOKALIKE_BIC`], the session's
//!   `[identify]` keys applied to them.
//! - `heldout`: the cross-validation ([`heldout`]) and a joint model's prior width.
//! - `curves`: a component error's curve over its stroke and its plausible range.
//! - `fitted`: one fitted model and the fit helpers (noise re-estimate, BIC, carry-over).
//! - `rank`: step 1, the candidates and their score tests ([`candidates`], [`rank`], [`Ranked`]).
//! - `step`: steps 2 and 3, a candidate refitted and judged, the accepted step and its
//!   look-alikes.
//! - `keep`: step 5, what the final model keeps.
//! - `discovery`: the accepted steps as [`Discovery`]s, the [`Concealed`] candidates, the search
//!   in words.
//! - here: [`search`], the loop that drives them, and its [`SearchResult`].
//!
//! [`Effect::shape_scan`]: mtcal_effects::Effect::shape_scan
//! [`Effect::prior_ladder`]: mtcal_effects::Effect::prior_ladder
//! [`heldout`]: fn@heldout
//! [`rank`]: fn@rank

mod curves;
mod discovery;
mod fitted;
mod heldout;
mod keep;
mod rank;
mod settings;
mod step;

pub use crate::findings::{
    Concealed, Correction, Discovery, DiscoveryParameter, Heldout, LookAlike, Remains,
    SearchFindings, SearchReport, SearchStop, Trial, Withdrawn,
};
pub use discovery::separating_measurement;
pub use heldout::heldout;
pub use rank::{Ranked, candidates, rank};
pub use settings::{CrossValidation, LOOKALIKE_BIC, SearchOptions};

use crate::IdentifyError;
use crate::report::Identification;
use crate::study::Study;
use discovery::{concealed, discovery, remains, telling_apart};
use fitted::{Fitted, fit, machine_values, with_noise};
use keep::keep_what_holds;
use mtcal_solve::Solution;
use rank::rank_with;
use settings::with_session_options;
use step::{Refitted, Stage, choose_tries, same_explanation, try_all};

/// What [`search`] returns: the final study (the session with the discoveries added), its
/// fit and report, and what the search found.
#[derive(Debug)]
pub struct SearchResult {
    pub study: Study,
    pub solution: Solution,
    pub identification: Identification,
    pub findings: SearchFindings,
    /// The fit before the search added anything.
    pub initial: Identification,
    /// Its solution, and the changes of its study (`study.rebuild(initial_changes)` gives it
    /// back: the parameter vector `initial_solution` belongs to).
    pub initial_solution: Solution,
    pub initial_changes: crate::study::Changes,
}

// ---------------------------------------------------------------------------------------------
// The loop

/// Runs the physics search on `study` (see the module documentation).
pub fn search(study: Study, options: &SearchOptions) -> Result<SearchResult, IdentifyError> {
    let options = &with_session_options(&study, options)?;
    let mut current = with_noise(fit(study, None, options)?, options)?;
    let initial = current.id()?.clone();
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
        withdrawn: Vec::new(),
        remains: Vec::new(),
    };
    if !current.solution.converged {
        // Every decision below compares χ² at optima: on a last iterate a candidate would
        // "explain" what the iteration had still to do.
        report.stopped = SearchStop::BaseNotConverged;
        let (study, solution, identification, _) = current.into_parts()?;
        return Ok(SearchResult {
            study,
            solution,
            identification,
            findings: SearchFindings {
                discoveries: Vec::new(),
                report,
            },
            initial,
            initial_solution,
            initial_changes,
        });
    }
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
        for (r, trial, fitted) in try_all(&current, tries, options)? {
            if let Some(f) = fitted {
                passed.push((trials.len(), r, f));
            }
            trials.push(trial);
        }
        // Among those that pass, the information criterion decides: the better fit unless it
        // pays for it with parameters (stick-slip with an endless decay is a reversal error
        // with one parameter more). Those within a whisker of it are its look-alikes.
        let scale = current.solution.chi2_reduced.max(1.0);
        let winner = step::winner(passed.iter().map(|p| &p.2), scale);
        let mut lookalikes = Vec::new();
        if let Some(w) = winner {
            let (wk, wr, wf) = &passed[w];
            let best = wf.criterion();
            for (k, r, f) in &passed {
                if k == wk {
                    continue;
                }
                let delta = (f.criterion() - best) / scale;
                let t = &mut trials[*k];
                t.accepted = false;
                // One the winner predicts clearly better than is told apart by these data.
                if delta < LOOKALIKE_BIC
                    && !same_explanation(&r.candidate, &wr.candidate)
                    && !step::clearly_better(&wf.heldout, &f.heldout)
                {
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
                    t.why = format!(
                        "passed, but another candidate predicts better (information criterion \
                         {delta:+.1}); {}",
                        t.why
                    );
                }
            }
        }
        report.steps.push(trials);
        let accepted = match winner {
            Some(w) => {
                let (_, r, f) = passed.swap_remove(w);
                Some((
                    r,
                    f.addition,
                    f.widens,
                    Fitted::new(f.study, f.solution, f.heldout),
                ))
            }
            None => None,
        };
        let Some((ranked_ok, addition, widens, fitted)) = accepted else {
            report.stopped = SearchStop::NoneImproved;
            last_ranking = Some(ranked);
            break;
        };
        if let Some(old) = widens {
            // A bank in the model at a wider prior: its stage holds the wider one.
            for stage in &mut stages {
                if let step::AddedChange::Effect(e) = &stage.addition.change
                    && std::sync::Arc::ptr_eq(e, &old)
                {
                    stage.addition.change = addition.change.clone();
                }
            }
            current = with_noise(fitted, options)?;
            continue;
        }
        let before_params = machine_values(&current.study, &current.solution);
        // Of the state after the step, its fit and validation are reported.
        let after_id = Identification::without_mismatch(&fitted.study, &fitted.solution)?;
        let (_, before_solution, before_id, before_heldout) = current.into_parts()?;
        stages.push(Stage {
            lookalikes,
            dropped: Vec::new(),
            ranked: ranked_ok,
            before_id,
            before_solution,
            before_heldout,
            before_params,
            after_heldout: fitted.heldout.clone(),
            after_id,
            after_solution: fitted.solution.clone(),
            addition,
            simplified: None,
        });
        current = with_noise(fitted, options)?;
    }
    let before_settling = stages.len();
    current = keep_what_holds(current, &mut stages, &initial_changes, options, &mut report)?;
    if stages.len() < before_settling {
        // The model changed after the last ranking: rank again.
        last_ranking = None;
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
    step::restore_lookalikes(&mut stages);
    report.concealed = concealed(&last_ranking);
    report.ranking = last_ranking.iter().take(5).map(Ranked::describe).collect();
    report.remains = remains(current.id()?, &last_ranking, &report.steps);
    let discoveries = stages.iter().map(|s| discovery(s, &current)).collect();
    let (study, solution, identification, _) = current.into_parts()?;
    Ok(SearchResult {
        study,
        solution,
        identification,
        findings: SearchFindings {
            discoveries,
            report,
        },
        initial,
        initial_solution,
        initial_changes,
    })
}

/// The physics search as an outcome holds it beside the final fit
/// ([`crate::pipeline::Outcome`]).
#[derive(Debug)]
pub struct Searched {
    /// The report of the fit before the search added anything.
    pub before: Identification,
    /// That fit's parameter vector (SI; of the session as loaded, [`Study::as_loaded`]).
    pub before_x: Vec<f64>,
    pub findings: SearchFindings,
}

impl SearchResult {
    /// The reports before and after the search with what `base` says (each with its own
    /// study's parameter vector, [`Identification::with_base`]).
    pub fn with_base(self, base: &crate::base::BaseModel) -> Result<Self, IdentifyError> {
        let initial_study = self.study.rebuild(self.initial_changes.clone())?;
        Ok(Self {
            initial: self
                .initial
                .with_base(base, &initial_study, &self.initial_solution),
            identification: self
                .identification
                .with_base(base, &self.study, &self.solution),
            ..self
        })
    }
}
