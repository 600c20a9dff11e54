//! One calibration campaign as the history stores it, and the checks it passes before it is
//! written (a history holds no NaN, no number for a parameter the data could not determine, no
//! nameless machine).

use crate::{Error, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;

/// A machine as the history knows it: the name the user gives it (the key of its series) and
/// the digests of the files that described it in this campaign (a changed digest means the
/// model changed between campaigns). Digests are taken as given; `None` when not known.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MachineIdentity {
    pub name: String,
    pub urdf_digest: Option<String>,
    pub error_model_digest: Option<String>,
}

/// The fit of the identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    pub rms_um: f64,
    /// χ²/dof; `None` when the fit had no degree of freedom.
    pub chi2_reduced: Option<f64>,
    pub dof: u64,
    /// Fitted runs.
    pub runs: u64,
    pub converged: bool,
    /// What a person reads first when the fit is not a calibration (identify's `verdict`).
    pub verdict: Option<String>,
}

/// A validation run (not fitted): how well the identified model predicted it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationRun {
    pub name: String,
    pub instrument: String,
    /// `None` when identify could not give one.
    pub rms_um: Option<f64>,
}

/// An effect the physics search added.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiscoverySummary {
    /// The effect family (`thermal-drift`, `reversal`, …).
    pub effect: String,
    /// Its label (`thermal-drift Z (t)`), the prefix of its parameters' names.
    pub label: String,
    /// The effect with its fitted values, in words.
    pub sentence: Option<String>,
}

/// How well the campaign's data determined a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ParameterStatus {
    /// A value with its 95 % interval.
    Identified,
    /// The value of a combination of parameters the data cannot separate, carried by this one
    /// (its [`Parameter::expression`] says which).
    Combination,
    /// A value whose interval is beyond what a machine plausibly has, or mostly another
    /// parameter's uncertainty.
    WeaklyDetermined,
    /// The data cannot determine it: no number is stored.
    NotIdentifiable,
}

impl ParameterStatus {
    /// The text stored in the database (and in JSON).
    pub fn as_str(self) -> &'static str {
        match self {
            ParameterStatus::Identified => "identified",
            ParameterStatus::Combination => "combination",
            ParameterStatus::WeaklyDetermined => "weakly-determined",
            ParameterStatus::NotIdentifiable => "not-identifiable",
        }
    }

    /// The status a stored text names.
    pub fn from_stored(text: &str) -> Option<ParameterStatus> {
        [
            ParameterStatus::Identified,
            ParameterStatus::Combination,
            ParameterStatus::WeaklyDetermined,
            ParameterStatus::NotIdentifiable,
        ]
        .into_iter()
        .find(|s| s.as_str() == text)
    }

    /// Whether a parameter of this status carries a number.
    pub fn has_value(self) -> bool {
        self != ParameterStatus::NotIdentifiable
    }
}

/// One parameter of a campaign. `value` and `u95` (the 95 % half-width, k = 2) are both given
/// unless the status is [`ParameterStatus::NotIdentifiable`], when neither is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    pub name: String,
    pub status: ParameterStatus,
    /// In `unit`.
    pub value: Option<f64>,
    pub u95: Option<f64>,
    /// `um`, `urad`, `ppm`…; `None` when identify did not say (a parameter it could not
    /// determine).
    pub unit: Option<String>,
    /// `machine`, the set-up a nuisance parameter belongs to, or `effect`; `None` when not said.
    pub kind: Option<String>,
    /// For a [`ParameterStatus::Combination`]: what the value stands for (`EC0Y − 0.5·EXX.P1`).
    pub expression: Option<String>,
}

impl Parameter {
    /// An identified parameter.
    pub fn identified(name: &str, value: f64, u95: f64, unit: &str) -> Parameter {
        Parameter {
            name: name.to_string(),
            status: ParameterStatus::Identified,
            value: Some(value),
            u95: Some(u95),
            unit: Some(unit.to_string()),
            kind: Some("machine".into()),
            expression: None,
        }
    }

    /// A parameter the data cannot determine (no number).
    pub fn not_identifiable(name: &str) -> Parameter {
        Parameter {
            name: name.to_string(),
            status: ParameterStatus::NotIdentifiable,
            value: None,
            u95: None,
            unit: None,
            kind: None,
            expression: None,
        }
    }

