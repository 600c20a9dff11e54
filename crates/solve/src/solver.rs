//! The Levenberg–Marquardt / Gauss–Newton iteration and the assembly of the [`Solution`].

use crate::accumulate::{Accumulator, Fault, NONE};
use crate::analysis::{Analysis, predicted};
use crate::bounds::bounded_step;
use crate::eval::{Failure, GradientAt, Layout, Lin, Prior, evaluate, evaluate_gradient};
use crate::{
    Linearization, Observer, Options, ParamSpec, Problem, Silent, Solution, SolveError,
    Termination, describe_null_space,
};

/// A step is accepted when the cost drops by at least this share of the predicted drop.
const ACCEPT: f64 = 1e-4;
/// A parameter that moves by less than this fraction of its plausible range along a null
/// direction, while the direction's main members move over theirs, is not counted as part of
/// it (`without_negligible_members`).
const NEGLIGIBLE_MEMBER: f64 = 1e-5;
/// ... or by less than this fraction of its own standard uncertainty while the others roam
/// over their whole plausible ranges,
const NEGLIGIBLE_SHARE_OF_SIGMA: f64 = 0.1;
/// ... provided it is a trace of the direction: it moves by less than this fraction of its
/// plausible range relative to the largest such fraction (a main member is never dropped),
const TRACE_MEMBER: f64 = 1e-3;
/// ... and the data determine it: its σ is below this fraction of its plausible range (a
/// parameter the pseudo-inverse gives a σ as wide as its range is not determined by anything).
const DETERMINED_SIGMA: f64 = 0.05;
/// When the cost drop matches the prediction this well (`|ρ − 1|` below it), the linear model is
/// as good as exact and the next step is undamped (Gauss–Newton): linear problems converge in two
/// steps and nonlinear ones quadratically near the solution.
const EXACT_MODEL: f64 = 1e-3;
/// A Gauss–Newton step shorter than this in the metric of the data (`‖R·dx‖`: standard
/// deviations of the estimate along the step), right after a step whose cost change the linear
/// model predicted to within [`EXACT_MODEL`], is taken without evaluating the problem again:
/// there the model error is far below the step itself (the next step would be of the order of
/// its square), so one more pass over millions of samples would only confirm it.
const FINAL_STEP: f64 = 1e-3;
/// When a trial point is checked with a gradient-only pass (no new factor, see [`solve`]), the
/// factor of the previous point may stand in for the new one only if the squared norms of the
/// probe directions changed by less than this: covariances and intervals then differ from those
/// of a fresh factor by less than about half of it (relative).
const METRIC_CHANGE: f64 = 1e-3;
/// A chord step ends the iteration without another pass when it is shorter than this
/// (standard deviations of the estimate), or when the error it leaves is expected to be below
/// it. The chord iteration contracts the error by about the relative change `δ` of the metric
/// per step (simplified Newton; the stopping rule of Hairer & Wanner for its iterations): a
/// step of length `L` (`‖R·dx‖`) leaves about `δ/(1 − δ)·L`. `δ` is the largest change the
/// probes measured, taken [`CHORD_SAFETY`] times over because the probes sample only some
/// directions. Since the chord method runs only while `δ ≤` [`METRIC_CHANGE`], steps up to
/// about 1 σ always end it. Where the residuals scatter less than the stated noise (simulated
/// noise-free data) σ is scaled down with them, so such fits still end at rounding level.
const CHORD_FINAL_STEP: f64 = 1e-2;
/// Margin on the measured metric change in the error estimate of a final chord step.
const CHORD_SAFETY: f64 = 10.0;
/// Chord steps (gradient-only passes after an accepted trial point) before a new factor is
/// computed instead.
const MAX_CHORD_STEPS: usize = 4;
/// Probe directions besides the step itself: the least determined singular directions and
/// pseudo-random ones (plus one per null-space direction).
const WEAK_PROBES: usize = 3;
const RANDOM_PROBES: usize = 2;
/// Damping after a rejected undamped step, relative to σ_max².
const LAMBDA_START: f64 = 1e-4;
/// Consecutive rejected steps before giving up.
const MAX_REJECTIONS: usize = 40;
/// When a trial step is rejected and the Gauss–Newton step promises less than this fraction of
/// the cost, the promise is below the rounding error of the cost itself (a sum of many
/// squares): no trial point could show a real decrease, so the iteration has converged. Without
/// this a noisy problem at its optimum rejected step after step until `MAX_REJECTIONS` and
/// reported `NoProgress`.
const ROUNDING: f64 = 1e-11;
/// Accepted steps that lower the cost by less than this share of it, in a row, end the
/// iteration as converged: the cost has settled to nine digits while a direction the data barely
/// see (a set-up parameter observed only to second order) keeps promising a linear-model drop
/// it never delivers. Without this a fit creeps along such a valley until `max_iterations`.
const STALL: f64 = 1e-9;
/// Accepted steps that lower the cost (half a χ²) by less than this, in a row, on residuals of
/// the size of their noise (χ²/dof of 0.5 or more, so that a unit of χ² is a unit of
/// evidence), end the iteration as [`Termination::Settled`]: the fit has settled to statistical
/// precision while it still creeps along a direction the data see only to second order, which
/// promises a drop of a few units of χ² that a linear model never delivers. The
/// eleven-error model on R-test + ball-bar sessions of the independent simulator (set-ups
/// re-mounted 20 µm off, AR(1) noise) crept like that in 7 of 16 sessions, for 557 to more
/// than 4,000 iterations; settled instead after at most 6, its reported parameters were
/// within 0.33 σ of where up to 4,000 iterations took them (0.21 σ or less in 6 of the 7).
const SETTLED_DROP: f64 = 1e-2;
/// A rejected trial whose Gauss–Newton step is shorter than this in the metric of the data
/// (`‖R·dx‖`: a millionth of the estimate's standard deviation along it) ends the iteration as
/// converged. On data the model fits exactly (all-zero readings of a perfect machine) the cost
/// sits at its own rounding level, where the step promises about the whole cost and no trial
/// point can show it; without this such a fit rejected step after step until `NoProgress`.
const NEGLIGIBLE_STEP: f64 = 1e-6;
/// A rejected trial whose Gauss–Newton step is shorter than [`FINAL_STEP`] (a thousandth of the
/// estimate's standard deviation) and promises less than this share of the cost also ends the
/// iteration as converged. The residuals of metre-sized poses carry rounding of ~1e-10 of a
/// whitened unit each, so a cost of thousands of squares is known to ~1e-8: a promise below
/// that (here 1e-11 relative, on a full ISO model with priors) can never be verified, and
/// damping only shrinks it further until `NoProgress`, although the point is the optimum to
/// a thousandth of σ.
const UNVERIFIABLE: f64 = 1e-9;
const STALLED_STEPS: usize = 3;

