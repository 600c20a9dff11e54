//! Parameter values from an identification: `mtcal identify --json` (schema `mtcal.identify/1`)
//! read into the coefficient vector of an error model, as a parameter file ([`crate::params`])
//! would be, and an account of what went in and what was left out.
//!
//! What goes in is what the identification gave a number: each machine parameter with its
//! value (its u95 is said, not used). What the session could not determine — a combination of
//! parameters, a parameter held because no run sees it — has no number in the JSON and stays
//! zero: a compensation never carries a number the identification refused to give. The
//! discoveries of the physics search (a backlash, a thermal drift) are named, not put into a
//! static table. An identification that did not converge is refused: nothing is built on it.

use crate::params::ParamsError;
use mtcal_kinematics::ErrorModel;
use mtcal_located::Location;
use serde::Deserialize;
use std::path::Path;

/// The schema of `mtcal identify --json`.
pub const IDENTIFY_SCHEMA: &str = "mtcal.identify/1";

/// Whether `text` looks like JSON rather than a TOML parameter file (its first character).
pub fn is_json(text: &str) -> bool {
    text.trim_start_matches('\u{feff}')
        .trim_start()
        .starts_with('{')
}

/// An identification's values in a model, and what they leave out.
#[derive(Clone, Debug, PartialEq)]
pub struct FromIdentify {
    /// The model's coefficients (SI): the identified ones set, the others zero.
    pub coeffs: Vec<f64>,
    /// The identified parameters put in: name, value and u95 in the file's units, the unit.
    pub used: Vec<(String, f64, Option<f64>, String)>,
    /// The model's parameters the identification gave no number (left at zero).
    pub not_given: Vec<String>,
    /// What the session could not separate, as the identification words it.
    pub combinations: Vec<String>,
    /// The discoveries of the physics search (not compensated by a static file).
    pub discoveries: Vec<String>,
}

#[derive(Deserialize)]
struct Json {
    schema: String,
    parameters: Vec<JsonParam>,
    #[serde(default)]
    unidentifiable: Vec<JsonCombination>,
    #[serde(default)]
    discoveries: Vec<JsonDiscovery>,
    solver: JsonSolver,
}

#[derive(Deserialize)]
struct JsonParam {
    name: String,
    value: f64,
    unit: String,
    u95: Option<f64>,
    kind: String,
}

#[derive(Deserialize)]
struct JsonCombination {
    why: String,
}

#[derive(Deserialize)]
struct JsonDiscovery {
    label: String,
}

#[derive(Deserialize)]
struct JsonSolver {
    converged: bool,
}

fn invalid(file: &Path, message: impl Into<String>) -> ParamsError {
    ParamsError::Invalid {
        at: Location {
            file: file.to_path_buf(),
            line: 1,
            column: 1,
        },
        message: message.into(),
    }
}

/// Reads the identify JSON `text` (`file` names it in errors) into `model`'s coefficients.
pub fn read_identify_json(
    text: &str,
    file: &Path,
    model: &ErrorModel,
) -> Result<FromIdentify, ParamsError> {
    let json: Json = serde_json::from_str(text.trim_start_matches('\u{feff}')).map_err(|e| {
        ParamsError::Invalid {
            at: Location {
                file: file.to_path_buf(),
                line: e.line(),
                column: e.column(),
            },
            message: format!("not an identification (`mtcal identify --json`): {e}"),
        }
    })?;
    if json.schema != IDENTIFY_SCHEMA {
        return Err(invalid(
            file,
            format!(
                "schema {:?}: expected {IDENTIFY_SCHEMA:?} (`mtcal identify --json`)",
                json.schema
            ),
        ));
    }
    if !json.solver.converged {
        return Err(invalid(
            file,
            "the identification did not converge: its numbers are the last iterate, not a \
             calibration, and no compensation is built on them",
        ));
    }
    let labels = model.coefficient_labels();
    let mut coeffs = vec![0.0; labels.len()];
    let mut given = vec![false; labels.len()];
    let mut used = Vec::new();
    for p in json.parameters.iter().filter(|p| p.kind == "machine") {
        let Some(k) = labels.iter().position(|l| *l == p.name) else {
            return Err(invalid(
                file,
                format!(
                    "{} was identified, but the machine's error model has no such parameter: \
                     give the machine files the identification used",
                    p.name
                ),
            ));
        };
        let per_si = match p.unit.as_str() {
            "um" | "urad" => 1e6,
            other => {
                return Err(invalid(
                    file,
                    format!("{}: unit {other:?}, expected \"um\" or \"urad\"", p.name),
                ));
            }
        };
        if !p.value.is_finite() {
            return Err(invalid(
                file,
                format!("{}: the value is not finite", p.name),
            ));
        }
        coeffs[k] = p.value / per_si;
        given[k] = true;
        used.push((p.name.clone(), p.value, p.u95, p.unit.clone()));
    }
    let not_given = labels
        .iter()
        .zip(&given)
        .filter(|(_, g)| !**g)
        .map(|(l, _)| l.clone())
        .collect();
    Ok(FromIdentify {
        coeffs,
        used,
        not_given,
        combinations: json.unidentifiable.into_iter().map(|c| c.why).collect(),
        discoveries: json.discoveries.into_iter().map(|d| d.label).collect(),
    })
}

impl FromIdentify {
    /// What went in and what did not, for the screen (and a card), lines without an end;
    /// `source` names the identification (its file).
    pub fn account(&self, source: &str) -> Vec<String> {
        let mut out = vec![format!(
            "parameters from the identification {source}: {} identified, each with its u95, put in",
            self.used.len()
        )];
        if !self.not_given.is_empty() {
            out.push(format!(
                "  left at zero, no number from the identification (not determined by its runs \
                 or not in its model): {}",
                self.not_given.join(", ")
            ));
        }
        for c in &self.combinations {
            out.push(format!("  not separated, left out: {c}"));
        }
        if !self.discoveries.is_empty() {
            out.push(format!(
                "  discoveries of the physics search, not in a static compensation: {}",
                self.discoveries.join("; ")
            ));
        }
        out
    }
}
