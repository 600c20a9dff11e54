//! Score tests: would adding a candidate's columns to a fitted least-squares problem lower χ²,
//! and by how much, without refitting?
//!
//! At the solution `x̂` of a whitened problem with Jacobian `J` and residuals `r`, a candidate
//! adds columns `Z` (its own parameters, zero in the current model). The Lagrange multiplier
//! (score) statistic is `s = uᵀ S⁺ u` with
//! - `u = Zᵀr − ZᵀJ·C·Jᵀr`: the candidate's gradient, orthogonal to what the fit can absorb
//!   (`Jᵀr ≈ 0` at a converged solution; kept for robustness),
//! - `S = ZᵀZ − ZᵀJ·C·JᵀZ`: what is left of the candidate's columns once the fitted parameters
//!   have taken their share (`C = (JᵀJ + priors)⁺` on the fit's rank).
//!
//! `JᵀJ` is summed in the same pass as `ZᵀZ` and `ZᵀJ`, at the solution: the fit's own
//! covariance may come from a factor of an earlier point (the chord method), close enough for
//! uncertainties but not for the difference `S` of a candidate the fit nearly absorbs, whose
//! projection must be exact to the rounding of the sums.
//!
//! Under the null hypothesis (the candidate's parameters are zero) `s` is χ² with `rank(S)`
//! degrees of freedom; for a linear model it is exactly the drop in χ² that fitting the
//! candidate would bring, so it is also the *predicted drop*. `θ̂ = −S⁺u` (residuals are
//! model − data) is the candidate's estimated amplitude with covariance `S⁺`, and `−C·JᵀZ·θ̂`
//! the change of every fitted parameter that comes with it: the bias the omitted candidate put
//! into them.
//!
//! *Absorbed* is the share of the candidate's columns that the fitted parameters reproduce,
//! `1 − λ_min(D^{-1/2} S D^{-1/2})` with `D = ZᵀZ`: near 1 the candidate hides inside the
//! span of the fitted model (concealed: the data cannot tell it from a shift of those
//! parameters), and its test has no power.
//!
//! One pass over the data at `x̂` accumulates `Zᵀr`, `Jᵀr`, `JᵀJ`, `JᵀZ` and each candidate's
//! own `ZₖᵀZₖ` (not the cross terms between candidates): `O(n·(n + E))` per row for `E`
//! candidate columns, matrix products per chunk of rows. Holm's method corrects the p-values for the
//! number of candidates.

use crate::{EvalError, ParamSpec, Solution, SolveError};
use faer::Mat;

/// Smallest eigenvalue, relative to the largest, of the fit's column-scaled Gram matrix that a
/// score test projects a candidate off (see [`covariance`]).
const RESOLVED: f64 = 1e-10;

/// Rows staged before they are reduced with matrix products.
const CHUNK: usize = 256;

/// A fitted problem whose rows also carry candidate columns.
pub trait ScoredProblem: Sync {
    /// Number of parameters of the fitted model (as [`crate::Problem::n_params`]).
    fn n_params(&self) -> usize;
    /// Columns of each candidate; candidate `k` owns the extra columns after those of
    /// candidates `0..k`.
    fn candidate_widths(&self) -> Vec<usize>;
    /// Independent pieces of the data, evaluated in parallel.
    fn n_blocks(&self) -> usize;
    /// The rows of block `b` at `x`, as [`crate::Problem::eval_block`], each with its row of
    /// candidate columns (all candidates, concatenated).
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError>;
}

/// The test of one candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Score {
    /// `uᵀS⁺u`: χ² with `df` degrees of freedom under the null hypothesis, and the drop in χ²
    /// fitting the candidate would bring (exactly, for a linear model).
    pub statistic: f64,
    /// `rank(S)`: the candidate's directions the data can see beside the fitted parameters.
    pub df: usize,
    pub p_value: f64,
    /// Holm-adjusted over all candidates of the call.
    pub adjusted_p: f64,
    /// `adjusted_p < α`.
    pub significant: bool,
    /// Estimated amplitude of each candidate parameter (`θ̂ = −S⁺u`) and its standard
    /// uncertainty (zero amplitude and `None` in directions the data cannot see).
    pub amplitude: Vec<f64>,
    pub amplitude_sigma: Vec<Option<f64>>,
    /// Share of the candidate's columns the fitted parameters reproduce (0…1).
    pub absorbed: f64,
    /// Per fitted parameter: how far it moves when the candidate is fitted, `−C·JᵀZ·θ̂`.
    pub shift: Vec<f64>,
    /// Per fitted parameter: how much of the candidate's first column it reproduces in the
    /// fit's best imitation of that column, `(C·JᵀZ)ₚ·‖Jₚ‖/‖Z₀‖` (0 for an all-zero column):
    /// the parameters a concealed candidate hides behind have the largest magnitudes.
    pub mimicked_by: Vec<f64>,
}

