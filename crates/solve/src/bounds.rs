//! Box-constrained steps: a small QP solved with Clarabel when the unconstrained step would
//! leave the bounds.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

use crate::SolveError;
use crate::analysis::Analysis;

/// The damped step `argmin ½‖R dx + z‖² + ½λ‖D dx‖²` over the identified directions subject to
/// `lo ≤ x + dx ≤ hi` (all in the column order of the factor; `lo`/`hi` may be infinite).
///
/// Variables are `u = Σ_r w` with the step `D·dx = V_r w`: then the objective is
/// `½‖u + c‖² + ½λ Σ uᵢ²/σᵢ²`, whose Hessian is diagonal and, undamped, the identity — the
/// singular values (which can span nine decades) move into the constraint rows, where Clarabel's
/// equilibration handles them.
pub(crate) fn bounded_step(
    an: &Analysis,
    lambda: f64,
    x: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<Vec<f64>, SolveError> {
    let n = x.len();
    let r = an.rank;
    if r == 0 {
        return Ok(vec![0.0; n]);
    }
    let p_diag: Vec<f64> = (0..r).map(|i| 1.0 + lambda / (an.s[i] * an.s[i])).collect();
    let p = CscMatrix::new(r, r, (0..=r).collect(), (0..r).collect(), p_diag);
    let q: Vec<f64> = an.c[..r].to_vec();
    // Constraint rows: ±(D_j dx_j) = ±Σᵢ V[j,i]/σᵢ uᵢ ≤ ±D_j (bound − x_j).
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    for j in 0..n {
        let a: Vec<f64> = (0..r).map(|i| an.v[(j, i)] / an.s[i]).collect();
        if hi[j].is_finite() {
            rows.push((a.clone(), an.d[j] * (hi[j] - x[j])));
        }
        if lo[j].is_finite() {
            rows.push((a.iter().map(|v| -v).collect(), an.d[j] * (x[j] - lo[j])));
        }
    }
    let m = rows.len();
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for i in 0..r {
        for (row, (a, _)) in rows.iter().enumerate() {
            if a[i] != 0.0 {
                rowval.push(row);
                nzval.push(a[i]);
            }
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(m, r, colptr, rowval, nzval);
    let b: Vec<f64> = rows.iter().map(|(_, b)| b.max(0.0)).collect();
    let cones = [SupportedConeT::NonnegativeConeT(m)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .map_err(|e| SolveError::Numerical(format!("QP settings: {e}")))?;
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings)
        .map_err(|e| SolveError::Numerical(format!("bounded step: {e}")))?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {}
        status => {
            return Err(SolveError::Numerical(format!(
                "the box-constrained step QP ended with status {status:?}"
            )));
        }
    }
    let u = &solver.solution.x;
    let mut dx: Vec<f64> = (0..n)
        .map(|j| (0..r).map(|i| an.v[(j, i)] * u[i] / an.s[i]).sum::<f64>() / an.d[j])
        .collect();
    // The interior-point solution is feasible only to the solver's tolerance: clamp exactly.
    for j in 0..n {
        dx[j] = (x[j] + dx[j]).clamp(lo[j], hi[j]) - x[j];
    }
    Ok(dx)
}
