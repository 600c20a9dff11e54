//! What an identification gives acceptance to check, as plain data: the instruments' own
//! evaluations of each run, the identified parameters, the component-error curves and what the
//! runs cannot determine. The command line builds it from an identification; tests build it by
//! hand.

/// A number from an instrument's evaluation of one run (an ISO 230-2 value, ISO 230-4 G).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MetricEvidence {
    pub run: String,
    /// As the instrument names it, `E (ISO 230-2)`.
    pub name: String,
    /// What it is about: an axis letter, a plane (`Metric::subject`).
    pub subject: Option<String>,
    /// In `unit`.
    pub value: f64,
    /// Its expanded uncertainty in `unit`, if the instrument gives one.
    pub u95: Option<f64>,
    /// The coverage factor of `u95` (2 for the instruments' budgets).
    pub k: f64,
    /// `um`, `urad`.
    pub unit: String,
}

/// An identified parameter: a value and its 95 % interval.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParameterEvidence {
    pub name: String,
    pub value: f64,
    pub u95: f64,
    /// The coverage factor of `u95` (1.96 for the identification's intervals).
    pub k: f64,
    pub unit: String,
}

/// A component error's curve over the stroke with its pointwise 95 % band.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurveEvidence {
    /// `EXX`.
    pub name: String,
    /// The values' unit, `um` or `urad`.
    pub unit: String,
    /// The positions' unit, `mm` or `deg`.
    pub position_unit: String,
    /// `[position, value, u95]`, from one end of the stroke to the other.
    pub samples: Vec<[f64; 3]>,
    /// The coverage factor of the samples' `u95`.
    pub k: f64,
}

/// Parameters the runs do not determine on their own, and why (a combination they see, a
/// direction they do not observe at all).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Undetermined {
    /// Every parameter or component error concerned.
    pub names: Vec<String>,
    pub why: String,
}

/// Everything a tolerance file can be checked against.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evidence {
    pub metrics: Vec<MetricEvidence>,
    pub parameters: Vec<ParameterEvidence>,
    pub curves: Vec<CurveEvidence>,
    pub undetermined: Vec<Undetermined>,
}
