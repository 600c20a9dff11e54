//! Sessions (a folder, or parts held in memory), `identify` and `simulate`.
//!
//! A folder is identified exactly as `mtcal identify` does it: `pipeline::Prepared::load`, then
//! `run`. A session in memory goes through `Study::from_parts` (the same study a folder of the
//! same tables gives), then `Prepared::from_study` and the same `run`.
//! python/tests/test_session.py checks that both give the same JSON.

use crate::errors::{Kind, identify_error, other};
use crate::machine::RsMachine;
use mtcal_identify::pipeline::{Outcome, PipelineOptions, Prepared};
use mtcal_identify::{IdentifyError, Study};
use mtcal_machine::LoadedMachine;
use mtcal_machine::topology::Reading;
use mtcal_session::{Location, RunSpec, RunTable, RunUse, Session, SetupRef};
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where a session's runs come from.
#[derive(Debug, Clone)]
enum Source {
    /// A session folder (or its `session.toml`).
    Folder(PathBuf),
    /// A session in memory: its manifest as parsed, its machine, one table per run.
    Memory {
        session: Box<Session>,
        machine: Box<LoadedMachine>,
        tables: Vec<RunTable>,
    },
}

/// A session: a folder, or runs held in memory.
#[pyclass(module = "mtcal._mtcal", frozen)]
#[derive(Debug)]
pub struct RsSession {
    source: Source,
    /// The session folder (in memory: the folder its tables name).
    dir: PathBuf,
    runs: Vec<(String, String, String, usize)>,
    machine: String,
}

impl RsSession {
    fn study(&self) -> Result<Study, IdentifyError> {
        match &self.source {
            Source::Folder(path) => Study::load(path),
            Source::Memory {
                session,
                machine,
                tables,
            } => Study::from_parts((**session).clone(), (**machine).clone(), tables.clone()),
        }
    }

    /// The session `source` checked by loading its study once.
    fn new(source: Source) -> PyResult<Self> {
        let dir = match &source {
            Source::Folder(p) => p.clone(),
            Source::Memory { session, .. } => session.dir.clone(),
        };
        let mut this = RsSession {
            source,
            dir,
            runs: Vec::new(),
            machine: String::new(),
        };
        let study = this.study().map_err(identify_error)?;
        this.runs = study
            .session
            .runs
            .iter()
            .zip(study.runs.iter())
            .map(|(spec, run)| {
                (
                    spec.name.clone(),
                    spec.instrument.clone(),
                    spec.use_.as_str().to_string(),
                    run.len(),
                )
            })
            .collect();
        this.machine = study.machine.source.clone();
        Ok(this)
    }
}

/// One run given from Python as a dict with these keys; `setup` and `extra` as JSON (a set-up's
/// name as a JSON string, or its own table as an object).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct RunArg<'py> {
    name: String,
    instrument: String,
    file: String,
    #[pyo3(item("use"))]
    use_: String,
    setup: String,
    extra: String,
    columns: Vec<String>,
    t: PyReadonlyArray1<'py, f64>,
    axes: String,
    positions: PyReadonlyArray2<'py, f64>,
    readings: Vec<String>,
    values: Option<PyReadonlyArray2<'py, f64>>,
    context: Vec<(String, PyReadonlyArray1<'py, f64>)>,
    labels: Vec<(String, Vec<String>)>,
}

/// A TOML table from JSON text (`what` names it in the message).
fn table_of(json: &str, what: &str) -> PyResult<toml::Table> {
    serde_json::from_str::<toml::Table>(json).map_err(|e| {
        other(
            Kind::Session,
            format!("{what}: expected a table of TOML values: {e}"),
        )
    })
}

