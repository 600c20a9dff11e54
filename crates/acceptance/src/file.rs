//! The tolerance file (`mtcal.acceptance/1`), read typed through serde with every problem
//! located (`file:line:column: …`). The format is docs/ACCEPTANCE.md's; the crate doc has an
//! example.

use crate::AcceptanceError;
use crate::rule::DecisionRule;
use mtcal_located::toml::{Found, Messages, Number, Problem, problem};
use mtcal_located::{Location, Source};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The `schema` value of this format.
pub const SCHEMA: &str = "mtcal.acceptance/1";

/// The top-level keys.
pub const TOP_KEYS: &[&str] = &[
    "schema",
    "decision_rule",
    "coverage",
    "iso230_2",
    "iso230_4",
    "parameters",
];

/// The keys of an `[iso230_2.<axis>]` table: bidirectional values, and `_uni_` ones that
/// apply to both unidirectional values (↑ and ↓).
pub const ISO230_2_KEYS: &[&str] = &[
    "A_um", "E_um", "R_um", "M_um", "B_um", "A_uni_um", "E_uni_um", "R_uni_um",
];

/// The linear axes an `[iso230_2.<axis>]` table may name.
pub const AXES: &[&str] = &["X", "Y", "Z", "U", "V", "W"];

/// The circle planes an `[iso230_4.<plane>]` table may name (as the ball-bar names them).
pub const PLANES: &[&str] = &["XY", "YZ", "ZX"];

/// The keys of a `[parameters]` entry.
pub const PARAMETER_KEYS: &[&str] = &["max_abs_um", "max_abs_urad"];

/// An ISO 230-2:2014 axis value a tolerance may limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Iso230_2Value {
    A,
    AUp,
    ADown,
    E,
    EUp,
    EDown,
    R,
    RUp,
    RDown,
    M,
    B,
}

impl Iso230_2Value {
    /// Its symbol, `E↑`.
    pub fn symbol(self) -> &'static str {
        use Iso230_2Value::*;
        match self {
            A => "A",
            AUp => "A↑",
            ADown => "A↓",
            E => "E",
            EUp => "E↑",
            EDown => "E↓",
            R => "R",
            RUp => "R↑",
            RDown => "R↓",
            M => "M",
            B => "B",
        }
    }

    /// The name the laser plugin's evaluation gives it, `E↑ (ISO 230-2)`.
    pub fn metric_name(self) -> String {
        format!("{} (ISO 230-2)", self.symbol())
    }
}

/// A tolerance on one ISO 230-2 value of one axis: `value ≤ limit_um`.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisTolerance {
    /// The axis letter, `X`.
    pub axis: String,
    pub value: Iso230_2Value,
    pub limit_um: f64,
}

/// A tolerance on the ISO 230-4 circular deviation G: `G ≤ limit_um`.
#[derive(Clone, Debug, PartialEq)]
pub struct CircleTolerance {
    /// The plane (`XY`), or `None` for every circle without a plane of its own.
    pub plane: Option<String>,
    pub limit_um: f64,
}

/// The unit of a parameter tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParameterUnit {
    Um,
    Urad,
}

impl ParameterUnit {
    /// As parameters name their unit (`um`, `urad`).
    pub fn as_str(self) -> &'static str {
        match self {
            ParameterUnit::Um => "um",
            ParameterUnit::Urad => "urad",
        }
    }

    /// The tolerance key of the unit.
    pub fn key(self) -> &'static str {
        match self {
            ParameterUnit::Um => "max_abs_um",
            ParameterUnit::Urad => "max_abs_urad",
        }
    }
}

/// A two-sided tolerance on an identified parameter, `|value| ≤ limit`; for a component error
/// (`EXX`) at every position of the stroke.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterTolerance {
    /// An ISO 230-1 name (`EC0Y`), a component error (`EXX`), one of its coefficients
    /// (`EXX.P1`) or any other parameter the identification reports.
    pub name: String,
    pub limit: f64,
    pub unit: ParameterUnit,
    /// Where the file names it, for a later check against the session's model.
    pub at: Location,
}

