//! Parameter values from an identification: `mtcal identify --json` (schema `mtcal.identify/1`)
//! read into the coefficient vector of an error model, as a parameter file ([`crate::params`])
//! would be, and an account of what went in and what was left out.
//!
//! What goes in is what the identification gave a number: each machine parameter with its
//! value (its u95 is said, not used). What the session could not determine — a combination of
//! parameters, a parameter held because no run sees it — has no number in the JSON and stays
//! zero: a compensation never carries a number the identification refused to give. The
//! discoveries of the physics search (a backlash, a thermal drift) are named, not put into a
//! static table; those a bidirectional table can hold (a linear axis' reversal) are read out as
//! the effect family that owns them says ([`CompensableDiscovery`], registered in
//! `mtcal-effects`). An identification that did not converge is refused: nothing is built on it.
//!
//! On request ([`FromIdentify::split_combinations`]), the combinations of machine parameters
//! alone get the minimum-norm split of their values: the smallest members (in the file's µm and
//! µrad) that reproduce every combination the runs saw. That is a choice, not an
//! identification, and the account says so; a combination with a set-up member (a laser's
//! zero, a tracer station) is not split: the set-up takes it.

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
    /// The discoveries of the physics search (labels); a static file holds none of them but
    /// a reversal of a linear axis, which a bidirectional pitch table can ([`Self::reversals`]).
    pub discoveries: Vec<String>,
    /// The reversals of linear axes the search found, with their numbers.
    pub reversals: Vec<FoundReversal>,
    /// The combinations with their values, as the JSON gives them (file units).
    pub combination_values: Vec<CombinationValue>,
    /// What [`Self::split_combinations`] put in, one line each; empty unless asked.
    pub split: Vec<String>,
}

/// A combination the runs saw of parameters they could not separate: `Σ coefficient·member =
/// value ± u95` (file units: µm or µrad).
#[derive(Clone, Debug, PartialEq)]
pub struct CombinationValue {
    /// Readable form (`EC0Y − ECY.P0`).
    pub expression: String,
    /// Each member with its coefficient (file units of the combination per file unit of the
    /// member); the first carries the number, coefficient 1.
    pub members: Vec<(String, f64)>,
    pub value: f64,
    pub u95: Option<f64>,
    pub unit: String,
}

/// A `reversal` discovery of a linear axis: the axis lags by half its backlash behind the
/// commanded position in the direction it last moved, the backlash `B + ΔB·û` along the
/// stroke (`û` the position normalised to `[−1, 1]` over the span the identification measured
/// — the axis' limits for a file without one —; `ΔB` 0 for a constant one).
#[derive(Clone, Debug, PartialEq)]
pub struct FoundReversal {
    /// The discovery's label (`reversal X (along X)`).
    pub label: String,
    pub axis: char,
    /// `B` at the middle of the span and its u95, µm.
    pub backlash_um: f64,
    pub backlash_u95_um: Option<f64>,
    /// `ΔB`, from the middle to the span's positive end, and its u95, µm (0 and `None` when
    /// the discovery has no change along the stroke).
    pub change_um: f64,
    pub change_u95_um: Option<f64>,
    /// The positions `B` and `ΔB` are given over (mm, the discovery's `spans`): what the
    /// identification measured, and nothing beyond. `None`: the axis' limits (a file written
    /// before discoveries gave their spans).
    pub span_mm: Option<(f64, f64)>,
}

impl FoundReversal {
    /// Whether the identification determined the backlash: an interval given, and zero
    /// outside it.
    pub fn determined(&self) -> bool {
        self.backlash_u95_um
            .is_some_and(|u| u.is_finite() && u < self.backlash_um.abs())
    }

    /// Whether its change along the stroke is determined likewise.
    pub fn change_determined(&self) -> bool {
        self.change_u95_um
            .is_some_and(|u| u.is_finite() && u < self.change_um.abs())
    }

    /// The discovery in words: `reversal X (along X) of the identification: backlash 8.0 ±
    /// 0.4 µm at 0 mm, changing by +1.2 ± 0.3 µm to 15 mm (measured over −15 … 15 mm)`.
    pub fn words(&self) -> String {
        let pm = |u: Option<f64>| u.map(|u| format!(" ± {u:.1}")).unwrap_or_default();
        let mut text = format!(
            "`{}` of the identification: backlash {:.1}{} µm",
            self.label,
            self.backlash_um,
            pm(self.backlash_u95_um)
        );
        if self.change_um != 0.0 {
            match self.span_mm {
                Some((lo, hi)) => text.push_str(&format!(
                    " at {} mm, changing by {:+.1}{} µm to {} mm (measured over {} … {} mm)",
                    mm(0.5 * (lo + hi)),
                    self.change_um,
                    pm(self.change_u95_um),
                    mm(hi),
                    mm(lo),
                    mm(hi)
                )),
                None => text.push_str(&format!(
                    " at mid-stroke, changing by {:+.1}{} µm to the positive end",
                    self.change_um,
                    pm(self.change_u95_um)
                )),
            }
        }
        text
    }
}

