//! The error-model configuration: which error parameters a machine model includes, and in which
//! basis each component error is expanded.
//!
//! URDF tools drop XML they do not know, so this lives in a TOML file beside the URDF:
//! `<stem>.errors.toml` next to `<stem>.urdf` ([`config_path_for`]). Without such a file a
//! machine gets [`default_config`], the ISO 230-1 full model (41 errors for the usual five-axis
//! machines, 21 for a three-axis machine); an empty file means the same.
//!
//! # Format
//!
//! Every key is optional. Lengths are in **mm** and angles in **degrees** (mtcal works in m and
//! rad inside). Unknown keys are errors, never silently ignored.
//!
//! ```toml
//! schema = "mtcal.errors/1"     # optional: the version of this format
//!
//! # which errors the model includes
//! components = "all"            # "all" | "none" | ["EXX", "EYX", ...]         (default "all")
//! locations  = "iso"            # "iso" | "none" | ["EX0C", "EC0Y", ...]       (default "iso")
//! setup      = ["TOOL_DZ"]      # set-up parameters TOOL_DX..TOOL_DZ, WP_DX..WP_DC (default none)
//! exclude    = ["EAC", "EBC"]   # drop these from the sets above              (default none)
//!
//! [basis.linear]                # basis of the component errors of linear axes
//! kind = "legendre"
//! degree = 3
//!
//! [basis.rotary]                # basis of the component errors of rotary axes
//! kind = "fourier"
//! harmonics = 2
//!
//! [component.EXX]               # the basis of one component error
//! kind = "table"
//! spacing_mm = 50.0
//! stroke_mm = [-350.0, 350.0]
//! ```
//!
//! ## Which parameters
//! - `components`: `"all"` is the six component errors `EXk EYk EZk EAk EBk ECk` of every axis
//!   `k` of the machine; a list names them one by one.
//! - `locations`: `"iso"` is, for every rotary axis, its two positions and two tilts across its
//!   own direction (for C: `EX0C EY0C EA0C EB0C`), plus the squareness errors `EC0Y` (Y to X,
//!   about Z), `EB0Z` (Z to X, about Y) and `EA0Z` (Z to Y, about X) of the linear axes present.
//!   A squareness error turns the second axis' direction of motion: positive `EC0Y` makes the
//!   angle between +X and +Y larger than 90° (all sign conventions: ARCHITECTURE.md,
//!   "Conventions"). A list may name any location error the machine can have; the letter `O`
//!   is accepted for the digit zero (`EXOC`).
//! - `setup`: where the tool point sits on the spindle (`TOOL_DX`, `TOOL_DY`, `TOOL_DZ`) and the
//!   workpiece on the table (`WP_DX` … `WP_DC`).
//! - `exclude`: names removed from the sets above; each must be in one of them.
//!
//! The model lists component errors first (in the order of `components`: for `"all"` axis by
//! axis in X Y Z U V W A B C order, directions X Y Z A B C), then locations, then set-up.
//!
//! ## Bases
//! `[basis.linear]` and `[basis.rotary]` set the basis of every component error of linear and
//! rotary axes (defaults: Legendre degree 3; Fourier with 2 harmonics). A `[component.<name>]`
//! section sets it for one component error, which must be in the model. Without `kind` it keeps
//! the kind of its axis' default and changes only the keys it gives; with another `kind` it
//! starts afresh.
//!
//! | `kind`     | axes   | size (one of)                                    | only in `[component.*]` |
//! |------------|--------|--------------------------------------------------|--------------------------|
//! | `legendre` | all    | `degree` (0..=20, default 3)                     | `min_degree`, `stroke_mm` |
//! | `fourier`  | rotary | `harmonics` (0..=50, default 2)                  | `min_harmonic`           |
//! | `table`    | all    | `knots` (count) or `spacing_mm`                  | `knots_mm`, `pin_first`, `pin_last`, `stroke_mm` |
//! | `bspline`  | all    | `control_points` (>= 4)                          | `pin_first`, `pin_last`, `stroke_mm` |
//!
//! On rotary axes the keys end in `_deg` instead of `_mm` (`spacing_deg`, `knots_deg`,
//! `stroke_deg`). Legendre, table and B-spline bases span the axis stroke: its limits, or one
//! turn (-180..180 deg) for an unlimited rotary axis; `stroke_mm` = `[lo, hi]` overrides it. A
//! table has `knots` equally spaced knots over the stroke, both ends included; `spacing_mm`
//! splits the stroke into as many equal intervals as fit at that spacing (700 mm at 300 mm gives
//! 2 intervals of 350 mm); `knots_mm` gives the knot positions (which then set the stroke).
//! A B-spline is cubic and clamped with `control_points` control points.
//!
//! ## What the model leaves out
//! Other parameters already carry some terms of a component error, so the model leaves them out
//! (the rules of `mtcal_kinematics::BasisChoice::build`):
//! - positioning (`EXX`, `EYY`, `EZZ`): no constant (the set-up offsets carry it); a Legendre
//!   series starts at degree 1, a table or spline is pinned to zero at the stroke's start;
//! - straightness (`EYX`, `EZX`, …): no constant and no slope (the slope is the squareness or
//!   location error); Legendre starts at degree 2, tables and splines are pinned at both ends;
//! - rotary axes: no constant term (location and set-up parameters carry it): Fourier starts
//!   at harmonic 1, Legendre at degree 1, tables and splines are pinned at the start;
//! - angular errors of linear axes (`EAX`, `EBX`, `ECX`, …): everything kept.
//!
//! A `[component.*]` section may opt out with `min_degree`, `min_harmonic`, `pin_first` or
//! `pin_last`, e.g. when the parameter that would carry the term is not in the model.
//!
//! ## Errors
//! A [`ConfigError`] names the file, the line and the column of the offending key or value, and
//! says what was expected.

use std::collections::BTreeMap;
use std::io;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use mtcal_kinematics::model::{default_stroke, iso_full_config, iso_location_names};
use mtcal_kinematics::{
    AxisKind, Basis, BasisChoice, BasisError, Direction, ErrorModel, Machine, ModelError,
    ParamConfig, ParamName,
};
use toml::de::{DeTable, DeValue};

use mtcal_located::Location;
use read::{At, Item, Parsed, Problem, Span, problem};

/// The `schema` value of version 1 of this format.
pub const SCHEMA: &str = "mtcal.errors/1";

/// Default Legendre degree of linear axes' component errors.
pub const DEFAULT_DEGREE: usize = 3;
/// Default number of Fourier harmonics of rotary axes' component errors.
pub const DEFAULT_HARMONICS: usize = 2;
/// Highest Legendre degree a configuration may ask for.
pub const MAX_DEGREE: usize = 20;
/// Highest Fourier harmonic a configuration may ask for.
pub const MAX_HARMONICS: usize = 50;
/// Most knots or control points a table or B-spline may have.
pub const MAX_POINTS: usize = 10_000;

/// Why an error-model configuration was rejected.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{}: cannot read the error-model configuration: {cause}", path.display())]
    Read { path: PathBuf, cause: io::Error },
    /// The file's contents are wrong at `at`; `message` says what was expected.
    #[error("{at}: {message}")]
    Invalid { at: Location, message: String },
}