/// Receives the rows of one block (see [`ScoredProblem::eval_block`]).
pub struct ScoreSink<'a> {
    acc: &'a mut ScoreAcc,
}

impl ScoreSink<'_> {
    /// Starts a group of rows whose fitted-model entries lie in `cols` (sorted, unique,
    /// `< n_params`).
    pub fn columns(&mut self, cols: &[usize]) {
        self.acc.columns(cols);
    }

    /// One row: residual `r`, fitted-model entries for the group's columns, and the candidate
    /// columns (`extra.len()` = the sum of the candidate widths).
    pub fn row(&mut self, r: f64, jac: &[f64], extra: &[f64]) {
        self.acc.row(r, jac, extra);
    }

    /// [`Self::row`] with the candidate columns written in place by `fill` into a zeroed
    /// slice of their number (no copy; for problems whose candidate columns are sparse).
    pub fn row_with(&mut self, r: f64, jac: &[f64], fill: impl FnOnce(&mut [f64])) {
        self.acc.row_with(
            r,
            jac,
            |out| {
                fill(out);
                true
            },
            0,
        );
    }
}

impl std::fmt::Debug for ScoreSink<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScoreSink").finish_non_exhaustive()
    }
}

/// Sums of one worker.
struct ScoreAcc {
    n: usize,
    /// Candidate column ranges.
    ranges: Vec<std::ops::Range<usize>>,
    /// Candidates of one column (most of them), as (candidate, column): their Gram "block" is
    /// a sum of squares, summed without slicing.
    single: Vec<(usize, usize)>,
    /// The other candidates.
    multi: Vec<usize>,
    e: usize,
    cols: Vec<usize>,
    /// `columns` has started a group.
    in_group: bool,
    /// Staged rows `CHUNK × (w + e + 1)`: fitted entries, candidate entries, residual.
    stage: Vec<f64>,
    rows: usize,
    /// `JᵀZ`, `n × e` column-major; `Jᵀr`; `Zᵀr`; per candidate its `ZₖᵀZₖ` (row-major).
    jz: Vec<f64>,
    /// `JᵀJ`, `n × n` column-major.
    jj: Vec<f64>,
    jr: Vec<f64>,
    zr: Vec<f64>,
    zz: Vec<Vec<f64>>,
    /// A chunk's `Jᵀ·[J Z r]` in the group's order (`w × (w + e + 1)`), before the scatter.
    group: Vec<f64>,
    /// Sum of the squares of the fitted entries and residuals staged: non-finite iff one of
    /// them is.
    finite_check: f64,
    fault: Option<String>,
}

impl ScoreAcc {
    fn new(n: usize, widths: &[usize]) -> Self {
        let mut ranges = Vec::with_capacity(widths.len());
        let mut e = 0;
        for &w in widths {
            ranges.push(e..e + w);
            e += w;
        }
        let single = ranges
            .iter()
            .enumerate()
            .filter(|(_, r)| r.len() == 1)
            .map(|(k, r)| (k, r.start))
            .collect();
        let multi = (0..ranges.len()).filter(|&k| ranges[k].len() > 1).collect();
        Self {
            n,
            zz: widths.iter().map(|w| vec![0.0; w * w]).collect(),
            single,
            multi,
            ranges,
            e,
            cols: Vec::new(),
            in_group: false,
            stage: Vec::new(),
            rows: 0,
            jz: vec![0.0; n * e],
            jj: vec![0.0; n * n],
            jr: vec![0.0; n],
            zr: vec![0.0; e],
            group: Vec::new(),
            finite_check: 0.0,
            fault: None,
        }
    }

    fn columns(&mut self, cols: &[usize]) {
        if self.in_group && self.cols == cols {
            return;
        }
        self.flush();
        if cols.windows(2).any(|w| w[0] >= w[1]) || cols.iter().any(|&c| c >= self.n) {
            self.fault = Some(format!(
                "columns {cols:?} are not sorted, unique and below {}",
                self.n
            ));
            return;
        }
        self.cols.clear();
        self.cols.extend_from_slice(cols);
        self.in_group = true;
        let w = cols.len();
        self.stage.resize(CHUNK * (w + self.e + 1), 0.0);
        self.group.resize(w * (w + self.e + 1), 0.0);
    }

