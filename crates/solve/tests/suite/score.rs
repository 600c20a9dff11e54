//! Score tests of candidate columns against a fit, checked against refitting: the statistic is
//! the drop in χ² that fitting the candidate brings (exact for a linear model), its amplitude
//! and the shift of the fitted parameters are the refit's; a candidate inside the fitted span is
//! reported as absorbed with no degrees of freedom; clean data raise a claim in at most about
//! α of the sessions.

use crate::common;

use common::*;
use mtcal_solve::{
    EvalError, ParamSpec, Problem, RowSink, ScoreSink, ScoredProblem, Silent, score_candidates,
    solve,
};

const SIGMA: f64 = 0.1;

/// `y(t) = a + b·t (+ planted effects) + noise`; the fitted model has `a, b` and, with
/// `extra_fitted`, the columns of candidate `extra_fitted` as well (for the refit).
struct Line {
    t: Vec<f64>,
    y: Vec<f64>,
    /// Fit these candidates' columns too (the refit).
    fitted_candidates: Vec<usize>,
}

/// The candidates, each a list of column functions of `t`.
fn candidate_columns(t: f64) -> Vec<Vec<f64>> {
    vec![
        // 0: a cycle of period 0.25 (sine and cosine)
        vec![
            (std::f64::consts::TAU * t / 0.25).sin(),
            (std::f64::consts::TAU * t / 0.25).cos(),
        ],
        // 1: curvature
        vec![t * t],
        // 2: a step halfway
        vec![if t > 0.5 { 1.0 } else { 0.0 }],
        // 3: inside the fitted span: an offset plus a slope
        vec![2.0 - 3.0 * t],
        // 4: a cycle of another period
        vec![(std::f64::consts::TAU * t / 0.13).sin()],
    ]
}

fn widths() -> Vec<usize> {
    candidate_columns(0.0).iter().map(Vec::len).collect()
}

impl Line {
    fn n_fit(&self) -> usize {
        2 + self
            .fitted_candidates
            .iter()
            .map(|&k| widths()[k])
            .sum::<usize>()
    }

    /// Residual, fitted columns and candidate columns of sample `i` at `x`.
    fn row(&self, i: usize, x: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
        let t = self.t[i];
        let cands = candidate_columns(t);
        let mut jac = vec![1.0, t];
        for &k in &self.fitted_candidates {
            jac.extend(&cands[k]);
        }
        let model: f64 = jac.iter().zip(x).map(|(a, b)| a * b).sum();
        let extra: Vec<f64> = cands.concat().iter().map(|v| v / SIGMA).collect();
        let jac = jac.iter().map(|v| v / SIGMA).collect();
        ((model - self.y[i]) / SIGMA, jac, extra)
    }

    fn blocks(&self) -> usize {
        self.t.len().div_ceil(64)
    }
}

impl Problem for Line {
    fn n_params(&self) -> usize {
        self.n_fit()
    }
    fn n_blocks(&self) -> usize {
        self.blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        let cols: Vec<usize> = (0..self.n_fit()).collect();
        sink.columns(&cols);
        for i in (64 * b..64 * (b + 1)).take_while(|&i| i < self.t.len()) {
            let (r, jac, _) = self.row(i, x);
            sink.row(r, &jac);
        }
        Ok(())
    }
}

impl ScoredProblem for Line {
    fn n_params(&self) -> usize {
        self.n_fit()
    }
    fn candidate_widths(&self) -> Vec<usize> {
        widths()
    }
    fn n_blocks(&self) -> usize {
        self.blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        let cols: Vec<usize> = (0..self.n_fit()).collect();
        sink.columns(&cols);
        for i in (64 * b..64 * (b + 1)).take_while(|&i| i < self.t.len()) {
            let (r, jac, extra) = self.row(i, x);
            sink.row(r, &jac, &extra);
        }
        Ok(())
    }
}

fn session(seed: u64, planted: impl Fn(f64) -> f64) -> Line {
    let mut g = rng(seed);
    let t: Vec<f64> = (0..500).map(|i| i as f64 / 500.0).collect();
    let y = t
        .iter()
        .map(|&t| 0.3 + 1.2 * t + planted(t) + SIGMA * normal(&mut g))
        .collect();
    Line {
        t,
        y,
        fitted_candidates: Vec::new(),
    }
}

fn specs(p: &Line) -> Vec<ParamSpec> {
    (0..p.n_fit())
        .map(|i| ParamSpec::new(format!("p{i}"), 0.0))
        .collect()
}

fn fit(p: &Line) -> mtcal_solve::Solution {
    solve(p, &specs(p), &options(2), &mut Silent).unwrap()
}

