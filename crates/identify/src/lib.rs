//! Identification of a machine tool's geometric errors from a measurement session.
//!
//! Data flow: a session folder ([`mtcal_session`]) → [`Study`] (machine model, set-ups from the
//! instrument plugins, every run in SI units) → [`FitProblem`] (whitened residuals of every
//! fitted sample, streamed to [`mtcal_solve`]) → [`Identification`] (parameters with 95 %
//! intervals, unidentifiable combinations by name, fit per run and channel, validation runs
//! predicted, [`mismatch`]: where the residuals are not noise) → JSON / summary / predicted CSVs.
//! A session held in memory (simulated: `mtcal-simulate`) becomes a study through
//! [`Study::from_parts`], the same code [`Study::load`] runs on a folder.
//!
//! [`pipeline`] runs it all as `mtcal identify` does (fit or physics search, information
//! account, what-if, suggested model, predictions), [`html_report`] gathers the HTML report's
//! model.
//!
//! # `[identify]` options in `session.toml` (mtcal's addition to the contract)
//! - `parameters = ["EC0Y", "EB0Z", …]`: the machine parameters to estimate (ISO 230-1 names;
//!   a component error brings all its coefficients). Default: every parameter of the machine's
//!   error model (its `.errors.toml`). The others stay at their start values.
//! - `start = "file.params.toml"`: start values (and the values of parameters not estimated);
//!   default zero.
//! - `held_prior = 3.0`: µm or µrad; without `parameters`, the machine coefficients the runs
//!   cannot determine stay in the fit with this prior standard deviation about their start
//!   ([`base`]).

pub mod acceptance;
pub mod band;
pub mod base;
mod blocks;
mod checks;
pub mod diagnostics;
pub mod findings;
pub mod fit;
pub mod html_report;
pub mod ids;
pub mod information;
pub mod layout;
pub mod mismatch;
pub mod noise;
mod options;
pub mod pipeline;
mod relabel;
pub mod report;
pub mod search;
pub mod series;
pub mod study;
pub mod whiten;

pub use fit::{FitProblem, predict_run, predict_runs};
pub use layout::{ParamLayout, ParamSlot};
pub use report::Identification;
pub use study::Study;

use mtcal_instrument::SetupError;
use mtcal_session::{RunColumns, RunTable};
use mtcal_solve::{Observer, Options, ParamSpec, Silent, SolveError};
use std::path::{Path, PathBuf};

/// Coverage factor of the reported intervals (normal, 95 %).
pub const K95: f64 = 1.96;

