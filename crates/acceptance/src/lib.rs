//! Acceptance of a machine against the standards' tolerances, decided with mtcal's own
//! uncertainties by the ISO 14253-1 rule (`mtcal identify --acceptance FILE`).
//!
//! A tolerance file (`mtcal.acceptance/1`, [`Tolerances::read`]; the format in full is
//! docs/ACCEPTANCE.md) limits what the instruments' own evaluations report — the ISO 230-2
//! axis values of laser runs, per axis; the ISO 230-4 circular deviation G of ball-bar circles,
//! per plane or for all — and the identified parameters, two-sided (`|EC0Y| ≤ 20 µrad`; a
//! component error `EXX` at every position of its stroke):
//!
//! ```toml
//! schema = "mtcal.acceptance/1"
//! decision_rule = "iso14253-1"   # the default; "simple" decides without guard bands
//!
//! [iso230_2.X]                   # µm, bidirectional values; A_uni_um etc. limit A↑ and A↓
//! A_um = 12
//! E_um = 8
//!
//! [iso230_4]
//! G_um = 15                      # every circle; [iso230_4.XY] G_um = 12 for one plane
//!
//! [parameters]
//! EC0Y = { max_abs_urad = 20 }
//! EXX = { max_abs_um = 5 }       # |EXX(x)| ≤ 5 µm over the whole stroke
//! ```
//!
//! [`evaluate`] checks it against an identification's [`Evidence`]: each value with its
//! expanded uncertainty `U` — the identification's u95 for parameters and curves, the
//! instruments' budgets for their values (`Metric::u95`: laser and ball-bar) — by
//! [`rule::decide`]: pass when the value is inside the tolerance by at least `U`, fail when it
//! is beyond it by more than `U`, otherwise "cannot decide". A parameter the runs cannot
//! separate, or a quantity no run measured, cannot be decided either, and the check says why. A
//! value without uncertainty is decided by the simple rule and says so.
//!
//! Layer 3: it reads files through `mtcal-located` and knows nothing of sessions, machines
//! or instruments; `mtcal-identify` gathers the evidence.

mod evaluate;
mod evidence;
mod file;
pub mod rule;

pub use evaluate::{Acceptance, CIRCULAR_DEVIATION, Check, evaluate};
pub use evidence::{CurveEvidence, Evidence, MetricEvidence, ParameterEvidence, Undetermined};
pub use file::{
    AXES, AxisTolerance, CircleTolerance, ISO230_2_KEYS, Iso230_2Value, PARAMETER_KEYS, PLANES,
    ParameterTolerance, ParameterUnit, SCHEMA, TOP_KEYS, Tolerances,
};
pub use rule::{DecisionRule, Verdict, Zone};

/// Why a tolerance file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum AcceptanceError {
    /// Missing, unreadable or not text.
    #[error(transparent)]
    Read(#[from] mtcal_located::ReadError),
    /// Wrong at a place in the file (`file:line:column: what was expected, what was found`).
    #[error(transparent)]
    Invalid(#[from] mtcal_located::Located),
}
