//! Linear problems against dense references: solution, covariance, streaming vs dense,
//! threads and block order, conditioning, priors, bounds, fixed parameters.

use crate::common;

use common::*;
use mtcal_solve::{Options, ParamSpec, Silent, linearize, solve};
use nalgebra::{DMatrix, DVector};

#[test]
fn full_rank_solution_and_covariance_match_dense_reference() {
    let mut truth = Vec::new();
    let p = arrowhead(1, 5, 2, 4, 40, &mut truth);
    let sol = solve(&p, &params(p.n), &options(2), &mut Silent).unwrap();
    let (j, w) = p.dense();
    let (x_ref, c_ref) = reference(&j, &w);
    assert!(sol.converged, "{:?}", sol.termination);
    assert!(
        rel_err(&sol.x, x_ref.as_slice()) < 1e-10,
        "x error {:e}",
        rel_err(&sol.x, x_ref.as_slice())
    );
    let c_ref_rows: Vec<f64> = (0..p.n)
        .flat_map(|i| (0..p.n).map(move |k| (i, k)))
        .map(|(i, k)| c_ref[(i, k)])
        .collect();
    let err = rel_err(&sol.covariance, &c_ref_rows);
    assert!(err < 1e-10, "covariance error {err:e}");
    for i in 0..p.n {
        let s = sol.sigma[i].expect("identified");
        assert!((s - c_ref[(i, i)].sqrt()).abs() < 1e-10 * s);
    }
    assert_eq!(sol.rank, p.n);
    assert_eq!(sol.n_rows, 160);
    assert_eq!(sol.dof, 160 - p.n);
    assert!(sol.identified.iter().all(|&b| b));
    assert!(sol.combinations.is_empty());
    let resid = &j * &x_ref - &w;
    assert!((sol.chi2 - resid.norm_squared()).abs() < 1e-9 * sol.chi2);
    assert!((sol.chi2_reduced - sol.chi2 / sol.dof as f64).abs() < 1e-15);
    // The problem is linear: one damped step, one Gauss–Newton step, then the check.
    assert!(sol.iterations <= 3, "{} iterations", sol.iterations);
}

#[test]
fn streaming_in_small_groups_equals_one_dense_solve() {
    let mut truth = Vec::new();
    let p = arrowhead(2, 6, 3, 5, 23, &mut truth);
    let dense = p.as_single_dense_block();
    let a = solve(&p, &params(p.n), &options(2), &mut Silent).unwrap();
    let b = solve(&dense, &params(p.n), &options(1), &mut Silent).unwrap();
    assert!(rel_err(&a.x, &b.x) < 1e-10, "x {:e}", rel_err(&a.x, &b.x));
    assert!(rel_err(&a.covariance, &b.covariance) < 1e-10);
    // And the factor itself: RᵀR = JᵀJ.
    let lin = linearize(&p, &params(p.n), &vec![0.0; p.n], 3).unwrap();
    let n = p.n;
    let r = DMatrix::from_row_slice(n, n, &lin.r);
    let (j, _) = p.dense();
    let g = r.transpose() * &r;
    let want = j.transpose() * &j;
    assert!((g - &want).amax() < 1e-12 * want.amax());
    assert_eq!(lin.n_rows, 5 * 23);
}

#[test]
fn result_is_independent_of_threads_and_block_order() {
    let mut truth = Vec::new();
    let p = arrowhead(3, 8, 4, 9, 30, &mut truth);
    let base = solve(&p, &params(p.n), &options(1), &mut Silent).unwrap();
    let sig = |s: &mtcal_solve::Solution| s.sigma.iter().map(|v| v.unwrap()).collect::<Vec<_>>();
    for threads in [2, 3, 8] {
        let s = solve(&p, &params(p.n), &options(threads), &mut Silent).unwrap();
        assert!(
            rel_err(&s.x, &base.x) < 1e-12,
            "threads {threads}: {:e}",
            rel_err(&s.x, &base.x)
        );
        assert!(rel_err(&sig(&s), &sig(&base)) < 1e-12);
    }
    let mut reversed = p.clone();
    reversed.blocks.reverse();
    let s = solve(&reversed, &params(p.n), &options(2), &mut Silent).unwrap();
    assert!(
        rel_err(&s.x, &base.x) < 1e-12,
        "reversed: {:e}",
        rel_err(&s.x, &base.x)
    );
    assert!(rel_err(&sig(&s), &sig(&base)) < 1e-12);
}

