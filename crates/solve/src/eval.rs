//! Parallel evaluation of all blocks at one point into a single streaming factor.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, mpsc};

use crate::accumulate::{Accumulator, Fault, NONE};
use crate::{EvalError, Observer, Problem, RowSink};

/// Which column of `R` each parameter has.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Layout {
    /// Parameter → column, [`NONE`] for fixed parameters.
    pub(crate) to_col: Vec<usize>,
    /// Column → parameter.
    pub(crate) order: Vec<usize>,
}

impl Layout {
    /// Columns in the order of the free parameters `order`.
    pub(crate) fn new(n_params: usize, order: Vec<usize>) -> Self {
        let mut to_col = vec![NONE; n_params];
        for (c, &p) in order.iter().enumerate() {
            to_col[p] = c;
        }
        Self { to_col, order }
    }

    pub(crate) fn n(&self) -> usize {
        self.order.len()
    }
}

/// A Gaussian prior on a free parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Prior {
    pub(crate) param: usize,
    pub(crate) mean: f64,
    pub(crate) sigma: f64,
}

/// The problem linearised at a point, in the column order of the layout it was built with.
#[derive(Debug, Clone)]
pub(crate) struct Lin {
    /// Column → parameter.
    pub(crate) order: Vec<usize>,
    /// `n × n` column-major upper triangular.
    pub(crate) r: Vec<f64>,
    pub(crate) z: Vec<f64>,
    pub(crate) rss: f64,
    /// `½ Σ r²`, prior rows included.
    pub(crate) cost: f64,
    pub(crate) n_rows: usize,
    /// Per parameter: number of blocks in which it was active.
    pub(crate) usage: Vec<u32>,
}

impl Lin {
    pub(crate) fn n(&self) -> usize {
        self.order.len()
    }
}

/// Why an evaluation failed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Failure {
    Fault(Fault),
    Eval {
        block: usize,
        source: EvalError,
    },
    /// Every residual is finite but `Σ r²` overflows.
    Overflow,
}

impl Failure {
    /// Numerical failures (as opposed to malformed rows or columns, which are bugs in the
    /// problem and fail the same way at every point).
    pub(crate) fn is_numerical(&self) -> bool {
        matches!(
            self,
            Failure::Eval { .. }
                | Failure::Overflow
                | Failure::Fault(Fault::NonFiniteResidual { .. } | Fault::NonFiniteJacobian { .. })
        )
    }

    fn block(&self) -> usize {
        match self {
            Failure::Overflow => 0,
            Failure::Eval { block, .. } => *block,
            Failure::Fault(
                Fault::NonFiniteResidual { block, .. }
                | Fault::NonFiniteJacobian { block, .. }
                | Fault::Columns { block, .. }
                | Fault::Row { block, .. },
            ) => *block,
        }
    }
}

/// Evaluates every block at `x` on up to `threads` threads and merges the lanes' factors.
/// `pool` keeps the accumulators (and their buffers) between calls.
pub(crate) fn evaluate<P: Problem>(
    problem: &P,
    x: &[f64],
    layout: &Layout,
    priors: &[Prior],
    pool: &mut Vec<Accumulator>,
    threads: usize,
    observer: &mut dyn Observer,
) -> Result<Lin, Failure> {
    let lanes = crate::lanes::lane_count(problem.n_blocks());
    if pool.len() != lanes || !pool[0].has_layout(&layout.to_col) || pool[0].gradient.is_some() {
        pool.clear();
        pool.resize_with(lanes, || {
            Accumulator::new(layout.to_col.clone(), layout.n())
        });
    }
    let prior_sumsq = run_blocks(problem, x, layout, priors, pool, threads, observer)?;
    let acc = &pool[0];
    Ok(Lin {
        order: layout.order.clone(),
        r: acc.r.clone(),
        z: acc.z.clone(),
        rss: acc.rss,
        cost: 0.5 * (acc.sumsq + prior_sumsq),
        n_rows: acc.n_rows,
        usage: acc.usage.clone(),
    })
}

/// The gradient of the cost and the squared norms `‖J·u_k‖²` of probe directions at one point.
#[derive(Debug, Clone)]
pub(crate) struct GradientAt {
    /// `Jᵀr` (prior rows included), column order of the layout.
    pub(crate) g: Vec<f64>,
    pub(crate) probe_sq: Vec<f64>,
    /// `Jᵀ(J·u_k)` for the last `n_cross` probes: `n × n_cross`, column-major.
    pub(crate) cross: Vec<f64>,
    /// `½ Σ r²`, prior rows included.
    pub(crate) cost: f64,
}