    fn row(&mut self, r: f64, jac: &[f64], extra: &[f64]) {
        self.row_with(
            r,
            jac,
            |out| {
                if out.len() == extra.len() {
                    out.copy_from_slice(extra);
                    true
                } else {
                    false
                }
            },
            extra.len(),
        );
    }

    /// One row whose candidate entries `fill` writes into the staging area directly (zeroed
    /// first); `fill` returns false if it cannot (`given` is then the wrong count it had).
    fn row_with(
        &mut self,
        r: f64,
        jac: &[f64],
        fill: impl FnOnce(&mut [f64]) -> bool,
        given: usize,
    ) {
        if self.fault.is_some() {
            return;
        }
        if !self.in_group {
            self.fault = Some("a row was pushed before `columns` started a group".into());
            return;
        }
        let (w, e) = (self.cols.len(), self.e);
        let stride = w + e + 1;
        let row = &mut self.stage[self.rows * stride..(self.rows + 1) * stride];
        let filled = {
            let extra = &mut row[w..w + e];
            extra.fill(0.0);
            fill(extra)
        };
        if jac.len() != w || !filled {
            self.fault = Some(format!(
                "a row has {} fitted and {} candidate entries, expected {w} and {e}",
                jac.len(),
                if filled { e } else { given }
            ));
            return;
        }
        row[..w].copy_from_slice(jac);
        row[w + e] = r;
        // Each candidate's own Gram block, directly: Σ wₖ² per row, far below n·e. A
        // non-finite entry anywhere in the row poisons the sum of squares of its candidate or
        // of the fitted part, which `rows_finite` checks (once per block, not per entry).
        let extra = &row[w..w + e];
        for &(k, col) in &self.single {
            let z = extra[col];
            self.zz[k][0] += z * z;
        }
        for &k in &self.multi {
            let z = &extra[self.ranges[k].clone()];
            // A candidate that does not reach this row (another sensor's joint model) adds
            // nothing: skipped, not summed as zeros (most rows, most candidates).
            if z.iter().all(|&v| v == 0.0) {
                continue;
            }
            let zz = &mut self.zz[k];
            let n = z.len();
            for i in 0..n {
                for j in 0..n {
                    zz[i * n + j] += z[i] * z[j];
                }
            }
        }
        let mut squares = r * r;
        for &v in jac {
            squares += v * v;
        }
        self.finite_check += squares;
        self.rows += 1;
        if self.rows == CHUNK {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let (m, w, e) = (self.rows, self.cols.len(), self.e);
        if m == 0 {
            return;
        }
        if !self.rows_finite() {
            self.rows = 0;
            return;
        }
        self.rows = 0;
        let stride = w + e + 1;
        let stage = &self.stage[..m * stride];
        let j = faer::MatRef::from_row_major_slice_with_stride(stage, m, w, stride);
        let z = faer::MatRef::from_row_major_slice_with_stride(&stage[w..], m, e, stride);
        let r = faer::MatRef::from_row_major_slice_with_stride(&stage[w + e..], m, 1, stride);
        let zr = faer::MatMut::from_column_major_slice_mut(&mut self.zr, e, 1);
        faer::linalg::matmul::matmul(zr, faer::Accum::Add, z.transpose(), r, 1.0, faer::Par::Seq);
        if w == 0 {
            return;
        }
        // The staged rows are `[J Z r]`: one product gives JᵀJ, JᵀZ and Jᵀr.
        let all = faer::MatRef::from_row_major_slice_with_stride(stage, m, stride, stride);
        let g = faer::MatMut::from_column_major_slice_mut(&mut self.group, w, stride);
        faer::linalg::matmul::matmul(
            g,
            faer::Accum::Replace,
            j.transpose(),
            all,
            1.0,
            faer::Par::Seq,
        );
        for (t, &pt) in self.cols.iter().enumerate() {
            for (s, &ps) in self.cols.iter().enumerate() {
                self.jj[pt * self.n + ps] += self.group[t * w + s];
            }
        }
        for col in 0..e {
            for (s, &p) in self.cols.iter().enumerate() {
                self.jz[col * self.n + p] += self.group[(w + col) * w + s];
            }
        }
        for (s, &p) in self.cols.iter().enumerate() {
            self.jr[p] += self.group[(w + e) * w + s];
        }
    }

    /// Whether every row so far was finite; records the fault if not.
    fn rows_finite(&mut self) -> bool {
        if self.finite_check.is_finite() && self.zz.iter().flatten().all(|v| v.is_finite()) {
            return true;
        }
        if self.fault.is_none() {
            self.fault = Some("a row is not finite".into());
        }
        false
    }

    fn merge(&mut self, other: &mut ScoreAcc) {
        other.flush();
        self.flush();
        for (a, b) in self.jz.iter_mut().zip(&other.jz) {
            *a += b;
        }
        for (a, b) in self.jj.iter_mut().zip(&other.jj) {
            *a += b;
        }
        for (a, b) in self.jr.iter_mut().zip(&other.jr) {
            *a += b;
        }
        for (a, b) in self.zr.iter_mut().zip(&other.zr) {
            *a += b;
        }
        for (a, b) in self.zz.iter_mut().zip(&other.zz) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        if self.fault.is_none() {
            self.fault = other.fault.take();
        }
    }
}

/// Scores every candidate of `problem` against the fit `solution` (of the same rows without
/// the candidate columns, with the parameter specs `params` of that fit: their priors and
/// fixed parameters); Holm's correction at family-wise level `alpha`. `threads = 0` uses every
/// core.
pub fn score_candidates<P: ScoredProblem>(
    problem: &P,
    params: &[ParamSpec],
    solution: &Solution,
    alpha: f64,
    threads: usize,
) -> Result<Vec<Score>, SolveError> {
    let n = problem.n_params();
    if solution.x.len() != n || params.len() != n {
        return Err(SolveError::Score(format!(
            "the solution has {} parameters and {} specs, the problem {n}",
            solution.x.len(),
            params.len()
        )));
    }
    let widths = problem.candidate_widths();
    let acc = accumulate(problem, &solution.x, &widths, threads)?;
    let (cov, kappa) = covariance(&acc.jj, params, solution.rank)?;
    let cov = &cov;
    // Rounding in `S = D − B·C·Bᵀ` grows with the condition of the fit's Gram matrix: directions
    // a candidate shares with the fit beyond this (relative to its own size) are untestable.
    let tol = (100.0 * f64::EPSILON * kappa).max(1e-10);
    // The whole gradient, prior rows included (at the optimum it is zero, not the data part
    // alone), and C times it, shared by every candidate.
    let grad: Vec<f64> = (0..n)
        .map(|i| match params[i].prior {
            Some((mu, sigma)) if !params[i].fixed => {
                acc.jr[i] + (solution.x[i] - mu) / (sigma * sigma)
            }
            _ => acc.jr[i],
        })
        .collect();
    let c_jr: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| cov[i * n + j] * grad[j]).sum())
        .collect();
    let mut scores: Vec<Score> = acc
        .ranges
        .iter()
        .zip(&acc.zz)
        .map(|(range, zz)| candidate(&acc, range.clone(), zz, cov, &c_jr, tol))
        .collect();
    holm(&mut scores, alpha);
    Ok(scores)
}

