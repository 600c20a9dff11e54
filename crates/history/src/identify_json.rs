//! A campaign from mtcal's identify JSON (`mtcal.identify/1`, docs/FORMATS.md "identify JSON
//! output" and "mtcal's additions"), read into this crate's own structs: the history does not
//! depend on the identification crate, only on its documented output.
//!
//! How each parameter's status is read:
//! - `parameters[]` are identified, or weakly determined when `weakly_determined[]` names them;
//! - `combinations[]`: the member that carries a combination's value (`name`) stores it, with
//!   the combination's `expression`;
//! - every other name in `unidentifiable[]` or `held[]` is not identifiable: no number.

use crate::campaign::{
    Campaign, DiscoverySummary, FitSummary, MachineIdentity, Parameter, ParameterStatus,
    ValidationRun,
};
use crate::{Error, Timestamp};
use serde::Deserialize;
use std::collections::HashSet;

/// The schema this reader understands.
const SCHEMA: &str = "mtcal.identify/1";

#[derive(Deserialize)]
struct Identification {
    #[serde(default)]
    verdict: Option<String>,
    parameters: Vec<Estimated>,
    #[serde(default)]
    combinations: Vec<Combination>,
    #[serde(default)]
    unidentifiable: Vec<Group>,
    #[serde(default)]
    held: Vec<Held>,
    #[serde(default)]
    weakly_determined: Vec<Group>,
    fit: Fit,
    #[serde(default)]
    validation: Vec<Run>,
    #[serde(default)]
    discoveries: Vec<Discovery>,
    solver: Solver,
}

/// `value` and `u95` are options because serde_json writes a NaN as `null`: the campaign's
/// checks then name the parameter.
#[derive(Deserialize)]
struct Estimated {
    name: String,
    value: Option<f64>,
    unit: String,
    u95: Option<f64>,
    #[serde(default)]
    kind: Option<String>,
}

#[derive(Deserialize)]
struct Combination {
    expression: String,
    name: String,
    value: Option<f64>,
    unit: String,
    u95: Option<f64>,
    #[serde(default)]
    kind: Option<String>,
}

#[derive(Deserialize)]
struct Group {
    parameters: Vec<String>,
}

#[derive(Deserialize)]
struct Held {
    name: String,
    #[serde(default)]
    unit: Option<String>,
}

#[derive(Deserialize)]
struct Fit {
    rms_um: Option<f64>,
    chi2_reduced: Option<f64>,
    dof: u64,
    runs: Vec<Run>,
}

#[derive(Deserialize)]
struct Run {
    name: String,
    instrument: String,
    rms_um: Option<f64>,
}

#[derive(Deserialize)]
struct Discovery {
    effect: String,
    #[serde(default)]
    label: Option<String>,
    #[serde(default)]
    sentence: Option<String>,
}

#[derive(Deserialize)]
struct Solver {
    converged: bool,
}

impl Campaign {
    /// The campaign an identify JSON reports, for the machine the user calls `machine_name`,
    /// measured at `date`. The digests, the mtcal version, the temperature and the note are
    /// left `None` for the caller to fill in. The instruments are those of the fitted and
    /// validation runs, in order of first appearance.
    pub fn from_identify_json(
        json_text: &str,
        machine_name: &str,
        date: Timestamp,
    ) -> Result<Campaign, Error> {
        let identification = read(json_text)?;
        let campaign = Campaign {
            machine: MachineIdentity {
                name: machine_name.to_string(),
                urdf_digest: None,
                error_model_digest: None,
            },
            date,
            session_digest: None,
            mtcal_version: None,
            instruments: instruments(&identification),
            fit: fit(&identification)?,
            validation: validation(&identification),
            discoveries: discoveries(&identification),
            parameters: parameters(&identification)?,
            temperature_c: None,
            note: None,
        };
        campaign.check()?;
        Ok(campaign)
    }
}

/// Only the schema key, read first: another schema's keys are not this one's to complain about.
#[derive(Deserialize)]
struct Schema {
    schema: Option<String>,
}

fn read(json_text: &str) -> Result<Identification, Error> {
    let schema: Schema = deserialize(json_text)?;
    match schema.schema.as_deref() {
        Some(SCHEMA) => deserialize(json_text),
        Some(other) => Err(Error::IdentifyJson(format!(
            "schema is {other:?}, this mtcal reads {SCHEMA:?}"
        ))),
        None => Err(Error::IdentifyJson(format!(
            "no `schema` key: not an identify JSON ({SCHEMA:?})"
        ))),
    }
}

