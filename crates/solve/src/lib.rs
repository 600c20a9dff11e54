//! Streaming weighted nonlinear least squares with identifiability analysis.
//!
//! This crate is the numerical core of identification. It knows nothing about machines: a
//! [`Problem`] is a set of parameters and blocks of residual rows, and [`solve`] returns the
//! estimate, its uncertainty and an account of what the data cannot tell apart.
//!
//! # Whitening
//!
//! Every residual row is *whitened* by the problem before it reaches the solver: a measurement
//! with standard uncertainty σ contributes `r = (model − measured)/σ` and the Jacobian row divided
//! by σ. The cost is then `½ Σ r²`, instruments with different units weigh fairly, `χ² = Σ r²`
//! should be close to the degrees of freedom when the σ are right, and the inverse of `JᵀJ` *is*
//! the covariance of the estimate (no further scaling by the fit quality is applied). Priors are
//! whitened rows too: `(x − mean)/sigma`.
//!
//! # Streaming QR
//!
//! The Jacobian can have millions of rows, so it is never stored. Rows are folded, a few hundred
//! at a time, into an upper-triangular `R` (`n × n` for `n` free parameters) and the rotated
//! right-hand side `z = Qᵀr`, plus the residual sum of squares that no column can explain:
//! `‖J·dx + r‖² = ‖R·dx + z‖² + rss` for every step `dx`. Folding a block `B` is a QR
//! factorisation of `[R; B]` that exploits the triangle (LAPACK's `tpqrt`, here blocked and
//! recursive on top of faer's matrix products). Memory depends on `n`, not on the number of rows.
//!
//! Why QR and not the normal equations `JᵀJ`, which cost half as many flops? Forming `JᵀJ`
//! squares the condition number: a Jacobian with condition 10⁷ — common when micrometre
//! parameters share a problem with long lever arms — leaves no correct digit in `JᵀJ`'s smallest
//! directions, while `R` keeps about nine. The factor of two in flops buys that accuracy; the
//! test `ill_conditioned_problem_is_solved_accurately` shows it.
//!
//! Rows come in *groups* that share a set of active columns (all machine parameters plus one
//! run's nuisance parameters, say). Only the active sub-block of `R` takes part in a fold. To
//! keep it that way the columns are ordered so that parameters used by few blocks come first and
//! shared ones last: then folding a run's rows never touches another run's nuisance columns
//! (no "fill-in"). The order is learned from the first evaluation (and hinted by
//! [`ParamSpec::group`] before that); any order gives the same result up to rounding.
//!
//! Blocks are evaluated in parallel: block `b` folds into lane `b mod 4`'s own `R`, threads take
//! whole lanes, and the lanes' factors are merged in lane order by folding one `R` into another
//! ([`run_lanes`]). The result is bitwise the same on any number of threads and from run to run
//! (a work-stealing sum was not: near a rank threshold its rounding changed which directions a
//! fit identified); reordering the blocks changes it only by rounding (about 10⁻¹⁴ relative).
//!
//! # Levenberg–Marquardt
//!
//! Each iteration re-evaluates all blocks at the current `x`, giving `R` and `z`. The columns
//! are scaled by their norms `D` (Marquardt scaling, so that micrometres and radians are
//! comparable) and the scaled factor `R·D⁻¹ = U Σ Vᵀ` is decomposed by an SVD, which costs
//! nothing next to the accumulation (`n` is at most a few hundred). The damped step
//! `min ‖R·dx + z‖² + λ‖D·dx‖²` is then `D⁻¹ Σᵢ −σᵢ/(σᵢ² + λ) (uᵢᵀz) vᵢ` — the same as a QR of
//! `[R; √λ·D]`, but the SVD is computed once per iteration for all λ tried, and the sum runs
//! only over the *identified* directions (σᵢ above the rank threshold), which makes it a
//! minimum-norm step: directions the data cannot see stay at their initial values instead of
//! drifting on rounding noise. The first step is undamped (most identification problems are
//! nearly linear); λ shrinks after good steps (to zero, pure Gauss–Newton, when the linear
//! model predicts the cost change well) and grows after rejected ones. With bounds, a
//! step that would leave the box is recomputed as a small box-constrained QP (Clarabel) in the
//! identified subspace. Iteration stops when the Gauss–Newton step from the current point is
//! negligible: smaller than `tolerance` relative to `x` (scaled), or changing the residual norm
//! by less than `tolerance` relative (or by less than `tolerance` standard deviations when the
//! fit is exact); or when three accepted steps in a row lower the cost by less than 10⁻⁹ of it
//! (a direction observed only to second order keeps promising a linear-model drop it never
//! delivers, and a model that cannot explain the data creeps along it). On residuals of the
//! size of their noise, three accepted steps in a row that each lower χ² by less than 0.02 end
//! it as [`Termination::Settled`]: settled to statistical precision, although such a creep
//! would go on for thousands of steps.
//!
//! # Chord steps: checking a point without a new factor
//!
//! Folding a row into `R` costs `O(n²)`; the model's Jacobian row costs far less for large
//! `n`. So an undamped trial point is first checked by a *gradient-only pass* ([`Options::chord`]):
//! it sums the cost, the gradient `g = Jᵀr` and, for a few probe directions `u` with
//! `‖R·u‖ = 1` (the step, the least determined singular directions, pseudo-random ones),
//! `‖J·u‖²`, plus `Jᵀ(J·w)` for the null-space directions `w` of `R`. The cost decides
//! acceptance as before. If the step confirmed the linear model and the metric of the data is
//! unchanged — every `‖J·u‖²` within 10⁻³ of 1, and the Schur complement of the null space
//! still below the rank threshold (no unidentified direction became identified) — the chord
//! method continues with Gauss–Newton steps `−(RᵀR)⁺g` on the old factor (simplified Newton),
//! each checked by another gradient-only pass, until one is expected to leave an error below
//! 0.01 σ: the iteration contracts the error by about the relative metric change `δ` per step,
//! so a step of length `L` leaves about `δ·L` (taken ten times over, as the probes sample only
//! some directions). The point that step reaches is the solution, and the old factor gives its
//! covariance (uncertainties within about 0.05 % of a fresh factor's). On a nearly linear
//! problem (an R-test identification: `δ ≈ 10⁻⁴`) the first chord step already ends it: one
//! factor and two passes in all.
//! Otherwise the point gets a factor of its own, and the chord method is not tried again. The
//! one exception is a direction that the old factor left unidentified becoming identified:
//! all errors zero is often such a degenerate point (a second-order effect separates two
//! set-up parameters only once some error is non-zero). That point gets a factor of its own
//! and the chord method resumes from it. A rank-deficient start with a constant null space
//! (ball height and tool length entering only together) keeps its first factor to the end.
//!
//! # Identifiability, combinations and covariance
//!
//! At the solution the same scaled SVD decides what the data determine. The numerical rank is
//! the number of singular values above `rank_tolerance · σ_max`; the condition number is
//! `σ_max/σ_rank`. A parameter with a [`ParamSpec::scale`] is scaled by no less than
//! `1/scale`, so one the data cannot see over its plausible range falls below the threshold
//! instead of being blown up to unit size. Right singular vectors beyond the rank span the null space: moving the
//! parameters along them changes no residual. The null space is turned into readable
//! [`Combination`]s by [`describe_null_space`]: a reduced row echelon form with complete pivoting
//! makes the basis sparse (independent groups of parameters separate), tiny entries are dropped,
//! and each combination is described in words — a single parameter is "not observed"; two
//! parameters that can move together unseen have "only their difference observed"; two that
//! can move oppositely have "only their sum observed". Every parameter that appears in a
//! combination is *unidentified*: its σ is `None` and its row and column of the covariance are
//! zero. Before that, a direction's members that move by less than 10⁻⁵ of their plausible
//! range ([`ParamSpec::scale`]), or traces (below 10⁻³ of it) of well-determined parameters (σ
//! below 5 % of the plausible range) that move by less than a tenth of their own σ, while its
//! main members move over their whole plausible ranges are left out of it: a
//! direction made of an almost invisible angle and a set-up constant, or a genuine set-up null
//! space (ball height and tool length), often carries a second-order trace of a
//! well-determined parameter, which is determined for any plausible value of the others and
//! keeps its number. (Without this, a trace at the 10⁻⁵ level decided whether a rotary axis'
//! location error of ±0.7 µm got its number, and a change of the data at 10⁻¹¹ flipped it.)
//!
//! The covariance is `C = D⁻¹ V Σ⁻² Vᵀ D⁻¹` over the identified singular directions — the
//! pseudo-inverse of `JᵀJ` computed from the triangular factor, never an explicit inverse of
//! `JᵀJ`, and without the LM damping.
//!
//! # Errors
//!
//! A non-finite residual or Jacobian entry at the starting point is an error that names the
//! block and row. At a trial point during the iteration it only rejects the step (the damping
//! grows and a shorter step is tried), as a step into a region where the model is undefined is
//! not a failure of the problem. Nothing in a [`Solution`] is ever NaN.

