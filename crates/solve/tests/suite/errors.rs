//! Every failure is an error that says what and where; nothing returns NaN.

use crate::common;

use common::*;
use mtcal_solve::{EvalError, ParamSpec, Problem, RowSink, Silent, SolveError, solve};

/// One block of rows `r = x0 − 1`; `bad` injects a fault at block 2, row 3.
struct Faulty {
    bad: &'static str,
}

impl Problem for Faulty {
    fn n_params(&self) -> usize {
        2
    }
    fn n_blocks(&self) -> usize {
        4
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        if b == 2 && self.bad == "eval" {
            return Err(EvalError::new("model undefined"));
        }
        if b == 2 && self.bad == "columns" {
            sink.columns(&[1, 0]);
        } else {
            sink.columns(&[0, 1]);
        }
        for i in 0..5 {
            let mut r = x[0] - 1.0;
            let mut jac = [1.0, 0.5];
            if b == 2 && i == 3 {
                match self.bad {
                    "residual" => r = f64::NAN,
                    "jacobian" => jac[1] = f64::INFINITY,
                    "length" => {
                        sink.row(r, &[1.0]);
                        continue;
                    }
                    _ => {}
                }
            }
            sink.row(r, &jac);
        }
        Ok(())
    }
}

fn run(bad: &'static str) -> Result<mtcal_solve::Solution, SolveError> {
    let spec = vec![ParamSpec::new("a", 0.0), ParamSpec::new("b", 0.0)];
    solve(&Faulty { bad }, &spec, &options(2), &mut Silent)
}

#[test]
fn non_finite_values_name_block_row_and_parameter() {
    match run("residual") {
        Err(SolveError::NonFiniteResidual {
            block: 2,
            row: 3,
            value,
        }) => assert!(value.is_nan()),
        other => panic!("{other:?}"),
    }
    let err = run("jacobian").unwrap_err();
    assert_eq!(
        err,
        SolveError::NonFiniteJacobian {
            block: 2,
            row: 3,
            param: 1,
            name: "b".into(),
            value: f64::INFINITY
        }
    );
    assert_eq!(
        err.to_string(),
        "block 2, row 3: the derivative by parameter 1 (b) is inf (non-finite)"
    );
}

#[test]
fn malformed_input_is_reported() {
    assert!(matches!(
        run("eval"),
        Err(SolveError::Eval { block: 2, .. })
    ));
    assert!(matches!(
        run("columns"),
        Err(SolveError::InvalidColumns { block: 2, .. })
    ));
    assert!(matches!(
        run("length"),
        Err(SolveError::InvalidRow {
            block: 2,
            row: 3,
            ..
        })
    ));
    // The healthy problem solves: every row has the derivatives (1, 0.5), so only a + 0.5·b is
    // observed.
    let sol = run("").unwrap();
    assert_eq!(sol.rank, 1);
    assert_eq!(sol.combinations.len(), 1);
    assert!(
        sol.combinations[0]
            .why
            .starts_with("only the combination a + 0.5*b is observed"),
        "{}",
        sol.combinations[0].why
    );
}

#[test]
fn bad_setups_are_rejected() {
    let p = Faulty { bad: "" };
    let one = vec![ParamSpec::new("a", 0.0)];
    assert_eq!(
        solve(&p, &one, &options(1), &mut Silent).unwrap_err(),
        SolveError::ParamCount {
            expected: 2,
            got: 1
        }
    );
    let mut fixed = vec![ParamSpec::new("a", 0.0), ParamSpec::new("b", 0.0)];
    fixed.iter_mut().for_each(|s| s.fixed = true);
    assert_eq!(
        solve(&p, &fixed, &options(1), &mut Silent).unwrap_err(),
        SolveError::AllFixed { n: 2 }
    );
    let mut prior = vec![ParamSpec::new("a", 0.0), ParamSpec::new("b", 0.0)];
    prior[1].prior = Some((0.0, 0.0));
    assert!(matches!(
        solve(&p, &prior, &options(1), &mut Silent),
        Err(SolveError::InvalidParam { index: 1, .. })
    ));
    let mut bounds = vec![ParamSpec::new("a", 0.0), ParamSpec::new("b", 0.0)];
    bounds[0].bounds = Some((1.0, -1.0));
    assert!(matches!(
        solve(&p, &bounds, &options(1), &mut Silent),
        Err(SolveError::InvalidParam { index: 0, .. })
    ));
    let mut nan = vec![ParamSpec::new("a", f64::NAN), ParamSpec::new("b", 0.0)];
    assert!(matches!(
        solve(&p, &nan, &options(1), &mut Silent),
        Err(SolveError::InvalidParam { index: 0, .. })
    ));
    nan[0].initial = 0.0;
    let empty = Linear {
        n: 2,
        blocks: vec![],
    };
    assert!(matches!(
        solve(&empty, &nan, &options(1), &mut Silent),
        Err(SolveError::Empty(_))
    ));
    let no_rows = Linear {
        n: 2,
        blocks: vec![vec![], vec![]],
    };
    assert!(matches!(
        solve(&no_rows, &nan, &options(1), &mut Silent),
        Err(SolveError::Empty(_))
    ));
    let none = Linear {
        n: 0,
        blocks: vec![],
    };
    assert!(matches!(
        solve(&none, &[], &options(1), &mut Silent),
        Err(SolveError::Empty(_))
    ));
}

#[test]
fn only_priors_is_a_valid_problem() {
    let empty = Linear {
        n: 2,
        blocks: vec![],
    };
    let mut spec = params(2);
    spec[0].prior = Some((1.5, 0.1));
    let sol = solve(&empty, &spec, &options(1), &mut Silent).unwrap();
    assert_eq!(sol.x[0], 1.5);
    assert_eq!(sol.sigma[0], Some(0.1));
    assert_eq!(sol.sigma[1], None);
    assert_eq!(sol.combinations[0].why, "p1 is not observed by these runs");
    assert_eq!(sol.dof, 0);
    assert_eq!(sol.chi2_reduced, 0.0);
}
