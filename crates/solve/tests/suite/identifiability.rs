//! Rank-deficient problems: combinations, identified flags, σ, covariance, minimum-norm steps.

use crate::common;

use common::*;
use mtcal_solve::{ParamSpec, Silent, solve};

/// Rows `y = Σ a_k x_k` where the columns are built from `basis` vectors: each row draws random
/// weights for `basis.len()` latent directions and maps them through `basis` (one per column), so
/// that only the latent combinations are observed.
fn latent(n: usize, columns: &[Vec<f64>], truth: &[f64], rows: usize, seed: u64) -> Linear {
    let mut g = rng(seed);
    let n_latent = columns[0].len();
    let block: Vec<Row> = (0..rows)
        .map(|_| {
            let w: Vec<f64> = (0..n_latent).map(|_| uniform(&mut g, -1.0, 1.0)).collect();
            let a: Vec<f64> = columns
                .iter()
                .map(|c| c.iter().zip(&w).map(|(ci, wi)| ci * wi).sum())
                .collect();
            let sigma = 0.1;
            let y = a.iter().zip(truth).map(|(a, t)| a * t).sum::<f64>() + sigma * normal(&mut g);
            let cols: Vec<usize> = (0..n).filter(|&c| a[c] != 0.0).collect();
            let a = cols.iter().map(|&c| a[c]).collect();
            Row { cols, a, y, sigma }
        })
        .collect();
    Linear {
        n,
        blocks: block.chunks(9).map(<[Row]>::to_vec).collect(),
    }
}

#[test]
fn only_the_sum_observed_leaves_a_readable_combination() {
    // Columns: p0 and p1 identical (only p0 + p1 observed), p2 independent, p3 never touched.
    let cols = vec![
        vec![1.0, 0.0],
        vec![1.0, 0.0],
        vec![0.0, 1.0],
        vec![0.0, 0.0],
    ];
    let p = latent(4, &cols, &[0.7, 0.3, -1.0, 0.0], 50, 1);
    let mut spec = params(4);
    spec[0].initial = 0.3;
    spec[1].initial = 0.1;
    spec[3].initial = 0.42;
    let sol = solve(&p, &spec, &options(2), &mut Silent).unwrap();
    assert!(sol.converged);
    assert_eq!(sol.rank, 2);
    assert_eq!(sol.combinations.len(), 2, "{:#?}", sol.combinations);
    let sum = &sol.combinations[0];
    assert_eq!(sum.params, vec![0, 1]);
    assert!(
        (sum.coefficients[1] + 1.0).abs() < 1e-9,
        "{:?}",
        sum.coefficients
    );
    assert!(
        sum.why.starts_with("only their sum is observed"),
        "{}",
        sum.why
    );
    assert!(sum.why.contains("p0") && sum.why.contains("p1"));
    let lone = &sol.combinations[1];
    assert_eq!(lone.params, vec![3]);
    assert_eq!(lone.why, "p3 is not observed by these runs");
    assert_eq!(sol.identified, vec![false, false, true, false]);
    assert_eq!(sol.sigma[0], None);
    assert_eq!(sol.sigma[1], None);
    assert_eq!(sol.sigma[3], None);
    assert!(sol.sigma[2].unwrap() > 0.0);
    // Unidentified rows and columns of the covariance are zero.
    for j in 0..4 {
        assert_eq!(sol.cov(0, j), 0.0);
        assert_eq!(sol.cov(j, 3), 0.0);
    }
    // Minimum-norm steps: the unobserved direction (p0 − p1) and p3 keep their initial values.
    assert!((sol.x[0] - sol.x[1] - 0.2).abs() < 1e-12, "{:?}", sol.x);
    assert_eq!(sol.x[3], 0.42);
    // The observed sum is estimated.
    assert!((sol.x[0] + sol.x[1] - 1.0).abs() < 0.1);
    assert_eq!(sol.dof, 50 - 2);
    assert_eq!(sol.singular_values.len(), 4);
    assert!(sol.singular_values.iter().all(|s| s.is_finite()));
    assert!(sol.condition_number >= 1.0 && sol.condition_number.is_finite());
    // p2 is identified: its σ matches the reduced problem with p0 + p1 as one parameter.
    let reduced_cols = vec![vec![1.0, 0.0], vec![0.0, 1.0]];
    let reduced = latent(2, &reduced_cols, &[1.0, -1.0], 50, 1);
    let (j, w) = reduced.dense();
    let (x_ref, c_ref) = reference(&j, &w);
    assert!((sol.sigma[2].unwrap() - c_ref[(1, 1)].sqrt()).abs() < 1e-10);
    assert!((sol.x[2] - x_ref[1]).abs() < 1e-10);
    assert!((sol.x[0] + sol.x[1] - x_ref[0]).abs() < 1e-10);
}

