//! Scoring candidate effects against a fit (issue 4's target: 100+ candidates against a fit of
//! 10⁵ samples in under a second): 10⁵ rows of a fit with 100 parameters (Chebyshev
//! polynomials in time and in a position), 120 candidates with 200 columns in all (60 cycles as
//! sine/cosine pairs, 40 steps, 20 position-by-time couplings), on all cores; the cycle of 71
//! periods is planted at 1/30 of the noise (slower ones the time polynomials absorb). The fit itself is made once, outside the timing.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_solve::{
    EvalError, Options, ParamSpec, Problem, RowSink, ScoreSink, ScoredProblem, Silent,
    score_candidates, solve,
};

const ROWS: usize = 100_000;
const FIT: usize = 100;
const BLOCK: usize = 4096;
/// Standard deviation of the uniform noise on (−½, ½).
const NOISE: f64 = 0.288_675_134_594_812_9;

struct Session {
    t: Vec<f64>,
    pos: Vec<f64>,
    y: Vec<f64>,
}

impl Session {
    fn new() -> Self {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut noise = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let t: Vec<f64> = (0..ROWS).map(|i| i as f64 / ROWS as f64).collect();
        // Positions visited in a scrambled order (a probe moved around a part between readings).
        let pos: Vec<f64> = (0..ROWS).map(|_| 2.0 * noise()).collect();
        let y = t
            .iter()
            .zip(&pos)
            .map(|(t, p)| {
                0.2 + t - 0.3 * p + 0.01 * (std::f64::consts::TAU * 71.0 * t).sin() + noise()
            })
            .collect();
        Self { t, pos, y }
    }

    /// The fitted columns, whitened: Chebyshev polynomials `T_0…T_49` of `2t − 1` and
    /// `T_1…T_50` of the position.
    fn fit_row(&self, i: usize, out: &mut [f64]) {
        let (u, p) = (2.0 * self.t[i] - 1.0, self.pos[i]);
        let (mut a0, mut a1) = (1.0, u);
        let (mut b0, mut b1) = (1.0, p);
        for k in 0..FIT / 2 {
            out[k] = a0 / NOISE;
            out[FIT / 2 + k] = b1 / NOISE;
            (a0, a1) = (a1, 2.0 * u * a1 - a0);
            (b0, b1) = (b1, 2.0 * p * b1 - b0);
        }
    }

    fn candidate_row(&self, i: usize, out: &mut Vec<f64>) {
        out.clear();
        let (t, p) = (self.t[i], self.pos[i]);
        for k in 0..60 {
            let (s, c) = (std::f64::consts::TAU * t * (3.0 + 1.7 * k as f64)).sin_cos();
            out.push(s);
            out.push(c);
        }
        for k in 0..40 {
            out.push(if t > (k as f64 + 0.5) / 40.0 {
                1.0
            } else {
                0.0
            });
        }
        for k in 0..20_i32 {
            out.push(p * t.powi(k % 4 + 1) * (1.0 + 0.1 * f64::from(k)));
        }
        out.iter_mut().for_each(|v| *v /= NOISE);
    }

    fn blocks(&self) -> usize {
        ROWS.div_ceil(BLOCK)
    }
}

impl Problem for Session {
    fn n_params(&self) -> usize {
        FIT
    }
    fn n_blocks(&self) -> usize {
        self.blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        let cols: Vec<usize> = (0..FIT).collect();
        sink.columns(&cols);
        let mut row = vec![0.0; FIT];
        for i in (b * BLOCK..(b + 1) * BLOCK).take_while(|&i| i < ROWS) {
            self.fit_row(i, &mut row);
            let model: f64 = row.iter().zip(x).map(|(a, b)| a * b).sum();
            sink.row(model - self.y[i] / NOISE, &row);
        }
        Ok(())
    }
}

impl ScoredProblem for Session {
    fn n_params(&self) -> usize {
        FIT
    }
    fn candidate_widths(&self) -> Vec<usize> {
        [vec![2; 60], vec![1; 40], vec![1; 20]].concat()
    }
    fn n_blocks(&self) -> usize {
        self.blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        let cols: Vec<usize> = (0..FIT).collect();
        sink.columns(&cols);
        let mut row = vec![0.0; FIT];
        let mut extra = Vec::with_capacity(200);
        for i in (b * BLOCK..(b + 1) * BLOCK).take_while(|&i| i < ROWS) {
            self.fit_row(i, &mut row);
            self.candidate_row(i, &mut extra);
            let model: f64 = row.iter().zip(x).map(|(a, b)| a * b).sum();
            sink.row(model - self.y[i] / NOISE, &row, &extra);
        }
        Ok(())
    }
}

fn bench_score(c: &mut Criterion) {
    let session = Session::new();
    let specs: Vec<ParamSpec> = (0..FIT)
        .map(|i| ParamSpec::new(format!("p{i}"), 0.0))
        .collect();
    let fit = solve(&session, &specs, &Options::default(), &mut Silent).unwrap();
    let scores = score_candidates(&session, &specs, &fit, 0.05, 0).unwrap();
    let claimed: Vec<usize> = (0..scores.len())
        .filter(|&k| scores[k].significant)
        .collect();
    eprintln!(
        "score: {} candidates, significant: {claimed:?} (planted: 40; the 60 cycles come first), fit rank {}, χ²/dof {:.3}",
        scores.len(),
        fit.rank,
        fit.chi2_reduced
    );
    let mut g = c.benchmark_group("score");
    g.sample_size(10);
    g.bench_function("120_candidates_1e5_rows_100_parameters", |b| {
        b.iter(|| black_box(score_candidates(&session, &specs, &fit, 0.05, 0).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench_score);
criterion_main!(benches);
