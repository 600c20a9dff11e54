//! One fitted model of the search ([`Fitted`]: study, solution, report, held-out score) and the
//! helpers every phase fits with: [`fit`] (fit and cross-validate), [`with_noise`] (refit on the
//! noise the residuals show, step 0), [`carry_over`] and [`machine_values`]. Uses the
//! settings and the cross-validation (`heldout`); the step, the discoveries and the loop use it.

use super::heldout::heldout;
use super::settings::SearchOptions;
use crate::IdentifyError;
use crate::findings::Heldout;
use crate::ids::ParamId;
use crate::report::Identification;
use crate::study::Study;
use mtcal_solve::{Silent, Solution};
use std::collections::HashMap;
use std::sync::OnceLock;

/// One fitted model.
pub(super) struct Fitted {
    pub(super) study: Study,
    pub(super) solution: Solution,
    /// Its report, built when first asked for ([`Fitted::id`]): most fits of the search are
    /// judged and left, and a report's mismatch analysis costs as much as a refit.
    id: OnceLock<Identification>,
    pub(super) heldout: Heldout,
}

impl Fitted {
    pub(super) fn new(study: Study, solution: Solution, heldout: Heldout) -> Self {
        Self {
            study,
            solution,
            id: OnceLock::new(),
            heldout,
        }
    }

    /// The report of this fit.
    pub(super) fn id(&self) -> Result<&Identification, IdentifyError> {
        if let Some(id) = self.id.get() {
            return Ok(id);
        }
        let id = Identification::new(&self.study, &self.solution)?;
        Ok(self.id.get_or_init(|| id))
    }

    /// The report of this fit, and the fit's study and solution.
    pub(super) fn into_parts(
        self,
    ) -> Result<(Study, Solution, Identification, Heldout), IdentifyError> {
        let id = match self.id.into_inner() {
            Some(id) => id,
            None => Identification::new(&self.study, &self.solution)?,
        };
        Ok((self.study, self.solution, id, self.heldout))
    }
}

/// `fitted` on the noise its residuals show ([`crate::noise`]): every decision of the search is
/// a χ² statistic, on the noise the recordings really carry rather than the σ the manifest
/// states. Estimated again after every step: a large effect left out inflates the estimate
/// (a cycle of a few samples reads as noise), and once it is in the model the smaller ones
/// need the noise it leaves. Within a step every candidate is compared on one metric.
pub(super) fn with_noise(fitted: Fitted, options: &SearchOptions) -> Result<Fitted, IdentifyError> {
    match crate::noise::rebuilt_on_estimate(&fitted.study, &fitted.solution.x)? {
        None => Ok(fitted),
        Some(study) => fit(study, Some(fitted.solution.x), options),
    }
}

/// The search's fit of `study` from `x0`, `held` parameters kept: run to its optimum (the
/// search compares χ² to a fraction of a unit, so no fit stops where the χ² has merely
/// settled); a fit that reaches its iteration limit while it creeps along a direction the data
/// see only to second order (a rich model's near-null directions) goes on from there until its
/// χ² has settled, and counts as converged if it then does. Nothing is judged on a fit that
/// converges neither way.
pub(super) fn solve(
    study: &Study,
    x0: &[f64],
    options: &SearchOptions,
    held: &[usize],
) -> Result<Solution, IdentifyError> {
    let solution = crate::solve_holding(study, x0, &options.solver, &mut Silent, held)?;
    if solution.termination != mtcal_solve::Termination::MaxIterations {
        return Ok(solution);
    }
    let settling = mtcal_solve::Options {
        settle: true,
        ..options.solver.clone()
    };
    let settled = crate::solve_holding(study, &solution.x, &settling, &mut Silent, held)?;
    Ok(if settled.converged { settled } else { solution })
}

/// Fits `study` (from `x0` or its own start) and cross-validates it.
pub(super) fn fit(
    study: Study,
    x0: Option<Vec<f64>>,
    options: &SearchOptions,
) -> Result<Fitted, IdentifyError> {
    let x0 = x0.unwrap_or_else(|| study.initial_x());
    let solution = solve(&study, &x0, options, &[])?;
    let heldout = heldout(&study, &solution.x, options)?;
    Ok(Fitted::new(study, solution, heldout))
}

/// `x` of `from` mapped into `to`'s parameter vector by parameter ([`Study::param_id`]); new
/// parameters at their starting values.
pub(super) fn carry_over(from: &Study, x: &[f64], to: &Study) -> Vec<f64> {
    let known = from.param_indices();
    let start = to.initial_x();
    (0..to.layout().n_x())
        .map(|i| known.get(&to.param_id(i)).map_or(start[i], |&k| x[k]))
        .collect()
}

/// The machine parameters of a fit, by id, in reported units.
pub(super) fn machine_values(study: &Study, solution: &Solution) -> HashMap<ParamId, f64> {
    (0..study.layout().n_machine())
        .map(|i| {
            (
                study.param_id(i),
                solution.x[i] * study.param_info(i).per_si,
            )
        })
        .collect()
}