impl ConfigError {
    /// Where in the file the problem is (None for read failures).
    pub fn position(&self) -> Option<&Location> {
        match self {
            ConfigError::Read { .. } => None,
            ConfigError::Invalid { at, .. } => Some(at),
        }
    }

    fn invalid(file: &Path, text: &str, p: Problem) -> Self {
        ConfigError::Invalid {
            at: Location::of_offset(file, text, p.span.start),
            message: p.message,
        }
    }
}

/// `<stem>.errors.toml` beside `<stem>.urdf`.
pub fn config_path_for(urdf: &Path) -> PathBuf {
    urdf.with_extension("errors.toml")
}

/// The ISO 230-1 full model: the six component errors of every axis (linear axes: Legendre
/// degree 3; rotary axes: Fourier, 2 harmonics) and the ISO location errors. What an empty
/// configuration file gives.
pub fn default_config(machine: &Machine) -> Vec<ParamConfig> {
    iso_full_config(
        machine,
        &BasisChoice::Legendre {
            degree: DEFAULT_DEGREE,
        },
        &BasisChoice::Fourier {
            harmonics: DEFAULT_HARMONICS,
        },
    )
    .expect("the default bases are valid on the stroke of every validated machine axis")
}

/// Reads and checks the configuration file at `path` for `machine`.
pub fn load_config(path: &Path, machine: &Machine) -> Result<Vec<ParamConfig>, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: path.to_path_buf(),
        cause: source,
    })?;
    parse_config(&text, path, machine)
}

/// Parses a configuration (`file` names it in errors) and checks it against `machine`,
/// including building the [`ErrorModel`].
pub fn parse_config(
    text: &str,
    file: &Path,
    machine: &Machine,
) -> Result<Vec<ParamConfig>, ConfigError> {
    build_config(text, machine).map_err(|p| ConfigError::invalid(file, text, p))
}

const TOP_KEYS: &[&str] = &[
    "schema",
    "components",
    "locations",
    "setup",
    "exclude",
    "basis",
    "component",
];

fn build_config(text: &str, machine: &Machine) -> Parsed<Vec<ParamConfig>> {
    let doc = read::document(text)?;
    read::check_keys(&doc, TOP_KEYS, "at the top level")?;
    read::check_schema(&doc, SCHEMA)?;
    let defaults = read_defaults(&doc)?;
    let selected = read_selection(&doc, machine)?;
    let overrides = read_overrides(&doc, machine, &selected, &defaults)?;
    let list = selected
        .iter()
        .map(|s| configure(machine, s, &defaults, &overrides))
        .collect::<Parsed<Vec<_>>>()?;
    validate(machine, list)
}

/// Builds the model to run its checks; a failure is reported where the parameter was named.
fn validate(machine: &Machine, list: Vec<(ParamConfig, Span)>) -> Parsed<Vec<ParamConfig>> {
    let (configs, spans): (Vec<_>, Vec<_>) = list.into_iter().unzip();
    match ErrorModel::new(machine, &configs) {
        Ok(_) => Ok(configs),
        Err(e) => {
            let name = match &e {
                ModelError::NoSuchAxis { name, .. }
                | ModelError::Duplicate { name }
                | ModelError::MissingBasis { name }
                | ModelError::Impossible { name, .. }
                | ModelError::Basis { name, .. } => name,
            };
            let span = configs
                .iter()
                .position(|c| c.name.to_string() == *name)
                .map_or(0..0, |i| spans[i].clone());
            Err(problem(span, e.to_string()))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Which parameters

/// The three kinds of names, each listed under its own key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    Component,
    Location,
    Setup,
}

impl Class {
    fn of(name: &ParamName) -> Self {
        match name {
            ParamName::Component { .. } => Class::Component,
            ParamName::Location { .. } => Class::Location,
            ParamName::Setup(_) => Class::Setup,
        }
    }

    fn noun(self) -> &'static str {
        match self {
            Class::Component => "a component error",
            Class::Location => "a location error",
            Class::Setup => "a set-up parameter",
        }
    }

    fn key(self) -> &'static str {
        match self {
            Class::Component => "components",
            Class::Location => "locations",
            Class::Setup => "setup",
        }
    }
}

/// One of the keys that select parameters.
struct SetKey {
    class: Class,
    keywords: &'static [&'static str],
    default: &'static str,
    expected: &'static str,
}

const SETS: [SetKey; 3] = [
    SetKey {
        class: Class::Component,
        keywords: &["all", "none"],
        default: "all",
        expected: "\"all\", \"none\" or a list of component error names such as [\"EXX\", \"EYX\"]",
    },
    SetKey {
        class: Class::Location,
        keywords: &["iso", "none"],
        default: "iso",
        expected: "\"iso\", \"none\" or a list of location error names such as [\"EX0C\", \"EC0Y\"]",
    },
    SetKey {
        class: Class::Setup,
        keywords: &["none"],
        default: "none",
        expected: "\"none\" or a list of set-up parameter names such as [\"TOOL_DZ\", \"WP_DX\"]",
    },
];

/// The parameters `components`, `locations` and `setup` select, less `exclude`; each with the
/// span that selected it.
fn read_selection(top: &DeTable, machine: &Machine) -> Parsed<Vec<At<ParamName>>> {
    let mut out = Vec::new();
    for set in &SETS {
        out.extend(read_set(top, set, machine)?);
    }
    apply_exclude(top, out, machine)
}

fn keyword_set(keyword: &str, machine: &Machine) -> Vec<ParamName> {
    match keyword {
        "all" => machine
            .axes()
            .iter()
            .flat_map(|ax| Direction::ALL.map(|d| ParamName::component(d, ax.letter())))
            .collect(),
        "iso" => iso_location_names(machine),
        _ => Vec::new(),
    }
}

fn read_set(top: &DeTable, set: &SetKey, machine: &Machine) -> Parsed<Vec<At<ParamName>>> {
    let key = set.class.key();
    let (keyword, span) = match top.get(key) {
        None => (set.default, 0..0),
        Some(item) => match item.get_ref() {
            DeValue::Array(list) => return read_names(list, set.class, machine),
            DeValue::String(s) if set.keywords.iter().any(|k| k == s) => (s.as_ref(), item.span()),
            DeValue::String(s) => {
                let msg = format!(
                    "{key} = \"{s}\" is not understood: expected {}",
                    set.expected
                );
                return Err(problem(item.span(), msg));
            }
            _ => return Err(read::wrong_type(item, &format!("`{key}`"), set.expected)),
        },
    };
    let names = keyword_set(keyword, machine);
    Ok(names
        .into_iter()
        .map(|value| At {
            value,
            span: span.clone(),
        })
        .collect())
}

fn read_names(list: &[Item], class: Class, machine: &Machine) -> Parsed<Vec<At<ParamName>>> {
    let key = class.key();
    let mut out: Vec<At<ParamName>> = Vec::new();
    for item in list {
        let name = read::name_item(item, key)?;
        let span = item.span();
        let found = Class::of(&name);
        if found != class {
            let msg = format!(
                "{name} is {}; list it under `{}`",
                found.noun(),
                found.key()
            );
            return Err(problem(span, msg));
        }
        check_axis(&name, &span, machine)?;
        if out.iter().any(|a| a.value == name) {
            return Err(problem(span, format!("{name} is listed twice in `{key}`")));
        }
        out.push(At { value: name, span });
    }
    Ok(out)
}

