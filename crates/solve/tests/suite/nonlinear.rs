//! Nonlinear problems: convergence from distant starts, Gauss–Newton mode, failed trial points.

use crate::common;

use common::*;
use mtcal_solve::{
    EvalError, Observer, Options, ParamSpec, Problem, RowSink, Silent, Termination, solve,
};

/// Circle fit: parameters (cx, cy, r); residual = (distance to centre − r)/σ.
struct Circle {
    pts: Vec<(f64, f64)>,
    sigma: f64,
}

impl Problem for Circle {
    fn n_params(&self) -> usize {
        3
    }
    fn n_blocks(&self) -> usize {
        self.pts.len().div_ceil(16)
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&[0, 1, 2]);
        for &(px, py) in self.pts.iter().skip(16 * b).take(16) {
            let (dx, dy) = (px - x[0], py - x[1]);
            let d = dx.hypot(dy);
            if d == 0.0 {
                return Err(EvalError::new("a point coincides with the centre"));
            }
            let s = self.sigma;
            sink.row((d - x[2]) / s, &[-dx / d / s, -dy / d / s, -1.0 / s]);
        }
        Ok(())
    }
}

fn circle(seed: u64) -> Circle {
    let mut g = rng(seed);
    let sigma = 0.01;
    let pts = (0..200)
        .map(|_| {
            // Only an arc of 120°: a harder, more correlated fit.
            let t = uniform(&mut g, 0.0, 2.1);
            let r = 5.0 + sigma * normal(&mut g);
            (3.0 + r * t.cos(), -2.0 + r * t.sin())
        })
        .collect();
    Circle { pts, sigma }
}

fn circle_params(start: [f64; 3]) -> Vec<ParamSpec> {
    ["cx", "cy", "r"]
        .iter()
        .zip(start)
        .map(|(n, v)| ParamSpec::new(*n, v))
        .collect()
}

#[derive(Default)]
struct Count {
    iterations: usize,
    last_cost: f64,
    rows_calls: usize,
}

impl Observer for Count {
    fn iteration(&mut self, it: usize, cost: f64, _lambda: f64) {
        self.iterations = it;
        if it > 0 {
            assert!(cost < self.last_cost, "accepted steps lower the cost");
        }
        self.last_cost = cost;
    }
    fn rows(&mut self, done: usize, total: usize) {
        assert!(done <= total);
        self.rows_calls += 1;
    }
}

#[test]
fn circle_fit_converges_from_a_distant_start() {
    let p = circle(21);
    let mut obs = Count::default();
    // 20 units from the centre and a fifth of the radius, on the concave side of the arc. (From
    // the convex side the cost falls all the way to the straight-line fit at infinite radius.)
    let a = solve(
        &p,
        &circle_params([-7.0, -19.0, 1.0]),
        &options(2),
        &mut obs,
    )
    .unwrap();
    assert!(
        a.converged,
        "{:?} after {} iterations",
        a.termination, a.iterations
    );
    assert_eq!(obs.iterations, a.iterations);
    assert!(obs.rows_calls >= p.n_blocks());
    for (x, (t, s)) in a.x.iter().zip([3.0, -2.0, 5.0].into_iter().zip(&a.sigma)) {
        assert!(
            (x - t).abs() < 5.0 * s.unwrap(),
            "{x} vs {t} ± {}",
            s.unwrap()
        );
    }
    // The same optimum from another start, to the tolerance.
    let b = solve(
        &p,
        &circle_params([3.5, -1.0, 4.0]),
        &options(1),
        &mut Silent,
    )
    .unwrap();
    assert!(rel_err(&a.x, &b.x) < 1e-9, "{:?} vs {:?}", a.x, b.x);
    assert!(
        (a.chi2_reduced - 1.0).abs() < 0.25,
        "chi2/dof {}",
        a.chi2_reduced
    );
}

/// y = A·exp(−k t) + c.
struct Decay {
    t: Vec<f64>,
    y: Vec<f64>,
    sigma: f64,
}

impl Problem for Decay {
    fn n_params(&self) -> usize {
        3
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&[0, 1, 2]);
        let s = self.sigma;
        for (&t, &y) in self.t.iter().zip(&self.y) {
            let e = (-x[1] * t).exp();
            sink.row(
                (x[0] * e + x[2] - y) / s,
                &[e / s, -x[0] * t * e / s, 1.0 / s],
            );
        }
        Ok(())
    }
}

fn decay() -> Decay {
    let mut g = rng(4);
    let sigma = 0.02;
    let t: Vec<f64> = (0..80).map(|i| i as f64 * 0.05).collect();
    let y = t
        .iter()
        .map(|t| 5.0 * (-1.3 * t).exp() + 0.5 + sigma * normal(&mut g))
        .collect();
    Decay { t, y, sigma }
}

