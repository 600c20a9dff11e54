//! The HTML report of an identification (`cargo xtask identify --report DIR`): one
//! self-contained page, `DIR/index.html`, with every plot inline as SVG — no external file, no
//! network, so the page can be mailed or archived as it is.
//!
//! This crate only renders. It takes a [`Report`], plain data that the command line builds from
//! the identification, the physics search, the study's residuals and the machine model, and
//! turns it into HTML ([`render`]) or writes it ([`write`], atomically: a temporary file renamed
//! into place, so an error leaves no partial page). It knows nothing of solvers or sessions and
//! names no instrument: the section of runs drawn on circles has the id, heading and empty-page
//! sentence the plugin that draws them declares (`mtcal_instrument::capability::PolarSection`).
//! Every number it shows it was given.
//!
//! # The page's sections
//! Each section is a `<section>` with a fixed `id`; every plot is a `<figure class="plot">` with
//! one inline `<svg>` drawn by `plotters`' SVG backend (text sizes are estimated, the browser
//! lays out the text itself).
//! - `summary` — session, machine, fit statistics, and every run's RMS (before and after the
//!   physics search when it ran).
//! - `acceptance` — only when the identification was checked against a tolerance file: the
//!   decision rule, the overall verdict and a table of every check (value ± U, tolerance,
//!   verdict, why); absent otherwise, so the page is as before.
//! - the polar views' section (`ballbar`, as the ball-bar plugin declares it) — one polar plot
//!   per ball-bar circle run: the bar-length deviation `dr` around the commanded angle, measured
//!   and as the identified model predicts it (and the model before the search), magnified about
//!   a reference circle; the ISO 230-4 results in the caption.
//! - `residuals` — per context variable (time, spindle speed, temperatures…), every fitted and
//!   validation residual (reading − model) against it, before and after the physics search side
//!   by side on one scale: a drift or a thermal effect shows as a trend on the left that is gone
//!   on the right.
//! - `components` — each estimated component error (a straightness, a positioning error…) along
//!   its axis with its 95 % band.
//! - `volumetric` — slices of the volumetric error map |Δ| (tool point relative to the
//!   workpiece) through the middle of the working volume, on one colour scale.
//! - `parameters` — every parameter with its 95 % interval; a parameter the data cannot
//!   separate reads "not identifiable" and never gets a number.
//! - `identifiability` — the combinations the data cannot separate and the effects that hide
//!   behind fitted parameters, in words, with the measurement that would separate them.
//! - `series` — only when the identification has them: the location errors cycle by cycle
//!   (R-test sets repeated between load cycles), each cycle's own change with its 95 %
//!   interval and the model's change as a line; absent otherwise, so other pages are as
//!   before.
//! - `discoveries` — what the physics search added, each in a sentence with its fit and
//!   held-out RMS before and after, and why it stopped.
//!
//! The page carries two tiny inline scripts and a Content-Security-Policy that forbids loading
//! anything: the first records script errors into `#script-errors`, the last counts the plots
//! into the contents and sets `data-report-ready="yes"` on `<body>`, so a test in a headless
//! browser can see that the page ran cleanly.

// The unit tests' pages have the plugins' polar section, as the identification's have.
#[cfg(test)]
use mtcal_plugins as _;

mod escape;
mod history;
mod page;
mod plots;
mod volumetric;

pub use escape::escape;
pub use history::{HistoryPage, render_history, write_history};
pub use volumetric::{
    VectorField, VectorPoint, VolumetricPage, VolumetricRow, VolumetricSeries, render_volumetric,
};

use std::path::{Path, PathBuf};

/// Why a report could not be rendered or written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Input that cannot be drawn (series of different lengths, an empty grid).
    #[error("report: {what}: {message}")]
    Invalid { what: String, message: String },
    /// The plotting backend failed.
    #[error("report: plot `{plot}`: {message}")]
    Plot { plot: String, message: String },
    /// The report could not be written; nothing of it was.
    #[error(transparent)]
    Write(#[from] mtcal_located::OutputError),
}