/// `(JᵀJ + priors)⁺` over the free parameters, on the `rank` largest eigenvalues of the
/// column-scaled matrix (the fit's rank); zero rows and columns for fixed parameters. Also the
/// condition number of that matrix over the rank.
fn covariance(
    jj: &[f64],
    params: &[ParamSpec],
    rank: usize,
) -> Result<(Vec<f64>, f64), SolveError> {
    let n = params.len();
    let free: Vec<usize> = (0..n).filter(|&i| !params[i].fixed).collect();
    let f = free.len();
    let mut g = Mat::from_fn(f, f, |a, b| jj[free[a] * n + free[b]]);
    for (a, &i) in free.iter().enumerate() {
        if let Some((_, sigma)) = params[i].prior {
            g[(a, a)] += 1.0 / (sigma * sigma);
        }
    }
    // The solver's column scaling, floors included (so `rank` counts the same directions).
    let mut visible = vec![true; f];
    let d: Vec<f64> = (0..f)
        .map(|a| {
            let floor = params[free[a]]
                .scale
                .filter(|s| *s > 0.0 && s.is_finite())
                .map_or(0.0, |s| 1.0 / s);
            visible[a] = crate::visible(g[(a, a)].max(0.0).sqrt(), floor);
            let v = g[(a, a)].sqrt().max(floor);
            if v > 0.0 { v } else { 1.0 }
        })
        .collect();
    let scaled = Mat::from_fn(f, f, |a, b| {
        if visible[a] && visible[b] {
            g[(a, b)] / (d[a] * d[b])
        } else {
            0.0
        }
    });
    if !scaled.as_ref().is_all_finite() {
        return Err(SolveError::Score("the Gram matrix is not finite".into()));
    }
    let (v, l) = symmetric_eigen(&scaled);
    // The fit's rank rule works on its factor; squared into the Gram matrix, directions it keeps
    // beyond an eigenvalue ratio of 1e10 are rounding here, and projecting a candidate off them
    // would take out of it only rounding and leave it no degrees of freedom (a rich model the
    // runs barely determine). Those directions count as unseen: a candidate is tested on what
    // is left once the well-determined ones have taken their share.
    let top = l.first().copied().unwrap_or(0.0);
    let resolved = l.iter().take_while(|&&x| x >= RESOLVED * top).count();
    let used = rank.min(f).min(resolved);
    let kappa = match (l.first(), used.checked_sub(1).map(|k| l[k])) {
        (Some(&hi), Some(lo)) if lo > 0.0 => hi / lo,
        _ => 1.0,
    };
    let mut cov = vec![0.0; n * n];
    for k in 0..used {
        if l[k] <= 0.0 {
            continue;
        }
        for a in 0..f {
            for b in 0..f {
                cov[free[a] * n + free[b]] += v[(a, k)] * v[(b, k)] / (l[k] * d[a] * d[b]);
            }
        }
    }
    Ok((cov, kappa))
}