/// Why an identification could not run. Each message names the file (and where possible the
/// line and column) and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    #[error(transparent)]
    Session(#[from] mtcal_session::SessionError),
    /// `at`: where the manifest names the machine (`session.toml:1:11`).
    #[error("{at}: machine: {message}")]
    Machine { at: String, message: String },
    #[error("{source_name}: error model: {message}")]
    Model {
        source_name: String,
        message: String,
    },
    #[error(transparent)]
    Params(#[from] mtcal_machine::params::ParamsError),
    #[error("{at}: run `{run}`: unknown instrument `{name}`; known instruments: {known}")]
    UnknownInstrument {
        at: String,
        run: String,
        name: String,
        known: String,
    },
    #[error("{at}: set-up `{setup}`: {cause}")]
    Setup {
        at: String,
        setup: String,
        cause: SetupError,
    },
    #[error("{at}: set-up `{setup}` is used by a `{second}` run but was first used by `{first}`")]
    SetupShared {
        at: String,
        setup: String,
        first: String,
        second: String,
    },
    /// `at`: the key's value in the manifest (`session.toml:7:14`).
    #[error("{at}: [identify] `{key}`: {message}")]
    Options {
        at: String,
        key: String,
        message: String,
    },
    /// A run file's values that the instrument cannot use (an unknown label, a missing
    /// environment column): `at` is `file:line:column` (or the file alone).
    #[error("{at}: {message}")]
    RunData { at: String, message: String },
    #[error(
        "{}: every run is `use = \"validate\"`: at least one run must be fitted",
        manifest.display()
    )]
    NothingToFit { manifest: PathBuf },
    #[error("identification failed: {0}")]
    Solve(SolveError),
    #[error("mismatch analysis: {0}")]
    Mismatch(mtcal_mismatch::MismatchError),
    /// The information account ([`information`]) met numbers it cannot use.
    #[error("information account: {0}")]
    Information(String),
    /// The HTML report's volumetric map cannot be laid out on the machine ([`html_report`]).
    #[error("cannot build the map grid")]
    MapGrid(#[source] mtcal_kinematics::volmap::GridError),
    #[error("cannot write the report")]
    Report(#[source] mtcal_report::ReportError),
    /// The tolerance file of `--acceptance` (unreadable, or wrong at a place in it).
    #[error(transparent)]
    Acceptance(#[from] mtcal_acceptance::AcceptanceError),
}

// Written out, not `#[from]`: the message shows the cause, so it is not also the source.
impl From<SolveError> for IdentifyError {
    fn from(e: SolveError) -> Self {
        IdentifyError::Solve(e)
    }
}

impl From<mtcal_mismatch::MismatchError> for IdentifyError {
    fn from(e: mtcal_mismatch::MismatchError) -> Self {
        IdentifyError::Mismatch(e)
    }
}

/// Fits `study`: every estimated machine coefficient and free nuisance parameter, priors from
/// the plugins' nuisance declarations.
pub fn identify(
    study: &Study,
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<Identification, IdentifyError> {
    Ok(identify_with_solution(study, options, observer)?.0)
}

/// [`identify`], also returning the solver's solution (for [`search::rank`]).
pub fn identify_with_solution(
    study: &Study,
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<(Identification, mtcal_solve::Solution), IdentifyError> {
    let specs = param_specs(study);
    let problem = FitProblem::new(study);
    let solution = mtcal_solve::solve(&problem, &specs, options, observer)?;
    Ok((Identification::new(study, &solution)?, solution))
}

/// The solver's parameter specs of `study`: start values, priors from the plugins' nuisance
/// declarations, bounds of the effects' shape parameters.
pub fn param_specs(study: &Study) -> Vec<ParamSpec> {
    param_specs_from(study, &study.initial_x())
}

/// [`param_specs`] starting from `x0` instead of the study's own start.
pub fn param_specs_from(study: &Study, x0: &[f64]) -> Vec<ParamSpec> {
    let held = &study.changes().hold;
    let start = if held.is_empty() {
        Vec::new()
    } else {
        study.initial_x()
    };
    (0..study.layout().n_x())
        .map(|i| {
            let info = study.param_info(i);
            // What the runs cannot determine stays near its start ([`base`]).
            let effect = study.effect_param(i);
            let is_held = !held.is_empty() && held.contains(&study.param_id(i));
            let prior = if info.machine && is_held {
                Some((start[i], study.held_prior))
            } else if let Some(s) = effect.and_then(|d| d.prior) {
                // A ridge on a joint model's columns (mtcal_effects::bank).
                Some((0.0, s))
            } else {
                info.prior_sigma.map(|s| (0.0, s))
            };
            // Plausible ranges: a millimetre or milliradian of machine or set-up error, a 1 %
            // gain; an effect says its own.
            let scale = match effect {
                Some(d) => d.scale,
                None if info.unit == "ppm" => 1e-2,
                None => 1e-3,
            };
            // A shape the data do not determine, held where the search left it
            // (`search::keep`): an assumption of the model, not a fitted parameter.
            let fixed = effect.is_some() && is_held;
            ParamSpec {
                name: info.name,
                initial: x0[i],
                fixed,
                prior,
                bounds: effect.and_then(|d| d.bounds),
                group: (!info.machine && effect.is_none()).then(|| "set-up".to_string()),
                scale: Some(scale),
            }
        })
        .collect()
}

/// Solves `study` from `x0` in two stages when it has effects with shape parameters: first
/// with the shapes held (the problem is then linear in the effects' amplitudes, so they come
/// out right even from zero), then with everything free. A shape parameter's column is its
/// amplitude times a derivative: next to a zero amplitude a Gauss–Newton step along it is
/// arbitrarily long.
pub fn solve_from(
    study: &Study,
    x0: &[f64],
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<mtcal_solve::Solution, IdentifyError> {
    solve_holding(study, x0, options, observer, &[])
}

/// [`solve_from`] with the parameters `held` (shape parameters of effects) kept at their values
/// in `x0` throughout.
pub fn solve_holding(
    study: &Study,
    x0: &[f64],
    options: &Options,
    observer: &mut dyn Observer,
    held: &[usize],
) -> Result<mtcal_solve::Solution, IdentifyError> {
    let problem = FitProblem::new(study);
    let mut specs = param_specs_from(study, x0);
    let shapes: Vec<usize> = (0..study.layout().n_x())
        .filter(|&i| {
            study
                .effect_param(i)
                .is_some_and(|p| p.kind == mtcal_effects::ParamKind::Shape)
        })
        .collect();
    if !shapes.is_empty() {
        for &i in &shapes {
            specs[i].fixed = true;
        }
        let first = mtcal_solve::solve(&problem, &specs, options, observer)?;
        specs = param_specs_from(study, &first.x);
    }
    for &i in held {
        specs[i].fixed = true;
    }
    Ok(mtcal_solve::solve(&problem, &specs, options, observer)?)
}

/// Loads and identifies `session` with default options and no progress output.
pub fn identify_session(session: &Path) -> Result<(Study, Identification), IdentifyError> {
    let study = Study::load(session)?;
    let id = identify(&study, &Options::default(), &mut Silent)?;
    Ok((study, id))
}

/// Where a validation run's predictions go: `dir/<run>.csv`.
pub fn prediction_path(dir: &Path, run: &str) -> PathBuf {
    dir.join(format!("{run}.csv"))
}

/// Every validation run's predicted readings as the file `dir/<run>.csv` would hold them (the
/// run's own columns, readings replaced by the predictions, or added when the run has none):
/// `(path, text)`, for the caller to write with its other outputs. Refuses a `dir` where a
/// prediction would replace one of the session's own files (inputs are never modified).
pub fn prediction_files(
    study: &Study,
    x: &[f64],
    dir: &Path,
) -> Result<Vec<(PathBuf, String)>, IdentifyError> {
    let inputs: Vec<PathBuf> = study
        .runs
        .iter()
        .filter_map(|run| run.file.path.canonicalize().ok())
        .collect();
    for run in study.runs.iter().filter(|run| !run.fit) {
        let target = prediction_path(dir, &run.name);
        if target.canonicalize().is_ok_and(|t| inputs.contains(&t)) {
            return Err(IdentifyError::RunData {
                at: target.display().to_string(),
                message: "the predictions would replace a run file of the session itself; \
                          write them into another folder (--predict DIR)"
                    .into(),
            });
        }
    }
    let mut out = Vec::new();
    for (r, run) in study.runs.iter().enumerate() {
        if run.fit {
            continue;
        }
        let channels = study.channels(r);
        let mut pred = predict_run(study, r, x);
        let setup = &study.setups[run.setup].setup;
        let expanded = run.expanded();
        setup
            .record_readings(&expanded.data(), &mut pred)
            .map_err(|e| IdentifyError::RunData {
                at: run.file.path.display().to_string(),
                message: format!("recording the predictions: {e}"),
            })?;
        let values: Vec<f64> = pred
            .chunks_exact(channels.len())
            .flat_map(|row| row.iter().zip(channels).map(|(v, c)| v * c.unit.per_si()))
            .collect();
        // The run's numbers as they were read, the predictions as its readings.
        let mut table = RunTable {
            path: run.file.path.clone(),
            columns: run.file.columns.clone(),
            t: run.t.raw_vec(),
            axes: run.file.axes.clone(),
            positions: run.q.raw_row_major(),
            readings: channels.iter().map(|c| c.name.clone()).collect(),
            values: Some(values),
            context: run
                .context
                .iter()
                .map(|(n, c)| (n.clone(), c.raw_vec()))
                .collect(),
            labels: run.file.labels.clone(),
        };
        let missing: Vec<String> = table
            .readings
            .iter()
            .filter(|c| !table.columns.contains(c))
            .cloned()
            .collect();
        table.columns.extend(missing);
        let path = prediction_path(dir, &run.name);
        let text = mtcal_session::run_text(&path, &table)?;
        // Read back: what we write must load as a run with readings.
        let axes: Vec<char> = table.axes.clone();
        let names: Vec<&str> = table.readings.iter().map(String::as_str).collect();
        mtcal_session::parse_run(
            &path,
            text.clone(),
            &RunColumns {
                axes: &axes,
                readings: &names,
                readings_optional: false,
                labels: &[],
            },
        )?;
        out.push((path, text));
    }
    Ok(out)
}