/// Not merely close: the same bits on any number of threads and from run to run (blocks go to
/// fixed lanes merged in order). Near a rank threshold the rounding of a work-stealing sum
/// changed which directions a fit identified, and with it the χ² the search compared.
#[test]
fn result_is_bitwise_the_same_on_any_number_of_threads() {
    let mut truth = Vec::new();
    let p = arrowhead(3, 8, 4, 9, 30, &mut truth);
    let bits = |s: &mtcal_solve::Solution| {
        let mut b: Vec<u64> = s.x.iter().map(|v| v.to_bits()).collect();
        b.push(s.chi2.to_bits());
        b
    };
    let base = bits(&solve(&p, &params(p.n), &options(1), &mut Silent).unwrap());
    for threads in [2, 3, 8, 2, 3] {
        let s = solve(&p, &params(p.n), &options(threads), &mut Silent).unwrap();
        assert_eq!(bits(&s), base, "{threads} threads");
    }
}

/// A random matrix with prescribed singular values (log-spaced from 1 to 1/cond).
fn conditioned(m: usize, n: usize, cond: f64, seed: u64) -> DMatrix<f64> {
    let mut g = rng(seed);
    let a = DMatrix::from_fn(m, n, |_, _| normal(&mut g));
    let b = DMatrix::from_fn(n, n, |_, _| normal(&mut g));
    let q1 = a.qr().q();
    let q2 = b.qr().q();
    let s = DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| {
        cond.powf(-(i as f64) / (n - 1) as f64)
    }));
    q1 * s * q2.transpose()
}

fn from_dense(j: &DMatrix<f64>, w: &DVector<f64>, blocks: usize) -> Linear {
    let (m, n) = j.shape();
    let per = m.div_ceil(blocks);
    let rows: Vec<Row> = (0..m)
        .map(|i| Row {
            cols: (0..n).collect(),
            a: (0..n).map(|k| j[(i, k)]).collect(),
            y: w[i],
            sigma: 1.0,
        })
        .collect();
    Linear {
        n,
        blocks: rows.chunks(per).map(<[Row]>::to_vec).collect(),
    }
}

#[test]
fn ill_conditioned_problem_is_solved_accurately() {
    let (m, n) = (300, 8);
    let j = conditioned(m, n, 1e7, 11);
    let mut g = rng(12);
    let truth = DVector::from_fn(n, |_, _| uniform(&mut g, -1.0, 1.0));
    let w = &j * &truth + DVector::from_fn(m, |_, _| 1e-3 * normal(&mut g));
    let p = from_dense(&j, &w, 7);
    let sol = solve(&p, &params(n), &options(2), &mut Silent).unwrap();
    assert!(
        sol.condition_number > 1e6,
        "condition {:e}",
        sol.condition_number
    );
    assert_eq!(sol.rank, n);
    // Dense reference by SVD of J itself (backward stable, error ~ ε·cond).
    let x_ref = j.clone().svd(true, true).solve(&w, 0.0).unwrap();
    let ours = rel_err(&sol.x, x_ref.as_slice());
    assert!(ours < 1e-7, "error {ours:e}");
    // The normal equations lose about twice as many digits.
    let jtj = j.transpose() * &j;
    let x_ne = jtj.cholesky().map(|c| c.solve(&(j.transpose() * &w)));
    if let Some(x_ne) = x_ne {
        let ne = rel_err(x_ne.as_slice(), x_ref.as_slice());
        assert!(ne > 10.0 * ours, "normal equations {ne:e} vs QR {ours:e}");
    }
}

#[test]
fn prior_shifts_the_estimate_as_the_formula_says() {
    // y_i = x + noise (σ = 0.5), prior x ~ N(2, 0.3²).
    let ys = [1.1, 0.7, 1.4, 0.9, 1.2, 1.0];
    let sigma = 0.5;
    let rows: Vec<Row> = ys
        .iter()
        .map(|&y| Row {
            cols: vec![0],
            a: vec![1.0],
            y,
            sigma,
        })
        .collect();
    let p = Linear {
        n: 1,
        blocks: vec![rows],
    };
    let (mu, sp) = (2.0, 0.3);
    let mut spec = params(1);
    spec[0].prior = Some((mu, sp));
    let sol = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    let info = ys.len() as f64 / (sigma * sigma) + 1.0 / (sp * sp);
    let want = (ys.iter().sum::<f64>() / (sigma * sigma) + mu / (sp * sp)) / info;
    assert!((sol.x[0] - want).abs() < 1e-12, "{} vs {want}", sol.x[0]);
    assert!((sol.sigma[0].unwrap() - info.powf(-0.5)).abs() < 1e-12);
    assert_eq!(sol.n_prior_rows, 1);
    assert_eq!(sol.dof, ys.len());
    let chi2: f64 =
        ys.iter().map(|y| ((want - y) / sigma).powi(2)).sum::<f64>() + ((want - mu) / sp).powi(2);
    assert!((sol.chi2 - chi2).abs() < 1e-10);
}