/// The machine has the axis the name belongs to (the model's own message otherwise).
fn check_axis(name: &ParamName, span: &Span, machine: &Machine) -> Parsed<()> {
    match name.axis() {
        Some(axis) if machine.axis_index(axis.as_char()).is_none() => {
            let e = ModelError::NoSuchAxis {
                name: name.to_string(),
                axis: axis.as_char(),
                axes: machine.letters(),
            };
            Err(problem(span.clone(), e.to_string()))
        }
        _ => Ok(()),
    }
}

fn apply_exclude(
    top: &DeTable,
    mut selected: Vec<At<ParamName>>,
    machine: &Machine,
) -> Parsed<Vec<At<ParamName>>> {
    let Some(item) = top.get("exclude") else {
        return Ok(selected);
    };
    let list = read::array(item, "`exclude`", "a list of parameter names")?;
    let mut removed = Vec::new();
    for entry in list {
        let name = read::name_item(entry, "exclude")?;
        if removed.contains(&name) {
            return Err(problem(
                entry.span(),
                format!("{name} is listed twice in `exclude`"),
            ));
        }
        let Some(i) = selected.iter().position(|s| s.value == name) else {
            let msg = format!(
                "cannot exclude {name}: `components`, `locations` and `setup` do not select it \
                 on this machine (axes {}); remove it from `exclude`",
                machine.letters()
            );
            return Err(problem(entry.span(), msg));
        };
        selected.remove(i);
        removed.push(name);
    }
    Ok(selected)
}

// ---------------------------------------------------------------------------------------------
// Bases

/// A basis family as the file names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Legendre,
    Fourier,
    Table,
    BSpline,
}

impl Kind {
    const ALL: [Kind; 4] = [Kind::Legendre, Kind::Fourier, Kind::Table, Kind::BSpline];

    fn name(self) -> &'static str {
        match self {
            Kind::Legendre => "legendre",
            Kind::Fourier => "fourier",
            Kind::Table => "table",
            Kind::BSpline => "bspline",
        }
    }

    /// The key that gives the number of functions.
    fn count_key(self) -> &'static str {
        match self {
            Kind::Legendre => "degree",
            Kind::Fourier => "harmonics",
            Kind::Table => "knots",
            Kind::BSpline => "control_points",
        }
    }

    fn count_range(self) -> RangeInclusive<usize> {
        match self {
            Kind::Legendre => 0..=MAX_DEGREE,
            Kind::Fourier => 0..=MAX_HARMONICS,
            Kind::Table => 2..=MAX_POINTS,
            Kind::BSpline => 4..=MAX_POINTS,
        }
    }

    /// The keys this kind takes, in the order the module docs list them.
    fn keys(self, unit: Unit, scope: Scope) -> Vec<String> {
        let u = unit.suffix();
        let mut keys = vec!["kind".to_string(), self.count_key().to_string()];
        if self == Kind::Table {
            keys.push(format!("spacing_{u}"));
        }
        if scope == Scope::Component {
            match self {
                Kind::Legendre => keys.push("min_degree".into()),
                Kind::Fourier => keys.push("min_harmonic".into()),
                Kind::Table => keys.push(format!("knots_{u}")),
                Kind::BSpline => {}
            }
            if matches!(self, Kind::Table | Kind::BSpline) {
                keys.extend(["pin_first".to_string(), "pin_last".to_string()]);
            }
            if self != Kind::Fourier {
                keys.push(format!("stroke_{u}"));
            }
        }
        keys
    }
}

/// Units of positions in the file: mm for linear axes, degrees for rotary ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Unit {
    Mm,
    Deg,
}

impl Unit {
    pub(crate) fn of(kind: AxisKind) -> Self {
        match kind {
            AxisKind::Linear => Unit::Mm,
            AxisKind::Rotary => Unit::Deg,
        }
    }

    pub(crate) fn suffix(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::Deg => "deg",
        }
    }

    /// File units to SI (m or rad).
    pub(crate) fn to_si(self, v: f64) -> f64 {
        match self {
            Unit::Mm => v / 1e3,
            Unit::Deg => v.to_radians(),
        }
    }

    /// SI (m or rad) to file units.
    pub(crate) fn to_file(self, v: f64) -> f64 {
        match self {
            Unit::Mm => v * 1e3,
            Unit::Deg => v.to_degrees(),
        }
    }

    fn other(self) -> Self {
        match self {
            Unit::Mm => Unit::Deg,
            Unit::Deg => Unit::Mm,
        }
    }

    fn axes(self) -> &'static str {
        match self {
            Unit::Mm => "linear",
            Unit::Deg => "rotary",
        }
    }
}

/// Where a basis is described: an axis-kind default or one component's section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scope {
    Default,
    Component,
}

/// How many functions, as the file says it (in SI once read).
#[derive(Clone, Debug, PartialEq)]
enum Size {
    Count(usize),
    Spacing(f64),
    Knots(Vec<f64>),
}

/// A basis description as read, with where each part was said.
#[derive(Clone, Debug)]
struct Spec {
    kind: At<Kind>,
    size: Option<At<Size>>,
    min: Option<At<usize>>,
    pin_first: Option<At<bool>>,
    pin_last: Option<At<bool>>,
    stroke: Option<At<(f64, f64)>>,
}

impl Spec {
    fn new(kind: At<Kind>) -> Self {
        Spec {
            kind,
            size: None,
            min: None,
            pin_first: None,
            pin_last: None,
            stroke: None,
        }
    }

    /// The built-in default of an axis kind.
    fn builtin(unit: Unit) -> Self {
        let (kind, count) = match unit {
            Unit::Mm => (Kind::Legendre, DEFAULT_DEGREE),
            Unit::Deg => (Kind::Fourier, DEFAULT_HARMONICS),
        };
        let mut spec = Spec::new(At {
            value: kind,
            span: 0..0,
        });
        spec.size = Some(At {
            value: Size::Count(count),
            span: 0..0,
        });
        spec
    }

    /// Where a problem with the number of functions is best shown.
    fn size_span(&self) -> Span {
        self.size
            .as_ref()
            .map_or(self.kind.span.clone(), |s| s.span.clone())
    }
}

/// The default bases of linear and rotary axes.
struct Defaults {
    linear: Spec,
    rotary: Spec,
}

impl Defaults {
    fn of(&self, kind: AxisKind) -> &Spec {
        match kind {
            AxisKind::Linear => &self.linear,
            AxisKind::Rotary => &self.rotary,
        }
    }
}

/// What `read_spec` needs besides the table.
struct SpecContext<'a> {
    unit: Unit,
    scope: Scope,
    /// The spec this one starts from (the axis default, or the built-in default).
    inherited: &'a Spec,
    /// How messages name the table, e.g. `[component.EXX]`.
    place: String,
}

fn read_defaults(top: &DeTable) -> Parsed<Defaults> {
    let mut defaults = Defaults {
        linear: Spec::builtin(Unit::Mm),
        rotary: Spec::builtin(Unit::Deg),
    };
    let Some(item) = top.get("basis") else {
        return Ok(defaults);
    };
    let table = read::table(item, "`basis`")?;
    read::check_keys(table, &["linear", "rotary"], "in [basis]")?;
    for (unit, slot) in [
        (Unit::Mm, &mut defaults.linear),
        (Unit::Deg, &mut defaults.rotary),
    ] {
        let key = if unit == Unit::Mm { "linear" } else { "rotary" };
        if let Some(item) = table.get(key) {
            let cx = SpecContext {
                unit,
                scope: Scope::Default,
                inherited: &Spec::builtin(unit),
                place: format!("[basis.{key}]"),
            };
            *slot = read_spec(item, &cx)?;
        }
    }
    Ok(defaults)
}