/// Validated parameters.
struct Setup {
    n_params: usize,
    x0: Vec<f64>,
    free: Vec<usize>,
    priors: Vec<Prior>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    has_bounds: bool,
    names: Vec<String>,
    threads: usize,
    /// Per parameter, the least column scale (`1/scale`; 0 without a scale).
    floor: Vec<f64>,
}

impl Setup {
    fn new<P: Problem>(
        problem: &P,
        params: &[ParamSpec],
        threads: usize,
    ) -> Result<Self, SolveError> {
        let n_params = problem.n_params();
        if params.len() != n_params {
            return Err(SolveError::ParamCount {
                expected: n_params,
                got: params.len(),
            });
        }
        if n_params == 0 {
            return Err(SolveError::Empty("it has no parameters".into()));
        }
        let invalid = |index: usize, reason: String| SolveError::InvalidParam {
            index,
            name: params[index].name.clone(),
            reason,
        };
        let mut x0 = Vec::with_capacity(n_params);
        let (mut lo, mut hi) = (
            vec![f64::NEG_INFINITY; n_params],
            vec![f64::INFINITY; n_params],
        );
        let mut priors = Vec::new();
        for (i, p) in params.iter().enumerate() {
            if !p.initial.is_finite() {
                return Err(invalid(
                    i,
                    format!("the initial value {} is not finite", p.initial),
                ));
            }
            if let Some((a, b)) = p.bounds {
                if a.is_nan() || b.is_nan() || a > b {
                    return Err(invalid(
                        i,
                        format!("the bounds ({a}, {b}) are not an interval"),
                    ));
                }
                (lo[i], hi[i]) = (a, b);
            }
            if let Some((mean, sigma)) = p.prior {
                if !(mean.is_finite() && sigma > 0.0 && sigma.is_finite()) {
                    return Err(invalid(
                        i,
                        format!(
                            "the prior ({mean}, {sigma}) needs a finite mean and a positive finite sigma"
                        ),
                    ));
                }
                if !p.fixed {
                    priors.push(Prior {
                        param: i,
                        mean,
                        sigma,
                    });
                }
            }
            // A fixed parameter stays where it is, bounds or not.
            x0.push(if p.fixed {
                p.initial
            } else {
                p.initial.clamp(lo[i], hi[i])
            });
        }
        let free: Vec<usize> = (0..n_params).filter(|&i| !params[i].fixed).collect();
        if free.is_empty() {
            return Err(SolveError::AllFixed { n: n_params });
        }
        if problem.n_blocks() == 0 && priors.is_empty() {
            return Err(SolveError::Empty("it has no blocks and no priors".into()));
        }
        let has_bounds = free.iter().any(|&i| lo[i].is_finite() || hi[i].is_finite());
        let threads = if threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            threads
        };
        // Ordering hint: grouped (block-local) parameters first, shared ones last.
        let mut free = free;
        free.sort_by_key(|&i| params[i].group.is_none());
        Ok(Self {
            n_params,
            x0,
            free,
            priors,
            lo,
            hi,
            has_bounds,
            names: params.iter().map(|p| p.name.clone()).collect(),
            threads,
            floor: params
                .iter()
                .map(|p| {
                    p.scale
                        .filter(|s| *s > 0.0 && s.is_finite())
                        .map_or(0.0, |s| 1.0 / s)
                })
                .collect(),
        })
    }

    fn error(&self, failure: Failure) -> SolveError {
        match failure {
            Failure::Eval { block, source } => SolveError::Eval {
                block,
                cause: source,
            },
            Failure::Overflow => SolveError::Numerical(
                "the sum of squared residuals overflows (residuals near 1e154 or larger)".into(),
            ),
            Failure::Fault(Fault::NonFiniteResidual { block, row, value }) => {
                SolveError::NonFiniteResidual { block, row, value }
            }
            Failure::Fault(Fault::NonFiniteJacobian {
                block,
                row,
                param,
                value,
            }) => SolveError::NonFiniteJacobian {
                block,
                row,
                param,
                name: self.names[param].clone(),
                value,
            },
            Failure::Fault(Fault::Columns { block, reason }) => {
                SolveError::InvalidColumns { block, reason }
            }
            Failure::Fault(Fault::Row { block, row, reason }) => {
                SolveError::InvalidRow { block, row, reason }
            }
        }
    }
}