/// Two correlated parameters with the unconstrained optimum near (1, 2).
fn correlated() -> Linear {
    let mut g = rng(5);
    let rows: Vec<Row> = (0..30)
        .map(|_| {
            let a = vec![uniform(&mut g, 0.5, 1.5), uniform(&mut g, 0.2, 1.0)];
            let y = a[0] * 1.0 + a[1] * 2.0 + 0.01 * normal(&mut g);
            Row {
                cols: vec![0, 1],
                a,
                y,
                sigma: 0.01,
            }
        })
        .collect();
    Linear {
        n: 2,
        blocks: vec![rows],
    }
}

#[test]
fn active_bound_is_respected_and_inactive_bounds_change_nothing() {
    let p = correlated();
    let free = solve(&p, &params(2), &options(1), &mut Silent).unwrap();
    assert!((free.x[0] - 1.0).abs() < 0.05 && (free.x[1] - 2.0).abs() < 0.1);

    let mut spec = params(2);
    spec[0].bounds = Some((-10.0, 10.0));
    spec[1].bounds = Some((f64::NEG_INFINITY, 100.0));
    let loose = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    assert_eq!(
        loose.x, free.x,
        "inactive bounds must return the unconstrained optimum"
    );

    let mut spec = params(2);
    spec[0].bounds = Some((-1.0, 0.5));
    let bounded = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    assert!(
        bounded.x[0] <= 0.5 && bounded.x[0] > 0.5 - 1e-7,
        "x0 = {}",
        bounded.x[0]
    );
    // With x0 on its bound, x1 is the conditional optimum: the solution with x0 fixed at 0.5.
    let mut fixed = params(2);
    fixed[0].initial = 0.5;
    fixed[0].fixed = true;
    let cond = solve(&p, &fixed, &options(1), &mut Silent).unwrap();
    assert!(
        (bounded.x[1] - cond.x[1]).abs() < 1e-6 * (1.0 + cond.x[1].abs()),
        "{} vs {}",
        bounded.x[1],
        cond.x[1]
    );
    assert!(bounded.cost > free.cost);
}

#[test]
fn fixed_parameter_keeps_its_value_and_the_rest_match_the_reduced_problem() {
    let mut truth = Vec::new();
    let p = arrowhead(8, 4, 1, 3, 20, &mut truth);
    let mut spec = params(p.n);
    spec[2].fixed = true;
    spec[2].initial = 0.25;
    let sol = solve(&p, &spec, &options(2), &mut Silent).unwrap();
    assert_eq!(sol.x[2], 0.25);
    assert_eq!(sol.sigma[2], None);
    assert!(!sol.identified[2]);
    let (j, w) = p.dense();
    let keep: Vec<usize> = (0..p.n).filter(|&c| c != 2).collect();
    let jr = j.select_columns(&keep);
    let wr = &w - j.column(2) * 0.25;
    let (x_ref, c_ref) = reference(&jr, &wr);
    for (k, &c) in keep.iter().enumerate() {
        assert!((sol.x[c] - x_ref[k]).abs() < 1e-10 * (1.0 + x_ref[k].abs()));
        assert!((sol.sigma[c].unwrap() - c_ref[(k, k)].sqrt()).abs() < 1e-10);
    }
    assert_eq!(sol.cov(2, 0), 0.0);
}

/// The step of a linearisation of a linear problem lands on the solution (fixed parameters
/// stay), whatever the point it was taken at.
#[test]
fn the_step_of_a_linearisation_reaches_the_least_squares_solution() {
    let mut truth = Vec::new();
    let p = arrowhead(8, 4, 1, 3, 20, &mut truth);
    let mut spec = params(p.n);
    spec[2].fixed = true;
    spec[2].initial = 0.25;
    let sol = solve(&p, &spec, &options(2), &mut Silent).unwrap();
    let x0: Vec<f64> = (0..p.n)
        .map(|i| if i == 2 { 0.25 } else { 0.1 * i as f64 })
        .collect();
    let lin = linearize(&p, &spec, &x0, 2).unwrap();
    let dx = lin.step(1e-9).unwrap();
    assert_eq!(dx[2], 0.0);
    let x: Vec<f64> = x0.iter().zip(&dx).map(|(a, b)| a + b).collect();
    assert!(rel_err(&x, &sol.x) < 1e-10, "{:e}", rel_err(&x, &sol.x));
}

#[test]
fn options_default_is_sensible() {
    let o = Options::default();
    assert!(o.lm && o.threads == 0 && o.rank_tolerance == 1e-9 && o.max_iterations > 10);
    let _ = ParamSpec::new("a", 1.0);
}