/// The `[component.<name>]` sections, checked against the selection.
fn read_overrides(
    top: &DeTable,
    machine: &Machine,
    selected: &[At<ParamName>],
    defaults: &Defaults,
) -> Parsed<BTreeMap<ParamName, Spec>> {
    let mut out = BTreeMap::new();
    let Some(item) = top.get("component") else {
        return Ok(out);
    };
    let table = read::table(item, "`component`")?;
    for (key, span, value) in read::entries(table) {
        let name = read::name(key, &span)?;
        let axis = override_axis(&name, &span, machine, selected)?;
        let unit = Unit::of(axis);
        let cx = SpecContext {
            unit,
            scope: Scope::Component,
            inherited: defaults.of(axis),
            place: format!("[component.{key}]"),
        };
        let spec = read_spec(value, &cx)?;
        if out.insert(name, spec).is_some() {
            return Err(problem(
                span,
                format!("{name} has two [component] sections"),
            ));
        }
    }
    Ok(out)
}

/// The kind of the axis a `[component.<name>]` section belongs to, if the name may have one.
fn override_axis(
    name: &ParamName,
    span: &Span,
    machine: &Machine,
    selected: &[At<ParamName>],
) -> Parsed<AxisKind> {
    let class = Class::of(name);
    if class != Class::Component {
        let msg = format!(
            "{name} is {} with a single value and no basis; only component errors \
             (such as EXX) have a [component.<name>] section",
            class.noun()
        );
        return Err(problem(span.clone(), msg));
    }
    check_axis(name, span, machine)?;
    if !selected.iter().any(|s| s.value == *name) {
        let msg = format!(
            "{name} is not in the model (`components` and `exclude` leave it out); \
             add it to `components` or remove this section"
        );
        return Err(problem(span.clone(), msg));
    }
    let axis = name.axis().and_then(|a| machine.axis_index(a.as_char()));
    Ok(axis.map_or(AxisKind::Linear, |i| machine.axes()[i].kind()))
}

fn read_spec(item: &Item, cx: &SpecContext) -> Parsed<Spec> {
    let table = read::table(item, &cx.place)?;
    let mut spec = start_spec(table, cx)?;
    let mut size_key: Option<&str> = None;
    for (key, span, value) in read::entries(table) {
        if key == "kind" {
            continue;
        }
        let kind = spec.kind.value;
        if !kind.keys(cx.unit, cx.scope).iter().any(|k| k == key) {
            let inherited = !table.contains_key("kind");
            return Err(problem(span, unknown_key(key, kind, inherited, cx)));
        }
        if let Some(size) = read_size(key, value, kind, cx.unit)? {
            if let Some(first) = size_key {
                let msg = format!("`{first}` and `{key}` both set the size; keep one of them");
                return Err(problem(span, msg));
            }
            size_key = Some(key);
            spec.size = Some(size);
        } else {
            read_option(&mut spec, key, value, cx.unit)?;
        }
    }
    check_spec(&spec, item.span(), cx)?;
    Ok(spec)
}

/// The spec a table starts from: the inherited one when it keeps the kind, else a fresh one.
fn start_spec(table: &DeTable, cx: &SpecContext) -> Parsed<Spec> {
    let Some(item) = table.get("kind") else {
        return Ok(cx.inherited.clone());
    };
    let kind = At {
        value: read_kind(item, cx.unit)?,
        span: item.span(),
    };
    if kind.value == cx.inherited.kind.value {
        let mut spec = cx.inherited.clone();
        spec.kind = kind;
        Ok(spec)
    } else {
        Ok(Spec::new(kind))
    }
}

fn read_kind(item: &Item, unit: Unit) -> Parsed<Kind> {
    let expected = "one of \"legendre\", \"table\", \"bspline\", \"fourier\" (rotary axes)";
    let text = read::string(item, "`kind`", expected)?;
    let Some(kind) = Kind::ALL.into_iter().find(|k| k.name() == text) else {
        let msg = format!("unknown basis kind \"{text}\": expected {expected}");
        return Err(problem(item.span(), msg));
    };
    if kind == Kind::Fourier && unit == Unit::Mm {
        let msg = "a Fourier series is periodic in the angle and needs a rotary axis; \
                   for a linear axis use \"legendre\", \"table\" or \"bspline\"";
        return Err(problem(item.span(), msg));
    }
    Ok(kind)
}

/// Says why `key` does not belong in this table and what would.
fn unknown_key(key: &str, kind: Kind, inherited: bool, cx: &SpecContext) -> String {
    let unit = cx.unit;
    let here = kind.keys(unit, cx.scope);
    let other = unit.other().suffix();
    if let Some(stem) = key.strip_suffix(&format!("_{other}")) {
        let fixed = format!("{stem}_{}", unit.suffix());
        if kind.keys(unit, Scope::Component).contains(&fixed) {
            return format!(
                "`{key}` is for {} axes; {} is for {} axes: use `{fixed}`",
                unit.other().axes(),
                cx.place,
                unit.axes()
            );
        }
    }
    if cx.scope == Scope::Default && kind.keys(unit, Scope::Component).iter().any(|k| k == key) {
        return format!(
            "`{key}` can only be set for one component error, in its [component.<name>] section"
        );
    }
    let from = if inherited {
        " (the axis default; set `kind` to change it)"
    } else {
        ""
    };
    let owner = Kind::ALL
        .into_iter()
        .find(|k| k.keys(unit, Scope::Component).iter().any(|x| x == key));
    match owner {
        Some(k) => format!(
            "`{key}` belongs to a {} basis, but this one is {}{from}; a {} basis takes: {}",
            k.name(),
            kind.name(),
            kind.name(),
            here.join(", ")
        ),
        None => format!(
            "unknown key `{key}` in {}; a {} basis takes: {}",
            cx.place,
            kind.name(),
            here.join(", ")
        ),
    }
}

/// Reads `key` if it sets the number of functions.
fn read_size(key: &str, item: &Item, kind: Kind, unit: Unit) -> Parsed<Option<At<Size>>> {
    let u = unit.suffix();
    let what = format!("`{key}`");
    let size = if key == kind.count_key() {
        Size::Count(read::count(item, &what, kind.count_range())?)
    } else if key == format!("spacing_{u}") {
        Size::Spacing(unit.to_si(read::positive(item, &what)?))
    } else if key == format!("knots_{u}") {
        Size::Knots(read_knots(item, &what, unit)?)
    } else {
        return Ok(None);
    };
    Ok(Some(At {
        value: size,
        span: item.span(),
    }))
}

fn read_knots(item: &Item, what: &str, unit: Unit) -> Parsed<Vec<f64>> {
    let list = read::array(item, what, "a list of knot positions")?;
    if list.len() < 2 || list.len() > MAX_POINTS {
        let msg = format!(
            "{what} must list 2 to {MAX_POINTS} knots, got {}",
            list.len()
        );
        return Err(problem(item.span(), msg));
    }
    let mut knots: Vec<f64> = Vec::with_capacity(list.len());
    for entry in list {
        let v = read::number(entry, &format!("a knot of {what}"))?;
        if let Some(&last) = knots.last()
            && unit.to_si(v) <= last
        {
            let msg = format!(
                "{what} must increase strictly: {v} follows {}",
                unit.to_file(last)
            );
            return Err(problem(entry.span(), msg));
        }
        knots.push(unit.to_si(v));
    }
    Ok(knots)
}