/// Evaluation state shared by the iterations.
struct Evaluator<'a, P: Problem> {
    problem: &'a P,
    setup: &'a Setup,
    layout: Layout,
    pool: Vec<Accumulator>,
    gradient_pool: Vec<Accumulator>,
    evaluations: usize,
    factorizations: usize,
}

impl<P: Problem> Evaluator<'_, P> {
    fn eval(&mut self, x: &[f64], observer: &mut dyn Observer) -> Result<Lin, Failure> {
        self.evaluations += 1;
        self.factorizations += 1;
        let lin = evaluate(
            self.problem,
            x,
            &self.layout,
            &self.setup.priors,
            &mut self.pool,
            self.setup.threads,
            observer,
        )?;
        if !lin.cost.is_finite() {
            return Err(Failure::Overflow);
        }
        Ok(lin)
    }

    /// The gradient and the probes' squared norms at `x`, without a factor, in the column
    /// order `order` (that of the factor they are used with, which need not be the current
    /// layout's: the first evaluation reorders it).
    fn eval_gradient(
        &mut self,
        x: &[f64],
        order: &[usize],
        probes: &[f64],
        n_cross: usize,
        observer: &mut dyn Observer,
    ) -> Result<GradientAt, Failure> {
        self.evaluations += 1;
        let layout = Layout::new(self.setup.n_params, order.to_vec());
        let at = evaluate_gradient(
            self.problem,
            x,
            &layout,
            &self.setup.priors,
            probes,
            n_cross,
            &mut self.gradient_pool,
            self.setup.threads,
            observer,
        )?;
        if !at.cost.is_finite() {
            return Err(Failure::Overflow);
        }
        Ok(at)
    }

    /// Columns used by few blocks first, shared ones last: no fill-in in the streaming QR.
    fn reorder(&mut self, usage: &[u32]) {
        let mut order = self.layout.order.clone();
        order.sort_by_key(|&p| usage[p]);
        if order != self.layout.order {
            self.layout = Layout::new(self.setup.n_params, order);
        }
    }
}

