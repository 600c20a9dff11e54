//! The physics search's library of candidate effects: what a model of a machine-tool
//! measurement may have left out, each effect with its parameters, its Jacobian columns and a
//! sentence that names it in words.
//!
//! # How an effect enters a fit
//! An effect adds, at every sample, small perturbations in up to three places, each a sum of
//! *terms* `amplitude × feature`:
//! - an **axis** is effectively somewhere else than commanded (`Δq`, SI: m or rad): a thermal
//!   drift of Z, the backlash of X, a cyclic screw error, a servo lag. The identification core
//!   carries it through the machine's axis Jacobian (`∂pose/∂q`), so it acts exactly as the
//!   axis would: through the workpiece-side rotary axes, with its Abbe arms;
//! - a **location error** of an axis changes (`ΔL`, m or rad): the line of a rotary axis moves,
//!   a linear axis' squareness changes as a column warms. The core carries it through the
//!   machine model's own Jacobian column of that parameter;
//! - a set-up's **nuisance** parameter drifts (`Δn`): the R-test head or the ball-bar pivot
//!   creeping on the table;
//! - a **reading** changes directly (`Δr`): a displacement sensor's own thermal drift; or its
//!   **gain** does (`reading·(1 + Δg)`): an instrument's scale error.
//!
//! Features may depend on time, on the axis positions and their history (direction of motion,
//! velocity, travel since a reversal) and on the context columns (spindle speed, temperatures)
//! through first-order thermal lags computed over the whole session in time order
//! ([`view::SessionView`]); some have *shape* parameters (a time constant τ, a screw pitch, a
//! decay length) that the fit refines along with the amplitudes. Every effect is linear in its
//! amplitudes, so a candidate can be scored against a fit without refitting (its amplitude
//! columns at the shape parameters' starting values).
//!
//! # Families and the registry
//! An [`EffectFamily`] (registered with `inventory`, like the instrument plugins) proposes the
//! candidates it would test on a session ([`EffectFamily::candidates`]) and builds a planted
//! effect from a test plan's `[[effect]]` table ([`EffectFamily::plant`]). The families are the
//! FORMATS.md effect names: [`families`] lists them. Two of them (`omitted-parameter`,
//! `component-order`) change the machine's error model instead ([`ModelChange`]): the
//! identification core turns those into columns of its kinematic model.
//!
//! # Adding an effect
//! Usually a new [`Feature`] variant of [`basic::Basic`] and a family module that proposes
//! candidates and parses plant tables (see `families/`); or any type implementing [`Effect`].
//! Submit an [`EffectFamily`] with `inventory::submit!` and add its name to the registry test.

pub mod bank;
pub mod basic;
mod families;
pub mod lag;
pub mod prepared;
pub mod view;

pub use basic::{Basic, Feature, Span};
pub use prepared::{Entry, PreparedEffects, SampleEffects, Slot, axis_slots};
pub use view::{
    AxisView, BasisOrder, Input, ModelParamView, RunView, SeriesCache, SessionView, SetupView,
};

use mtcal_kinematics::ParamName;
use std::fmt;
use std::sync::Arc;

/// Where a term of an effect acts.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// Axis `a` (index into [`SessionView::axes`]) is effectively at `q + Δ` (SI).
    Axis(usize),
    /// The tool side of the machine shifts as a whole by `Δ` (m) along the machine frame's X,
    /// Y or Z (`k` = 0, 1, 2): the identification core carries it as it carries an axis,
    /// through [`mtcal_kinematics::MachineModel::tool_motion_columns`] (slot
    /// [`Slot::Axis`]`(n_axes + k)`, [`axis_slots`]).
    ToolShift(usize),
    /// The tool side of the machine turns as a whole by `Δ` (rad) about the machine frame's
    /// X, Y or Z (`k` = 0, 1, 2) through its origin (a cross-beam twisting): slot
    /// [`Slot::Axis`]`(n_axes + 3 + k)`.
    ToolTurn(usize),
    /// A constant of the machine's geometry — a rotary axis' location error or a linear axis'
    /// squareness (`EY0A`, `EC0Y`) — is effectively `Δ` larger (m or rad): a bearing housing or
    /// a column warming unevenly moves an axis line. The identification core carries it
    /// through the model's own Jacobian column of that parameter at the nominal machine
    /// ([`Slot::Location`]`(j)`, `j` its place in [`SessionView::locations`]); a parameter not
    /// there (the fit does not estimate it) makes the term act nowhere.
    Location(ParamName),
    /// Nuisance parameter `index` of set-up `setup` deviates by `Δ` (SI).
    Nuisance { setup: usize, index: usize },
    /// A reading changes by `Δ` (SI): per set-up, the channel it acts on (`None`: the term
    /// does nothing in that set-up's runs).
    Channel { per_setup: Vec<Option<usize>> },
    /// A reading's gain changes by `Δ` (dimensionless): the reading becomes `(1 + Δ)·reading`.
    Gain { per_setup: Vec<Option<usize>> },
}

