//! The result of an identification as users read it: parameters with 95 % intervals, named
//! unidentifiable combinations (never numbers), fit statistics per run and channel, validation
//! predictions; the FORMATS.md `mtcal.identify/1` JSON and a plain-text summary.

use crate::base::{BaseModel, ConditionalCovariance, HeldWhy, expression};
use crate::study::Study;
use mtcal_kinematics::model::Role;
use mtcal_solve::Solution;
use serde::Serialize;
use std::fmt::Write as _;

mod build;
mod json;
mod text;

pub(crate) use build::component_curves_sampled;
pub use json::IdentifyJson;
pub use text::chi2_within_noise;

pub use crate::K95;

/// Samples per component-error curve in the JSON.
const CURVE_SAMPLES: usize = 11;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParameterValue {
    pub name: String,
    /// In `unit` (µm, µrad, ppm).
    pub value: f64,
    pub unit: String,
    pub u95: f64,
    /// The 95 % interval if the parameters the runs cannot determine ([`crate::base`]) were
    /// exactly at their start values: what the runs alone say. `u95` also holds their prior
    /// uncertainty. Only when some are held.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u95_given_held: Option<f64>,
    /// `machine` or the set-up it belongs to.
    pub kind: String,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ComponentCurve {
    pub name: String,
    /// `[position mm|deg, value um|urad, u95]`.
    pub samples: Vec<[f64; 3]>,
}

/// What the runs determine of parameters they cannot separate: the taken parameter's estimate
/// stands for `name + Σ coefficient·term` ([`crate::base`]).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CombinationValue {
    /// Readable form, e.g. `EC0Y − 0.5·EXX.P1`.
    pub expression: String,
    /// The parameter that carries the number (coefficient 1).
    pub name: String,
    pub terms: Vec<crate::base::Term>,
    pub value: f64,
    pub unit: String,
    pub u95: f64,
    /// As [`ParameterValue::u95_given_held`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u95_given_held: Option<f64>,
    pub kind: String,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Unidentifiable {
    pub parameters: Vec<String>,
    pub why: String,
}

/// Identified parameters the runs barely determine: numbers are given, but their intervals are
/// beyond what a machine plausibly has (the runs hardly see the parameter), or their estimates
/// correlate so strongly that each interval is mostly the others' uncertainty.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct WeaklyDetermined {
    pub parameters: Vec<String>,
    pub why: String,
}

/// Two identified parameters whose estimates correlate beyond this are reported as weakly
/// determined (each interval is then at least 70 × what it would be with the other known).
pub const WEAK_CORRELATION: f64 = 0.9999;

/// A parameter whose 95 % interval exceeds this share of its plausible range (the solver's
/// `ParamSpec::scale`: a millimetre or milliradian for machine and set-up parameters) is
/// reported as weakly determined.
pub const WEAK_SHARE_OF_RANGE: f64 = 0.1;

/// A parameter whose standard uncertainty is more than this share of its prior's was not
/// narrowed by the runs (they take less than 10 % off its prior's width): its interval is the
/// prior's, and it is reported as weakly determined whatever the prior's width.
pub const PRIOR_ONLY: f64 = 0.9;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChannelFit {
    pub name: String,
    pub unit: String,
    pub rms: f64,
    /// Σ (residual/σ)².
    pub chi2: f64,
    pub samples: usize,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RunFit {
    pub name: String,
    pub instrument: String,
    /// RMS over the run's channels, in µm (or the channels' unit).
    pub rms_um: f64,
    pub channels: Vec<ChannelFit>,
    /// The instrument's own evaluation of the measured readings (e.g. ISO 230-4).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub metrics: Vec<MetricValue>,
}

#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct MetricValue {
    pub name: String,
    pub value: f64,
    pub unit: String,
    /// The instrument's expanded uncertainty of `value` (k = 2, in `unit`), if it gives one;
    /// not in the JSON's run metrics (acceptance shows it with its verdicts).
    #[serde(skip)]
    pub u95: Option<f64>,
    /// What the value is about (an axis letter, a plane; `mtcal_instrument::Metric::subject`);
    /// not in the JSON.
    #[serde(skip)]
    pub subject: Option<String>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Fit {
    pub rms_um: f64,
    pub chi2_reduced: f64,
    pub chi2: f64,
    pub dof: usize,
    pub runs: Vec<RunFit>,
}

/// The fitted runs weighed by the σ their manifests state, for a fit that assumed another
/// noise.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AgainstStated {
    /// Σ (residual/σ_stated)² over the fitted runs.
    pub chi2: f64,
    /// The run and channel with the largest share of it.
    pub worst: Option<WorstChannel>,
    /// The largest ratio of the noise the fit assumes to the stated σ.
    pub largest_scale: f64,
}