/// Solves the weighted nonlinear least-squares problem and analyses what it identifies.
pub fn solve<P: Problem>(
    problem: &P,
    params: &[ParamSpec],
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<Solution, SolveError> {
    let setup = Setup::new(problem, params, options.threads)?;
    let mut ev = Evaluator {
        problem,
        setup: &setup,
        layout: Layout::new(setup.n_params, setup.free.clone()),
        pool: Vec::new(),
        gradient_pool: Vec::new(),
        evaluations: 0,
        factorizations: 0,
    };
    let mut x = setup.x0.clone();
    let mut lin = ev.eval(&x, observer).map_err(|f| setup.error(f))?;
    if lin.n_rows == 0 && setup.priors.is_empty() {
        return Err(SolveError::Empty(
            "its blocks produced no rows and there are no priors".into(),
        ));
    }
    ev.reorder(&lin.usage);
    let mut an = Analysis::new(&lin, options.rank_tolerance, &setup.floor)?;
    // The first step is undamped: most identification problems are nearly linear, and a
    // Gauss–Newton step that fails costs no more than a damped one that falls short.
    let mut lambda = 0.0;
    let mut nu = 2.0;
    // The damping to return to when an undamped step fails.
    let mut lambda_resume = LAMBDA_START * an.s2max();
    let mut iterations = 0;
    let mut model_exact = false;
    // Whether the next undamped trial point is checked by a gradient-only pass first (see the
    // module doc): at the start, and after steps the linear model predicted well.
    let mut chord_failed = false;
    // A rank-deficient start may be a degenerate point (all errors zero is often one): the
    // null-space check of the first trial point then sees a direction become identified and
    // hands over to a new factor.
    let mut last_rank = an.rank;
    let mut chord = options.lm && options.chord;
    let mut stalled = 0;
    let mut settled = 0;
    observer.iteration(0, lin.cost, lambda);
    let termination = 'outer: loop {
        let gn = step(&an, &lin, &x, &setup, 0.0)?;
        let (gn_pred, gn_change) = predicted(&lin, &gn);
        let x_col: Vec<f64> = lin.order.iter().map(|&p| x[p]).collect();
        let rnorm = (2.0 * lin.cost).sqrt();
        if an.scaled_norm(&gn) <= options.tolerance * an.scaled_norm(&x_col)
            || gn_change <= options.tolerance * rnorm.max(1.0)
        {
            break Termination::Converged;
        }
        // A step the cost cannot verify (its promised drop is below the rounding of the cost)
        // is as good as exact: take it without another pass.
        if (model_exact && gn_change <= FINAL_STEP) || gn_pred <= ROUNDING * lin.cost {
            for (&p, d) in lin.order.iter().zip(&gn) {
                x[p] = (x[p] + d).clamp(setup.lo[p], setup.hi[p]);
            }
            lin.cost = (lin.cost - gn_pred).max(0.0);
            iterations += 1;
            observer.iteration(iterations, lin.cost, 0.0);
            break Termination::Converged;
        }
        if iterations >= options.max_iterations {
            break Termination::MaxIterations;
        }
        let mut t = 1.0;
        let mut rejections = 0;
        loop {
            let dx = if options.lm {
                step(&an, &lin, &x, &setup, lambda)?
            } else {
                gn.iter().map(|v| v * t).collect()
            };
            let (pred, _) = predicted(&lin, &dx);
            let mut x_new = x.clone();
            for (&p, d) in lin.order.iter().zip(&dx) {
                x_new[p] = (x[p] + d).clamp(setup.lo[p], setup.hi[p]);
            }
            // A trial checked by a gradient-only pass that passes is accepted with a fresh factor
            // (`None` from the check: evaluate fully).
            let checked = if chord && lambda == 0.0 && pred > 0.0 {
                match chord_check(
                    &mut ev,
                    &an,
                    &lin,
                    &x_new,
                    &dx,
                    pred,
                    options.rank_tolerance,
                    observer,
                )
                .map_err(|f| setup.error(f))?
                {
                    Chord::Converged { x: x_end, cost } => {
                        x = x_end;
                        lin.cost = cost;
                        iterations += 2;
                        observer.iteration(iterations, lin.cost, 0.0);
                        break 'outer Termination::Converged;
                    }
                    Chord::Rejected => Some(None),
                    Chord::Refactor {
                        x: reached,
                        rho,
                        rank_gained,
                    } => {
                        // The chord method did not finish here. Unless a direction unidentified
                        // at the old point became identified (a degenerate start), the Jacobian
                        // changes too much along the path for it to pay later either.
                        chord_failed |= !rank_gained;
                        x_new = reached;
                        Some(Some(rho))
                    }
                }
            } else {
                None
            };
            let rho = match checked {
                Some(None) => None,
                _ if pred <= 0.0 => None,
                _ => match ev.eval(&x_new, observer) {
                    Ok(new) => {
                        let rho = checked.flatten().unwrap_or((lin.cost - new.cost) / pred);
                        if rho > ACCEPT {
                            let drop = lin.cost - new.cost;
                            stalled = if drop < STALL * lin.cost {
                                stalled + 1
                            } else {
                                0
                            };
                            settled = if drop < settle_floor(&lin) {
                                settled + 1
                            } else {
                                0
                            };
                            x = x_new;
                            lin = new;
                            Some(rho)
                        } else {
                            None
                        }
                    }
                    Err(f) if f.is_numerical() => None,
                    Err(f) => return Err(setup.error(f)),
                },
            };
            if let Some(rho) = rho {
                // Nielsen's update: shrink λ by up to 3 after good steps, keep it after poor ones.
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                model_exact = exact(rho, pred, lin.cost);
                chord = model_exact && !chord_failed && options.lm && options.chord;
                if model_exact && lambda > 0.0 {
                    lambda_resume = lambda;
                    lambda = 0.0;
                }
                nu = 2.0;
                break;
            }
            rejections += 1;
            if gn_pred <= ROUNDING * lin.cost
                || gn_change <= NEGLIGIBLE_STEP
                || (gn_change <= FINAL_STEP && gn_pred <= UNVERIFIABLE * lin.cost)
            {
                // The cost cannot show the decrease the step promises: at the optimum.
                break 'outer Termination::Converged;
            }
            if rejections > MAX_REJECTIONS {
                break 'outer Termination::NoProgress;
            }
            if options.lm {
                lambda = if lambda == 0.0 {
                    lambda_resume
                } else {
                    lambda * nu
                };
                nu *= 2.0;
            } else {
                t *= 0.5;
            }
        }
        iterations += 1;
        observer.iteration(iterations, lin.cost, lambda);
        an = Analysis::new(&lin, options.rank_tolerance, &setup.floor)?;
        if stalled >= STALLED_STEPS {
            break Termination::Converged;
        }
        if options.settle && settled >= STALLED_STEPS {
            break Termination::Settled;
        }
        chord &= an.rank >= last_rank;
        last_rank = an.rank;
    };
    Ok(assemble(
        &setup,
        x,
        &lin,
        &an,
        iterations,
        (ev.evaluations, ev.factorizations),
        termination,
    ))
}