/// One term: `params[amplitude] × feature`, acting on `target`.
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    pub amplitude: usize,
    pub target: Target,
}

/// Linear amplitude or nonlinear shape parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    Amplitude,
    Shape,
}

/// One parameter of an effect.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDef {
    /// Its name with its unit (`tau_s`, `amplitude_um`, `gain_um_per_K`), also the key of a
    /// plant table.
    pub name: String,
    /// The unit it is reported in (`s`, `um`, `um/K`, `ppm`).
    pub unit: String,
    /// Factor from SI to the reported unit.
    pub per_si: f64,
    pub kind: ParamKind,
    /// Starting value (SI): zero for amplitudes, the grid value for shapes.
    pub initial: f64,
    /// Box bounds (SI) for shape parameters.
    pub bounds: Option<(f64, f64)>,
    /// The largest plausible value (SI): a millimetre of drift, a 10 % gain error, the
    /// starting value of a time constant (`mtcal_solve::ParamSpec::scale`).
    pub scale: f64,
    /// A zero-mean Gaussian prior's standard deviation (SI), for effects fitted with a ridge
    /// ([`bank::Bank`]); `None`: no prior.
    pub prior: Option<f64>,
    /// A nuisance amplitude: fitted with the effect but not part of what it claims (an axis'
    /// state where the side it arrived from is unknown, [`basic::Basic::with_start_states`]).
    /// The data need not determine it, and a discovery does not report it as a number.
    pub nuisance: bool,
}

/// How an effect is named in reports and in FORMATS.md `discoveries`.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectInfo {
    /// The FORMATS.md effect name (`thermal-drift`, `reversal`, …).
    pub class: &'static str,
    /// The axis it acts on, if one.
    pub axis: Option<char>,
    /// The ISO 230-1 component or the set-up parameter / channel it acts on, if one.
    pub component: Option<String>,
    /// What it follows: `t`, a context column (`S`, `T_spindle`), an axis letter.
    pub driver: Option<String>,
    /// A short unique label (`thermal-drift Z (t)`), the prefix of its parameters' names.
    pub label: String,
}