/// A fitted run's channel and its χ² against the stated σ.
#[derive(Debug, Clone, PartialEq)]
pub struct WorstChannel {
    pub run: String,
    pub channel: String,
    /// RMS residual, in `unit`.
    pub rms: f64,
    pub unit: String,
    pub chi2: f64,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SolverReport {
    pub iterations: usize,
    /// Passes over the data (evaluations at trial points and the start).
    pub passes: usize,
    /// Passes that built a factor; the others only checked a point (gradient-only).
    pub factorizations: usize,
    pub converged: bool,
    pub termination: mtcal_solve::Termination,
    pub rank: usize,
    pub parameters: usize,
    pub condition_number: f64,
}

/// The report of one fit: its parameters with their intervals, what the runs cannot
/// determine, how well it fits and predicts, where its residuals depart from the noise. Built
/// once per fit ([`Identification::new`], then [`Identification::with_base`] and
/// [`Identification::with_prediction_bands`] where they apply); what the search found, the
/// information account and the acceptance stand beside it in [`crate::pipeline::Outcome`],
/// and the JSON is a view of them all ([`IdentifyJson`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    pub parameters: Vec<ParameterValue>,
    pub component_errors: Vec<ComponentCurve>,
    /// Combinations of parameters the runs determine although they cannot separate them
    /// ([`crate::base`]).
    pub combinations: Vec<CombinationValue>,
    pub unidentifiable: Vec<Unidentifiable>,
    /// Parameters the runs do not determine, held near their start ([`crate::base`]).
    pub held: Vec<crate::base::Held>,
    /// Validation runs that depend on held parameters the fitted runs do not determine
    /// ([`crate::base::BaseModel::validation`]).
    pub undetermined_validation: Vec<(String, Vec<crate::base::Term>)>,
    /// Identified parameters the runs barely determine ([`WeaklyDetermined`]).
    pub weakly_determined: Vec<WeaklyDetermined>,
    pub fit: Fit,
    /// The noise the fit assumed where it is not the stated white noise ([`crate::noise`]),
    /// one sentence per set-up.
    pub noise: Vec<String>,
    /// Validation runs: not fitted; how well the identified model predicts them.
    pub validation: Vec<RunFit>,
    /// The instruments' own diagnostics in their users' terms (a ball-bar's circle pairs),
    /// with the model's value and what stands behind it ([`crate::diagnostics`]).
    pub diagnostics: Vec<crate::diagnostics::DiagnosisReport>,
    /// The location errors cycle by cycle where the runs overlap in time (R-test sets
    /// repeated between load cycles), each cycle's own value beside the model's
    /// ([`crate::series`]).
    pub location_series: Vec<crate::series::LocationSeries>,
    /// The fit judged against the σ the manifests state, when it weighs the runs by another
    /// noise ([`crate::noise`]): a model that explains the recordings only at a noise far above
    /// the stated one is not said to explain them ([`Identification::verdict`]).
    pub against_stated: Option<AgainstStated>,
    /// Where the fitted runs' residuals depart from their noise (FORMATS.md `mismatch`).
    pub mismatch: mtcal_mismatch::Mismatch,
    /// Every structure test behind `mismatch`, one sentence each for the rejected ones; in the
    /// JSON as `mismatch_tests`.
    pub mismatch_detail: Vec<String>,
    /// Every structure test behind `mismatch` (for the physics search's sentences).
    pub tests: Vec<mtcal_mismatch::TestRecord>,
    pub solver: SolverReport,
    /// What the parameters' numbers mean: errors, ISO 230-1 signs, the squareness definition,
    /// rotary direction, units ([`mtcal_machine::card::ConventionCard::mtcal_parameters`]).
    pub conventions: mtcal_machine::card::ConventionCard,
}