/// Whether a step whose cost drop was `rho` times the predicted `pred` confirms the linear
/// model: to within [`EXACT_MODEL`] of the prediction, or of the rounding of the cost itself
/// (tiny steps of a large sum of squares cannot do better).
fn exact(rho: f64, pred: f64, cost: f64) -> bool {
    (rho - 1.0).abs() * pred <= EXACT_MODEL * pred + ROUNDING * cost
}

/// What gradient-only passes from a trial point found.
enum Chord {
    /// The trial point is acceptable and the Gauss–Newton steps from it, computed with the old
    /// factor, converged while the metric did not change: the solution.
    Converged { x: Vec<f64>, cost: f64 },
    /// The cost did not drop enough.
    Rejected,
    /// Acceptable (`rho`: actual over predicted drop of the trial step), but the point `x` it
    /// reached (the trial point or a later chord step) needs its own factor; `rank_gained`: only
    /// because a direction the old factor left unidentified is identified there.
    Refactor {
        x: Vec<f64>,
        rho: f64,
        rank_gained: bool,
    },
}

/// Checks the trial point `x + dx` with a gradient-only pass: its cost decides acceptance as a
/// full evaluation would. The probes (see [`Analysis::probes`]) check that the metric did not
/// change, and [`Analysis::null_space_kept`] that no unidentified direction became identified.
/// When the linear model was exact there and the probes show the metric of the data unchanged,
/// the chord method continues: Gauss–Newton steps with the factor of `x` and the gradient of the
/// new point, each checked by another gradient-only pass, until one is expected to leave an
/// error below [`CHORD_FINAL_STEP`]; the point it reaches is the solution and the factor of `x`
/// serves for its covariance. A gradient-only pass skips the `O(n²)` fold per row, the larger part of a full
/// pass. Non-numerical failures are returned; numerical ones reject (or end the chord steps).
// The iteration's state at the trial point, passed as it is at the call site.
#[allow(clippy::too_many_arguments)]
fn chord_check<P: Problem>(
    ev: &mut Evaluator<'_, P>,
    an: &Analysis,
    lin: &Lin,
    x_new: &[f64],
    dx: &[f64],
    pred: f64,
    rank_tolerance: f64,
    observer: &mut dyn Observer,
) -> Result<Chord, Failure> {
    let (lo, hi) = (&ev.setup.lo, &ev.setup.hi);
    let (probes, n_null) = an.probes(lin, dx, WEAK_PROBES, RANDOM_PROBES);
    let mut at = match ev.eval_gradient(x_new, &lin.order, &probes, n_null, observer) {
        Ok(at) => at,
        Err(f) if f.is_numerical() => return Ok(Chord::Rejected),
        Err(f) => return Err(f),
    };
    let rho = (lin.cost - at.cost) / pred;
    if rho <= ACCEPT {
        return Ok(Chord::Rejected);
    }
    let mut x = x_new.to_vec();
    let mut rank_gained = false;
    if !exact(rho, pred, at.cost) {
        return Ok(Chord::Refactor {
            x,
            rho,
            rank_gained,
        });
    }
    for _ in 0..MAX_CHORD_STEPS {
        let kept = &at.probe_sq[..at.probe_sq.len() - n_null];
        let metric_change = kept.iter().map(|q| (q - 1.0).abs()).fold(0.0, f64::max);
        if metric_change > METRIC_CHANGE {
            break;
        }
        if !an.null_space_kept(&at.cross, rank_tolerance) {
            rank_gained = true;
            break;
        }
        let (step, len) = an.chord_step(&at.g);
        let mut x_next = x.clone();
        for (&p, d) in lin.order.iter().zip(&step) {
            x_next[p] += d;
        }
        // A chord step that leaves the bounds is the bounded solver's job.
        if (0..x_next.len()).any(|p| !(lo[p]..=hi[p]).contains(&x_next[p])) {
            break;
        }
        let promised = 0.5 * len * len;
        let delta = CHORD_SAFETY * metric_change;
        // Measured in the scatter of the residuals where that is below the stated noise (a
        // simulated noise-free session is then solved to rounding, not to 1 % of a σ it does
        // not have).
        let dof = lin.n_rows.saturating_sub(an.rank).max(1) as f64;
        let scatter = (2.0 * at.cost / dof).min(1.0).sqrt();
        if len <= CHORD_FINAL_STEP || delta / (1.0 - delta) * len <= CHORD_FINAL_STEP * scatter {
            return Ok(Chord::Converged {
                x: x_next,
                cost: (at.cost - promised).max(0.0),
            });
        }
        let next = match ev.eval_gradient(&x_next, &lin.order, &probes, n_null, observer) {
            Ok(next) => next,
            Err(f) if f.is_numerical() => break,
            Err(f) => return Err(f),
        };
        if at.cost - next.cost <= ACCEPT * promised {
            break;
        }
        (x, at) = (x_next, next);
    }
    Ok(Chord::Refactor {
        x,
        rho,
        rank_gained,
    })
}

