//! Accumulation throughput of the streaming QR: 10⁵ rows × 110 active columns (100 shared
//! parameters + 10 per block, 10 blocks), evaluated on all cores and on one.

use std::hint::black_box;

use mtcal_solve::{EvalError, ParamSpec, Problem, RowSink, linearize};

const SHARED: usize = 100;
const LOCAL: usize = 10;
const BLOCKS: usize = 10;
const ROWS: usize = 100_000;
const TABLE: usize = 1024;

/// Rows cycle through a table of pseudo-random Jacobian rows, so that evaluating a row costs
/// next to nothing and the benchmark measures the accumulation.
struct Synthetic {
    table: Vec<f64>,
}

impl Synthetic {
    fn new() -> Self {
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        let table = (0..TABLE * (SHARED + LOCAL + 1))
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        Self { table }
    }
}

impl Problem for Synthetic {
    fn n_params(&self) -> usize {
        SHARED + LOCAL * BLOCKS
    }
    fn n_blocks(&self) -> usize {
        BLOCKS
    }
    fn eval_block(&self, b: usize, _x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        let cols: Vec<usize> = (0..SHARED)
            .chain(SHARED + b * LOCAL..SHARED + (b + 1) * LOCAL)
            .collect();
        sink.columns(&cols);
        let w = SHARED + LOCAL + 1;
        for i in 0..ROWS / BLOCKS {
            let k = (i * 7 + b * 131) % TABLE;
            let row = &self.table[k * w..(k + 1) * w];
            sink.row(row[w - 1], &row[..w - 1]);
        }
        Ok(())
    }
}

fn main() {
    let p = Synthetic::new();
    let params: Vec<ParamSpec> = (0..p.n_params())
        .map(|i| ParamSpec {
            group: (i >= SHARED).then(|| format!("b{}", (i - SHARED) / LOCAL)),
            ..ParamSpec::new(format!("p{i}"), 0.0)
        })
        .collect();
    let x = vec![0.0; p.n_params()];
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (threads, reps) = (args[0], args[1]);
    for _ in 0..reps {
        black_box(linearize(&p, &params, &x, threads).unwrap());
    }
}