#[test]
fn exponential_decay_converges_with_lm_and_with_gauss_newton() {
    let p = decay();
    let spec: Vec<ParamSpec> = [("A", 1.0), ("k", 0.1), ("c", 0.0)]
        .iter()
        .map(|(n, v)| ParamSpec::new(*n, *v))
        .collect();
    let lm = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    assert!(lm.converged);
    assert!((lm.x[1] - 1.3).abs() < 5.0 * lm.sigma[1].unwrap());
    let gn_opts = Options {
        lm: false,
        threads: 1,
        ..Options::default()
    };
    let near: Vec<ParamSpec> = [("A", 4.0), ("k", 1.0), ("c", 0.4)]
        .iter()
        .map(|(n, v)| ParamSpec::new(*n, *v))
        .collect();
    let gn = solve(&p, &near, &gn_opts, &mut Silent).unwrap();
    assert!(gn.converged, "{:?}", gn.termination);
    assert!(rel_err(&gn.x, &lm.x) < 1e-9);
}

/// r = (√x − y): undefined for x < 0, which a full Gauss–Newton step from x = 4 reaches.
struct Sqrt;

impl Problem for Sqrt {
    fn n_params(&self) -> usize {
        1
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        if x[0] < 0.0 {
            return Err(EvalError::new(format!("x = {} < 0", x[0])));
        }
        let s = x[0].sqrt();
        sink.columns(&[0]);
        sink.row(s - 0.1, &[0.5 / s]);
        sink.row(s - 0.1, &[0.5 / s]);
        Ok(())
    }
}

#[test]
fn failed_trial_point_rejects_the_step_and_the_solve_goes_on() {
    let gn = Options {
        lm: false,
        threads: 1,
        ..Options::default()
    };
    let sol = solve(&Sqrt, &[ParamSpec::new("x", 4.0)], &gn, &mut Silent).unwrap();
    assert!(sol.converged);
    // Converged to 1e-10 standard deviations (σ ≈ 0.14 here).
    assert!((sol.x[0] - 0.01).abs() < 1e-10, "{}", sol.x[0]);
    assert!(
        sol.evaluations > sol.iterations + 1,
        "some trial points must have failed"
    );
    assert!(sol.cost < 1e-20);
}

#[test]
fn max_iterations_is_reported() {
    let p = circle(3);
    let opts = Options {
        max_iterations: 1,
        threads: 1,
        ..Options::default()
    };
    let sol = solve(&p, &circle_params([-20.0, 30.0, 1.0]), &opts, &mut Silent).unwrap();
    assert_eq!(sol.termination, Termination::MaxIterations);
    assert!(!sol.converged);
    assert_eq!(sol.iterations, 1);
    assert!(sol.x.iter().all(|v| v.is_finite()));
}

/// The last, statistically negligible Gauss–Newton step is taken without a further pass over
/// the data. What is returned must still be the optimum: solving again from the returned point
/// moves it by far less than its uncertainty, and the reported χ² is the χ² there.
#[test]
fn the_final_step_without_evaluation_lands_on_the_optimum() {
    let p = circle(5);
    let a = solve(
        &p,
        &circle_params([2.0, -1.0, 4.5]),
        &options(1),
        &mut Silent,
    )
    .unwrap();
    assert!(a.converged, "{:?}", a.termination);
    let b = solve(
        &p,
        &circle_params([a.x[0], a.x[1], a.x[2]]),
        &options(1),
        &mut Silent,
    )
    .unwrap();
    for i in 0..3 {
        let sigma = a.sigma[i].unwrap();
        assert!(
            (a.x[i] - b.x[i]).abs() < 1e-4 * sigma,
            "parameter {i}: {} vs {} (σ {sigma})",
            a.x[i],
            b.x[i]
        );
    }
    assert!(
        (a.chi2 - b.chi2).abs() < 1e-6,
        "χ² {} vs {}",
        a.chi2,
        b.chi2
    );
    assert!(
        b.iterations <= 1,
        "restart took {} iterations",
        b.iterations
    );
}

/// The chord method (gradient-only passes on the last factor) ends where building a factor at
/// every trial point ends: the same estimate to far below its uncertainty, the same
/// uncertainties to 0.1 %, the same χ², with fewer factorisations.
#[test]
fn chord_steps_end_where_full_factorisations_end() {
    let p = circle(7);
    let start = circle_params([3.02, -2.03, 5.01]);
    let full = solve(
        &p,
        &start,
        &Options {
            chord: false,
            ..options(2)
        },
        &mut Silent,
    )
    .unwrap();
    let chord = solve(&p, &start, &options(2), &mut Silent).unwrap();
    assert!(full.converged && chord.converged);
    assert_eq!(full.factorizations, full.evaluations);
    assert!(
        chord.factorizations < chord.evaluations,
        "the chord path was not taken: {} factorisations of {} evaluations",
        chord.factorizations,
        chord.evaluations
    );
    assert!(chord.factorizations <= full.factorizations);
    for i in 0..3 {
        let (sf, sc) = (full.sigma[i].unwrap(), chord.sigma[i].unwrap());
        assert!((full.x[i] - chord.x[i]).abs() < 1e-3 * sf, "x[{i}]");
        assert!((sf - sc).abs() < 1e-3 * sf, "σ[{i}] {sf} vs {sc}");
    }
    assert!((full.chi2 - chord.chi2).abs() < 1e-6 * full.chi2.max(1.0));
    assert_eq!(full.rank, chord.rank);
}