/// A position for words: up to three decimals, no trailing zeros.
fn mm(x: f64) -> String {
    let text = format!("{x:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

#[derive(Deserialize)]
struct Json {
    schema: String,
    parameters: Vec<JsonParam>,
    #[serde(default)]
    unidentifiable: Vec<JsonCombination>,
    #[serde(default)]
    combinations: Vec<JsonCombinationValue>,
    #[serde(default)]
    discoveries: Vec<Discovery>,
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
struct JsonCombinationValue {
    expression: String,
    name: String,
    #[serde(default)]
    terms: Vec<JsonTerm>,
    value: f64,
    unit: String,
    u95: Option<f64>,
}

#[derive(Deserialize)]
struct JsonTerm {
    name: String,
    coefficient: f64,
}

/// A discovery of the physics search as the identify JSON gives it.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Discovery {
    pub label: String,
    /// The effect family's name.
    #[serde(default)]
    pub effect: String,
    #[serde(default)]
    pub axis: Option<String>,
    #[serde(default)]
    pub parameters: Vec<DiscoveryParameter>,
    /// The spans of axis positions the parameters are given over (absent in files written
    /// before discoveries gave them).
    #[serde(default)]
    pub spans: Vec<DiscoverySpan>,
}

/// A span of one axis' positions a [`Discovery`]'s parameters are given over.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct DiscoverySpan {
    pub axis: String,
    pub from: f64,
    pub to: f64,
    pub unit: String,
}

/// One parameter of a [`Discovery`], in its file unit.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct DiscoveryParameter {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub u95: Option<f64>,
}

impl Discovery {
    /// The axis the discovery acts on, when it names one axis by its letter.
    pub fn axis_letter(&self) -> Option<char> {
        let mut chars = self.axis.as_deref()?.chars();
        match (chars.next(), chars.next()) {
            (Some(axis), None) => Some(axis),
            _ => None,
        }
    }

    /// The span of axis `axis`'s positions its parameters are given over, in `unit`, if it
    /// gives one.
    pub fn span(&self, axis: char, unit: &str) -> Option<(f64, f64)> {
        self.spans
            .iter()
            .find(|s| {
                s.axis.chars().eq(std::iter::once(axis))
                    && s.unit == unit
                    && s.from.is_finite()
                    && s.to.is_finite()
                    && s.from < s.to
            })
            .map(|s| (s.from, s.to))
    }

    /// The parameter `name` given in `unit` with a finite value.
    pub fn parameter(&self, name: &str, unit: &str) -> Option<&DiscoveryParameter> {
        self.parameters
            .iter()
            .find(|p| p.name == name && p.unit == unit && p.value.is_finite())
    }
}

/// An effect family whose discoveries a static compensation can hold, and how: registered with
/// `inventory::submit!` by the family that owns them (`mtcal-effects`), so that this reader
/// names no family. A binary that does not link the families reads no reversals.
#[derive(Debug)]
pub struct CompensableDiscovery {
    /// The reversal of a linear axis `discovery` is, if it is one of the family's.
    pub as_reversal: fn(discovery: &Discovery) -> Option<FoundReversal>,
}

inventory::collect!(CompensableDiscovery);

/// The reversal a discovery holds, as the family that registered it reads it.
fn found_reversal(d: &Discovery) -> Option<FoundReversal> {
    inventory::iter::<CompensableDiscovery>
        .into_iter()
        .find_map(|family| (family.as_reversal)(d))
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
        reversals: json.discoveries.iter().filter_map(found_reversal).collect(),
        discoveries: json.discoveries.into_iter().map(|d| d.label).collect(),
        combination_values: json
            .combinations
            .into_iter()
            .map(|c| CombinationValue {
                expression: c.expression,
                members: std::iter::once((c.name, 1.0))
                    .chain(c.terms.into_iter().map(|t| (t.name, t.coefficient)))
                    .collect(),
                value: c.value,
                u95: c.u95,
                unit: c.unit,
            })
            .collect(),
        split: Vec::new(),
    })
}

/// The account of an identification ([`FromIdentify::account`] with no source) a parameter
/// file carries as its header (`identify --params-out`): its leading comment lines from the
/// first, which names the identification, without the `# `. Empty for a file without one.
pub fn account_in_header(text: &str) -> Vec<String> {
    let mut lines = text
        .trim_start_matches('\u{feff}')
        .lines()
        .map_while(|l| l.strip_prefix("# "));
    match lines.next() {
        Some(first) if first.starts_with("parameters from the identification:") => {
            std::iter::once(first)
                .chain(lines.take_while(|l| l.starts_with("  ")))
                .map(str::to_string)
                .collect()
        }
        _ => Vec::new(),
    }
}

