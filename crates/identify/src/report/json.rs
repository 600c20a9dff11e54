//! The FORMATS.md JSON (`mtcal.identify/1`, with mtcal's additional keys): a view of a fit's
//! report and of what stands beside it — what the physics search found, the information
//! account, the acceptance verdicts. Nothing here is computed; the keys are in the order the
//! format has always written them.

use super::*;
use crate::findings::{Discovery, SearchFindings, SearchReport};

/// The `mtcal.identify/1` document, borrowed from its parts.
#[derive(Debug, Serialize)]
pub struct IdentifyJson<'a> {
    schema: &'static str,
    /// What a person reads first when the fit is not a calibration
    /// ([`Identification::verdict`]); only then.
    #[serde(skip_serializing_if = "Option::is_none")]
    verdict: Option<String>,
    parameters: &'a [ParameterValue],
    component_errors: &'a [ComponentCurve],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    combinations: &'a [CombinationValue],
    unidentifiable: &'a [Unidentifiable],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    held: &'a [crate::base::Held],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    undetermined_validation: &'a [(String, Vec<crate::base::Term>)],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    weakly_determined: &'a [WeaklyDetermined],
    fit: &'a Fit,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    noise: &'a [String],
    validation: &'a [RunFit],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    diagnostics: &'a [crate::diagnostics::DiagnosisReport],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    location_series: &'a [crate::series::LocationSeries],
    mismatch: &'a mtcal_mismatch::Mismatch,
    mismatch_tests: &'a [String],
    /// Empty without `--search`.
    discoveries: &'a [Discovery],
    #[serde(skip_serializing_if = "Option::is_none")]
    search: Option<&'a SearchReport>,
    solver: &'a SolverReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    information: Option<&'a crate::information::InformationAccount>,
    conventions: &'a mtcal_machine::card::ConventionCard,
    /// Last, only with a tolerance file.
    #[serde(skip_serializing_if = "Option::is_none")]
    acceptance: Option<&'a mtcal_acceptance::Acceptance>,
}

impl<'a> IdentifyJson<'a> {
    /// The document of `id` alone (no search, account or acceptance).
    pub fn of(id: &'a Identification) -> Self {
        Self {
            schema: "mtcal.identify/1",
            verdict: id.verdict(),
            parameters: &id.parameters,
            component_errors: &id.component_errors,
            combinations: &id.combinations,
            unidentifiable: &id.unidentifiable,
            held: &id.held,
            undetermined_validation: &id.undetermined_validation,
            weakly_determined: &id.weakly_determined,
            fit: &id.fit,
            noise: &id.noise,
            validation: &id.validation,
            diagnostics: &id.diagnostics,
            location_series: &id.location_series,
            mismatch: &id.mismatch,
            mismatch_tests: &id.mismatch_detail,
            discoveries: &[],
            search: None,
            solver: &id.solver,
            information: None,
            conventions: &id.conventions,
            acceptance: None,
        }
    }

    /// With what the physics search found.
    pub fn search(self, findings: Option<&'a SearchFindings>) -> Self {
        Self {
            discoveries: findings.map_or(&[], |f| &f.discoveries),
            search: findings.map(|f| &f.report),
            ..self
        }
    }

    /// With the information account.
    pub fn information(self, account: Option<&'a crate::information::InformationAccount>) -> Self {
        Self {
            information: account,
            ..self
        }
    }

    /// With the acceptance verdicts.
    pub fn acceptance(self, acceptance: Option<&'a mtcal_acceptance::Acceptance>) -> Self {
        Self { acceptance, ..self }
    }

    /// The document as `mtcal identify --json` writes it.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the report serialises") + "\n"
    }
}