/// `y = a·t + a·b·t²`: at the start a = b = 0 the column of b is zero (rank 1), away from it
/// both are identified. The chord method must not keep the start's rank: the answer has rank
/// 2 and matches the solve that factors every point.
struct Product {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Problem for Product {
    fn n_params(&self) -> usize {
        2
    }
    fn n_blocks(&self) -> usize {
        self.t.len().div_ceil(32)
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&[0, 1]);
        let s = 0.01;
        for (&t, &y) in self.t.iter().zip(&self.y).skip(32 * b).take(32) {
            let model = x[0] * t + x[0] * x[1] * t * t;
            sink.row((model - y) / s, &[(t + x[1] * t * t) / s, x[0] * t * t / s]);
        }
        Ok(())
    }
}

#[test]
fn a_rank_gained_away_from_a_degenerate_start_is_kept() {
    let mut g = rng(3);
    let t: Vec<f64> = (0..400).map(|i| i as f64 / 400.0).collect();
    let y = t
        .iter()
        .map(|t| 2.0 * t + 2.0 * 0.5 * t * t + 0.01 * normal(&mut g))
        .collect();
    let p = Product { t, y };
    let start = vec![ParamSpec::new("a", 0.0), ParamSpec::new("b", 0.0)];
    let full = solve(
        &p,
        &start,
        &Options {
            chord: false,
            ..options(1)
        },
        &mut Silent,
    )
    .unwrap();
    let chord = solve(&p, &start, &options(1), &mut Silent).unwrap();
    assert_eq!(full.rank, 2);
    assert_eq!(chord.rank, 2, "{:?}", chord.combinations);
    for i in 0..2 {
        let s = full.sigma[i].unwrap();
        assert!((full.x[i] - chord.x[i]).abs() < 1e-3 * s, "x[{i}]");
        assert!((s - chord.sigma[i].unwrap()).abs() < 1e-3 * s, "σ[{i}]");
    }
}

/// `y = (a + b)·t + c·t² + 0.0001·c²·t³`: `a` and `b` enter only as their sum everywhere (a genuine
/// null direction, as a ball height and a tool length do), and `c` is nonlinear. The rank is the
/// same at the start as at the solution, so the chord method runs from the first factor: one
/// factorisation, two passes, and the answer of the solve that factors every point.
struct SumAndSquare {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Problem for SumAndSquare {
    fn n_params(&self) -> usize {
        3
    }
    fn n_blocks(&self) -> usize {
        self.t.len().div_ceil(32)
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&[0, 1, 2]);
        let s = 0.01;
        let c = x[2];
        for (&t, &y) in self.t.iter().zip(&self.y).skip(32 * b).take(32) {
            let model = (x[0] + x[1]) * t + c * t * t + 0.0001 * c * c * t * t * t;
            let dc = t * t + 0.0002 * c * t * t * t;
            sink.row((model - y) / s, &[t / s, t / s, dc / s]);
        }
        Ok(())
    }
}

#[test]
fn a_constant_null_space_from_the_start_needs_one_factor() {
    let mut g = rng(5);
    let t: Vec<f64> = (0..400).map(|i| i as f64 / 400.0).collect();
    let y = t
        .iter()
        .map(|t| 1.5 * t + 0.4 * t * t + 0.000016 * t * t * t + 0.01 * normal(&mut g))
        .collect();
    let p = SumAndSquare { t, y };
    let start = vec![
        ParamSpec::new("a", 0.0),
        ParamSpec::new("b", 0.0),
        ParamSpec::new("c", 0.0),
    ];
    let full = solve(
        &p,
        &start,
        &Options {
            chord: false,
            ..options(1)
        },
        &mut Silent,
    )
    .unwrap();
    let chord = solve(&p, &start, &options(1), &mut Silent).unwrap();
    assert!(full.converged && chord.converged);
    assert_eq!((full.rank, chord.rank), (2, 2));
    assert_eq!(chord.factorizations, 1, "{} evaluations", chord.evaluations);
    // Nearly linear: the first chord step leaves an error far below 1 % of σ and ends it
    // without another pass.
    assert_eq!(chord.evaluations, 2);
    assert!(full.factorizations > 1);
    assert_eq!(chord.combinations.len(), 1);
    assert_eq!(chord.combinations[0].params, full.combinations[0].params);
    assert_eq!(chord.combinations[0].why, full.combinations[0].why);
    let (sf, sc) = (full.sigma[2].unwrap(), chord.sigma[2].unwrap());
    assert!((full.x[2] - chord.x[2]).abs() < 1e-3 * sf, "c");
    assert!((sf - sc).abs() < 1e-3 * sf, "σ(c) {sf} vs {sc}");
    // The sum is determined; its parts are not (no σ for them).
    assert!(((full.x[0] + full.x[1]) - (chord.x[0] + chord.x[1])).abs() < 1e-3 * sf);
    assert!(chord.sigma[0].is_none() && chord.sigma[1].is_none());
}