fn read_option(spec: &mut Spec, key: &str, item: &Item, unit: Unit) -> Parsed<()> {
    let what = format!("`{key}`");
    let span = item.span();
    match key {
        "min_degree" | "min_harmonic" => {
            let range = spec.kind.value.count_range();
            let value = read::count(item, &what, range)?;
            spec.min = Some(At { value, span });
        }
        "pin_first" | "pin_last" => {
            let value = read::boolean(item, &what)?;
            let slot = if key == "pin_first" {
                &mut spec.pin_first
            } else {
                &mut spec.pin_last
            };
            *slot = Some(At { value, span });
        }
        _ => {
            let value = read_stroke(item, &what, unit)?;
            spec.stroke = Some(At { value, span });
        }
    }
    Ok(())
}

fn read_stroke(item: &Item, what: &str, unit: Unit) -> Parsed<(f64, f64)> {
    let expected = "[lo, hi] with lo < hi";
    let list = read::array(item, what, expected)?;
    let [lo, hi] = list else {
        let msg = format!("{what} must be {expected}, got {} values", list.len());
        return Err(problem(item.span(), msg));
    };
    let lo = read::number(lo, what)?;
    let hi = read::number(hi, what)?;
    if lo >= hi {
        let msg = format!("{what} must be {expected}, got [{lo}, {hi}]");
        return Err(problem(item.span(), msg));
    }
    Ok((unit.to_si(lo), unit.to_si(hi)))
}