mod accumulate;
mod analysis;
mod bounds;
mod combos;
mod eval;
mod lanes;
mod qr;
pub mod score;
mod solver;

pub use combos::describe_null_space;

/// Below this change of the whitened residuals (in σ, over all rows) when a parameter moves by
/// its [`ParamSpec::scale`], the data cannot see it: its column is taken as zero.
pub const INVISIBLE: f64 = 1e-3;

/// Whether a column of norm `norm` (whitened) is visible for a parameter whose least column
/// scale is `floor` (`1/scale`; 0 without a scale, and then every non-zero column is).
pub fn visible(norm: f64, floor: f64) -> bool {
    norm > INVISIBLE * floor
}
pub use lanes::{LANES, lane_count, map_in_order, run_lanes};
pub use score::{Score, ScoreSink, ScoredProblem, holm, score_candidates};
pub use solver::{linearize, solve};

use accumulate::Accumulator;

/// A least-squares problem: residuals already whitened (divided by their σ), so the cost is
/// `½ Σ r²`.
pub trait Problem: Sync {
    /// Number of parameters (columns of the Jacobian).
    fn n_params(&self) -> usize;
    /// Independent pieces of the data (e.g. runs, or sample ranges of a run) that can be
    /// evaluated in parallel.
    fn n_blocks(&self) -> usize;
    /// Evaluates block `b` at parameters `x`: pushes its whitened residual rows and their
    /// Jacobian rows into `sink`.
    ///
    /// Returns `Err` on a numerical failure (e.g. a model undefined at `x`); the solver reports
    /// it and never continues with NaN. Non-finite values pushed into the sink are caught too.
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut RowSink<'_>) -> Result<(), EvalError>;
}