/// The (damped, bounded) step in the column order of `lin`.
fn step(
    an: &Analysis,
    lin: &Lin,
    x: &[f64],
    setup: &Setup,
    lambda: f64,
) -> Result<Vec<f64>, SolveError> {
    let dx = an.step(lambda);
    if !setup.has_bounds {
        return Ok(dx);
    }
    let x_col: Vec<f64> = lin.order.iter().map(|&p| x[p]).collect();
    let lo: Vec<f64> = lin.order.iter().map(|&p| setup.lo[p]).collect();
    let hi: Vec<f64> = lin.order.iter().map(|&p| setup.hi[p]).collect();
    let inside = (0..dx.len()).all(|c| {
        let v = x_col[c] + dx[c];
        v >= lo[c] && v <= hi[c]
    });
    if inside {
        return Ok(dx);
    }
    match bounded_step(an, lambda, &x_col, &lo, &hi) {
        Ok(step) => Ok(step),
        // The QP can stall on a badly scaled step far from the solution: the same direction,
        // shortened to stay inside the box, still lowers a convex model of the cost; the
        // iteration's acceptance test decides as for any step.
        Err(SolveError::Numerical(_)) => Ok(shortened_into_box(&dx, &x_col, &lo, &hi)),
        Err(e) => Err(e),
    }
}