/// A machine's row of the history page's fleet table.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetEntry {
    pub machine: String,
    pub campaigns: u64,
    /// The day of its latest campaign, `2026-03-01`.
    pub last_check_day: String,
    /// Parameters of the latest campaign proven beyond their limit.
    pub out_of_tolerance: Vec<String>,
    /// Parameters of the latest campaign within their limit by less than U (guard band).
    pub cannot_decide: Vec<String>,
}

/// One parameter of one machine over its campaigns.
#[derive(Debug, Clone, PartialEq)]
pub struct TrendPlot {
    pub machine: String,
    pub parameter: String,
    pub unit: Option<String>,
    /// Every campaign's entry, in date order.
    pub points: Vec<TrendPoint>,
    /// The limit on `|value|`, when one is known.
    pub limit: Option<f64>,
    /// The analysis of the values that count.
    pub trend: Option<mtcal_trend::Trend>,
    /// Why there is no analysis (too few values…).
    pub not_analysed: Option<String>,
}

/// One campaign's entry on a trend plot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrendPoint {
    /// The campaign's date (s since 1970, UTC).
    pub time_s: f64,
    /// `None` when not identifiable (not drawn).
    pub value: Option<f64>,
    pub u95: Option<f64>,
    /// Superseded campaigns are drawn grey.
    pub superseded: bool,
}

/// Everything the page shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Report {
    /// The page title, e.g. `mtcal identification — five-axis-warm`.
    pub title: String,
    pub summary: Summary,
    /// The runs drawn on circles, each under its instrument's section.
    pub polar: Vec<PolarRun>,
    /// The instruments' diagnostics in their users' terms (a ball-bar's circle pairs),
    /// tabled under their instrument's polar plots.
    pub diagnostics: Vec<DiagnosisTable>,
    pub residuals: Vec<ResidualPlot>,
    pub components: Vec<ComponentCurve>,
    pub volumetric: Volumetric,
    pub parameters: Vec<ParameterRow>,
    pub identifiability: Identifiability,
    /// `None` when the physics search did not run.
    pub search: Option<SearchOutcome>,
    /// What the parameters' numbers mean (the convention card: errors, signs, squareness,
    /// rotary direction, units), key and value per row; shown under the parameter table.
    pub conventions: Vec<(String, String)>,
    /// `None` without a tolerance file: the page then has no acceptance section.
    pub acceptance: Option<AcceptanceSection>,
    /// The location errors cycle by cycle (R-test sets repeated between load cycles); empty:
    /// the page has no such section.
    pub location_series: Vec<LocationSeriesPlot>,
}

/// One location error's changes cycle by cycle, each cycle's own value beside the model's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LocationSeriesPlot {
    /// `EY0A`.
    pub name: String,
    /// `um` or `urad`.
    pub unit: String,
    /// A sentence: whether a thermal model changes it, how many cycles agree with it.
    pub caption: String,
    pub cycles: Vec<SeriesPoint>,
}

/// One cycle of a [`LocationSeriesPlot`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SeriesPoint {
    /// The cycle's middle, h.
    pub t_h: f64,
    /// The cycle's own change and its 95 % half-width (`None`: the cycle cannot separate it).
    pub value: Option<f64>,
    pub u95: Option<f64>,
    /// The model's change over the cycle.
    pub model: f64,
    pub validation: bool,
}

/// An instrument's diagnostics of a group of runs (a ball-bar's circle pair), ranked by their
/// contribution to circularity.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiagnosisTable {
    /// The instrument whose runs it diagnoses (its plugin's name).
    pub instrument: String,
    /// e.g. `ballbar XY: ballbar-xy-ccw + ballbar-xy-cw`.
    pub title: String,
    pub circularity_um: f64,
    /// Determined items first (ranked), then those within the noise.
    pub rows: Vec<DiagnosisRow>,
    /// What could not be evaluated and why.
    pub notes: Vec<String>,
}

/// One diagnostic of a [`DiagnosisTable`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiagnosisRow {
    /// `None` for a value within the noise (reported, not claimed).
    pub rank: Option<usize>,
    pub name: String,
    pub about: String,
    pub value: f64,
    pub u95: f64,
    pub unit: String,
    pub share_of_circularity: f64,
    /// The identified model's value and what it comes from (`EC0Y 98 %`); empty when
    /// nothing in the model draws it.
    pub model: f64,
    pub behind: String,
}

