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

mod build;
pub(crate) mod read;
mod selection;
mod spec;
#[cfg(test)]
pub(crate) mod tests;

use build::*;
use selection::*;
pub(crate) use spec::Unit;
use spec::*;

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