/// An effect: parameters, terms, and features at given shape parameters.
pub trait Effect: fmt::Debug + Send + Sync {
    fn info(&self) -> &EffectInfo;
    fn params(&self) -> &[ParamDef];
    fn terms(&self) -> &[Term];
    /// The features at shape parameters `shape` (SI, in the order of the shape parameters in
    /// [`Effect::params`]).
    fn prepare(&self, view: &Arc<SessionView>, shape: &[f64]) -> Box<dyn Features>;
    /// The spans of axis positions its amplitudes are given over (a backlash at the middle of
    /// one and its change to the positive end): a number about positions holds over these and
    /// says nothing beyond them. Empty for an effect whose numbers hold anywhere.
    fn spans(&self) -> Vec<Span> {
        Vec::new()
    }
    /// The effect in words, for fitted values (SI) and their 95 % half-widths (SI; `None`
    /// where the data cannot tell).
    fn describe(&self, values: &[f64], u95: &[Option<f64>]) -> String;
    /// Keys of the session-long series [`Effect::prepare`] caches in the view (a lag of an
    /// input at a time constant): effects sharing a key share the memory. The search batches
    /// candidates by it.
    fn cached_series(&self) -> Vec<String> {
        Vec::new()
    }
    /// Starting shapes to scan before the effect is refitted, when its fit in the shape is
    /// many-valued (a cycle's pitch: a phase that drifts by a turn over the stroke for a
    /// pitch a few per cent off); empty when a Gauss–Newton refinement from the starting
    /// shape finds the optimum.
    fn shape_scan(&self, _view: &SessionView) -> Vec<Vec<f64>> {
        Vec::new()
    }
    /// The same effect starting from other shape parameters (`None` if it has none).
    fn with_shape(&self, _shape: &[f64]) -> Option<Arc<dyn Effect>> {
        None
    }
    /// The same effect with the priors of its parameters at every width the search should
    /// compare by cross-validation (a ridge's strength); empty for an effect without priors.
    fn prior_ladder(&self) -> Vec<Arc<dyn Effect>> {
        Vec::new()
    }
    /// The width of the prior its [`Effect::prior_ladder`] steps through, in words ("0.30 um
    /// per column"); `None` for an effect without one.
    fn prior_words(&self) -> Option<String> {
        None
    }
    /// Whether the effect has a course over the session: it follows the time since the
    /// session (or a set-up) started, or an input that evolves with it (a temperature, the
    /// spindle speed). An effect of the axes' positions and of their motion (a bump, a
    /// backlash, a spike after each reversal) is the same early in the session as late, and a
    /// forecast of the later part has nothing to ask of it. The default, `true`, keeps an
    /// effect that does not say under the forecast's judgement.
    fn follows_the_session(&self) -> bool {
        true
    }
    /// The simpler effect of the same family this one becomes when its shape parameter
    /// `param` (an index into [`Effect::params`]) reaches the lower (`low`) or upper edge of
    /// its box: a lateral play taken up over no travel is the plain play. A fit that pins the
    /// shape there found that form, not a failed effect. `None` where the edge is no other
    /// effect.
    fn at_edge(&self, _param: usize, _low: bool) -> Option<Arc<dyn Effect>> {
        None
    }
    /// The simpler effect of the same family this one is without its amplitude `param` (an
    /// index into [`Effect::params`]): a backlash that changes along the stroke, with no
    /// change, is the plain backlash. A fit that leaves that amplitude within its interval of
    /// zero found the simpler effect, and claims no more. `None` where no amplitude is such a
    /// refinement.
    fn without(&self, _param: usize) -> Option<Arc<dyn Effect>> {
        None
    }
}

/// An effect's features at fixed shape parameters.
pub trait Features: Send + Sync {
    /// At sample `i` of run `r`: per term its feature `f[term]`, and per term and shape
    /// parameter the derivative `df[term·n_shape + s]`.
    fn eval(&self, r: usize, i: usize, f: &mut [f64], df: &mut [f64]);
}

/// A change of the machine's error model the search may propose.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelChange {
    /// `omitted-parameter` (estimate a parameter the fit held) or `component-order` (raise a
    /// component error's basis by `extra_order`).
    pub class: &'static str,
    pub param: ParamName,
    pub extra_order: usize,
}

impl ModelChange {
    pub fn label(&self) -> String {
        match self.extra_order {
            0 => self.param.to_string(),
            k => format!("{} +{k} orders", self.param),
        }
    }
}

/// A candidate of the search.
#[derive(Clone, Debug)]
pub enum Candidate {
    Effect(Arc<dyn Effect>),
    Model(ModelChange),
}

impl Candidate {
    pub fn class(&self) -> &'static str {
        match self {
            Candidate::Effect(e) => e.info().class,
            Candidate::Model(m) => m.class,
        }
    }
    pub fn label(&self) -> String {
        match self {
            Candidate::Effect(e) => e.info().label.clone(),
            Candidate::Model(m) => m.label(),
        }
    }
}

/// Why an `[[effect]]` table does not make an effect: the key at fault, where one is, and what
/// was expected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct PlantError {
    pub key: Option<String>,
    pub message: String,
}

impl PlantError {
    /// A problem with the value of `key`.
    pub fn at(key: &str, message: impl Into<String>) -> Self {
        PlantError {
            key: Some(key.to_string()),
            message: message.into(),
        }
    }
}

/// A problem of the table as a whole (a missing target, a combination of keys).
impl From<String> for PlantError {
    fn from(message: String) -> Self {
        PlantError { key: None, message }
    }
}

impl From<&str> for PlantError {
    fn from(message: &str) -> Self {
        message.to_string().into()
    }
}

/// An effect built from a table, with the parameter values the table gives (SI; `None` where
/// it gives none).
pub type Planted = (Arc<dyn Effect>, Vec<Option<f64>>);

/// A family's builder of effects from an `[[effect]]` table (a test plan's planted effect, or
/// an effect a session's `[identify]` starts from).
pub type PlantFn = fn(&toml::Table, &SessionView) -> Result<Planted, PlantError>;

