//! Deterministic parallel sums over blocks.
//!
//! Floating-point sums depend on their order. Dealing blocks to whichever thread is free
//! (work stealing) or to a fixed number of threads makes the rounding, and near a rank
//! threshold the solution, vary from run to run or from machine to machine. Here blocks go to
//! a fixed number of lanes — lane `l` takes blocks `l, l + L, …` in order — threads take whole
//! lanes, and the caller merges the lanes in order: the same sums on any number of cores.

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
    let threads = if threads == 0 {
        std::thread::available_parallelism().map_or(1, |t| t.get())
    } else {
        threads
    }
    .clamp(1, n_lanes);
    let lane = |l: usize, state: &mut T| -> Result<(), (usize, E)> {
        for b in (l..n_blocks).step_by(n_lanes) {
            f(b, state).map_err(|e| (b, e))?;
        }
        Ok(())
    };
    let mut failures: Vec<(usize, E)> = Vec::new();
    if threads == 1 {
        for (l, state) in lanes.iter_mut().enumerate() {
            failures.extend(lane(l, state).err());
        }
    } else {
        let queue = Mutex::new(lanes.iter_mut().enumerate());
        std::thread::scope(|s| {
            let worker = || {
                let mut failed = Vec::new();
                // A poisoned queue means another worker panicked: re-raised at join.
                while let Ok(Some((l, state))) = queue.lock().map(|mut q| q.next()) {
                    failed.extend(lane(l, state).err());
                }
                failed
            };
            let handles: Vec<_> = (1..threads).map(|_| s.spawn(worker)).collect();
            failures.extend(worker());
            for h in handles {
                match h.join() {
                    Ok(f) => failures.extend(f),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
        });
    }
    match failures.into_iter().min_by_key(|(b, _)| *b) {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