/// serde's error with the path of the key it is about.
fn deserialize<T: serde::de::DeserializeOwned>(json_text: &str) -> Result<T, Error> {
    let mut deserializer = serde_json::Deserializer::from_str(json_text);
    serde_path_to_error::deserialize(&mut deserializer)
        .map_err(|e| Error::IdentifyJson(format!("at `{}`: {}", e.path(), e.inner())))
}

fn instruments(identification: &Identification) -> Vec<String> {
    let mut seen = HashSet::new();
    identification
        .fit
        .runs
        .iter()
        .chain(&identification.validation)
        .filter(|run| seen.insert(run.instrument.as_str()))
        .map(|run| run.instrument.clone())
        .collect()
}

fn fit(identification: &Identification) -> Result<FitSummary, Error> {
    let fit = &identification.fit;
    let rms_um = fit
        .rms_um
        .ok_or_else(|| Error::IdentifyJson("`fit.rms_um` is null".into()))?;
    Ok(FitSummary {
        rms_um,
        chi2_reduced: fit.chi2_reduced,
        dof: fit.dof,
        runs: fit.runs.len() as u64,
        converged: identification.solver.converged,
        verdict: identification.verdict.clone(),
    })
}

fn validation(identification: &Identification) -> Vec<ValidationRun> {
    identification
        .validation
        .iter()
        .map(|run| ValidationRun {
            name: run.name.clone(),
            instrument: run.instrument.clone(),
            rms_um: run.rms_um,
        })
        .collect()
}

fn discoveries(identification: &Identification) -> Vec<DiscoverySummary> {
    identification
        .discoveries
        .iter()
        .map(|d| DiscoverySummary {
            effect: d.effect.clone(),
            label: d.label.clone().unwrap_or_else(|| d.effect.clone()),
            sentence: d.sentence.clone(),
        })
        .collect()
}

fn parameters(identification: &Identification) -> Result<Vec<Parameter>, Error> {
    let weak: HashSet<&str> = identification
        .weakly_determined
        .iter()
        .flat_map(|g| g.parameters.iter().map(String::as_str))
        .collect();
    let mut out: Vec<Parameter> = identification
        .parameters
        .iter()
        .map(|p| estimated(p, weak.contains(p.name.as_str())))
        .collect();
    out.extend(identification.combinations.iter().map(combination));
    let mut named: HashSet<String> = HashSet::new();
    for parameter in &out {
        if !named.insert(parameter.name.clone()) {
            return Err(Error::IdentifyJson(format!(
                "parameter {} has two values (in `parameters` or `combinations`)",
                parameter.name
            )));
        }
    }
    for (name, unit) in undetermined(identification) {
        if named.insert(name.clone()) {
            let mut parameter = Parameter::not_identifiable(&name);
            parameter.unit = unit;
            out.push(parameter);
        }
    }
    Ok(out)
}

fn estimated(p: &Estimated, weak: bool) -> Parameter {
    Parameter {
        name: p.name.clone(),
        status: if weak {
            ParameterStatus::WeaklyDetermined
        } else {
            ParameterStatus::Identified
        },
        value: p.value,
        u95: p.u95,
        unit: Some(p.unit.clone()),
        kind: p.kind.clone(),
        expression: None,
    }
}

fn combination(c: &Combination) -> Parameter {
    Parameter {
        name: c.name.clone(),
        status: ParameterStatus::Combination,
        value: c.value,
        u95: c.u95,
        unit: Some(c.unit.clone()),
        kind: c.kind.clone(),
        expression: Some(c.expression.clone()),
    }
}

/// Names the data cannot determine, with their unit when identify gives it (`held[]` does,
/// `unidentifiable[]` does not: held first, so a name in both keeps its unit).
fn undetermined(identification: &Identification) -> Vec<(String, Option<String>)> {
    let held = identification
        .held
        .iter()
        .map(|h| (h.name.clone(), h.unit.clone()));
    let unidentifiable = identification
        .unidentifiable
        .iter()
        .flat_map(|g| g.parameters.iter().map(|name| (name.clone(), None)));
    held.chain(unidentifiable).collect()
}