/// The verdicts against a tolerance file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AcceptanceSection {
    /// The tolerance file as the user named it.
    pub file: String,
    /// The decision rule in words.
    pub rule: String,
    /// `pass`, `fail` or `cannot decide`.
    pub verdict: String,
    pub rows: Vec<AcceptanceRow>,
}

/// One check of an [`AcceptanceSection`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AcceptanceRow {
    /// What is checked, e.g. `E (ISO 230-2) X`.
    pub item: String,
    /// The run it was measured in (empty for a parameter).
    pub run: String,
    /// `None` when there is no value (the data cannot separate it, no run measured it).
    pub value: Option<f64>,
    /// The expanded uncertainty the rule used.
    pub uncertainty: Option<f64>,
    /// The tolerance zone without its unit, e.g. `≤ 12`, `|·| ≤ 20`.
    pub tolerance: String,
    /// `um`, `urad`.
    pub unit: String,
    /// `pass`, `fail` or `cannot decide`.
    pub verdict: String,
    /// Why, where, or which rule (may be empty).
    pub note: String,
}

/// The header facts and the run table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Summary {
    /// The session folder as the user named it.
    pub session: String,
    /// Machine name and where it came from.
    pub machine: String,
    /// One line each: fit statistics, solver, mismatch verdict.
    pub facts: Vec<String>,
    pub runs: Vec<RunRow>,
}

/// One run's fit.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunRow {
    pub name: String,
    pub instrument: String,
    /// `fit` or `validate`.
    pub role: String,
    /// RMS with the model before the physics search, µm (`None` without a search).
    pub rms_before_um: Option<f64>,
    /// RMS with the identified model, µm.
    pub rms_um: f64,
}

/// A ball-bar circle run for a polar plot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PolarRun {
    pub name: String,
    /// The instrument that draws it (its plugin's name): the section it goes under.
    pub instrument: String,
    /// The plane, e.g. `XY`: angles run from the first letter's axis towards the second's.
    pub plane: String,
    /// Nominal bar length, mm.
    pub radius_mm: f64,
    /// Commanded angle of every sample, degrees.
    pub angles_deg: Vec<f64>,
    /// Measured bar-length deviation `dr`, µm.
    pub measured_um: Vec<f64>,
    /// `dr` as the identified model predicts it, µm.
    pub model_um: Vec<f64>,
    /// `dr` as the model before the physics search predicted it, µm.
    pub model_before_um: Option<Vec<f64>>,
    /// The instrument's own evaluation (ISO 230-4 G, centre offsets…): name, value, unit.
    pub metrics: Vec<(String, f64, String)>,
}

/// Residuals against one context variable.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResidualPlot {
    /// The variable's name as the run files have it (`t`, `S`, `T_spindle`).
    pub variable: String,
    /// What it is, e.g. `time since the session started` (may be empty).
    pub description: String,
    /// Its unit (`s`, `rpm`, `°C`).
    pub unit: String,
    /// The residuals' unit (`µm`, or `σ` when the channels' units differ and the residuals are
    /// whitened).
    pub residual_unit: String,
    /// `(variable, residual)` with the identified model.
    pub after: Vec<(f64, f64)>,
    /// The same before the physics search (`None` without a search).
    pub before: Option<Vec<(f64, f64)>>,
}

/// A component error along its axis.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ComponentCurve {
    /// ISO 230-1 name, e.g. `EXX`.
    pub name: String,
    /// `mm` or `deg`.
    pub position_unit: String,
    /// `µm` or `µrad`.
    pub value_unit: String,
    pub samples: Vec<CurvePoint>,
}

/// One sample of a [`ComponentCurve`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CurvePoint {
    pub position: f64,
    pub value: f64,
    /// 95 % half-width of `value`.
    pub u95: f64,
}

/// Slices of the volumetric map.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Volumetric {
    pub slices: Vec<MapSlice>,
    /// What the maps are of (model, method, where the other axes are held).
    pub note: String,
}