#[test]
fn the_score_is_the_drop_in_chi2_of_the_refit_with_its_amplitude_and_shifts() {
    // A cycle of 0.05 amplitude (half the noise of one sample) and a little curvature.
    let planted = |t: f64| 0.05 * (std::f64::consts::TAU * t / 0.25 + 0.7).sin() + 0.02 * t * t;
    let mut p = session(1, planted);
    let base = fit(&p);
    let scores = score_candidates(&p, &specs(&p), &base, 0.05, 2).unwrap();
    assert_eq!(scores.len(), 5);
    for k in [0, 1, 2, 4] {
        p.fitted_candidates = vec![k];
        let refit = fit(&p);
        let drop = base.chi2 - refit.chi2;
        let s = &scores[k];
        assert!(
            (s.statistic - drop).abs() < 1e-8 * base.chi2,
            "candidate {k}: score {} vs refit drop {drop}",
            s.statistic
        );
        assert_eq!(s.df, widths()[k]);
        for (j, amp) in s.amplitude.iter().enumerate() {
            let refit_value = refit.x[2 + j];
            assert!(
                (amp - refit_value).abs() < 1e-8,
                "candidate {k} amplitude {j}"
            );
            let sigma = s.amplitude_sigma[j].unwrap();
            assert!((sigma - refit.sigma[2 + j].unwrap()).abs() < 1e-8 * sigma);
        }
        for q in 0..2 {
            let moved = refit.x[q] - base.x[q];
            assert!(
                (s.shift[q] - moved).abs() < 1e-8,
                "candidate {k} shift of p{q}"
            );
        }
    }
    // The planted cycle is the strongest, and significant after Holm's correction.
    let best = (0..5)
        .max_by(|&a, &b| scores[a].statistic.total_cmp(&scores[b].statistic))
        .unwrap();
    assert_eq!(best, 0);
    assert!(scores[0].significant, "{:?}", scores[0]);
    let amp = scores[0].amplitude[0].hypot(scores[0].amplitude[1]);
    assert!((amp - 0.05).abs() < 4.0 * scores[0].amplitude_sigma[0].unwrap());
}

#[test]
fn a_candidate_inside_the_fitted_span_is_absorbed_and_untestable() {
    let p = session(2, |t| 0.1 * (2.0 - 3.0 * t));
    let base = fit(&p);
    let scores = score_candidates(&p, &specs(&p), &base, 0.05, 1).unwrap();
    let s = &scores[3];
    assert_eq!(s.df, 0, "{s:?}");
    assert!(s.absorbed > 1.0 - 1e-9, "{s:?}");
    assert_eq!(s.p_value, 1.0);
    assert!(!s.significant);
    assert!(s.amplitude_sigma.iter().all(Option::is_none));
    // A step halfway is partly absorbed by offset and slope, not wholly.
    assert!(
        scores[2].absorbed > 0.3 && scores[2].absorbed < 0.99,
        "{:?}",
        scores[2]
    );
}

#[test]
fn clean_sessions_raise_a_claim_in_about_alpha_of_them() {
    let sessions = 200;
    let claims = (0..sessions)
        .filter(|&seed| {
            let p = session(1000 + seed, |_| 0.0);
            let base = fit(&p);
            score_candidates(&p, &specs(&p), &base, 0.05, 1)
                .unwrap()
                .iter()
                .any(|s| s.significant)
        })
        .count();
    // Holm keeps the family-wise rate at or below 5 %: 10 of 200 expected at most; 18 or more
    // would happen by chance with probability below 1 %.
    assert!(
        claims < 18,
        "{claims} of {sessions} clean sessions raised a claim"
    );
}

#[test]
fn the_result_does_not_depend_on_threads() {
    let p = session(3, |t| 0.03 * t * t);
    let base = fit(&p);
    let one = score_candidates(&p, &specs(&p), &base, 0.05, 1).unwrap();
    let two = score_candidates(&p, &specs(&p), &base, 0.05, 2).unwrap();
    for (a, b) in one.iter().zip(&two) {
        assert!((a.statistic - b.statistic).abs() <= 1e-9 * (1.0 + a.statistic));
        assert_eq!(a.df, b.df);
    }
}

#[test]
fn a_solution_of_another_problem_is_an_error() {
    let p = session(4, |_| 0.0);
    let mut base = fit(&p);
    base.x.push(0.0);
    let err = score_candidates(&p, &specs(&p), &base, 0.05, 1).unwrap_err();
    assert!(err.to_string().contains("parameters"), "{err}");
}

/// Rows without a group, and rows of the wrong width, are errors naming the block.
struct Broken(usize);

impl ScoredProblem for Broken {
    fn n_params(&self) -> usize {
        2
    }
    fn candidate_widths(&self) -> Vec<usize> {
        vec![1]
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _: usize, _: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        match self.0 {
            0 => sink.row(0.0, &[], &[1.0]),
            1 => {
                sink.columns(&[0, 1]);
                sink.row(0.0, &[1.0, 2.0], &[1.0, 2.0]);
            }
            _ => {
                sink.columns(&[]);
                sink.row(f64::NAN, &[], &[1.0]);
            }
        }
        Ok(())
    }
}