/// `dx` scaled by the largest factor in (0, 1] that keeps `x + t·dx` inside `[lo, hi]`, then
/// clamped exactly (a start on a bound gives a zero step along that coordinate).
fn shortened_into_box(dx: &[f64], x: &[f64], lo: &[f64], hi: &[f64]) -> Vec<f64> {
    let mut t: f64 = 1.0;
    for c in 0..dx.len() {
        let room = if dx[c] > 0.0 {
            hi[c] - x[c]
        } else if dx[c] < 0.0 {
            lo[c] - x[c]
        } else {
            continue;
        };
        if (x[c] + dx[c] - x[c]).abs() > room.abs() {
            t = t.min((room / dx[c]).max(0.0));
        }
    }
    (0..dx.len())
        .map(|c| (x[c] + t * dx[c]).clamp(lo[c], hi[c]) - x[c])
        .collect()
}

/// A null direction's members that move by a negligible amount while the others roam over
/// their plausible ranges: by less than [`NEGLIGIBLE_MEMBER`] of their own plausible range
/// relative to the largest such fraction, or — for a trace, below [`TRACE_MEMBER`] of it, whose
/// `sigma` (from the identified directions) is below [`DETERMINED_SIGMA`] of its plausible
/// range — by less than [`NEGLIGIBLE_SHARE_OF_SIGMA`] of that σ.
///
/// A direction that exists only because an almost invisible parameter (one whose column is
/// zero at first order and tiny at second) pairs with a set-up constant, or a genuine set-up
/// null space (ball height and tool length), picks up rounding-size or second-order components
/// along well-determined parameters; moving it over a millimetre moves, say, a location error
/// by a hundredth of a micrometre while its interval is ±0.7 µm. That parameter is determined
/// for any plausible value of the others and keeps its number (and its interval). Entries are
/// in scaled units (`scale`: column norms), `floor[p]` is `1/plausible range` of parameter `p`
/// (0 when it has none: then nothing is dropped against it).
fn without_negligible_members(
    mut dir: Vec<f64>,
    scale: &[f64],
    params: &[usize],
    floor: &[f64],
    sigma: &[f64],
) -> Vec<f64> {
    let fraction = |i: usize| (dir[i] / scale[i]).abs() * floor[params[i]];
    if params.iter().any(|&p| floor[p] <= 0.0) {
        return dir;
    }
    let largest = (0..dir.len()).map(fraction).fold(0.0, f64::max);
    if largest <= 0.0 {
        return dir;
    }
    // Moving along the direction until its fastest member has crossed its plausible range
    // moves member i by |dir[i] / scale[i]| / largest (parameter units).
    let small: Vec<usize> = (0..dir.len())
        .filter(|&i| {
            fraction(i) < NEGLIGIBLE_MEMBER * largest
                || (fraction(i) < TRACE_MEMBER * largest
                    && sigma[i] * floor[params[i]] < DETERMINED_SIGMA
                    && (dir[i] / scale[i]).abs() / largest < NEGLIGIBLE_SHARE_OF_SIGMA * sigma[i])
        })
        .collect();
    for i in small {
        dir[i] = 0.0;
    }
    dir
}

/// The cost drop below which an accepted step counts towards [`Termination::Settled`]:
/// [`SETTLED_DROP`] when the residuals are of the size of their noise, else 0 (an exact fit's
/// cost is no χ²).
fn settle_floor(lin: &Lin) -> f64 {
    let noise_sized = 2.0 * lin.cost >= 0.5 * lin.n_rows as f64;
    if noise_sized { SETTLED_DROP } else { 0.0 }
}