impl FromIdentify {
    /// Puts in the minimum-norm split of every combination whose members are all parameters
    /// of `model` (coefficient labels such as `EC0Y`, `ECY.P0`): of all member values that
    /// reproduce those combinations' values, the smallest in the file's units (`p = Aᵀ(AAᵀ)⁺v`
    /// over the combinations together, as they may share members). The members leave
    /// [`Self::not_given`]; each split combination is said in [`Self::split`] and no longer
    /// among the combinations left out. Returns how many combinations were split.
    pub fn split_combinations(&mut self, model: &ErrorModel) -> usize {
        let labels = model.coefficient_labels();
        let index = |name: &str| labels.iter().position(|l| l == name);
        let chosen: Vec<&CombinationValue> = self
            .combination_values
            .iter()
            .filter(|c| c.members.iter().all(|(m, _)| index(m).is_some()))
            // A member the identification gave a number is not the JSON's combination.
            .filter(|c| {
                !c.members
                    .iter()
                    .any(|(m, _)| self.used.iter().any(|u| u.0 == *m))
            })
            .filter(|c| c.value.is_finite() && c.members.iter().all(|(_, a)| a.is_finite()))
            .collect();
        if chosen.is_empty() {
            return 0;
        }
        let mut unknowns: Vec<usize> = Vec::new();
        for c in &chosen {
            for (m, _) in &c.members {
                let k = index(m).expect("checked above");
                if !unknowns.contains(&k) {
                    unknowns.push(k);
                }
            }
        }
        let a = nalgebra::DMatrix::from_fn(chosen.len(), unknowns.len(), |r, j| {
            chosen[r]
                .members
                .iter()
                .filter(|(m, _)| index(m) == Some(unknowns[j]))
                .map(|(_, a)| a)
                .sum::<f64>()
        });
        let v = nalgebra::DVector::from_iterator(chosen.len(), chosen.iter().map(|c| c.value));
        let gram = &a * a.transpose();
        let eps = 1e-12 * gram.amax().max(1.0);
        let Ok(pinv) = gram.pseudo_inverse(eps) else {
            return 0;
        };
        let p = a.transpose() * (pinv * v);
        // Every label's unit: µrad for rotations, µm otherwise, as the file writes them.
        for (j, &k) in unknowns.iter().enumerate() {
            self.coeffs[k] = p[j] * 1e-6;
            self.not_given.retain(|n| *n != labels[k]);
        }
        for c in &chosen {
            let parts: Vec<String> = c
                .members
                .iter()
                .map(|(m, _)| {
                    let j = unknowns
                        .iter()
                        .position(|&k| labels[k] == *m)
                        .expect("a member is an unknown");
                    format!("{m} = {:.3}", p[j])
                })
                .collect();
            let u95 = c.u95.map(|u| format!(" ± {u:.3}")).unwrap_or_default();
            self.split.push(format!(
                "{} ({}) of {} = {:.3}{u95} {}",
                parts.join(", "),
                c.unit,
                c.expression,
                c.value,
                c.unit
            ));
            let expression = format!("combination {} =", c.expression);
            self.combinations.retain(|why| !why.contains(&expression));
        }
        chosen.len()
    }