/// |Δ| on a plane of two linear axes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MapSlice {
    /// e.g. `X–Y at Z = −250 mm`.
    pub title: String,
    /// Horizontal axis, e.g. `X (mm)`.
    pub x_label: String,
    pub y_label: String,
    /// Grid positions along the horizontal axis, increasing.
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    /// |Δ| in µm, row-major `ys × xs`: `values_um[j * xs.len() + i]` is at `(xs[i], ys[j])`.
    pub values_um: Vec<f64>,
}

/// One row of the parameter table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParameterRow {
    pub name: String,
    /// `machine`, `effect` or the set-up it belongs to.
    pub group: String,
    /// `um`, `urad`, `ppm`, `s` (shown as µm, µrad…).
    pub unit: String,
    pub estimate: Estimate,
}

/// What the data say about a parameter.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum Estimate {
    /// Identified: value and 95 % half-width, in the row's unit.
    Value { value: f64, u95: f64 },
    /// In a combination the data cannot separate: it has no value.
    #[default]
    NotIdentifiable,
}

/// What the data cannot tell apart.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Identifiability {
    pub combinations: Vec<Combination>,
    pub concealed: Vec<ConcealedEffect>,
    /// Identified parameters the data barely determine (a value is given, but its interval is
    /// beyond anything plausible, or it is mostly another parameter's uncertainty); `why` says
    /// which.
    pub weakly_determined: Vec<Combination>,
}

/// Parameters that move together without changing a reading.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Combination {
    pub parameters: Vec<String>,
    /// The solver's sentence about how they move together.
    pub why: String,
}

/// A candidate effect the data cannot tell from fitted parameters.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConcealedEffect {
    pub effect: String,
    /// Fitted parameters that imitate it.
    pub hides_behind: Vec<String>,
    /// A measurement that would separate it.
    pub measurement: String,
}

/// How the physics search went.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SearchOutcome {
    /// Candidates scored at the first step.
    pub candidates: usize,
    /// Why it stopped.
    pub stopped: String,
    pub discoveries: Vec<DiscoveryText>,
    /// Candidates tried and not kept, one sentence each.
    pub not_kept: Vec<String>,
}

/// One effect the search added.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiscoveryText {
    /// Its label, e.g. `reversal X (X)`.
    pub label: String,
    /// The search's sentence about it.
    pub explanation: String,
    pub rms_before_um: f64,
    pub rms_after_um: f64,
    pub heldout_rms_before_um: f64,
    pub heldout_rms_after_um: f64,
    pub validation_rms_um: Option<(f64, f64)>,
}

/// One point of a tool path for [`path_error_svg`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PathPoint {
    /// Distance along the path from its first point, mm.
    pub along_mm: f64,
    /// Predicted tool-tip error magnitude, µm.
    pub error_um: f64,
    /// Predicted tilt of the tool axis, µrad (five-axis paths).
    pub tilt_urad: Option<f64>,
}

/// A standalone SVG of the predicted error along a tool path (CL data): the tool-tip error
/// against the distance along the path, and beside it the tool-axis tilt when the points carry
/// one. Errors if there are fewer than two points.
pub fn path_error_svg(title: &str, points: &[PathPoint]) -> Result<String, ReportError> {
    plots::path_error(title, points)
}

/// The page for `report`.
pub fn render(report: &Report) -> Result<String, ReportError> {
    page::page(report)
}

/// Renders `report` and writes it to `dir/index.html` (creating `dir`); returns that path.
/// Rendering finishes before anything is written, and the file is replaced atomically.
pub fn write(dir: &Path, report: &Report) -> Result<PathBuf, ReportError> {
    let html = render(report)?;
    write_page(dir, &html)
}

/// Writes `html` to `dir/index.html` (creating `dir`), atomically; returns that path. A file
/// where the folder goes is refused, and nothing (not the folder) is left on an error.
fn write_page(dir: &Path, html: &str) -> Result<PathBuf, ReportError> {
    let path = dir.join("index.html");
    let mut files = mtcal_located::Outputs::new();
    files.folder(dir);
    files.file(&path, html);
    files.commit()?;
    Ok(path)
}

#[cfg(test)]
mod tests;
