//! Test problems and dense references shared by the integration tests.
#![allow(dead_code)]

use mtcal_solve::{EvalError, Options, ParamSpec, Problem, RowSink};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// One measurement `y = Σ a·x[cols] + noise` with standard uncertainty `sigma`.
#[derive(Debug, Clone)]
pub struct Row {
    pub cols: Vec<usize>,
    pub a: Vec<f64>,
    pub y: f64,
    pub sigma: f64,
}

/// A linear problem whose blocks are lists of rows; consecutive rows with the same columns
/// form one group.
#[derive(Debug, Clone)]
pub struct Linear {
    pub n: usize,
    pub blocks: Vec<Vec<Row>>,
}

impl Problem for Linear {
    fn n_params(&self) -> usize {
        self.n
    }
    fn n_blocks(&self) -> usize {
        self.blocks.len()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        let mut last: Option<&[usize]> = None;
        let mut jac = Vec::new();
        for row in &self.blocks[b] {
            if last != Some(row.cols.as_slice()) {
                sink.columns(&row.cols);
                last = Some(&row.cols);
            }
            let pred: f64 = row.cols.iter().zip(&row.a).map(|(&c, a)| a * x[c]).sum();
            jac.clear();
            jac.extend(row.a.iter().map(|a| a / row.sigma));
            sink.row((pred - row.y) / row.sigma, &jac);
        }
        Ok(())
    }
}

impl Linear {
    /// The whitened dense Jacobian and the whitened data `J x = w`.
    pub fn dense(&self) -> (DMatrix<f64>, DVector<f64>) {
        let rows: Vec<&Row> = self.blocks.iter().flatten().collect();
        let mut j = DMatrix::zeros(rows.len(), self.n);
        let mut w = DVector::zeros(rows.len());
        for (i, row) in rows.iter().enumerate() {
            for (&c, a) in row.cols.iter().zip(&row.a) {
                j[(i, c)] += a / row.sigma;
            }
            w[i] = row.y / row.sigma;
        }
        (j, w)
    }

    /// Every row with all columns (zeros included), one block: the dense way to feed it.
    pub fn as_single_dense_block(&self) -> Linear {
        let all: Vec<usize> = (0..self.n).collect();
        let rows = self
            .blocks
            .iter()
            .flatten()
            .map(|row| {
                let mut a = vec![0.0; self.n];
                for (&c, v) in row.cols.iter().zip(&row.a) {
                    a[c] += v;
                }
                Row {
                    cols: all.clone(),
                    a,
                    y: row.y,
                    sigma: row.sigma,
                }
            })
            .collect();
        Linear {
            n: self.n,
            blocks: vec![rows],
        }
    }
}

/// Reference least-squares solution and covariance from the normal equations (fine for
/// well-conditioned problems): `x = (JᵀJ)⁻¹ Jᵀ w`, `C = (JᵀJ)⁻¹`.
pub fn reference(j: &DMatrix<f64>, w: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let jtj = j.transpose() * j;
    let c = jtj.clone().try_inverse().expect("invertible");
    let x = &c * (j.transpose() * w);
    (x, c)
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

pub fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// Arrowhead problem: `n_shared` parameters seen by every block plus `n_local` per block.
/// Rows are split into groups that each use a random subset of the block's columns.
pub fn arrowhead(
    seed: u64,
    n_shared: usize,
    n_local: usize,
    n_blocks: usize,
    rows: usize,
    truth_out: &mut Vec<f64>,
) -> Linear {
    let mut g = rng(seed);
    let n = n_shared + n_local * n_blocks;
    let truth: Vec<f64> = (0..n).map(|_| uniform(&mut g, -2.0, 2.0)).collect();
    let mut blocks = Vec::new();
    for b in 0..n_blocks {
        let mut block = Vec::new();
        let local: Vec<usize> = (0..n_local).map(|k| n_shared + b * n_local + k).collect();
        for i in 0..rows {
            // Groups of 5 rows share a column subset.
            let seed_cols = i / 5;
            let mut cols: Vec<usize> = (0..n_shared)
                .filter(|&c| (c + seed_cols) % 3 != 0 || seed_cols % 2 == 0)
                .collect();
            cols.extend(&local);
            let a: Vec<f64> = cols.iter().map(|_| uniform(&mut g, -1.0, 1.0)).collect();
            let sigma = uniform(&mut g, 0.5, 2.0);
            let y = cols.iter().zip(&a).map(|(&c, v)| v * truth[c]).sum::<f64>()
                + sigma * normal(&mut g);
            block.push(Row { cols, a, y, sigma });
        }
        blocks.push(block);
    }
    *truth_out = truth;
    Linear { n, blocks }
}

pub fn params(n: usize) -> Vec<ParamSpec> {
    (0..n)
        .map(|i| ParamSpec::new(format!("p{i}"), 0.0))
        .collect()
}

pub fn options(threads: usize) -> Options {
    Options {
        threads,
        ..Options::default()
    }
}

/// max |a − b| / max |b|.
pub fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    let num = a
        .iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
    let den = b.iter().fold(0.0_f64, |m, y| m.max(y.abs()));
    num / den
}