fn assemble(
    setup: &Setup,
    x: Vec<f64>,
    lin: &Lin,
    an: &Analysis,
    iterations: usize,
    (evaluations, factorizations): (usize, usize),
    termination: Termination,
) -> Solution {
    let n = setup.n_params;
    let cols = lin.n();
    let mut col_of = vec![NONE; n];
    for (c, &p) in lin.order.iter().enumerate() {
        col_of[p] = c;
    }
    // Null space, rows in ascending parameter order so that "relative to the first" reads in
    // parameter order.
    let mut sorted = lin.order.clone();
    sorted.sort_unstable();
    let null = an.null_space();
    let scale: Vec<f64> = sorted.iter().map(|&p| an.d[col_of[p]]).collect();
    let cov_col = an.covariance();
    let sigma_sorted: Vec<f64> = sorted
        .iter()
        .map(|&p| cov_col[(col_of[p], col_of[p])].max(0.0).sqrt())
        .collect();
    let dirs: Vec<Vec<f64>> = (0..null.ncols())
        .map(|k| {
            let dir: Vec<f64> = sorted.iter().map(|&p| null[(col_of[p], k)]).collect();
            without_negligible_members(dir, &scale, &sorted, &setup.floor, &sigma_sorted)
        })
        .collect();
    let names: Vec<&str> = sorted.iter().map(|&p| setup.names[p].as_str()).collect();
    let mut combinations = describe_null_space(&dirs, &scale, &names);
    for c in &mut combinations {
        for p in &mut c.params {
            *p = sorted[*p];
        }
    }
    let mut identified = vec![false; n];
    for &p in &lin.order {
        identified[p] = true;
    }
    for c in &combinations {
        for &p in &c.params {
            identified[p] = false;
        }
    }
    let mut covariance = vec![0.0; n * n];
    for (ci, &pi) in lin.order.iter().enumerate() {
        if !identified[pi] {
            continue;
        }
        for (cj, &pj) in lin.order.iter().enumerate() {
            if identified[pj] {
                covariance[pi * n + pj] = cov_col[(ci, cj)];
            }
        }
    }
    let sigma: Vec<Option<f64>> = (0..n)
        .map(|p| identified[p].then(|| covariance[p * n + p].max(0.0).sqrt()))
        .collect();
    let rank = an.rank;
    let n_prior = setup.priors.len();
    let dof = (lin.n_rows + n_prior).saturating_sub(rank);
    let chi2 = 2.0 * lin.cost;
    debug_assert_eq!(cols, an.d.len());
    Solution {
        x,
        cost: lin.cost,
        n_rows: lin.n_rows,
        n_prior_rows: n_prior,
        dof,
        chi2,
        chi2_reduced: if dof > 0 { chi2 / dof as f64 } else { 0.0 },
        iterations,
        evaluations,
        factorizations,
        converged: matches!(termination, Termination::Converged | Termination::Settled),
        termination,
        rank,
        condition_number: if rank > 0 {
            an.s[0] / an.s[rank - 1]
        } else {
            1.0
        },
        singular_values: an.s.clone(),
        identified,
        sigma,
        covariance,
        combinations,
    }
}

/// Evaluates the problem at `x` (one value per parameter; fixed ones included) and returns its
/// linearisation, prior rows included and fixed parameters' columns dropped.
pub fn linearize<P: Problem>(
    problem: &P,
    params: &[ParamSpec],
    x: &[f64],
    threads: usize,
) -> Result<Linearization, SolveError> {
    let setup = Setup::new(problem, params, threads)?;
    if x.len() != setup.n_params {
        return Err(SolveError::ParamCount {
            expected: setup.n_params,
            got: x.len(),
        });
    }
    let layout = Layout::new(setup.n_params, setup.free.clone());
    let mut pool = Vec::new();
    let lin = evaluate(
        problem,
        x,
        &layout,
        &setup.priors,
        &mut pool,
        setup.threads,
        &mut Silent,
    )
    .map_err(|f| setup.error(f))?;
    let n = setup.n_params;
    let cols = lin.n();
    let mut r = vec![0.0; n * n];
    for (c, &p) in lin.order.iter().enumerate() {
        for i in 0..=c {
            r[i * n + p] = lin.r[i + c * cols];
        }
    }
    let mut z = lin.z.clone();
    z.resize(n, 0.0);
    Ok(Linearization {
        r,
        z,
        rss: lin.rss,
        cost: lin.cost,
        n_rows: lin.n_rows,
        free: setup.free,
        floor: setup.floor,
    })
}

#[cfg(test)]
mod tests {
    use super::shortened_into_box;

    #[test]
    fn a_step_leaving_the_box_is_shortened_along_itself() {
        let x = [0.0, 1.0, 5.0];
        let lo = [-1.0, 0.0, f64::NEG_INFINITY];
        let hi = [1.0, 2.0, f64::INFINITY];
        // The first coordinate would reach 4 (limit 1): a quarter of the step; the others
        // follow in proportion.
        let dx = shortened_into_box(&[4.0, -2.0, 8.0], &x, &lo, &hi);
        assert_eq!(dx, vec![1.0, -0.5, 2.0]);
        // Inside already: unchanged.
        assert_eq!(
            shortened_into_box(&[0.5, 0.5, -3.0], &x, &lo, &hi),
            vec![0.5, 0.5, -3.0]
        );
        // A start on the bound moving out: nothing moves (no direction is feasible at any
        // positive length along this step).
        let dx = shortened_into_box(&[1.0, 0.1, 0.0], &[1.0, 1.0, 0.0], &lo, &hi);
        assert_eq!(dx, vec![0.0, 0.0, 0.0]);
    }
}