/// A tolerance file as read.
#[derive(Clone, Debug, PartialEq)]
pub struct Tolerances {
    /// The file as the user named it.
    pub path: PathBuf,
    pub rule: DecisionRule,
    /// The coverage factor `k` of every `U`; `None`: each uncertainty as mtcal reports it
    /// (parameters' u95 at k = 1.96, the instruments' U at k = 2).
    pub coverage: Option<f64>,
    /// In file order of the axes, each axis' values in [`ISO230_2_KEYS`] order.
    pub iso230_2: Vec<AxisTolerance>,
    /// The tolerance for every circle first (if any), then the planes'.
    pub iso230_4: Vec<CircleTolerance>,
    /// In the order of the names (the file's `[parameters]` table, sorted).
    pub parameters: Vec<ParameterTolerance>,
}

impl Tolerances {
    /// Reads and checks the tolerance file at `path`.
    pub fn read(path: &Path) -> Result<Tolerances, AcceptanceError> {
        let source = Source::read(path)?;
        Tolerances::parse(&source)
    }

    /// Checks the text of a tolerance file.
    pub fn parse(source: &Source) -> Result<Tolerances, AcceptanceError> {
        let at = |p: Problem| AcceptanceError::Invalid(source.at(p.span, p.message));
        let raw: Raw =
            mtcal_located::toml::from_str(&source.text, &AcceptanceMessages).map_err(at)?;
        check(raw, source).map_err(at)
    }

