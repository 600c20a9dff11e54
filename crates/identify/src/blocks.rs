//! Runs as block sums of consecutive samples: what the mismatch analysis reads of a long run,
//! and what it needs of a run's commanded positions, computed when the run is loaded.

use mtcal_session::RunTable;

/// Runs longer than this are analysed as block sums of consecutive samples (in time order),
/// `Σ rᵢ / √m` over blocks of `m`: under the null hypothesis still independent with unit
/// variance, so the tests keep their level, and effects slower than a block keep their power
/// (the periodogram's cost grows with the number of samples times frequencies).
pub(crate) const MAX_SAMPLES: usize = 1024;

/// What the analysis needs of a run's commanded positions (file units), computed when the run
/// is loaded so that the study need not keep them beside their SI copy: per axis the block
/// means and each block's direction of motion.
#[derive(Clone, Debug, Default)]
pub(crate) struct PositionBlocks {
    /// `(axis letter, block means)`.
    pub(crate) means: Vec<(String, Vec<f64>)>,
    /// `("<letter> direction", +1 / −1 / 0 per block)`.
    pub(crate) splits: Vec<(String, Vec<i32>)>,
}

impl PositionBlocks {
    pub(crate) fn of(table: &RunTable) -> Self {
        let n = table.len();
        let na = table.axes.len();
        if n == 0 || table.positions.len() != n * na {
            return Self::default();
        }
        let (m, blocks) = blocking(n);
        let means = table
            .axes
            .iter()
            .enumerate()
            .map(|(a, &letter)| {
                let pos = |i: usize| table.positions[i * na + a];
                (letter.to_string(), block_sums(n, &pos, Norm::Mean))
            })
            .collect();
        let splits = table
            .axes
            .iter()
            .enumerate()
            .map(|(a, &letter)| {
                let pos = |i: usize| table.positions[i * na + a];
                let labels = (0..blocks)
                    .map(|b| {
                        let (first, last) = (b * m, ((b + 1) * m).min(n) - 1);
                        // Direction of motion: the central difference around the block.
                        let (lo, hi) = (first.saturating_sub(1), (last + 1).min(n - 1));
                        direction(pos(hi) - pos(lo))
                    })
                    .collect();
                (format!("{letter} direction"), labels)
            })
            .collect();
        Self { means, splits }
    }
}

/// Samples per block and number of blocks of a run of `n` samples.
pub(crate) fn blocking(n: usize) -> (usize, usize) {
    let m = n.div_ceil(MAX_SAMPLES).max(1);
    (m, n.div_ceil(m))
}

/// Block sums over consecutive samples of `f` (`n` samples); the context is the block mean.
pub(crate) fn block_sums(n: usize, f: &dyn Fn(usize) -> f64, normalise: Norm) -> Vec<f64> {
    let (m, blocks) = blocking(n);
    (0..blocks)
        .map(|b| {
            let range = b * m..((b + 1) * m).min(n);
            let len = range.len() as f64;
            let s: f64 = range.map(f).sum();
            match normalise {
                Norm::Residual => s / len.sqrt(),
                Norm::Mean => s / len,
            }
        })
        .collect()
}

#[derive(Clone, Copy)]
pub(crate) enum Norm {
    /// `Σ rᵢ / √m`: unit variance under the null hypothesis.
    Residual,
    /// The mean (context values).
    Mean,
}

/// +1 moving up, −1 moving down, 0 standing (below a nanometre or a nano-degree per sample).
pub(crate) fn direction(delta: f64) -> i32 {
    if delta > 1e-9 {
        1
    } else if delta < -1e-9 {
        -1
    } else {
        0
    }
}
