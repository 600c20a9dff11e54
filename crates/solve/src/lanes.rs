//! Deterministic parallel sums over blocks.
//!
//! Floating-point sums depend on their order. Dealing blocks to whichever thread is free
//! (work stealing) or to a fixed number of threads makes the rounding, and near a rank
//! threshold the solution, vary from run to run or from machine to machine. Here blocks go to
//! a fixed number of lanes — lane `l` takes blocks `l, l + L, …` in order — threads take whole
//! lanes, and the caller merges the lanes in order: the same sums on any number of cores.

use std::convert::Infallible;
use std::sync::Mutex;

/// Lanes of every parallel sum over blocks.
pub const LANES: usize = 4;

/// Number of lanes for `n_blocks` blocks (at least one).
pub fn lane_count(n_blocks: usize) -> usize {
    LANES.min(n_blocks).max(1)
}

/// Runs `f(block, lane_state)` for every block, lane `l` of `lanes` taking blocks
/// `l, l + lanes.len(), …` in order, on up to `threads` threads (0: the available cores).
/// Returns the error of the lowest failing block; a lane stops at its first error.
pub fn run_lanes<T: Send, E: Send>(
    n_blocks: usize,
    lanes: &mut [T],
    threads: usize,
    f: impl Fn(usize, &mut T) -> Result<(), E> + Sync,
) -> Result<(), E> {
    let n_lanes = lanes.len();
    if n_lanes == 0 {
        return Ok(());
    }
    let lane = |(l, state): (usize, &mut T)| -> Result<Result<(), (usize, E)>, Infallible> {
        for b in (l..n_blocks).step_by(n_lanes) {
            if let Err(e) = f(b, state) {
                return Ok(Err((b, e)));
            }
        }
        Ok(Ok(()))
    };
    let Ok(outcomes) = map_in_order(lanes.iter_mut().enumerate().collect(), threads, lane);
    match outcomes
        .into_iter()
        .filter_map(Result::err)
        .min_by_key(|(b, _)| *b)
    {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// `f(item)` for every item, on up to `threads` threads (0: the available cores), each item
/// taken by whichever thread is free; the outputs in the items' order, whatever thread
/// computed them — so a caller whose items each compute alone gets the same answer on any
/// number of cores. The error of the first failing item in that order is returned (every item
/// is still computed); a panic in one is raised again here.
pub fn map_in_order<I: Send, O: Send, E: Send>(
    items: Vec<I>,
    threads: usize,
    f: impl Fn(I) -> Result<O, E> + Sync,
) -> Result<Vec<O>, E> {
    let n = items.len();
    let threads = if threads == 0 {
        std::thread::available_parallelism().map_or(1, |t| t.get())
    } else {
        threads
    }
    .clamp(1, n.max(1));
    let mut done: Vec<(usize, Result<O, E>)> = Vec::with_capacity(n);
    if threads == 1 {
        done.extend(items.into_iter().map(&f).enumerate());
    } else {
        let queue = Mutex::new(items.into_iter().enumerate());
        std::thread::scope(|s| {
            let worker = || {
                let mut out = Vec::new();
                // A poisoned queue means another worker panicked: re-raised at join.
                while let Ok(Some((k, item))) = queue.lock().map(|mut q| q.next()) {
                    out.push((k, f(item)));
                }
                out
            };
            let handles: Vec<_> = (1..threads).map(|_| s.spawn(worker)).collect();
            done.extend(worker());
            for h in handles {
                match h.join() {
                    Ok(out) => done.extend(out),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
        });
    }
    done.sort_by_key(|(k, _)| *k);
    done.into_iter().map(|(_, o)| o).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outputs in the items' order on any number of threads; of several failing items, the
    /// first in order is reported, however long the others take.
    #[test]
    fn a_map_keeps_the_items_order_and_reports_the_first_failure() {
        let items: Vec<u64> = (0..40).collect();
        let slow_square = |i: u64| -> Result<u64, u64> {
            // Early items take longest: on several threads they finish last.
            std::thread::sleep(std::time::Duration::from_micros(200 * (40 - i)));
            Ok(i * i)
        };
        for threads in [1, 3, 8] {
            let out = map_in_order(items.clone(), threads, slow_square).unwrap();
            assert_eq!(out, items.iter().map(|i| i * i).collect::<Vec<_>>());
            let failing = |i: u64| if i % 7 == 5 { Err(i) } else { slow_square(i) };
            assert_eq!(map_in_order(items.clone(), threads, failing), Err(5));
        }
        assert_eq!(map_in_order(Vec::<u64>::new(), 0, slow_square), Ok(vec![]));
    }

    /// Sums of terms whose rounding depends on the order: the same on 1, 2 and 7 threads.
    #[test]
    fn sums_do_not_depend_on_the_thread_count() {
        let terms: Vec<f64> = (0..1000)
            .map(|i| 1.0 / (1.0 + i as f64).powf(1.3) * 1e8)
            .collect();
        let sum = |threads: usize| -> f64 {
            let mut lanes = vec![0.0f64; lane_count(terms.len() / 10)];
            run_lanes(terms.len() / 10, &mut lanes, threads, |b, acc: &mut f64| {
                for t in &terms[10 * b..10 * b + 10] {
                    *acc += t;
                }
                Ok::<(), ()>(())
            })
            .unwrap();
            lanes.iter().sum()
        };
        let one = sum(1);
        for threads in [2, 7, 0] {
            assert_eq!(sum(threads).to_bits(), one.to_bits(), "{threads} threads");
        }
    }

    #[test]
    fn the_lowest_failing_block_is_reported() {
        let mut lanes = vec![(); 4];
        for threads in [1, 3] {
            let res = run_lanes(20, &mut lanes, threads, |b, _: &mut ()| {
                if b == 6 || b == 13 { Err(b) } else { Ok(()) }
            });
            assert_eq!(res, Err(6));
        }
    }
}