/// Receives the rows of one block. Rows come in groups that share a set of active columns
/// (e.g. all machine parameters plus one run's nuisance parameters).
///
/// Rows are buffered and folded into the streaming QR factor in blocks of a few hundred; a
/// `row` call only copies the values, it never allocates.
pub struct RowSink<'a> {
    acc: &'a mut Accumulator,
}

impl RowSink<'_> {
    /// Starts a group of rows whose nonzero Jacobian entries lie in `cols` (sorted, unique,
    /// `< n_params`). Calling it again with the same columns is cheap.
    pub fn columns(&mut self, cols: &[usize]) {
        self.acc.columns(cols);
    }

    /// One row: residual `r` and Jacobian entries for the active columns (`jac.len()` equals the
    /// number of columns of the group).
    pub fn row(&mut self, r: f64, jac: &[f64]) {
        self.acc.row(r, jac);
    }
}

impl std::fmt::Debug for RowSink<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RowSink")
            .field("rows", &self.acc.n_rows)
            .finish_non_exhaustive()
    }
}

/// A failure reported by [`Problem::eval_block`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct EvalError {
    /// What went wrong, for a person.
    pub message: String,
}

impl EvalError {
    /// An error with this message.
    pub fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
        }
    }
}

/// Solver settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Maximum number of accepted steps.
    pub max_iterations: usize,
    /// Convergence threshold on the Gauss–Newton step: relative to `x` (column-scaled), and on
    /// the change of the residual norm it would bring, relative to the residual norm.
    pub tolerance: f64,
    /// Levenberg–Marquardt damping; `false` gives Gauss–Newton with step halving.
    pub lm: bool,
    /// Relative singular-value threshold on the column-scaled Jacobian: directions with
    /// `σᵢ ≤ rank_tolerance · σ_max` are not identified.
    pub rank_tolerance: f64,
    /// Worker threads for the evaluation; 0 uses all available cores.
    pub threads: usize,
    /// Check undamped trial points with gradient-only passes and finish with chord steps on
    /// the last factor while the metric of the data is unchanged (see the module doc). `false`
    /// builds a new factor at every trial point.
    pub chord: bool,
    /// End a creep along a direction the data see only to second order as
    /// [`Termination::Settled`] once the cost has settled to statistical precision (see the
    /// module doc). `false` lets it creep on until it converges or reaches `max_iterations`:
    /// for fits whose χ² is compared with another's to a fraction of a unit (the physics
    /// search), where the few units a creep still promises would read as evidence.
    pub settle: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-10,
            lm: true,
            rank_tolerance: 1e-9,
            threads: 0,
            chord: true,
            settle: true,
        }
    }
}