    fn check(&self) -> Result<(), String> {
        let name = &self.name;
        required_text("a parameter name", name)?;
        optional_text(&format!("parameter {name}'s unit"), &self.unit)?;
        optional_text(&format!("parameter {name}'s kind"), &self.kind)?;
        if self.status.has_value() {
            finite(&format!("parameter {name}'s value"), self.value)?;
            let u95 = finite(&format!("parameter {name}'s u95"), self.u95)?;
            if u95 < 0.0 {
                return Err(format!("parameter {name}'s u95 is negative ({u95})"));
            }
        } else if self.value.is_some() || self.u95.is_some() {
            return Err(format!(
                "parameter {name} is not identifiable and must carry no number"
            ));
        }
        let combination = self.status == ParameterStatus::Combination;
        match (&self.expression, combination) {
            (None, true) => Err(format!("combination {name} needs its expression")),
            (Some(_), false) => Err(format!(
                "parameter {name} has an expression but is not a combination"
            )),
            (Some(e), true) => required_text(&format!("combination {name}'s expression"), e),
            (None, false) => Ok(()),
        }
    }
}

/// One calibration campaign of one machine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Campaign {
    pub machine: MachineIdentity,
    /// When the machine was measured (UTC; stored to the second).
    pub date: Timestamp,
    /// The digest of the session's files.
    pub session_digest: Option<String>,
    /// The mtcal version that identified it.
    pub mtcal_version: Option<String>,
    /// The instruments of its runs (`laser`, `ballbar`, …), each once.
    pub instruments: Vec<String>,
    pub fit: FitSummary,
    pub validation: Vec<ValidationRun>,
    pub discoveries: Vec<DiscoverySummary>,
    /// Every parameter, in identify's order; names are unique.
    pub parameters: Vec<Parameter>,
    /// The machine's temperature during the campaign, °C.
    pub temperature_c: Option<f64>,
    pub note: Option<String>,
}

impl Campaign {
    /// Why this campaign cannot be stored, if it cannot.
    pub(crate) fn check(&self) -> Result<(), Error> {
        self.check_fields().map_err(|why| {
            Error::InvalidCampaign(format!("machine {:?}: {why}", self.machine.name))
        })
    }

    fn check_fields(&self) -> Result<(), String> {
        required_text("the machine name", &self.machine.name)?;
        optional_text("the URDF digest", &self.machine.urdf_digest)?;
        optional_text("the error-model digest", &self.machine.error_model_digest)?;
        optional_text("the session digest", &self.session_digest)?;
        optional_text("the mtcal version", &self.mtcal_version)?;
        crate::date::stored(self.date)?;
        finite("the fit's rms_um", Some(self.fit.rms_um))?;
        if let Some(chi2) = self.fit.chi2_reduced {
            finite("the fit's chi2_reduced", Some(chi2))?;
        }
        i64::try_from(self.fit.dof).map_err(|_| "the fit's dof is too large".to_string())?;
        i64::try_from(self.fit.runs).map_err(|_| "the fit's runs is too large".to_string())?;
        if let Some(t) = self.temperature_c {
            finite("the temperature", Some(t))?;
        }
        for instrument in &self.instruments {
            required_text("an instrument name", instrument)?;
        }
        for run in &self.validation {
            required_text("a validation run's name", &run.name)?;
            if let Some(rms) = run.rms_um {
                finite(&format!("validation run {}'s rms_um", run.name), Some(rms))?;
            }
        }
        for discovery in &self.discoveries {
            required_text("a discovery's effect", &discovery.effect)?;
            required_text("a discovery's label", &discovery.label)?;
        }
        self.check_parameters()
    }

    fn check_parameters(&self) -> Result<(), String> {
        let mut names = HashSet::new();
        for parameter in &self.parameters {
            parameter.check()?;
            if !names.insert(parameter.name.as_str()) {
                return Err(format!("parameter {} appears twice", parameter.name));
            }
        }
        Ok(())
    }
}

fn required_text(what: &str, text: &str) -> Result<(), String> {
    if text.trim().is_empty() {
        return Err(format!("{what} is empty"));
    }
    if text.chars().any(char::is_control) {
        return Err(format!("{what} {text:?} holds a control character"));
    }
    Ok(())
}

/// `Some("")` would read back as `None` (the database stores an absent unit as ''), so it is
/// refused rather than silently changed.
fn optional_text(what: &str, text: &Option<String>) -> Result<(), String> {
    match text {
        Some(t) => required_text(what, t),
        None => Ok(()),
    }
}

fn finite(what: &str, value: Option<f64>) -> Result<f64, String> {
    match value {
        None => Err(format!("{what} is missing")),
        Some(v) if !v.is_finite() => Err(format!("{what} is not a finite number ({v})")),
        Some(v) => Ok(v),
    }
}