    /// What went in and what did not, for the screen (and a card), lines without an end;
    /// `source` names the identification (its file; empty for a card or a parameter file's
    /// header, which must read the same whichever file carried the identification).
    pub fn account(&self, source: &str) -> Vec<String> {
        let source = if source.is_empty() {
            String::new()
        } else {
            format!(" {source}")
        };
        let mut out = vec![format!(
            "parameters from the identification{source}: {} identified, each with its u95, put in",
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
        for s in &self.split {
            out.push(format!(
                "  not separated, split by minimum norm on request (a choice, not an \
                 identification): {s}"
            ));
        }
        if !self.discoveries.is_empty() {
            out.push(format!(
                "  discoveries of the physics search, not in a static compensation (a \
                 bidirectional pitch table holds a linear axis' reversal): {}",
                self.discoveries.join("; ")
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::default_config;
    use crate::config::tests::three_axis;

    /// An identify JSON of the three-axis test machine with `combinations` (its JSON array).
    fn json_with(combinations: &str) -> String {
        format!(
            r#"{{"schema": "mtcal.identify/1", "solver": {{"converged": true}},
               "parameters": [{{"name": "EB0Z", "value": 4.0, "unit": "urad", "u95": 0.5,
                                "kind": "machine"}}],
               "unidentifiable": [
                 {{"parameters": ["EC0Y", "ECY.P0"],
                   "why": "these runs see only their combination EC0Y − ECY.P0 = 3.0000 ± 0.4000 urad"}},
                 {{"parameters": ["laser-x.zero", "EBX.P0"],
                   "why": "these runs see only their combination laser-x.zero + 0.5·EBX.P0 = 2.0000 ± 9.0000 um"}}],
               "combinations": {combinations}}}"#
        )
    }

    /// On request, a combination of machine parameters alone gets its minimum-norm split (each
    /// member `a_i·v/Σa²`: EC0Y − ECY.P0 = 3 µrad gives 1.5 and −1.5), said as a choice; one
    /// with a set-up member is not split; without the request nothing changes.
    #[test]
    fn a_combination_of_machine_parameters_is_split_by_minimum_norm_on_request() {
        let m = three_axis();
        let model = ErrorModel::new(&m, &default_config(&m)).unwrap();
        let text = json_with(
            r#"[{"expression": "EC0Y − ECY.P0", "name": "EC0Y",
                 "terms": [{"name": "ECY.P0", "coefficient": -1.0}],
                 "value": 3.0, "unit": "urad", "u95": 0.4, "kind": "machine"},
                {"expression": "laser-x.zero + 0.5·EBX.P0", "name": "laser-x.zero",
                 "terms": [{"name": "EBX.P0", "coefficient": 0.5}],
                 "value": 2.0, "unit": "um", "u95": 9.0, "kind": "setup"}]"#,
        );
        let file = Path::new("id.json");
        let plain = read_identify_json(&text, file, &model).unwrap();
        let mut from = plain.clone();
        let at = |name: &str| model.find(&name.parse().unwrap()).unwrap().offset;
        assert_eq!(from.coeffs[at("EC0Y")], 0.0);
        assert!(from.not_given.contains(&"EC0Y".to_string()));
        assert_eq!(from.split_combinations(&model), 1);
        assert!((from.coeffs[at("EC0Y")] - 1.5e-6).abs() < 1e-15);
        let c = model.coefficient_labels();
        let ecy0 = c.iter().position(|l| l == "ECY.P0").unwrap();
        assert!((from.coeffs[ecy0] + 1.5e-6).abs() < 1e-15);
        // The combination is reproduced, EB0Z untouched, EBX.P0 (with a set-up) left out.
        assert!((from.coeffs[at("EC0Y")] - from.coeffs[ecy0] - 3e-6).abs() < 1e-15);
        assert_eq!(from.coeffs[at("EB0Z")], 4e-6);
        let ebx0 = c.iter().position(|l| l == "EBX.P0").unwrap();
        assert_eq!(from.coeffs[ebx0], 0.0);
        assert!(!from.not_given.contains(&"EC0Y".to_string()));
        assert!(from.not_given.contains(&"EBX.P0".to_string()));
        let account = from.account("").join("\n");
        assert!(
            account.contains("split by minimum norm on request (a choice, not an identification)")
                && account.contains("EC0Y = 1.500, ECY.P0 = -1.500 (urad) of EC0Y − ECY.P0"),
            "{account}"
        );
        assert!(!account.contains("left out: these runs see only their combination EC0Y"));
        assert!(account.contains("left out: these runs see only their combination laser-x"));
        assert!(plain.split.is_empty() && plain.coeffs[at("EC0Y")] == 0.0);
        // An older JSON without the values: nothing to split.
        let mut old = read_identify_json(&json_with("[]"), file, &model).unwrap();
        assert_eq!(old.split_combinations(&model), 0);
    }

    /// The account `identify --params-out` writes as the parameter file's header reads back
    /// line for line (so a card made from the file says what one made from the JSON says); a
    /// file without one, or whose comments say something else, gives none.
    #[test]
    fn the_account_in_a_parameter_files_header_reads_back() {
        let from = FromIdentify {
            coeffs: vec![0.0],
            used: vec![("EC0Y".into(), 1.5, Some(0.2), "urad".into())],
            not_given: vec!["EZ0A".into()],
            combinations: vec!["only their sum is observed".into()],
            discoveries: vec!["reversal X (X)".into()],
            reversals: Vec::new(),
            combination_values: Vec::new(),
            split: vec![
                "EC0Y = 1.000, ECY.P0 = -1.000 (urad) of EC0Y − ECY.P0 = 2.000 urad".into(),
            ],
        };
        let account = from.account("");
        assert!(account[0].starts_with("parameters from the identification: 1 identified"));
        let header: String = account.iter().map(|l| format!("# {l}\n")).collect();
        let file = format!("{header}# mtcal parameter values: translations in um\n[values]\n");
        assert_eq!(account_in_header(&file), account);
        assert!(account_in_header("# mtcal parameter values\n[values]\n").is_empty());
        assert!(account_in_header("[values]\nEC0Y = 1\n").is_empty());
    }
}