/// One pass over the data at `x`, in parallel.
fn accumulate<P: ScoredProblem>(
    problem: &P,
    x: &[f64],
    widths: &[usize],
    threads: usize,
) -> Result<ScoreAcc, SolveError> {
    let n = problem.n_params();
    // Lanes merged in order (see `crate::lanes`): the same scores on any number of cores.
    let mut pool: Vec<ScoreAcc> = (0..crate::lane_count(problem.n_blocks()))
        .map(|_| ScoreAcc::new(n, widths))
        .collect();
    crate::run_lanes(problem.n_blocks(), &mut pool, threads, |b, acc| {
        problem
            .eval_block(b, x, &mut ScoreSink { acc })
            .map_err(|source| SolveError::Eval {
                block: b,
                cause: source,
            })?;
        acc.rows_finite();
        if let Some(fault) = acc.fault.take() {
            return Err(SolveError::Score(format!("block {b}: {fault}")));
        }
        Ok(())
    })?;
    let (first, rest) = pool.split_at_mut(1);
    let acc = &mut first[0];
    for other in rest {
        acc.merge(other);
    }
    acc.flush();
    if let Some(fault) = acc.fault.take() {
        return Err(SolveError::Score(fault));
    }
    Ok(pool.swap_remove(0))
}

/// The test of the candidate owning the extra columns `range`.
fn candidate(
    acc: &ScoreAcc,
    range: std::ops::Range<usize>,
    zz: &[f64],
    cov: &[f64],
    c_jr: &[f64],
    tol_rel: f64,
) -> Score {
    let (n, k) = (acc.n, range.len());
    let jz = |p: usize, i: usize| acc.jz[(range.start + i) * acc.n + p];
    // C·JᵀZ (n × k).
    let c_jz: Vec<Vec<f64>> = (0..k)
        .map(|i| {
            (0..n)
                .map(|p| (0..n).map(|q| cov[p * n + q] * jz(q, i)).sum())
                .collect()
        })
        .collect();
    let u: Vec<f64> = (0..k)
        .map(|i| acc.zr[range.start + i] - (0..n).map(|p| jz(p, i) * c_jr[p]).sum::<f64>())
        .collect();
    let s = Mat::from_fn(k, k, |i, j| {
        zz[i * k + j] - (0..n).map(|p| jz(p, i) * c_jz[j][p]).sum::<f64>()
    });
    let d = Mat::from_fn(k, k, |i, j| zz[i * k + j]);
    // S⁺ from its eigen-decomposition (symmetric, positive semi-definite), relative tolerance
    // on the scale of D: directions the fitted parameters absorb completely are not counted.
    let scale: f64 = (0..k).map(|i| d[(i, i)]).fold(0.0, f64::max);
    let (vecs, vals) = symmetric_eigen(&s);
    let tol = tol_rel * scale;
    let mut theta = vec![0.0; k];
    let mut s_pinv = Mat::<f64>::zeros(k, k);
    let mut df = 0;
    for (l, &lam) in vals.iter().enumerate() {
        if lam <= tol {
            continue;
        }
        df += 1;
        // Fitting the candidate minimises ‖r + Z·θ‖: θ = −S⁺u.
        let proj: f64 = -(0..k).map(|i| vecs[(i, l)] * u[i]).sum::<f64>() / lam;
        for i in 0..k {
            theta[i] += vecs[(i, l)] * proj;
            for j in 0..k {
                s_pinv[(i, j)] += vecs[(i, l)] * vecs[(j, l)] / lam;
            }
        }
    }
    let statistic = (-theta.iter().zip(&u).map(|(t, u)| t * u).sum::<f64>()).max(0.0);
    let p_value = chi2_sf(statistic, df);
    let amplitude_sigma = (0..k)
        .map(|i| (df > 0 && s_pinv[(i, i)] > 0.0).then(|| s_pinv[(i, i)].sqrt()))
        .collect();
    let shift = (0..n)
        .map(|p| -(0..k).map(|i| c_jz[i][p] * theta[i]).sum::<f64>())
        .collect();
    let z0 = if k > 0 { zz[0].sqrt() } else { 0.0 };
    let mimicked_by = (0..n)
        .map(|p| {
            if z0 > 0.0 {
                c_jz[0][p] * acc.jj[p * n + p].max(0.0).sqrt() / z0
            } else {
                0.0
            }
        })
        .collect();
    Score {
        mimicked_by,
        statistic,
        df,
        p_value,
        adjusted_p: p_value,
        significant: false,
        amplitude: theta,
        amplitude_sigma,
        absorbed: absorbed(&s, &d),
        shift,
    }
}

