//! Parallel evaluation of all blocks at one point into a single streaming factor.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;

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

/// Evaluates every block at `x` on `threads` threads and merges the per-thread factors.
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
    let threads = threads.clamp(1, problem.n_blocks().max(1));
    if pool.len() != threads || !pool[0].has_layout(&layout.to_col) || pool[0].gradient.is_some() {
        pool.clear();
        pool.resize_with(threads, || {
            Accumulator::new(layout.to_col.clone(), layout.n())
        });
    }
    let prior_sumsq = run_blocks(problem, x, layout, priors, pool, observer)?;
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
    let threads = threads.clamp(1, problem.n_blocks().max(1));
    pool.clear();
    pool.resize_with(threads, || {
        Accumulator::new_gradient(layout.to_col.clone(), layout.n(), probes, n_cross)
    });
    let prior_sumsq = run_blocks(problem, x, layout, priors, pool, observer)?;
    let acc = &pool[0];
    let grad = acc.gradient.as_ref().expect("gradient accumulators");
    Ok(GradientAt {
        g: grad.g.clone(),
        probe_sq: grad.probe_sq.clone(),
        cross: grad.cross.clone(),
        cost: 0.5 * (acc.sumsq + prior_sumsq),
    })
}

/// Runs every block through the accumulators of `pool` (one thread each) and merges them into
/// `pool[0]`. Returns the priors' sum of squares.
fn run_blocks<P: Problem>(
    problem: &P,
    x: &[f64],
    layout: &Layout,
    priors: &[Prior],
    pool: &mut [Accumulator],
    observer: &mut dyn Observer,
) -> Result<f64, Failure> {
    let n_blocks = problem.n_blocks();
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

    let next = AtomicUsize::new(0);
    let abort = AtomicBool::new(false);
    let mut failures: Vec<Failure> = Vec::new();
    if pool.len() == 1 {
        let mut done = 0;
        let res = work(
            problem,
            x,
            &mut pool[0],
            &next,
            &abort,
            n_blocks,
            &mut |_| {
                done += 1;
                observer.rows(done, n_blocks);
            },
        );
        failures.extend(res.err());
    } else {
        let (tx, rx) = mpsc::channel::<()>();
        std::thread::scope(|s| {
            let handles: Vec<_> = pool
                .iter_mut()
                .map(|acc| {
                    let tx = tx.clone();
                    let (next, abort) = (&next, &abort);
                    s.spawn(move || {
                        work(problem, x, acc, next, abort, n_blocks, &mut |_| {
                            let _ = tx.send(());
                        })
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
                    Ok(res) => failures.extend(res.err()),
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

/// One worker: takes blocks from the shared counter until none are left.
fn work<P: Problem>(
    problem: &P,
    x: &[f64],
    acc: &mut Accumulator,
    next: &AtomicUsize,
    abort: &AtomicBool,
    n_blocks: usize,
    done: &mut dyn FnMut(usize),
) -> Result<(), Failure> {
    loop {
        if abort.load(Ordering::Relaxed) {
            return Ok(());
        }
        let b = next.fetch_add(1, Ordering::Relaxed);
        if b >= n_blocks {
            break;
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