    /// Checks every `[parameters]` name against the session's model: `unit_of(name)` is the
    /// unit of the parameter or component error of that name (`um`, `urad`, …), `None` when
    /// the model has none. The error is located at the name in the file.
    pub fn check_parameters(
        &self,
        unit_of: &dyn Fn(&str) -> Option<String>,
    ) -> Result<(), AcceptanceError> {
        for p in &self.parameters {
            let fault = |message: String| {
                AcceptanceError::Invalid(mtcal_located::Located {
                    at: p.at.clone(),
                    message,
                })
            };
            match unit_of(&p.name) {
                None => {
                    return Err(fault(format!(
                        "[parameters] `{}` is not a parameter of this session's model (an ISO \
                         230-1 name of its error model such as EC0Y, a component error such as \
                         EXX, a coefficient such as EXX.P1, or a set-up parameter)",
                        p.name
                    )));
                }
                Some(unit) if unit != p.unit.as_str() => {
                    let hint = match unit.as_str() {
                        "um" => "; use max_abs_um".to_string(),
                        "urad" => "; use max_abs_urad".to_string(),
                        _ => String::new(),
                    };
                    return Err(fault(format!(
                        "[parameters] `{}` is in {unit}, its tolerance `{}` in {}{hint}",
                        p.name,
                        p.unit.key(),
                        p.unit.as_str()
                    )));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// Whether the file sets any tolerance.
    pub fn is_empty(&self) -> bool {
        self.iso230_2.is_empty() && self.iso230_4.is_empty() && self.parameters.is_empty()
    }
}

// ---------------------------------------------------------------------------------------------
// The file as serde reads it

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    schema: Option<Spanned<String>>,
    decision_rule: Option<Spanned<String>>,
    coverage: Option<Spanned<Number>>,
    #[serde(default)]
    iso230_2: RawAxes,
    iso230_4: Option<Spanned<RawCircles>>,
    #[serde(default)]
    parameters: BTreeMap<Spanned<String>, Spanned<RawParameter>>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
struct RawAxes {
    X: Option<Spanned<RawAxis>>,
    Y: Option<Spanned<RawAxis>>,
    Z: Option<Spanned<RawAxis>>,
    U: Option<Spanned<RawAxis>>,
    V: Option<Spanned<RawAxis>>,
    W: Option<Spanned<RawAxis>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
struct RawAxis {
    A_um: Option<Spanned<Number>>,
    E_um: Option<Spanned<Number>>,
    R_um: Option<Spanned<Number>>,
    M_um: Option<Spanned<Number>>,
    B_um: Option<Spanned<Number>>,
    A_uni_um: Option<Spanned<Number>>,
    E_uni_um: Option<Spanned<Number>>,
    R_uni_um: Option<Spanned<Number>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
struct RawCircles {
    G_um: Option<Spanned<Number>>,
    XY: Option<Spanned<RawPlane>>,
    YZ: Option<Spanned<RawPlane>>,
    ZX: Option<Spanned<RawPlane>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
struct RawPlane {
    G_um: Spanned<Number>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawParameter {
    max_abs_um: Option<Spanned<Number>>,
    max_abs_urad: Option<Spanned<Number>>,
}

/// The format's wording of unknown keys and wrong types.
struct AcceptanceMessages;

/// A key path without the segments `toml::Spanned` adds to serde's path.
fn plain(path: &str) -> String {
    path.split('.')
        .filter(|part| !part.starts_with("$__serde_spanned"))
        .collect::<Vec<_>>()
        .join(".")
}

impl Messages for AcceptanceMessages {
    fn unknown_key(&self, table: &str, key: &str, expected: &[&str]) -> Option<String> {
        let table = plain(table);
        let table = table.as_str();
        // A `[parameters]` entry's name is not in serde's path (the key is data).
        let place = match table {
            "" => "at the top level".to_string(),
            "parameters" => "in a [parameters] entry".to_string(),
            t => format!("in [{t}]"),
        };
        let expected = match table {
            "" => TOP_KEYS.to_vec(),
            "iso230_2" => AXES.to_vec(),
            "iso230_4" => {
                let mut keys = vec!["G_um"];
                keys.extend(PLANES);
                keys
            }
            t if t.starts_with("iso230_2.") => ISO230_2_KEYS.to_vec(),
            "parameters" => PARAMETER_KEYS.to_vec(),
            _ => expected.to_vec(),
        };
        Some(format!(
            "unknown key `{key}` {place}; expected one of: {}",
            expected.join(", ")
        ))
    }

    fn wrong_type(&self, path: &str, found: &Found, expected: &str) -> Option<String> {
        let what = if expected == "a number" {
            "a number (a tolerance ≥ 0)"
        } else if expected.contains("map") || expected.starts_with("struct") {
            "a table"
        } else if expected.contains("string") {
            "a string"
        } else {
            return None;
        };
        let path = plain(path);
        if path == "parameters" && what == "a table" {
            // The entry's name is not in serde's path; the location points at its value.
            return Some(format!(
                "a [parameters] entry must be a table such as {{ max_abs_urad = 20 }}, found {}",
                found.noun
            ));
        }
        Some(format!("`{path}` must be {what}, found {}", found.noun))
    }
}

// ---------------------------------------------------------------------------------------------
// Checks

type Checked<T> = Result<T, Problem>;

fn check(raw: Raw, source: &Source) -> Checked<Tolerances> {
    if let Some(s) = &raw.schema
        && s.get_ref() != SCHEMA
    {
        return Err(problem(
            s.span(),
            format!(
                "schema \"{}\" is not supported: this version of mtcal reads \"{SCHEMA}\"",
                s.get_ref()
            ),
        ));
    }
    let rule = match &raw.decision_rule {
        None => DecisionRule::default(),
        Some(r) => DecisionRule::parse(r.get_ref()).ok_or_else(|| {
            problem(
                r.span(),
                format!(
                    "decision_rule \"{}\" is not known; expected \"iso14253-1\" (guard bands of \
                     U, the default) or \"simple\" (no guard band)",
                    r.get_ref()
                ),
            )
        })?,
    };
    let coverage = raw.coverage.as_ref().map(coverage_factor).transpose()?;
    let tolerances = Tolerances {
        path: source.path.clone(),
        rule,
        coverage,
        iso230_2: axes(&raw.iso230_2)?,
        iso230_4: raw
            .iso230_4
            .as_ref()
            .map(circles)
            .transpose()?
            .unwrap_or_default(),
        parameters: parameters(&raw.parameters, source)?,
    };
    if tolerances.is_empty() {
        return Err(problem(
            0..0,
            "this acceptance file sets no tolerance: give [iso230_2.<axis>] values, [iso230_4] \
             G_um or [parameters] (docs/ACCEPTANCE.md)",
        ));
    }
    Ok(tolerances)
}

fn coverage_factor(k: &Spanned<Number>) -> Checked<f64> {
    let v = k.get_ref().value;
    if v.is_finite() && v > 0.0 && v <= 10.0 {
        Ok(v)
    } else {
        Err(problem(
            k.span(),
            format!(
                "coverage must be a coverage factor k from above 0 to 10 (2 for about 95 %), \
                 found {}",
                k.get_ref()
            ),
        ))
    }
}

/// A tolerance value: a finite number ≥ 0.
fn limit(v: &Spanned<Number>, what: &str) -> Checked<f64> {
    let x = v.get_ref().value;
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(problem(
            v.span(),
            format!(
                "`{what}` must be a tolerance ≥ 0 (an upper limit), found {}",
                v.get_ref()
            ),
        ))
    }
}

/// A key of an `[iso230_2.<axis>]` table, its value as read and the values it limits.
type AxisKey<'a> = (
    &'static str,
    &'a Option<Spanned<Number>>,
    &'static [Iso230_2Value],
);

fn axes(raw: &RawAxes) -> Checked<Vec<AxisTolerance>> {
    use Iso230_2Value::*;
    let mut out = Vec::new();
    let named = [
        ("X", &raw.X),
        ("Y", &raw.Y),
        ("Z", &raw.Z),
        ("U", &raw.U),
        ("V", &raw.V),
        ("W", &raw.W),
    ];
    let mut present: Vec<(&str, &Spanned<RawAxis>)> = named
        .into_iter()
        .filter_map(|(axis, t)| t.as_ref().map(|t| (axis, t)))
        .collect();
    present.sort_by_key(|(_, t)| t.span().start);
    for (axis, table) in present {
        let t = table.get_ref();
        let keys: [AxisKey<'_>; 8] = [
            ("A_um", &t.A_um, &[A]),
            ("E_um", &t.E_um, &[E]),
            ("R_um", &t.R_um, &[R]),
            ("M_um", &t.M_um, &[M]),
            ("B_um", &t.B_um, &[B]),
            ("A_uni_um", &t.A_uni_um, &[AUp, ADown]),
            ("E_uni_um", &t.E_uni_um, &[EUp, EDown]),
            ("R_uni_um", &t.R_uni_um, &[RUp, RDown]),
        ];
        let before = out.len();
        for (key, value, values) in keys {
            let Some(v) = value else { continue };
            let limit_um = limit(v, &format!("iso230_2.{axis}.{key}"))?;
            out.extend(values.iter().map(|&value| AxisTolerance {
                axis: axis.to_string(),
                value,
                limit_um,
            }));
        }
        if out.len() == before {
            return Err(problem(
                table.span(),
                format!(
                    "[iso230_2.{axis}] sets no tolerance; give one or more of: {}",
                    ISO230_2_KEYS.join(", ")
                ),
            ));
        }
    }
    Ok(out)
}

fn circles(raw: &Spanned<RawCircles>) -> Checked<Vec<CircleTolerance>> {
    let c = raw.get_ref();
    let mut out = Vec::new();
    if let Some(g) = &c.G_um {
        out.push(CircleTolerance {
            plane: None,
            limit_um: limit(g, "iso230_4.G_um")?,
        });
    }
    for (plane, table) in [("XY", &c.XY), ("YZ", &c.YZ), ("ZX", &c.ZX)] {
        if let Some(t) = table {
            out.push(CircleTolerance {
                plane: Some(plane.to_string()),
                limit_um: limit(&t.get_ref().G_um, &format!("iso230_4.{plane}.G_um"))?,
            });
        }
    }
    if out.is_empty() {
        return Err(problem(
            raw.span(),
            "[iso230_4] sets no tolerance; give G_um (every circle) or a plane's table such as \
             [iso230_4.XY] G_um",
        ));
    }
    Ok(out)
}

fn parameters(
    raw: &BTreeMap<Spanned<String>, Spanned<RawParameter>>,
    source: &Source,
) -> Checked<Vec<ParameterTolerance>> {
    let mut out = Vec::new();
    for (name, entry) in raw {
        let e = entry.get_ref();
        let what = |key: &str| format!("parameters.{}.{key}", name.get_ref());
        let (value, unit) = match (&e.max_abs_um, &e.max_abs_urad) {
            (Some(v), None) => (limit(v, &what("max_abs_um"))?, ParameterUnit::Um),
            (None, Some(v)) => (limit(v, &what("max_abs_urad"))?, ParameterUnit::Urad),
            (Some(_), Some(v)) => {
                return Err(problem(
                    v.span(),
                    format!(
                        "[parameters] `{}` gives both max_abs_um and max_abs_urad; a parameter \
                         has one unit",
                        name.get_ref()
                    ),
                ));
            }
            (None, None) => {
                return Err(problem(
                    entry.span(),
                    format!(
                        "[parameters] `{}` needs its tolerance: max_abs_um (a length) or \
                         max_abs_urad (an angle)",
                        name.get_ref()
                    ),
                ));
            }
        };
        out.push(ParameterTolerance {
            name: name.get_ref().clone(),
            limit: value,
            unit,
            at: source.locate(name.span().start),
        });
    }
    Ok(out)
}