/// One parameter of the problem.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamSpec {
    /// Name used in messages and in [`Combination::why`].
    pub name: String,
    /// Starting value (fixed parameters keep it).
    pub initial: f64,
    /// Held at `initial`; its column is dropped.
    pub fixed: bool,
    /// Gaussian prior `(mean, sigma)`: adds the whitened row `(x − mean)/sigma`.
    pub prior: Option<(f64, f64)>,
    /// Box constraint `(lower, upper)`; either side may be infinite.
    pub bounds: Option<(f64, f64)>,
    /// The group the parameter belongs to, e.g. the run of a nuisance parameter. Informational,
    /// and a hint for the column order before the first evaluation: grouped (block-local)
    /// parameters are placed before ungrouped (shared) ones.
    pub group: Option<String>,
    /// The largest change of the parameter that is still plausible (SI; e.g. a millimetre for
    /// a set-up offset, a milliradian for a squareness). A parameter the data cannot see over
    /// this range — moving it by `scale` changes the whitened residuals by less than the rank
    /// threshold — is not identified, however small its own column is: without it, a column
    /// that is zero to first order at the start (a ball-bar pivot's height in a circle at that
    /// height) is scaled up to unit size and the Gauss–Newton step moves it by kilometres.
    /// `None`: the column's own norm decides (scale-free). A column whose norm times `scale`
    /// is below [`INVISIBLE`] counts as zero: the parameter is reported unidentified.
    pub scale: Option<f64>,
}

impl ParamSpec {
    /// A free parameter without prior, bounds or group.
    pub fn new(name: impl Into<String>, initial: f64) -> Self {
        Self {
            name: name.into(),
            initial,
            ..Self::default()
        }
    }
}

/// Progress hooks; the command line attaches a progress bar, libraries print nothing. Called on
/// the thread that called [`solve`]; must be cheap.
pub trait Observer {
    /// After each accepted step (and with `it = 0` for the starting point).
    fn iteration(&mut self, it: usize, cost: f64, lambda: f64) {
        let _ = (it, cost, lambda);
    }
    /// During an evaluation, after each finished block.
    fn rows(&mut self, done_blocks: usize, total_blocks: usize) {
        let _ = (done_blocks, total_blocks);
    }
}

/// An [`Observer`] that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {}