/// `1 − λ_min(D^{-1/2} S D^{-1/2})` over the directions `D` sees (0 for an all-zero candidate).
fn absorbed(s: &Mat<f64>, d: &Mat<f64>) -> f64 {
    let k = d.nrows();
    let (dv, dl) = symmetric_eigen(d);
    let dmax = dl.iter().copied().fold(0.0, f64::max);
    if dmax <= 0.0 {
        return 0.0;
    }
    // D^{-1/2} on the directions with weight.
    let keep: Vec<usize> = (0..k).filter(|&l| dl[l] > 1e-12 * dmax).collect();
    let w = Mat::from_fn(k, keep.len(), |i, c| dv[(i, keep[c])] / dl[keep[c]].sqrt());
    let m = w.transpose() * s * &w;
    let (_, ml) = symmetric_eigen(&m);
    let lmin = ml.iter().copied().fold(f64::INFINITY, f64::min);
    (1.0 - lmin).clamp(0.0, 1.0)
}

/// Eigenvectors (columns) and eigenvalues of a small symmetric matrix, via its SVD (the
/// matrices here are positive semi-definite up to rounding; a tiny negative eigenvalue comes
/// out as a tiny positive singular value, which the tolerances treat alike).
fn symmetric_eigen(a: &Mat<f64>) -> (Mat<f64>, Vec<f64>) {
    let k = a.nrows();
    if k == 0 {
        return (Mat::zeros(0, 0), Vec::new());
    }
    let sym = Mat::from_fn(k, k, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    match sym.svd() {
        Ok(svd) => {
            let vals = svd.S().column_vector().iter().copied().collect();
            (svd.V().to_owned(), vals)
        }
        Err(_) => (Mat::identity(k, k), vec![0.0; k]),
    }
}

/// Survival function of χ² with `df` degrees of freedom (1 for `df = 0`).
fn chi2_sf(x: f64, df: usize) -> f64 {
    if df == 0 {
        return 1.0;
    }
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    ChiSquared::new(df as f64).map_or(1.0, |d| d.sf(x))
}

/// Holm's step-down adjustment over all scores; marks those below `alpha`.
pub fn holm(scores: &mut [Score], alpha: f64) {
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| scores[a].p_value.total_cmp(&scores[b].p_value));
    let m = scores.len();
    let mut running: f64 = 0.0;
    for (rank, &i) in order.iter().enumerate() {
        let adj = ((m - rank) as f64 * scores[i].p_value).min(1.0);
        running = running.max(adj);
        scores[i].adjusted_p = running;
        scores[i].significant = running < alpha;
    }
}
