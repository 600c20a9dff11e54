//! Tolerance analysis: from manufacturing tolerances of a machine's structural parts to the
//! statistics of its volumetric error (source 001, Valášek, CTU Prague).
//!
//! Source 001 asks which tolerances matter: how the straightness of the surfaces the linear-guide
//! rails are mounted on sets each assembled axis' errors, and how those set the volumetric error.
//! Its prediction: draw random machines within the tolerances (Monte Carlo), record each one's
//! maximum volumetric error over the workspace, report the **90th percentile** of that maximum
//! (the accuracy 90 % of built machines reach), and rank the tolerances by sensitivity. This
//! crate implements it on any mtcal machine whose linear axes are X, Y and Z:
//!
//! 1. [`rail`]: the rail/carriage model (a rigid plate on four spring blocks on two rails, the
//!    source's eqs. 14–15) turns rail mounting-surface profiles and block-pad deviations into an
//!    axis' straightness, pitch, roll and yaw along its stroke, and those into mtcal's
//!    functional ISO 230-1 component errors (`EXX … ECZ`), with random profiles from
//!    [`rail::ProfileBasis`].
//! 2. [`spec`]: the tolerance specification (TOML, below).
//! 3. [`eval`]: the analysis model (tables at the grid knots, mtcal's conventions for what a
//!    component error leaves out) and an allocation-free maximum of `|Δ|` over the grid.
//! 4. [`monte_carlo`]: the sampling, the percentiles with order-statistics confidence intervals,
//!    and one-at-a-time sensitivities with common random numbers and bootstrap errors.
//!
//! The command line is `cargo xtask tolerance MACHINE --spec tolerances.toml`; the method, every
//! assumption and a worked example are in docs/TOLERANCE.md.
//!
//! # The specification
//! Lengths in the file are mm (geometry) or µm (tolerances), angles µrad, stiffness N/µm, loads
//! N. Unknown keys are errors; every error names file, line and column.
//!
//! ```toml
//! schema = "mtcal.tolerances/1"     # optional
//!
//! [monte_carlo]                     # optional; the command line overrides each
//! samples = 5000                    # sampled machines (source 001: 50,000)
//! seed = 1
//! grid = [11, 11, 11]               # points on X, Y, Z over their limits (>= 3 each)
//!
//! [sensitivity]                     # optional
//! levels = [0.0, 0.5, 1.5, 2.0]     # each tolerance alone scaled by these (default); [] = none
//!
//! [axis.X]                          # the guide of an axis: needed by its rail / pads tolerances
//! normal = "+Z"                     # from the rails to the carriage ("vertical"); ⟂ the axis
//! rail_spacing_mm = 400.0           # W, between the two rails
//! block_pitch_mm = 300.0            # L, between the two blocks on a rail
//! stiffness_n_per_um = 500.0        # blocks' normal stiffness: one value or [k1, k2, k3, k4]
//! lateral_stiffness_n_per_um = 500.0
//! load_n = 0.0                      # F_zz, pressing the carriage onto the rails
//! lateral_load_n = 0.0              # F_zy, along l = n × a
//! modes = 8                         # profile generator: harmonics
//! decay = 1.0                       # amplitude of harmonic m ∝ m^-decay
//!
//! [[tolerance]]
//! kind = "rail"                     # straightness of both rails' mounting surfaces
//! axis = "X"
//! direction = "vertical"            # or "horizontal"
//! tolerance_um = 30.0               # zone width
//! distribution = "limit"            # default for rails: every surface uses its whole zone
//!
//! [[tolerance]]
//! kind = "pads"                     # parallelism of the four block pads of the carriage
//! axis = "X"
//! tolerance_um = 10.0               # pad deviations within ±tolerance/2
//!
//! [[tolerance]]
//! kind = "component"                # a component error directly…
//! name = "EXX"
//! shape = "linear"                  # "linear" (0 → tol), "bow" (0 at the ends, tol mid), "constant"
//! tolerance_um = 10.0               # tolerance_urad for EA*, EB*, EC*
//! distribution = "uniform"          # default: "uniform" (a bound), "normal" (2σ), "limit" (±tol)
//!
//! [[tolerance]]
//! kind = "component"                # …or a squareness
//! name = "EC0Y"
//! tolerance_urad = 20.0
//! label = "XY squareness"           # optional, for reports
//! ```
//!
//! A tolerance's sampled error is `tolerance · X` with `X` from its distribution: uniform on
//! `[−1, 1]`, normal with σ = 1/2, or ±1. For a rail the zone width is `tolerance · |X|` and the
//! shape of the profile is random ([`rail::ProfileBasis`]); each of the two rails gets its own.
//!
//! # What is reported
//! Per sampled machine, the maximum over the grid of the first-order translation error `|Δ|`
//! (µm) of the tool point relative to the workpiece (source 001 leaves open whether "maximum"
//! is of the norm or of a component: the norm, like `cargo xtask map`). Over the machines:
//! P90 (source 001's statistic) with a distribution-free confidence interval from order
//! statistics, P50, P95, mean, spread, histogram. Per tolerance: the P90 with it at zero and
//! the other levels, what it adds to the P90, and the least-squares slope of P90 against the
//! tolerance (like source 001's Table 1), each with a paired-bootstrap standard error. The
//! sampled errors are linear in each tolerance, so with one tolerance alone doubling it doubles
//! every maximum exactly.

pub mod eval;
mod grid_text;
pub mod monte_carlo;
pub mod rail;
pub mod spec;
pub mod stats;

pub use grid_text::{GridTextError, parse_grid};
pub use monte_carlo::{
    Analysis, AnalysisError, DEFAULT_GRID, DEFAULT_SAMPLES, Options, Report, Sampler, Sensitivity,
};
pub use spec::{Spec, SpecError, Tolerance, load_spec, parse_spec};