#[test]
fn two_dimensional_null_space_over_four_parameters_gives_two_combinations() {
    // Equal columns p0 = p1: moving them oppositely changes nothing, only their sum is observed.
    // Opposite columns p2 = −p3: moving them together changes nothing, only their difference is
    // observed. p4 is identified.
    let cols = vec![
        vec![1.0, 0.0, 0.0],
        vec![1.0, 0.0, 0.0],
        vec![0.0, 1.0, 0.0],
        vec![0.0, -1.0, 0.0],
        vec![0.3, 0.2, 1.0],
    ];
    let p = latent(5, &cols, &[1.0, 2.0, 3.0, 4.0, 5.0], 60, 2);
    let sol = solve(&p, &params(5), &options(2), &mut Silent).unwrap();
    assert_eq!(sol.rank, 3);
    let c = &sol.combinations;
    assert_eq!(c.len(), 2, "{c:#?}");
    assert_eq!(c[0].params, vec![0, 1]);
    assert!(
        c[0].why.starts_with("only their sum is observed"),
        "{}",
        c[0].why
    );
    assert_eq!(c[1].params, vec![2, 3]);
    assert!(
        c[1].why.starts_with("only their difference is observed"),
        "{}",
        c[1].why
    );
    assert!((c[1].coefficients[1] - 1.0).abs() < 1e-9);
    assert_eq!(sol.identified, vec![false, false, false, false, true]);
}

#[test]
fn a_prior_makes_the_sum_identifiable() {
    let cols = vec![vec![1.0], vec![1.0]];
    let p = latent(2, &cols, &[0.7, 0.3], 40, 3);
    let mut spec = params(2);
    spec[0].prior = Some((0.7, 0.05));
    let sol = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    assert_eq!(sol.rank, 2);
    assert!(sol.combinations.is_empty());
    assert!(sol.identified.iter().all(|&b| b));
    // Information [[S + 1/σp², S], [S, S]] with S = Σ(a/σ)²: Var(p1) = σp² + 1/S, Var(p0) = σp².
    let s: f64 = p
        .blocks
        .iter()
        .flatten()
        .map(|r| (r.a[0] / r.sigma).powi(2))
        .sum();
    let s1 = sol.sigma[1].unwrap();
    assert!(
        (s1 - (0.05f64.powi(2) + 1.0 / s).sqrt()).abs() < 1e-12,
        "{s1}"
    );
    assert!((sol.sigma[0].unwrap() - 0.05).abs() < 1e-12);
    let corr = -0.05 / s1;
    assert!((sol.correlation(0, 1).unwrap() - corr).abs() < 1e-10);
}

#[test]
fn scaled_columns_give_coefficients_in_parameter_units() {
    // Column of p1 is 1000× that of p0 (e.g. mm vs m): only p0 + 1000·p1 is observed.
    let cols = vec![vec![1.0, 0.0], vec![1000.0, 0.0], vec![0.0, 1.0]];
    let p = latent(3, &cols, &[0.5, 0.001, 2.0], 30, 4);
    let sol = solve(&p, &params(3), &options(1), &mut Silent).unwrap();
    let c = &sol.combinations[0];
    assert_eq!(c.params, vec![0, 1]);
    assert!(
        (c.coefficients[1] + 1e-3).abs() < 1e-12,
        "{:?}",
        c.coefficients
    );
    assert!(
        c.why
            .starts_with("only the combination p0 + 1000*p1 is observed"),
        "{}",
        c.why
    );
    let _ = ParamSpec::default();
}