/// A registered family of effects.
#[derive(Debug)]
pub struct EffectFamily {
    /// The FORMATS.md effect name.
    pub name: &'static str,
    /// One line for people.
    pub about: &'static str,
    /// The candidates this family would test on a session.
    pub candidates: fn(&SessionView) -> Vec<Candidate>,
    /// Builds a planted effect from a test plan's `[[effect]]` table (its keys are documented
    /// in the family's module); `None` for families planted another way (model changes are
    /// planted through the truth parameter file).
    pub plant: Option<PlantFn>,
    /// The measurement that would tell this family's effect from the machine's geometry it
    /// hides behind, for people; `None` where the general advice holds (another ball
    /// position, the axis over its whole stroke).
    pub separated_by: Option<&'static str>,
    /// What would tell this family's effect from another family's that explains the data as
    /// well: the other family's name and the measurement (said once, by either of the two).
    pub told_from: &'static [(&'static str, &'static str)],
}

inventory::collect!(EffectFamily);

/// The measurement that would tell an effect of family `class` from the geometry it hides
/// behind ([`EffectFamily::separated_by`]).
pub fn separating_measurement(class: &str) -> Option<&'static str> {
    find(class).and_then(|f| f.separated_by)
}

/// The measurement that would tell an effect of family `a` from one of family `b`
/// ([`EffectFamily::told_from`] of either).
pub fn telling_apart(a: &str, b: &str) -> Option<&'static str> {
    let said = |x: &str, y: &str| {
        find(x).and_then(|f| f.told_from.iter().find(|(o, _)| *o == y).map(|(_, t)| *t))
    };
    said(a, b).or_else(|| said(b, a))
}

/// Every registered family, sorted by name.
pub fn families() -> Vec<&'static EffectFamily> {
    let mut all: Vec<_> = inventory::iter::<EffectFamily>.into_iter().collect();
    all.sort_by_key(|f| f.name);
    all
}

/// The family registered under `name`.
pub fn find(name: &str) -> Option<&'static EffectFamily> {
    inventory::iter::<EffectFamily>
        .into_iter()
        .find(|f| f.name == name)
}

/// Every family's candidates for `view`.
pub fn candidates(view: &SessionView) -> Vec<Candidate> {
    families()
        .iter()
        .flat_map(|f| (f.candidates)(view))
        .collect()
}

/// Builds the planted effect of a plan's `[[effect]]` table (`effect = "<family>"` plus the
/// family's keys): every parameter's value is required (SI).
pub fn plant(
    table: &toml::Table,
    view: &SessionView,
) -> Result<(Arc<dyn Effect>, Vec<f64>), PlantError> {
    let (effect, values) = build(table, view)?;
    let values = values
        .iter()
        .zip(effect.params())
        .map(|(v, p)| {
            v.ok_or_else(|| PlantError::at(&p.name, format!("missing `{}` ({})", p.name, p.unit)))
        })
        .collect::<Result<Vec<f64>, PlantError>>()?;
    Ok((effect, values))
}

/// Builds the effect of an `[[effect]]` table whose parameter values are starting values and
/// may be left out (a session's `[[identify.effect]]`): missing ones start at the effect's own
/// starting values.
pub fn configure(
    table: &toml::Table,
    view: &SessionView,
) -> Result<(Arc<dyn Effect>, Vec<f64>), PlantError> {
    let (effect, values) = build(table, view)?;
    let values = values
        .iter()
        .zip(effect.params())
        .map(|(v, p)| v.unwrap_or(p.initial))
        .collect();
    Ok((effect, values))
}