/// Like [`evaluate`] but sums `Jᵀr` and the probes' `‖J·u_k‖²` instead of factoring: a row
/// costs `O(n·k)`, not `O(n²)`. `probes` holds `k` vectors of `layout.n()` entries; the last
/// `n_cross` of them also get `Jᵀ(J·u)`.
// The arguments of `evaluate` plus the probes; a struct for them would only move the list.
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate_gradient<P: Problem>(
    problem: &P,
    x: &[f64],
    layout: &Layout,
    priors: &[Prior],
    probes: &[f64],
    n_cross: usize,
    pool: &mut Vec<Accumulator>,
    threads: usize,
    observer: &mut dyn Observer,
) -> Result<GradientAt, Failure> {
    pool.clear();
    pool.resize_with(crate::lanes::lane_count(problem.n_blocks()), || {
        Accumulator::new_gradient(layout.to_col.clone(), layout.n(), probes, n_cross)
    });
    let prior_sumsq = run_blocks(problem, x, layout, priors, pool, threads, observer)?;
    let acc = &pool[0];
    let grad = acc.gradient.as_ref().expect("gradient accumulators");
    Ok(GradientAt {
        g: grad.g.clone(),
        probe_sq: grad.probe_sq.clone(),
        cross: grad.cross.clone(),
        cost: 0.5 * (acc.sumsq + prior_sumsq),
    })
}

/// Runs every block through the lanes of `pool` on up to `threads` threads and merges them into
/// `pool[0]`, in lane order (see [`crate::lanes`]: the same factor on any number of cores). Its
/// own loop rather than [`crate::run_lanes`]: the observer hears of every finished block on the
/// calling thread while the workers run, and one lane's failure stops the others. Returns the priors' sum of squares.
fn run_blocks<P: Problem>(
    problem: &P,
    x: &[f64],
    layout: &Layout,
    priors: &[Prior],
    pool: &mut [Accumulator],
    threads: usize,
    observer: &mut dyn Observer,
) -> Result<f64, Failure> {
    let n_blocks = problem.n_blocks();
    let lanes = pool.len();
    for acc in pool.iter_mut() {
        acc.reset();
    }
    // Priors first: diagonal rows on an empty factor cost nothing and cause no fill-in.
    let mut prior_sumsq = 0.0;
    let rows: Vec<(usize, f64, f64)> = priors
        .iter()
        .map(|p| {
            let r = (x[p.param] - p.mean) / p.sigma;
            prior_sumsq += r * r;
            (layout.to_col[p.param], 1.0 / p.sigma, r)
        })
        .collect();
    pool[0].set_diagonal_rows(&rows);

    let abort = AtomicBool::new(false);
    let workers = threads.clamp(1, lanes);
    let mut failures: Vec<Failure> = Vec::new();
    if workers == 1 {
        let mut done = 0;
        for (lane, acc) in pool.iter_mut().enumerate() {
            let res = work(problem, x, acc, lane, lanes, &abort, &mut |_| {
                done += 1;
                observer.rows(done, n_blocks);
            });
            failures.extend(res.err());
        }
    } else {
        // Threads take whole lanes; which thread runs a lane does not change its sums.
        let queue = Mutex::new(pool.iter_mut().enumerate());
        let (tx, rx) = mpsc::channel::<()>();
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..workers)
                .map(|_| {
                    let tx = tx.clone();
                    let (queue, abort) = (&queue, &abort);
                    s.spawn(move || {
                        let mut failures = Vec::new();
                        // A poisoned queue means another worker panicked: re-raised at join.
                        while let Ok(Some((lane, acc))) = queue.lock().map(|mut q| q.next()) {
                            let res = work(problem, x, acc, lane, lanes, abort, &mut |_| {
                                let _ = tx.send(());
                            });
                            failures.extend(res.err());
                        }
                        failures
                    })
                })
                .collect();
            drop(tx);
            let mut done = 0;
            for () in rx {
                done += 1;
                observer.rows(done, n_blocks);
            }
            for h in handles {
                match h.join() {
                    Ok(res) => failures.extend(res),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
        });
    }
    if let Some(f) = failures.into_iter().min_by_key(Failure::block) {
        return Err(f);
    }
    let (first, rest) = pool.split_at_mut(1);
    let acc = &mut first[0];
    for other in rest {
        acc.merge(other);
    }
    acc.flush();
    Ok(prior_sumsq)
}

/// One lane: blocks `lane, lane + lanes, …` in order, until done or another lane failed.
fn work<P: Problem>(
    problem: &P,
    x: &[f64],
    acc: &mut Accumulator,
    lane: usize,
    lanes: usize,
    abort: &AtomicBool,
    done: &mut dyn FnMut(usize),
) -> Result<(), Failure> {
    for b in (lane..problem.n_blocks()).step_by(lanes) {
        if abort.load(Ordering::Relaxed) {
            return Ok(());
        }
        acc.start_block(b);
        let res = problem.eval_block(b, x, &mut RowSink { acc: &mut *acc });
        if let Some(fault) = acc.fault.take() {
            abort.store(true, Ordering::Relaxed);
            return Err(Failure::Fault(fault));
        }
        if let Err(source) = res {
            abort.store(true, Ordering::Relaxed);
            return Err(Failure::Eval { block: b, source });
        }
        done(b);
    }
    acc.flush();
    Ok(())
}