#[test]
fn malformed_rows_are_errors_not_panics() {
    let p = session(5, |_| 0.0);
    let base = fit(&p);
    for (case, expected) in [
        (0, "before `columns`"),
        (1, "expected 2 and 1"),
        (2, "not finite"),
    ] {
        let err = score_candidates(&Broken(case), &specs(&p), &base, 0.05, 1).unwrap_err();
        assert!(err.to_string().contains(expected), "{err}");
        assert!(err.to_string().contains("block 0"), "{err}");
    }
}

/// A fit whose columns are given as functions of `t`, with candidate columns: for the
/// ill-conditioned case.
struct Columns {
    t: Vec<f64>,
    y: Vec<f64>,
    fitted: Vec<fn(f64) -> f64>,
    candidates: Vec<fn(f64) -> f64>,
}

impl Columns {
    fn row(&self, i: usize, x: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
        let t = self.t[i];
        let jac: Vec<f64> = self.fitted.iter().map(|f| f(t) / SIGMA).collect();
        let model: f64 = jac.iter().zip(x).map(|(a, b)| a * b).sum::<f64>() * SIGMA;
        let extra = self.candidates.iter().map(|f| f(t) / SIGMA).collect();
        ((model - self.y[i]) / SIGMA, jac, extra)
    }
}

impl Problem for Columns {
    fn n_params(&self) -> usize {
        self.fitted.len()
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&(0..self.fitted.len()).collect::<Vec<_>>());
        for i in 0..self.t.len() {
            let (r, jac, _) = self.row(i, x);
            sink.row(r, &jac);
        }
        Ok(())
    }
}

impl ScoredProblem for Columns {
    fn n_params(&self) -> usize {
        self.fitted.len()
    }
    fn candidate_widths(&self) -> Vec<usize> {
        vec![1; self.candidates.len()]
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        sink.columns(&(0..self.fitted.len()).collect::<Vec<_>>());
        for i in 0..self.t.len() {
            let (r, jac, extra) = self.row(i, x);
            sink.row(r, &jac, &extra);
        }
        Ok(())
    }
}

/// A rich model the data barely determine (two columns that differ by a ten-millionth: the
/// fit's factor keeps both, its Gram matrix cannot tell them apart) leaves a candidate outside
/// its span its degrees of freedom and its statistic (the drop in χ² of the refit), and still
/// calls a candidate inside the span absorbed. Before, the Gram matrix's rounding left every
/// candidate of such a fit zero degrees of freedom.
#[test]
fn a_candidate_outside_an_ill_conditioned_fit_keeps_its_degrees_of_freedom() {
    let mut g = rng(5);
    let t: Vec<f64> = (0..400).map(|i| i as f64 / 400.0).collect();
    let cycle = |t: f64| (std::f64::consts::TAU * t / 0.2).sin();
    let y: Vec<f64> = t
        .iter()
        .map(|&t| 0.5 + t + 0.3 * cycle(t) + SIGMA * normal(&mut g))
        .collect();
    let fitted: Vec<fn(f64) -> f64> = vec![|_| 1.0, |t| t, |t| t + 1e-7 * t * t];
    let p = Columns {
        t,
        y,
        fitted: fitted.clone(),
        candidates: vec![cycle, |t| 1.0 - 2.0 * t],
    };
    let specs: Vec<ParamSpec> = (0..3)
        .map(|i| ParamSpec::new(format!("p{i}"), 0.0))
        .collect();
    let base = solve(&p, &specs, &options(1), &mut Silent).unwrap();
    let scores = score_candidates(&p, &specs, &base, 0.05, 1).unwrap();
    assert_eq!(scores[0].df, 1, "{:?}", scores[0]);
    assert!(scores[0].significant);
    // The refit with the cycle: its χ² drop is the statistic.
    let mut with = fitted;
    with.push(cycle);
    let q = Columns {
        fitted: with,
        candidates: Vec::new(),
        ..p
    };
    let specs4: Vec<ParamSpec> = (0..4)
        .map(|i| ParamSpec::new(format!("p{i}"), 0.0))
        .collect();
    let refit = solve(&q, &specs4, &options(1), &mut Silent).unwrap();
    // Equal but for what the refit gains along the direction the Gram matrix cannot resolve.
    let drop = base.chi2 - refit.chi2;
    assert!(
        (scores[0].statistic - drop).abs() < 1e-4 * drop,
        "score {} vs drop {drop}",
        scores[0].statistic
    );
    // An offset and a slope: inside the span.
    assert_eq!(scores[1].df, 0);
    assert!(scores[1].absorbed > 0.99);
}