fn build(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let name = match table.get("effect") {
        Some(toml::Value::String(s)) => s.as_str(),
        Some(v) => {
            return Err(PlantError::at(
                "effect",
                format!("`effect` must be a family name, found {v}"),
            ));
        }
        None => return Err(PlantError::at("effect", "missing `effect = \"<family>\"`")),
    };
    let family = find(name).ok_or_else(|| {
        PlantError::at(
            "effect",
            format!(
                "unknown effect `{name}`; known: {}",
                families()
                    .iter()
                    .map(|f| f.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
    })?;
    let plant = family.plant.ok_or_else(|| {
        PlantError::at(
            "effect",
            format!(
                "`{name}` is planted through the truth parameter file, not an [[effect]] table"
            ),
        )
    })?;
    plant(table, view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_formats_effect_is_registered_once() {
        let names: Vec<&str> = families().iter().map(|f| f.name).collect();
        assert_eq!(
            names,
            [
                "component-order",
                "cross-coupling",
                "cyclic",
                "instrument-scale",
                "lateral-play",
                "local-error",
                "omitted-parameter",
                "reversal",
                "reversal-spike",
                "servo-lag",
                "setup-drift",
                "spindle-growth",
                "stick-slip",
                "temperature-coupling",
                "thermal-drift",
                "thermal-expansion",
                "thermal-location",
                "thermal-model",
                "thermal-tilt",
            ]
        );
        for name in names {
            assert_eq!(find(name).map(|f| f.name), Some(name));
            assert!(!find(name).expect("registered").about.is_empty());
        }
    }

    /// What tells two families apart is said of registered families, once per pair, and
    /// either family finds it; a family's own separating measurement is its registration's.
    #[test]
    fn what_tells_families_apart_is_theirs() {
        let mut pairs = std::collections::BTreeSet::new();
        for f in families() {
            for (other, text) in f.told_from {
                assert!(
                    find(other).is_some(),
                    "{} names no family `{other}`",
                    f.name
                );
                assert_ne!(*other, f.name);
                let pair = if f.name < *other {
                    (f.name, *other)
                } else {
                    (*other, f.name)
                };
                assert!(pairs.insert(pair), "{pair:?} said twice");
                assert_eq!(telling_apart(f.name, other), Some(*text));
                assert_eq!(telling_apart(other, f.name), Some(*text));
            }
            assert_eq!(separating_measurement(f.name), f.separated_by);
        }
        assert!(pairs.contains(&("reversal", "servo-lag")));
        assert_eq!(telling_apart("reversal", "thermal-drift"), None);
        assert_eq!(separating_measurement("no-such-family"), None);
    }

    /// A linear axis' reversal discovery goes into a compensation with its backlash and its
    /// change along the stroke; a rotary axis' or another family's does not.
    #[test]
    fn the_reversal_family_says_which_discoveries_a_table_holds() {
        use mtcal_machine::from_identify::{CompensableDiscovery, Discovery, DiscoveryParameter};
        let parameter = |name: &str, value: f64, unit: &str| DiscoveryParameter {
            name: name.into(),
            value,
            unit: unit.into(),
            u95: Some(0.4),
        };
        let discovery = |effect: &str, axis: &str, parameters| Discovery {
            label: format!("{effect} {axis}"),
            effect: effect.into(),
            axis: Some(axis.into()),
            parameters,
            spans: Vec::new(),
        };
        let read = |d: &Discovery| {
            inventory::iter::<CompensableDiscovery>
                .into_iter()
                .find_map(|c| (c.as_reversal)(d))
        };
        let linear = discovery(
            "reversal",
            "X",
            vec![
                parameter("backlash_um", 8.0, "um"),
                parameter("backlash_change_um", 1.5, "um"),
            ],
        );
        let found = read(&linear).expect("a linear axis' reversal");
        assert_eq!(
            (
                found.axis,
                found.backlash_um,
                found.change_um,
                found.span_mm
            ),
            ('X', 8.0, 1.5, None)
        );
        assert_eq!(found.label, "reversal X");
        // Given over the span it measured: the table takes it there (another axis' span, or
        // one in another unit, is not X's).
        let span = |axis: &str, from, to, unit: &str| mtcal_machine::from_identify::DiscoverySpan {
            axis: axis.into(),
            from,
            to,
            unit: unit.into(),
        };
        let measured = Discovery {
            spans: vec![span("Y", 0.0, 9.0, "mm"), span("X", -15.0, 15.0, "mm")],
            ..linear.clone()
        };
        assert_eq!(read(&measured).unwrap().span_mm, Some((-15.0, 15.0)));
        let elsewhere = Discovery {
            spans: vec![span("X", -15.0, 15.0, "deg")],
            ..linear.clone()
        };
        assert_eq!(read(&elsewhere).unwrap().span_mm, None);
        let rotary = discovery(
            "reversal",
            "C",
            vec![parameter("backlash_urad", 8.0, "urad")],
        );
        assert_eq!(read(&rotary), None);
        let lag = discovery("servo-lag", "X", vec![parameter("backlash_um", 8.0, "um")]);
        assert_eq!(read(&lag), None);
    }
}