/// Every parameter with a plausible range of 1.
fn with_plausible_ranges(mut spec: Vec<ParamSpec>) -> Vec<ParamSpec> {
    for s in &mut spec {
        s.scale = Some(1.0);
    }
    spec
}

/// A null direction made of an almost invisible parameter and a constant (an angle seen only
/// as an offset the run's zero takes) that carries, through a tiny second coupling, a trace of
/// a well-determined parameter: that parameter moves by 10⁻⁹ of its plausible range while the
/// others roam over theirs. It stays identified, with its number; the direction is described
/// without it. Without plausible ranges nothing is dropped.
#[test]
fn a_negligible_member_of_a_null_direction_keeps_its_number() {
    // Latent directions: a slope (seen by p0) and a constant (p1, and p2 through a short
    // lever). p2's column is 2.5e-4 × p1's plus 1e-9 × p0's: exactly in their span, and in
    // scaled units p0's share of the direction is 4e-6, above the rounding threshold.
    let cols = vec![vec![1.0, 0.0], vec![0.0, 1.0], vec![1e-9, 2.5e-4]];
    let p = latent(3, &cols, &[2.0, 0.5, 0.0], 60, 4);
    let spec = with_plausible_ranges(params(3));
    let sol = solve(&p, &spec, &options(1), &mut Silent).unwrap();
    assert_eq!(sol.rank, 2);
    assert!(sol.identified[0], "{:#?}", sol.combinations);
    assert!(sol.sigma[0].is_some());
    assert_eq!(sol.combinations.len(), 1);
    // p1 moves by 2.5e-4 while p2 crosses its plausible range: a hundredth of p1's σ (≈ 0.02),
    // so p1 keeps its number too, and what is left unobserved is p2 itself.
    assert_eq!(sol.combinations[0].params, vec![2]);
    assert!(sol.identified[1]);
    // Without plausible ranges the trace keeps p0 in the combination (the old rule).
    let sol = solve(&p, &params(3), &options(1), &mut Silent).unwrap();
    assert!(!sol.identified[0], "{:#?}", sol.combinations);
}

/// The same kind of direction where the well-determined parameter's trace is larger (10⁻⁴ of
/// its plausible range, above the range rule) but still moves it by less than a tenth of its
/// own uncertainty while the others roam over their plausible ranges: it keeps its number. A
/// trace that moves it by more than that (5·10⁻² against σ ≈ 0.02) keeps it in the
/// combination, unidentified.
#[test]
fn a_member_moved_by_less_than_a_tenth_of_its_sigma_keeps_its_number() {
    for (trace, identified) in [(1e-4, true), (5e-2, false)] {
        let cols = vec![vec![1.0, 0.0], vec![0.0, 1.0], vec![trace, 0.5]];
        let p = latent(3, &cols, &[2.0, 0.5, 0.0], 60, 4);
        let spec = with_plausible_ranges(params(3));
        let sol = solve(&p, &spec, &options(1), &mut Silent).unwrap();
        assert_eq!(sol.rank, 2);
        let sigma0 = (1.0 / sol.n_rows as f64).sqrt();
        assert_eq!(
            sol.identified[0], identified,
            "trace {trace} (σ0 ≈ {sigma0:.3}): {:#?}",
            sol.combinations
        );
        assert_eq!(sol.sigma[0].is_some(), identified);
        assert_eq!(sol.combinations.len(), 1);
        let expected: Vec<usize> = if identified {
            vec![1, 2]
        } else {
            vec![0, 1, 2]
        };
        assert_eq!(sol.combinations[0].params, expected, "trace {trace}");
    }
}