fn array_vec(a: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

fn array2_vec(a: &PyReadonlyArray2<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

#[pymethods]
impl RsSession {
    /// A session folder (or its `session.toml`), loaded and checked.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| RsSession::new(Source::Folder(path)))
    }

    /// A session in memory: `dir` the folder its files would be in (relative machine paths
    /// start there; messages name files in it), `machine` a URDF path relative to `dir` or a
    /// topology code, `setups` and `identify` as JSON objects, one [`RunArg`] per run.
    #[staticmethod]
    fn from_parts(
        dir: PathBuf,
        machine: String,
        setups: &str,
        identify: &str,
        runs: Vec<RunArg<'_>>,
    ) -> PyResult<Self> {
        let manifest = dir.join(mtcal_session::MANIFEST_NAME);
        let at = Location::at(&manifest, 1, 1);
        let mut setup_tables = BTreeMap::new();
        for (name, value) in table_of(setups, "setups")? {
            match value {
                toml::Value::Table(t) => {
                    setup_tables.insert(name, t);
                }
                _ => {
                    return Err(other(
                        Kind::Session,
                        format!("setups: `{name}`: expected a table of the set-up's keys"),
                    ));
                }
            }
        }
        let mut specs = Vec::with_capacity(runs.len());
        let mut tables = Vec::with_capacity(runs.len());
        for RunArg {
            name,
            instrument,
            file,
            use_,
            setup,
            extra,
            columns,
            t,
            axes,
            positions,
            readings,
            values,
            context,
            labels,
        } in runs
        {
            let use_ = match use_.as_str() {
                "fit" => RunUse::Fit,
                "validate" => RunUse::Validate,
                u => {
                    return Err(other(
                        Kind::Session,
                        format!(
                            "run `{name}`: use: expected \"fit\" or \"validate\", found \"{u}\""
                        ),
                    ));
                }
            };
            let setup = match serde_json::from_str::<serde_json::Value>(&setup) {
                Ok(serde_json::Value::String(s)) => {
                    if !setup_tables.contains_key(&s) {
                        return Err(other(
                            Kind::Session,
                            format!("run `{name}`: setup `{s}` is not one of the set-ups"),
                        ));
                    }
                    SetupRef::Shared(s)
                }
                _ => SetupRef::Own(table_of(&setup, &format!("run `{name}`: setup"))?),
            };
            let path = dir.join(&file);
            specs.push(RunSpec {
                name: name.clone(),
                instrument,
                file: path.clone(),
                file_as_written: file,
                use_,
                setup,
                extra: table_of(&extra, &format!("run `{name}`: extra"))?,
                location: at.clone(),
            });
            let positions_shape = positions.shape();
            let axes: Vec<char> = axes.chars().collect();
            if positions_shape[1] != axes.len() {
                return Err(other(
                    Kind::Session,
                    format!(
                        "run `{name}`: positions: expected {} columns (axes {}), found {}",
                        axes.len(),
                        axes.iter().collect::<String>(),
                        positions_shape[1]
                    ),
                ));
            }
            if let Some(v) = &values {
                if v.shape()[1] != readings.len() {
                    return Err(other(
                        Kind::Session,
                        format!(
                            "run `{name}`: readings: expected {} columns ({}), found {}",
                            readings.len(),
                            readings.join(", "),
                            v.shape()[1]
                        ),
                    ));
                }
            }
            tables.push(RunTable {
                path,
                columns,
                t: array_vec(&t),
                axes,
                positions: array2_vec(&positions),
                readings,
                values: values.as_ref().map(array2_vec),
                context: context
                    .iter()
                    .map(|(n, c)| (n.clone(), array_vec(c)))
                    .collect(),
                labels,
            });
        }
        let machine_file = dir.join(&machine);
        let machine_path =
            (machine_file.is_file() || machine.ends_with(".urdf")).then_some(machine_file);
        let arg = machine_path
            .as_ref()
            .map_or(machine.clone(), |p| p.to_string_lossy().into_owned());
        let loaded = mtcal_machine::load_machine(&arg, Reading::default())
            .map_err(|e| other(Kind::Machine, format!("{}: machine: {e}", at)))?;
        let session = Session {
            dir: dir.clone(),
            manifest,
            machine,
            machine_at: at,
            machine_path,
            setups: setup_tables,
            runs: specs,
            identify: table_of(identify, "identify")?,
            identify_at: BTreeMap::new(),
            setup_at: BTreeMap::new(),
        };
        RsSession::new(Source::Memory {
            session: Box::new(session),
            machine: Box::new(loaded),
            tables,
        })
    }

    /// The session folder (in memory: the folder its run tables name).
    #[getter]
    fn dir(&self) -> PathBuf {
        self.dir.clone()
    }

    /// Whether the session is held in memory (not read from a folder).
    #[getter]
    fn in_memory(&self) -> bool {
        matches!(self.source, Source::Memory { .. })
    }

    /// `(name, instrument, use, samples)` of every run, in the manifest's order.
    #[getter]
    fn runs(&self) -> Vec<(String, String, String, usize)> {
        self.runs.clone()
    }

    /// Where the machine came from (a file path or `topology code …`).
    #[getter]
    fn machine_source(&self) -> String {
        self.machine.clone()
    }

    /// The session's machine.
    fn machine(&self) -> PyResult<RsMachine> {
        let study = self.study().map_err(identify_error)?;
        RsMachine::from_loaded((*study.machine).clone())
    }

    fn __repr__(&self) -> String {
        let samples: usize = self.runs.iter().map(|r| r.3).sum();
        format!(
            "Session({}{}: {} runs, {} samples; machine {})",
            self.dir.display(),
            if self.in_memory() { ", in memory" } else { "" },
            self.runs.len(),
            samples,
            self.machine
        )
    }
}

/// One row of [`RsOutcome::what_if`]: `(name, now_u95, after_u95, unit)`.
type WhatIfRow = (String, f64, f64, String);

/// What `identify` computed: the JSON `mtcal identify --json` writes, and what it prints.
#[pyclass(module = "mtcal._mtcal", unsendable)]
#[derive(Debug)]
pub struct RsOutcome {
    outcome: Outcome,
}

#[pymethods]
impl RsOutcome {
    /// The identification as `mtcal identify --json` writes it (`mtcal.identify/1`).
    fn json(&self) -> String {
        self.outcome.to_json()
    }

    /// The fit before the physics search, as JSON; `None` without the search.
    fn initial_json(&self) -> Option<String> {
        self.outcome
            .search
            .as_ref()
            .map(|s| mtcal_identify::report::IdentifyJson::of(&s.before).to_json())
    }

    /// What a person reads first when the fit did not converge or the model does not explain
    /// the recordings; `None` when both hold.
    fn verdict(&self) -> Option<String> {
        self.outcome.identification.verdict()
    }

    /// What `mtcal identify` prints after its header.
    #[pyo3(signature = (verbose = false))]
    fn screen(&self, verbose: bool) -> String {
        self.outcome.screen(verbose)
    }

    /// What adding the runs of another session folder would do to every interval:
    /// `(name, now_u95, after_u95, unit)` rows, and the table `--what-if` prints.
    fn what_if(&self, py: Python<'_>, session: PathBuf) -> PyResult<(Vec<WhatIfRow>, String)> {
        let w = py
            .detach(|| self.outcome.what_if(&session))
            .map_err(identify_error)?;
        let rows = w
            .rows
            .iter()
            .map(|r| (r.name.clone(), r.now_u95, r.after_u95, r.unit.clone()))
            .collect();
        Ok((rows, w.to_string()))
    }

    /// The error model these runs identify, as an `.errors.toml`.
    fn suggested_model(&self) -> String {
        self.outcome.suggested_model()
    }

    /// The HTML report's page (`index.html`).
    fn report_page(&self) -> PyResult<String> {
        self.outcome.report_page().map_err(identify_error)
    }
}

/// `identify`: a session identified as `mtcal identify` does it (see the module doc).
#[pyfunction]
#[pyo3(signature = (session, search = false, acceptance = None, threads = 0, max_iterations = None))]
pub fn identify(
    py: Python<'_>,
    session: &RsSession,
    search: bool,
    acceptance: Option<PathBuf>,
    threads: usize,
    max_iterations: Option<usize>,
) -> PyResult<RsOutcome> {
    let acceptance = acceptance
        .as_deref()
        .map(mtcal_acceptance::Tolerances::read)
        .transpose()
        .map_err(|e| identify_error(e.into()))?;
    let options = PipelineOptions {
        solver: {
            let defaults = mtcal_solve::Options::default();
            mtcal_solve::Options {
                threads,
                max_iterations: max_iterations.unwrap_or(defaults.max_iterations),
                ..defaults
            }
        },
        search,
        acceptance,
    };
    let outcome = py
        .detach(|| match &session.source {
            Source::Folder(path) => Prepared::load(path, options)?.run(&mut mtcal_solve::Silent),
            Source::Memory { .. } => run_study(session.study()?, &session.dir, options),
        })
        .map_err(identify_error)?;
    Ok(RsOutcome { outcome })
}

/// The pipeline for a study built in memory ([`Prepared::from_study`]): the same steps as
/// for a folder.
fn run_study(study: Study, dir: &Path, options: PipelineOptions) -> Result<Outcome, IdentifyError> {
    Prepared::from_study(dir, study, options)?.run(&mut mtcal_solve::Silent)
}

/// `simulate`: the session a test plan describes; written into `out` as `mtcal simulate` does
/// (and returned as that folder), or held in memory for the folder `dir`.
#[pyfunction]
#[pyo3(signature = (plan, out = None, dir = None))]
pub fn simulate(
    py: Python<'_>,
    plan: PathBuf,
    out: Option<PathBuf>,
    dir: Option<PathBuf>,
) -> PyResult<RsSession> {
    py.detach(|| {
        if let Some(out) = out {
            mtcal_simulate::simulate(&plan, &out).map_err(|e| other(Kind::Simulate, e))?;
            return RsSession::new(Source::Folder(out));
        }
        let read = mtcal_simulate::Plan::read(&plan).map_err(|e| other(Kind::Simulate, e))?;
        let machine = read.machine().map_err(|e| other(Kind::Simulate, e))?;
        let dir = dir.unwrap_or_else(|| {
            plan.parent()
                .unwrap_or(Path::new("."))
                .join("simulated-session")
        });
        let simulated = mtcal_simulate::simulate_session(&read, machine, &[], &dir)
            .map_err(|e| other(Kind::Simulate, e))?;
        let (session, machine, tables) = simulated.into_parts();
        RsSession::new(Source::Memory {
            session: Box::new(session),
            machine: Box::new(machine),
            tables,
        })
    })
}