/// Why the iteration stopped. Reports write the variant's name (`"MaxIterations"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Termination {
    /// The Gauss–Newton step from the final point is negligible.
    Converged,
    /// The cost settled to statistical precision (three accepted steps in a row each lowered
    /// χ² by less than 0.02) while the iteration still crept along a direction the data see
    /// only to second order. Counts as converged: the parameters reported with an interval
    /// are within a fraction of their σ of the optimum (see `SETTLED_DROP` in the solver).
    Settled,
    /// `max_iterations` steps were taken without converging.
    MaxIterations,
    /// No step along the computed direction lowers the cost, even heavily damped.
    NoProgress,
}

/// A parameter combination that the data do not determine.
#[derive(Debug, Clone, PartialEq)]
pub struct Combination {
    /// Parameter indices, ascending.
    pub params: Vec<usize>,
    /// A null-space direction in parameter units, relative to the first parameter (which has
    /// coefficient 1): moving the parameters by `t·coefficients` changes no residual.
    pub coefficients: Vec<f64>,
    /// The same in words, with parameter names.
    pub why: String,
}

/// The result of [`solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Estimated parameters (fixed ones at their initial value).
    pub x: Vec<f64>,
    /// `½ Σ r²` at `x`, prior rows included.
    pub cost: f64,
    /// Data rows (prior rows not included).
    pub n_rows: usize,
    /// Prior rows.
    pub n_prior_rows: usize,
    /// Degrees of freedom: rows + prior rows − rank.
    pub dof: usize,
    /// `Σ r² = 2·cost`.
    pub chi2: f64,
    /// `chi2 / dof` (0 when `dof` is 0).
    pub chi2_reduced: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Residual evaluations (accepted and rejected trial points, and the start).
    pub evaluations: usize,
    /// Evaluations that built a factor; the others were gradient-only passes.
    pub factorizations: usize,
    /// Whether the iteration converged.
    pub converged: bool,
    /// Why the iteration stopped.
    pub termination: Termination,
    /// Numerical rank of the column-scaled Jacobian.
    pub rank: usize,
    /// `σ_max/σ_min` of the column-scaled Jacobian over the identified subspace (1 when the rank
    /// is 0).
    pub condition_number: f64,
    /// All singular values of the column-scaled Jacobian, descending (one per free parameter).
    pub singular_values: Vec<f64>,
    /// Per parameter: false if it has a component in the numerical null space (or is fixed —
    /// a fixed parameter is not estimated).
    pub identified: Vec<bool>,
    /// 1-σ standard uncertainty; `None` for unidentified and fixed parameters.
    pub sigma: Vec<Option<f64>>,
    /// Covariance, `n × n` row-major (`n` = number of parameters); rows and columns of
    /// unidentified and fixed parameters are zero. See also [`Solution::cov`].
    pub covariance: Vec<f64>,
    /// The null space in readable form.
    pub combinations: Vec<Combination>,
}

impl Solution {
    /// Covariance of parameters `i` and `j`.
    pub fn cov(&self, i: usize, j: usize) -> f64 {
        self.covariance[i * self.x.len() + j]
    }

    /// Correlation coefficient of parameters `i` and `j` (`None` if either has no σ).
    pub fn correlation(&self, i: usize, j: usize) -> Option<f64> {
        Some(self.cov(i, j) / (self.sigma[i]? * self.sigma[j]?))
    }
}

/// The problem linearised at a point: `‖J·dx + r‖² = ‖R·dx + z‖² + rss` (prior rows included),
/// from [`linearize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    /// Square root of the information matrix, `n × n` row-major (`n` = number of parameters)
    /// with columns in parameter order: `Rᵀ R = Jᵀ J`. The first rows (one per free parameter)
    /// form an upper-triangular factor up to a permutation of its columns; the remaining rows
    /// and the columns of fixed parameters are zero.
    pub r: Vec<f64>,
    /// Rotated residual `Qᵀ r`, one entry per row of `r` (zero beyond the free parameters).
    pub z: Vec<f64>,
    /// The part of `Σ r²` no step can remove.
    pub rss: f64,
    /// `½ Σ r²`.
    pub cost: f64,
    /// Data rows.
    pub n_rows: usize,
    /// Free parameters in the factor's column order.
    free: Vec<usize>,
    /// Per parameter: least column scale (`1/ParamSpec::scale`, 0 without one).
    floor: Vec<f64>,
}

