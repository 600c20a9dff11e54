//! `ParamSpec::scale`: a parameter the data see only to second order at the start (like a
//! ball-bar pivot's height in a circle at that height) has a column of rounding size there.
//! Scaled up to unit size it is "identified", and the Gauss–Newton step moves it by the
//! residual over that rounding (kilometres, in a five-axis session with an unmodelled effect).
//! With a plausible scale it is invisible, reported unidentified, left alone, and the rest of the
//! fit converges.

use mtcal_solve::{EvalError, Options, ParamSpec, Problem, RowSink, Silent, solve};

/// `r = (a + b·t + 1e-15·h + h²·t² − y(t))/σ` with data that the model cannot fit exactly (an
/// unmodelled cycle): `a`, `b` linear; `h` barely there to first order at `h = 0`.
struct Quadratic;

const N: usize = 200;

fn data(i: usize) -> (f64, f64) {
    let t = i as f64 / N as f64 - 0.5;
    (t, 2e-6 + 3e-6 * t + 1e-6 * (40.0 * t).sin())
}

impl Problem for Quadratic {
    fn n_params(&self) -> usize {
        3
    }
    fn n_blocks(&self) -> usize {
        1
    }
    fn eval_block(&self, _: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError> {
        sink.columns(&[0, 1, 2]);
        let s = 0.5e-6;
        for i in 0..N {
            let (t, y) = data(i);
            let h = x[2];
            let model = x[0] + x[1] * t + 1e-15 * h + h * h * t * t;
            sink.row(
                (model - y) / s,
                &[1.0 / s, t / s, (1e-15 + 2.0 * h * t * t) / s],
            );
        }
        Ok(())
    }
}

fn specs(scale: Option<f64>) -> Vec<ParamSpec> {
    ["a", "b", "h"]
        .iter()
        .map(|n| ParamSpec {
            scale,
            ..ParamSpec::new(*n, 0.0)
        })
        .collect()
}

#[test]
fn a_plausible_scale_keeps_a_first_order_invisible_parameter_in_place() {
    let sol = solve(
        &Quadratic,
        &specs(Some(1e-3)),
        &Options::default(),
        &mut Silent,
    )
    .unwrap();
    assert!(sol.converged, "{:?}", sol.termination);
    assert!(sol.x[2].abs() < 1e-6, "h moved to {}", sol.x[2]);
    assert!(!sol.identified[2]);
    assert!(
        (sol.x[0] - 2e-6).abs() < 1e-7 && (sol.x[1] - 3e-6).abs() < 1e-6,
        "{:?}",
        sol.x
    );
    // Without a scale the rounding-size column is blown up to unit size: h is "identified"
    // and the fit trades the unmodelled cycle against its second-order term (a sign the data
    // cannot tell), a step of the residual's size over a column of rounding's size.
    let free = solve(&Quadratic, &specs(None), &Options::default(), &mut Silent).unwrap();
    assert!(
        free.x[2].abs() > 1e-5 || !free.converged,
        "without a scale h = {} ({:?})",
        free.x[2],
        free.termination
    );
}