/// What a spec needs as a whole: a size for tables and splines, no stroke beside knot positions.
fn check_spec(spec: &Spec, table_span: Span, cx: &SpecContext) -> Parsed<()> {
    let u = cx.unit.suffix();
    let needs = match spec.kind.value {
        Kind::Table if cx.scope == Scope::Component => {
            format!("one of `knots`, `spacing_{u}` or `knots_{u}`")
        }
        Kind::Table => format!("`knots` or `spacing_{u}`"),
        Kind::BSpline => "`control_points`".to_string(),
        Kind::Legendre | Kind::Fourier => String::new(),
    };
    if spec.size.is_none() && !needs.is_empty() {
        let msg = format!(
            "{}: a {} basis needs {needs}",
            cx.place,
            spec.kind.value.name()
        );
        return Err(problem(table_span, msg));
    }
    if let (
        Some(stroke),
        Some(At {
            value: Size::Knots(_),
            ..
        }),
    ) = (&spec.stroke, &spec.size)
    {
        let msg = format!("`knots_{u}` sets the stroke already; remove `stroke_{u}`");
        return Err(problem(stroke.span.clone(), msg));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Building the bases

/// The terms the model leaves out of a component's basis, as `BasisChoice::build` decides them.
#[derive(Clone, Copy, Debug)]
struct Rule {
    min_degree: usize,
    min_harmonic: usize,
    pin_first: bool,
    pin_last: bool,
    /// Why, for messages.
    why: &'static str,
}

/// Reads the exclusion rules off `BasisChoice::build`, so that they have one home.
fn exclusion_rule(kind: AxisKind, own: usize, direction: Direction) -> Rule {
    let probe = |choice: BasisChoice| choice.build(kind, own, direction, (0.0, 1.0)).ok();
    let min_degree = match probe(BasisChoice::Legendre { degree: 20 }) {
        Some(Basis::Legendre { min_degree, .. }) => min_degree,
        _ => 0,
    };
    let (pin_first, pin_last) = match probe(BasisChoice::Table { knots: 20 }) {
        Some(Basis::Table {
            pin_first,
            pin_last,
            ..
        }) => (pin_first, pin_last),
        _ => (false, false),
    };
    let min_harmonic = match probe(BasisChoice::Fourier { harmonics: 20 }) {
        Some(Basis::Fourier { min_harmonic, .. }) => min_harmonic,
        _ => 0,
    };
    let along = !direction.is_rotation() && direction.cartesian() == own;
    let why = match (kind, direction.is_rotation(), along) {
        (AxisKind::Rotary, _, _) => {
            "the model leaves out the constant of a rotary axis' component errors \
             (location and set-up parameters carry it)"
        }
        (AxisKind::Linear, true, _) => "",
        (AxisKind::Linear, false, true) => {
            "the model leaves out the constant of a positioning error (the set-up carries it)"
        }
        (AxisKind::Linear, false, false) => {
            "the model leaves out the constant and the slope of a straightness error \
             (the set-up and the squareness or location errors carry them)"
        }
    };
    Rule {
        min_degree,
        min_harmonic,
        pin_first,
        pin_last,
        why,
    }
}

fn configure(
    machine: &Machine,
    selected: &At<ParamName>,
    defaults: &Defaults,
    overrides: &BTreeMap<ParamName, Spec>,
) -> Parsed<(ParamConfig, Span)> {
    let name = selected.value;
    let basis = match name {
        ParamName::Component { direction, axis } => {
            let a = machine.axis_index(axis.as_char()).ok_or_else(|| {
                let msg = format!("{name}: the machine has no axis {axis}");
                problem(selected.span.clone(), msg)
            })?;
            let kind = machine.axes()[a].kind();
            let spec = overrides.get(&name).unwrap_or(defaults.of(kind));
            Some(component_basis(machine, a, direction, &name, spec)?)
        }
        _ => None,
    };
    Ok((ParamConfig { name, basis }, selected.span.clone()))
}

fn component_basis(
    machine: &Machine,
    a: usize,
    direction: Direction,
    name: &ParamName,
    spec: &Spec,
) -> Parsed<Basis> {
    let axis = &machine.axes()[a];
    let rule = exclusion_rule(axis.kind(), axis.own_cartesian(), direction);
    let (lo, hi) = spec
        .stroke
        .as_ref()
        .map_or_else(|| default_stroke(machine, a), |s| s.value);
    let min = |default: usize| spec.min.as_ref().map_or(default, |m| m.value);
    let pin_first = spec.pin_first.as_ref().map_or(rule.pin_first, |p| p.value);
    let pin_last = spec.pin_last.as_ref().map_or(rule.pin_last, |p| p.value);
    let size = spec.size.as_ref().map(|s| &s.value);
    let unit = Unit::of(axis.kind());
    let result = match (spec.kind.value, size) {
        (Kind::Legendre, size) => Basis::legendre(lo, hi, min(rule.min_degree), count(size, 3)),
        (Kind::Fourier, size) => Basis::fourier(min(rule.min_harmonic), count(size, 2)),
        (Kind::BSpline, size) => Basis::bspline(lo, hi, count(size, 4), pin_first, pin_last),
        (Kind::Table, Some(Size::Knots(knots))) => Basis::table(knots.clone(), pin_first, pin_last),
        (Kind::Table, Some(Size::Spacing(s))) => {
            let n = spacing_knots((lo, hi), *s, unit, spec)?;
            Basis::table(equal_knots((lo, hi), n), pin_first, pin_last)
        }
        (Kind::Table, size) => {
            Basis::table(equal_knots((lo, hi), count(size, 2)), pin_first, pin_last)
        }
    };
    result.map_err(|e| basis_problem(name, &e, spec, &rule))
}

fn count(size: Option<&Size>, default: usize) -> usize {
    match size {
        Some(Size::Count(n)) => *n,
        _ => default,
    }
}

/// `n` equally spaced knots over the stroke, ends included (as `BasisChoice::Table` does).
fn equal_knots((lo, hi): (f64, f64), n: usize) -> Vec<f64> {
    let n = n.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// How many knots a spacing gives: as many equal intervals as fit at that spacing.
fn spacing_knots((lo, hi): (f64, f64), spacing: f64, unit: Unit, spec: &Spec) -> Parsed<usize> {
    let intervals = ((hi - lo) / spacing * (1.0 + 1e-9)).floor();
    let u = unit.suffix();
    if intervals < 1.0 {
        let msg = format!(
            "spacing_{u} = {} is longer than the stroke ({} {u}): a table needs at least 2 knots; \
             use a spacing of at most the stroke, or `knots = N`",
            unit.to_file(spacing),
            unit.to_file(hi - lo)
        );
        return Err(problem(spec.size_span(), msg));
    }
    if intervals >= MAX_POINTS as f64 {
        let msg = format!("spacing_{u} gives more than {MAX_POINTS} knots; use a larger spacing");
        return Err(problem(spec.size_span(), msg));
    }
    Ok(intervals as usize + 1)
}

/// A basis that cannot be built, explained in the file's terms.
fn basis_problem(name: &ParamName, e: &BasisError, spec: &Spec, rule: &Rule) -> Problem {
    let explicit_min = spec.min.as_ref();
    let ((key, noun), min, max) = match *e {
        BasisError::EmptyDegreeRange { min, max } => (("degree", "degree"), min, max),
        BasisError::EmptyHarmonicRange { min, max } => (("harmonics", "harmonic"), min, max),
        BasisError::NoFunctions => {
            let msg = format!(
                "{name}: {e}; {}, so the table is pinned to zero at {}",
                rule.why,
                if rule.pin_last {
                    "both ends"
                } else {
                    "its start"
                }
            );
            return problem(spec.size_span(), msg);
        }
        _ => return problem(spec.size_span(), format!("{name}: {e}")),
    };
    if let Some(m) = explicit_min {
        let msg = format!("{name}: min_{noun} = {min} is above {key} = {max}; lower it");
        return problem(m.span.clone(), msg);
    }
    let msg = format!(
        "{name}: {key} = {max} leaves no functions: {}, so its series starts at {noun} {min}; \
         use {key} >= {min}, or exclude {name}",
        rule.why
    );
    problem(spec.size_span(), msg)
}

// ---------------------------------------------------------------------------------------------
// Reading TOML with positions (shared with `params`)

/// Typed access to a parsed TOML document that keeps every key's and value's position, so that
/// errors can point at them.
/// The located TOML reader (`mtcal-located`) and what this crate adds to it: parameter names
/// written as keys or strings.
pub(crate) mod read {
    use mtcal_kinematics::ParamName;
    pub(crate) use mtcal_located::toml::*;

    /// A value and where the file says it.
    #[derive(Clone, Debug, PartialEq)]
    pub(crate) struct At<T> {
        pub(crate) value: T,
        pub(crate) span: Span,
    }

    /// A parameter name written as a key.
    pub(crate) fn name(text: &str, span: &Span) -> Parsed<ParamName> {
        text.parse()
            .map_err(|e: mtcal_kinematics::names::ParseNameError| {
                problem(span.clone(), e.to_string())
            })
    }

    /// A parameter name written as a string in the list under `key`.
    pub(crate) fn name_item(item: &Item, key: &str) -> Parsed<ParamName> {
        let what = format!("entries of `{key}`");
        let text = string(item, &what, "parameter names (strings) such as \"EXX\"")?;
        name(text, &item.span())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use mtcal_kinematics::{BranchSpec, JointSpec, MachineSpec};
    use nalgebra::{Isometry3, Vector3};
    use std::f64::consts::PI;

    fn joint(letter: char, axis: [f64; 3], limits: Option<(f64, f64)>) -> JointSpec {
        let kind = if matches!(letter, 'A' | 'B' | 'C') {
            AxisKind::Rotary
        } else {
            AxisKind::Linear
        };
        JointSpec {
            letter,
            kind,
            origin: Isometry3::identity(),
            axis: Vector3::from(axis),
            limits,
        }
    }

    fn machine(workpiece: Vec<JointSpec>, tool: Vec<JointSpec>) -> Machine {
        let branch = |joints| BranchSpec {
            joints,
            end: Isometry3::identity(),
        };
        Machine::try_new(&MachineSpec {
            name: "test".into(),
            workpiece: branch(workpiece),
            tool: branch(tool),
        })
        .unwrap()
    }

    /// CAFYXZ: a C table on an A trunnion; Y, X, Z on the tool side. X -350..350 mm,
    /// Y -250..250 mm, Z -400..100 mm, A -120..30 deg, C unlimited.
    pub(crate) fn five_axis() -> Machine {
        machine(
            vec![
                joint(
                    'A',
                    [-1., 0., 0.],
                    Some((-120f64.to_radians(), 30f64.to_radians())),
                ),
                joint('C', [0., 0., -1.], None),
            ],
            vec![
                joint('Y', [0., 1., 0.], Some((-0.25, 0.25))),
                joint('X', [1., 0., 0.], Some((-0.35, 0.35))),
                joint('Z', [0., 0., 1.], Some((-0.4, 0.1))),
            ],
        )
    }

    /// ZFYX: X and Y table, Z column.
    pub(crate) fn three_axis() -> Machine {
        machine(
            vec![
                joint('Y', [0., -1., 0.], Some((-0.2, 0.2))),
                joint('X', [-1., 0., 0.], Some((-0.3, 0.3))),
            ],
            vec![joint('Z', [0., 0., 1.], Some((-0.25, 0.25)))],
        )
    }

    fn file() -> &'static Path {
        Path::new("m.errors.toml")
    }

    /// The parameter names of a successful parse, space-separated, or the error message
    /// without the file name: "line:column: message".
    fn outcome(m: &Machine, input: &str) -> String {
        match parse_config(input, file(), m) {
            Ok(list) => list
                .iter()
                .map(|c| c.name.to_string())
                .collect::<Vec<_>>()
                .join(" "),
            Err(e) => e
                .to_string()
                .strip_prefix("m.errors.toml:")
                .unwrap_or("?")
                .to_string(),
        }
    }

    /// `expect` is a full name list, `count=N`, or the start of an error "line:column: message".
    fn check(m: &Machine, input: &str, expect: &str) {
        let got = outcome(m, input);
        let ok = match expect.strip_prefix("count=") {
            Some(n) => got.split(' ').count().to_string() == n && !got.contains(':'),
            None => got.starts_with(expect),
        };
        assert!(ok, "input:\n{input}\nexpected: {expect}\ngot:      {got}");
    }

    fn basis_of(list: &[ParamConfig], name: &str) -> Basis {
        let name: ParamName = name.parse().unwrap();
        let c = list.iter().find(|c| c.name == name).unwrap();
        c.basis.clone().unwrap()
    }

    /// The first ```toml block of this module's documentation.
    fn doc_example() -> String {
        let src = include_str!("config.rs");
        let start = src.find("//! ```toml\n").unwrap() + "//! ```toml\n".len();
        let end = start + src[start..].find("//! ```\n").unwrap();
        src[start..end]
            .lines()
            .map(|l| l.strip_prefix("//!").unwrap_or(l).trim_start_matches(' '))
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn selections() {
        let five = five_axis();
        let three = three_axis();
        check(&five, "", "count=41");
        check(
            &five,
            "components = \"all\"\nlocations = \"iso\"",
            "count=41",
        );
        check(&three, "", "count=21");
        check(&three, "components = \"none\"", "EC0Y EB0Z EA0Z");
        check(
            &five,
            "components = [\"EXX\", \"ECC\"]\nlocations = [\"EXOC\"]\nsetup = [\"TOOL_DZ\"]",
            "EXX ECC EX0C TOOL_DZ",
        );
        check(&five, "exclude = [\"EAC\", \"EBC\"]", "count=39");
        check(
            &three,
            "components = \"none\"\nlocations = \"none\"\nsetup = [\"WP_DX\", \"WP_DC\"]",
            "WP_DX WP_DC",
        );
        // The 41 errors of the five-axis machine: 30 components, 3 squareness, 8 locations.
        let names = outcome(&five, "");
        for n in [
            "EXX", "ECC", "EAA", "EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A",
        ] {
            assert!(names.split(' ').any(|x| x == n), "{n} missing from {names}");
        }
        for n in ["EX0C", "EY0C", "EA0C", "EB0C"] {
            assert!(names.split(' ').any(|x| x == n), "{n} missing from {names}");
        }
    }

    #[test]
    fn empty_file_is_the_default_model() {
        for m in [five_axis(), three_axis()] {
            let parsed = parse_config("", file(), &m).unwrap();
            assert_eq!(parsed, default_config(&m));
            let explicit = "[basis.linear]\nkind = \"legendre\"\ndegree = 3\n\
                            [basis.rotary]\nkind = \"fourier\"\nharmonics = 2\n";
            assert_eq!(parse_config(explicit, file(), &m).unwrap(), parsed);
        }
        assert_eq!(default_config(&five_axis()).len(), 41);
        assert_eq!(default_config(&three_axis()).len(), 21);
    }

    #[test]
    fn doc_example_parses() {
        let m = five_axis();
        let example = doc_example();
        let list = parse_config(&example, file(), &m).unwrap();
        // 41 - EAC - EBC + TOOL_DZ
        assert_eq!(list.len(), 40);
        assert_eq!(list.last().unwrap().name.to_string(), "TOOL_DZ");
        // spacing 50 mm over 700 mm: 15 knots, the first pinned (positioning).
        match basis_of(&list, "EXX") {
            Basis::Table {
                knots,
                pin_first,
                pin_last,
            } => {
                assert_eq!(knots.len(), 15);
                assert!((knots[0] + 0.35).abs() < 1e-15 && (knots[14] - 0.35).abs() < 1e-15);
                assert!((knots[1] - knots[0] - 0.05).abs() < 1e-15);
                assert!(pin_first && !pin_last);
            }
            other => panic!("EXX: {other:?}"),
        }
    }

    #[test]
    fn bases_and_units() {
        let m = five_axis();
        let text = "[basis.linear]\ndegree = 5\n\
                    [component.EYX]\nstroke_mm = [0.0, 700.0]\n\
                    [component.EZX]\nkind = \"bspline\"\ncontrol_points = 8\n\
                    [component.EXC]\nkind = \"table\"\nknots_deg = [-180, 0, 90, 180]\n\
                    [component.ECA]\nkind = \"legendre\"\nmin_degree = 0\nstroke_deg = [-90, 0]\n\
                    [component.EXY]\nkind = \"table\"\nspacing_mm = 300\npin_first = false\n\
                    [component.ECC]\nmin_harmonic = 0\nharmonics = 3\n";
        let list = parse_config(text, file(), &m).unwrap();
        let check = |name: &str, expect: Basis| assert_eq!(basis_of(&list, name), expect);
        check("EXX", Basis::legendre(-0.35, 0.35, 1, 5).unwrap());
        check("EYX", Basis::legendre(0.0, 0.7, 2, 5).unwrap());
        check("EAX", Basis::legendre(-0.35, 0.35, 0, 5).unwrap());
        check("EZX", Basis::bspline(-0.35, 0.35, 8, true, true).unwrap());
        let deg = |v: f64| v.to_radians();
        let knots = vec![deg(-180.0), 0.0, deg(90.0), deg(180.0)];
        check("EXC", Basis::table(knots, true, false).unwrap());
        // Another kind starts afresh: the linear default's degree 5 does not apply.
        check("ECA", Basis::legendre(deg(-90.0), 0.0, 0, 3).unwrap());
        // 500 mm at a 300 mm spacing: one interval; straightness pins the last knot only now.
        check("EXY", Basis::table(vec![-0.25, 0.25], false, true).unwrap());
        check("ECC", Basis::fourier(0, 3).unwrap());
        check("EXA", Basis::fourier(1, 2).unwrap());
    }

    /// Error cases: TOML input, then `=> line:column: start of the message`, separated by
    /// `----` lines. A case whose input starts with `# three-axis` runs on the 3-axis machine.
    const ERROR_CASES: &str = r#"
components = "all"
foo = 1
=> 2:1: unknown key `foo` at the top level
----
components =
=> 1:13: this is not valid TOML
----
components = 3
=> 1:14: `components` must be "all", "none" or a list
----
components = "full"
=> 1:14: components = "full" is not understood
----
components = ["EXX", "EQX"]
=> 1:22: `EQX` is not an error parameter name
----
components = ["EXX", 3]
=> 1:22: entries of `components` must be parameter names
----
components = ["EXX", "EXX"]
=> 1:22: EXX is listed twice
----
components = ["EX0C"]
=> 1:15: EX0C is a location error; list it under `locations`
----
locations = ["EXX"]
=> 1:14: EXX is a component error; list it under `components`
----
setup = ["EX0C"]
=> 1:10: EX0C is a location error
----
components = ["EXU"]
=> 1:15: EXU: the machine has no axis U (it has XYZAC)
----
locations = ["EX0Y"]
=> 1:14: EX0Y: a linear axis has no translational location error
----
locations = ["EB0Y"]
=> 1:14: EB0Y: a rotation of a linear axis about its own direction
----
exclude = ["EXU"]
=> 1:12: cannot exclude EXU
----
components = "none"
exclude = ["EXX"]
=> 2:12: cannot exclude EXX
----
schema = "mtcal.errors/9"
=> 1:10: schema "mtcal.errors/9" is not supported
----
[basis.linear]
kind = "spline"
=> 2:8: unknown basis kind "spline"
----
[basis.linear]
kind = "fourier"
=> 2:8: a Fourier series is periodic in the angle and needs a rotary axis
----
[basis.linear]
degree = 30
=> 2:10: `degree` must be an integer from 0 to 20, got 30
----
[basis.linear]
degree = -1
=> 2:10: `degree` must be an integer from 0 to 20, got -1
----
[basis.linear]
degree = 2.5
=> 2:10: `degree` must be an integer from 0 to 20, found a float
----
[basis.linear]
degree = 1
=> 2:10: EYX: degree = 1 leaves no functions: the model leaves out the constant and the slope of a straightness error
----
[basis.linear]
degree = 0
=> 2:10: EXX: degree = 0 leaves no functions: the model leaves out the constant of a positioning error
----
[basis.rotary]
harmonics = 0
=> 2:13: EXA: harmonics = 0 leaves no functions
----
[basis.linear]
harmonics = 2
=> 2:1: `harmonics` belongs to a fourier basis, but this one is legendre
----
[basis.linear]
stroke_mm = [0, 1]
=> 2:1: `stroke_mm` can only be set for one component error
----
[basis.linear]
kind = "table"
=> 1:1: [basis.linear]: a table basis needs `knots` or `spacing_mm`
----
[basis.linear]
kind = "table"
knots = 1
=> 3:9: `knots` must be an integer from 2 to 10000, got 1
----
[basis.linear]
kind = "table"
knots = 2
=> 3:9: EYX: basis has no functions left after pinning
----
[basis.linear]
kind = "table"
spacing_mm = 0
=> 3:14: `spacing_mm` must be positive
----
[basis.linear]
kind = "table"
knots = 5
spacing_mm = 5
=> 4:1: `knots` and `spacing_mm` both set the size
----
[basis]
planar = 1
=> 2:1: unknown key `planar` in [basis]
----
basis = 1
=> 1:9: `basis` must be a table, found an integer
----
[component.EXX]
kind = "table"
spacing_mm = 900
=> 3:14: spacing_mm = 900 is longer than the stroke (700 mm)
----
[component.EXX]
stroke_mm = [700, 0]
=> 2:13: `stroke_mm` must be [lo, hi] with lo < hi, got [700, 0]
----
[component.EXX]
stroke_mm = [1, 2, 3]
=> 2:13: `stroke_mm` must be [lo, hi] with lo < hi, got 3 values
----
[component.EXX]
stroke_mm = [0, nan]
=> 2:17: `stroke_mm` must be a finite number
----
[component.EXX]
stroke_deg = [0, 1]
=> 2:1: `stroke_deg` is for rotary axes; [component.EXX] is for linear axes: use `stroke_mm`
----
[component.ECC]
stroke_deg = [0, 1]
=> 2:1: `stroke_deg` belongs to a legendre basis, but this one is fourier (the axis default
----
[component.ECC]
kind = "table"
knots_deg = [0, 90, 45]
=> 3:21: `knots_deg` must increase strictly: 45 follows 90
----
[component.ECC]
kind = "table"
knots_deg = [0, 90]
stroke_deg = [0, 90]
=> 4:14: `knots_deg` sets the stroke already
----
[component.EXX]
kind = "fourier"
=> 2:8: a Fourier series is periodic in the angle and needs a rotary axis
----
[component.EXX]
min_degree = 4
=> 2:14: EXX: min_degree = 4 is above degree = 3
----
[component.ECC]
min_harmonic = 3
=> 2:16: ECC: min_harmonic = 3 is above harmonics = 2
----
[component.EXZ]
kind = "table"
knots = 3
pin_first = 1
=> 4:13: `pin_first` must be true or false, found an integer
----
[component.EXX]
pin_first = true
=> 2:1: `pin_first` belongs to a table basis, but this one is legendre (the axis default; set `kind` to change it)
----
[component.EXX]
colour = 1
=> 2:1: unknown key `colour` in [component.EXX]; a legendre basis takes: kind, degree, min_degree, stroke_mm
----
[component.EX0C]
degree = 1
=> 1:12: EX0C is a location error with a single value
----
[component.EXU]
degree = 1
=> 1:12: EXU: the machine has no axis U
----
exclude = ["EXX"]
[component.EXX]
degree = 1
=> 2:12: EXX is not in the model
----
[component.EXX]
degree = 4
[component.EXX]
degree = 5
=> 3:12: this is not valid TOML: duplicate key
----
[component]
EXX = { degree = 4 }
EXQ = 1
=> 3:1: `EXQ` is not an error parameter name
----
[component]
EXX = 3
=> 2:7: [component.EXX] must be a table, found an integer
----
# three-axis
[component.ECC]
degree = 4
=> 2:12: ECC: the machine has no axis C (it has XYZ)
"#;

    /// Splits a case table into (input, expected) pairs.
    pub(crate) fn cases(table: &str) -> Vec<(String, String)> {
        table
            .split("\n----\n")
            .map(|case| {
                let (input, expect) = case.rsplit_once("=> ").expect("a case needs `=> `");
                (
                    input.trim_start().to_string(),
                    expect.trim_end().to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn errors_point_at_the_problem() {
        let (five, three) = (five_axis(), three_axis());
        for (input, expect) in cases(ERROR_CASES) {
            let m = if input.starts_with("# three-axis") {
                &three
            } else {
                &five
            };
            check(m, &input, &expect);
        }
    }

    #[test]
    fn opting_out_of_exclusion_rules() {
        let m = five_axis();
        let text = "[component.EYX]\nmin_degree = 0\n[component.EZX]\nkind = \"table\"\n\
                    knots = 2\npin_first = false\npin_last = false\n";
        let list = parse_config(text, file(), &m).unwrap();
        assert_eq!(
            basis_of(&list, "EYX"),
            Basis::legendre(-0.35, 0.35, 0, 3).unwrap()
        );
        assert_eq!(
            basis_of(&list, "EZX"),
            Basis::table(vec![-0.35, 0.35], false, false).unwrap()
        );
    }

    #[test]
    fn unlimited_rotary_axis_spans_one_turn() {
        let m = five_axis();
        let text = "[component.EXC]\nkind = \"table\"\nspacing_deg = 30\n";
        let list = parse_config(text, file(), &m).unwrap();
        let Basis::Table { knots, .. } = basis_of(&list, "EXC") else {
            panic!("not a table")
        };
        assert_eq!(knots.len(), 13);
        assert!((knots[0] + PI).abs() < 1e-15 && (knots[12] - PI).abs() < 1e-15);
    }

    #[test]
    fn columns_count_characters() {
        let p = Location::of_offset(Path::new("f"), "a = \"µµ\"\nbé = 1", 14);
        assert_eq!((p.line, p.column), (2, 3));
        assert_eq!(p.to_string(), "f:2:3");
        let end = Location::of_offset(Path::new("f"), "ab", 99);
        assert_eq!((end.line, end.column), (1, 3));
    }

    #[test]
    fn config_path_is_beside_the_urdf() {
        assert_eq!(
            config_path_for(Path::new("dir/dmu50.urdf")),
            PathBuf::from("dir/dmu50.errors.toml")
        );
        assert_eq!(
            config_path_for(Path::new("m.v2.urdf")),
            PathBuf::from("m.v2.errors.toml")
        );
    }

    #[test]
    fn load_reads_files_and_names_missing_ones() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.errors.toml");
        std::fs::write(
            &path,
            "components = \"none\"\nlocations = \"none\"\nsetup = [\"TOOL_DZ\"]",
        )
        .unwrap();
        let list = load_config(&path, &five_axis()).unwrap();
        assert_eq!(list.len(), 1);
        let missing = dir.path().join("none.errors.toml");
        let err = load_config(&missing, &five_axis()).unwrap_err();
        assert!(
            err.to_string().contains("none.errors.toml: cannot read"),
            "{err}"
        );
        assert!(err.position().is_none());
    }
}