impl Linearization {
    /// The Gauss–Newton step from the point of linearisation (one entry per parameter, zero
    /// for fixed ones), restricted to the directions the solver would call identified at
    /// `rank_tolerance` — the same column scaling, visibility rule and rank as [`solve`].
    pub fn step(&self, rank_tolerance: f64) -> Result<Vec<f64>, SolveError> {
        let n = self.floor.len();
        let cols = self.free.len();
        let mut r = vec![0.0; cols * cols];
        for (c, &p) in self.free.iter().enumerate() {
            for i in 0..=c {
                r[i + c * cols] = self.r[i * n + p];
            }
        }
        let lin = eval::Lin {
            order: self.free.clone(),
            r,
            z: self.z[..cols].to_vec(),
            rss: self.rss,
            cost: self.cost,
            n_rows: self.n_rows,
            usage: Vec::new(),
        };
        let dx = analysis::Analysis::new(&lin, rank_tolerance, &self.floor)?.step(0.0);
        let mut out = vec![0.0; n];
        for (c, &p) in self.free.iter().enumerate() {
            out[p] = dx[c];
        }
        Ok(out)
    }
}

/// Errors of [`solve`] and [`linearize`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SolveError {
    /// `params` does not match the problem.
    #[error("the problem has {expected} parameters but {got} parameter specs were given")]
    ParamCount {
        /// `Problem::n_params`.
        expected: usize,
        /// `params.len()`.
        got: usize,
    },
    /// A parameter spec is unusable.
    #[error("parameter {index} ({name}): {reason}")]
    InvalidParam {
        /// Parameter index.
        index: usize,
        /// Its name.
        name: String,
        /// What to fix.
        reason: String,
    },
    /// Nothing to solve.
    #[error("the problem is empty: {0}")]
    Empty(String),
    /// Every parameter is fixed.
    #[error("all {n} parameters are fixed: free at least one")]
    AllFixed {
        /// Number of parameters.
        n: usize,
    },
    /// A residual is NaN or infinite.
    #[error("block {block}, row {row}: the residual is {value} (non-finite)")]
    NonFiniteResidual {
        /// Block index.
        block: usize,
        /// Row within the block (0-based, in push order).
        row: usize,
        /// The value.
        value: f64,
    },
    /// A Jacobian entry is NaN or infinite.
    #[error(
        "block {block}, row {row}: the derivative by parameter {param} ({name}) is {value} (non-finite)"
    )]
    NonFiniteJacobian {
        /// Block index.
        block: usize,
        /// Row within the block.
        row: usize,
        /// Parameter index.
        param: usize,
        /// Parameter name.
        name: String,
        /// The value.
        value: f64,
    },
    /// Candidate scoring ([`score_candidates`]) got inconsistent input.
    #[error("candidate scores: {0}")]
    Score(String),
    /// `eval_block` failed at the starting point.
    #[error("block {block}: evaluation failed: {cause}")]
    Eval {
        /// Block index.
        block: usize,
        /// The problem's error.
        cause: EvalError,
    },
    /// A block passed an invalid column set to [`RowSink::columns`].
    #[error("block {block}: invalid columns: {reason}")]
    InvalidColumns {
        /// Block index.
        block: usize,
        /// What is wrong.
        reason: String,
    },
    /// A block pushed a malformed row.
    #[error("block {block}, row {row}: {reason}")]
    InvalidRow {
        /// Block index.
        block: usize,
        /// Row within the block.
        row: usize,
        /// What is wrong.
        reason: String,
    },
    /// A dense linear-algebra kernel failed.
    #[error("numerical failure: {0}")]
    Numerical(String),
}
