//! A loaded session ready to identify: the machine model, which coefficients are estimated,
//! every distinct set-up with its nuisance parameters, and every run's samples in SI units.

use crate::IdentifyError;
use crate::checks::cell;
use crate::layout::{ParamLayout, ParamSlot};
use crate::options::{StudyOptions, identify_key};
use mtcal_effects::{
    AxisView, BasisOrder, Effect, ModelParamView, RunView, SeriesCache, SessionView, SetupView,
};
use mtcal_instrument::{At, Channel, InstrumentPlugin, Setup, SetupContext};
use mtcal_kinematics::Basis;
use mtcal_kinematics::{AxisKind, MachineModel, ParamName};
use mtcal_machine::{LoadedMachine, load_machine, params, topology::Reading};
use mtcal_session::{
    Column, Columns, RunColumns, RunSpec, RunTable, RunUse, Scale, Session, SetupRef, load_session,
    read_run,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

pub use crate::options::IDENTIFY_KEYS;

/// Run ends this many sample intervals apart or closer continue one another
/// ([`Study::continues`]).
pub const CONTINUES_INTERVALS: f64 = 3.0;

/// Default prior standard deviation of the machine coefficients the runs cannot determine
/// (`[identify] held_prior`, µm or µrad per coefficient; [`crate::base`]).
pub const DEFAULT_HELD_PRIOR: f64 = 3.0;

/// One distinct set-up: a shared `[setup.<name>]` or a run's own `[run.setup]`.
#[derive(Debug)]
pub struct SetupSlot {
    /// The shared set-up's name, or the run's name for an own set-up.
    pub name: String,
    pub plugin: &'static InstrumentPlugin,
    pub setup: Box<dyn Setup>,
    /// The manifest table it was loaded from.
    pub table: toml::Table,
}

/// One run's samples.
///
/// The samples are held once: `table` keeps the file's times, context and (for validation
/// runs, which [`crate::prediction_files`] writes back) the positions and labels as read,
/// while the positions and readings the fit uses are converted to SI in place (`q`,
/// `readings`): a fitted run's `table.positions` and every run's `table.values` are empty, a
/// fitted run's label columns are empty (their numbers are `labels`). What the mismatch
/// analysis needs from the positions in file units is summarised when the run is loaded.
#[derive(Debug)]
pub struct RunSlot {
    pub name: String,
    pub fit: bool,
    /// Index into [`Study::setups`].
    pub setup: usize,
    /// The run file: path, header, label texts.
    pub file: RunFile,
    /// Time of each sample, s.
    pub t: Column,
    /// Commanded positions, `samples × axes`: [`Columns::get`] gives SI (m, rad),
    /// [`Column::raw`] the file's mm and degrees.
    pub q: Columns,
    /// Readings, SI, `samples × channels`, as the set-up prepared them
    /// ([`SetupFormat::prepare_readings`]); `None` for a validation run without them.
    pub readings: Option<Columns>,
    /// Context columns (`T_<name>`, `P_<name>`, `H_<name>`, `S`, `F`), file units, file order.
    pub context: Vec<(String, Column)>,
    /// Each sample's label number ([`SetupFormat::resolve_label`]); empty when the instrument has no
    /// label columns.
    pub labels: Vec<u32>,
    /// Block means and directions of the commanded positions, file units (for the mismatch
    /// analysis).
    pub(crate) position_blocks: crate::blocks::PositionBlocks,
}

/// A run's samples as loaded, before they take their place in the study.
struct LoadedRun {
    file: RunFile,
    t: Column,
    q: Columns,
    readings: Option<Columns>,
    context: Vec<(String, Column)>,
    labels: Vec<u32>,
    position_blocks: crate::blocks::PositionBlocks,
}

/// Where [`Study::assemble`] gets each run's samples, in the manifest's run order.
enum RunSource {
    /// The run files the manifest names ([`Study::load`]).
    Files,
    /// Tables held in memory, as reading the run files would give them
    /// ([`Study::from_parts`]).
    Tables(std::vec::IntoIter<RunTable>),
}

impl RunSource {
    /// Run `spec`'s samples, loaded for the study: `setup` is its set-up, `fit` whether it is
    /// fitted.
    fn next_run(
        &mut self,
        spec: &RunSpec,
        model: &MachineModel,
        setup: &dyn Setup,
        fit: bool,
    ) -> Result<LoadedRun, IdentifyError> {
        match self {
            RunSource::Files => {
                let table = read_run_file(spec, model, setup, fit)?;
                load_run(model, setup, table, fit)
            }
            RunSource::Tables(tables) => {
                let table = tables
                    .next()
                    .expect("Study::from_parts checked: one table per run");
                // A file's table was checked by the reader; one from memory is checked here.
                crate::checks::check_table(model, setup, &table, fit)?;
                load_run(model, setup, table, fit)
            }
        }
    }
}

impl RunSlot {
    /// Sample `i`'s label number (0 without label columns).
    pub fn label(&self, i: usize) -> u32 {
        self.labels.get(i).copied().unwrap_or(0)
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The context column called `name`.
    pub fn context_column(&self, name: &str) -> Option<&Column> {
        self.context.iter().find(|(n, _)| n == name).map(|(_, c)| c)
    }

    /// The run's numbers as plain vectors, for an instrument's whole-run functions
    /// ([`mtcal_instrument::RunData`], [`mtcal_instrument::Evaluation`]): SI positions
    /// (row-major), times and context columns.
    pub fn expanded(&self) -> ExpandedRun {
        ExpandedRun {
            q: self.q.to_row_major(),
            t: self.t.to_vec(),
            context: self
                .context
                .iter()
                .map(|(n, c)| (n.clone(), c.to_vec()))
                .collect(),
        }
    }
}

/// A run file as the study remembers it; its numbers are in [`RunSlot`]'s columns.
#[derive(Clone, Debug)]
pub struct RunFile {
    pub path: PathBuf,
    /// The header, in file order.
    pub columns: Vec<String>,
    /// The machine's axis letters.
    pub axes: Vec<char>,
    /// The instrument's reading columns.
    pub readings: Vec<String>,
    /// The label columns; a fitted run's texts are dropped once resolved to numbers.
    pub labels: Vec<(String, Vec<String>)>,
}

/// A run's positions, times and context as vectors ([`RunSlot::expanded`]).
#[derive(Debug)]
pub struct ExpandedRun {
    pub q: Vec<f64>,
    pub t: Vec<f64>,
    pub context: Vec<(String, Vec<f64>)>,
}

impl ExpandedRun {
    pub fn data(&self) -> mtcal_instrument::RunData<'_> {
        mtcal_instrument::RunData {
            q: &self.q,
            t: &self.t,
            context: &self.context,
        }
    }
}

/// A session loaded for identification.
#[derive(Debug)]
pub struct Study {
    pub session: Arc<Session>,
    pub machine: Arc<LoadedMachine>,
    pub model: Arc<MachineModel>,
    /// Machine coefficients (SI) that are not estimated keep these values; estimated ones start
    /// from them. Zero unless `[identify] start` names a parameter file.
    pub base_coeffs: Vec<f64>,
    /// The model the fit evaluates: only the parameters that are estimated or have a nonzero
    /// base value. A parameter held at zero changes no prediction, so leaving it out gives the
    /// same poses while the Jacobian skips its columns (the 11-error R-test fit of a machine
    /// with a full error model evaluates 11 columns instead of 121).
    pub fit_model: Arc<MachineModel>,
    /// A label per machine coefficient (`EX0C`, `EXX.P2`).
    pub coeff_labels: Vec<String>,
    /// The set-ups and runs as loaded: shared by every study rebuilt from this one.
    pub setups: Arc<Vec<SetupSlot>>,
    pub runs: Arc<Vec<RunSlot>>,
    /// `[identify]` as read, and the start file's text: read once, shared likewise.
    inputs: Arc<Inputs>,
    /// The parameter vector: which machine coefficients are estimated, every set-up's free
    /// nuisance parameters, the effects' parameters (and the reduced model's coefficients).
    layout: ParamLayout,
    /// Prior standard deviation (SI) of the machine coefficients [`Changes::hold`] names:
    /// `[identify] held_prior` (µm or µrad), default [`DEFAULT_HELD_PRIOR`].
    pub held_prior: f64,
    changes: Changes,
    /// The session as the effects see it, built on first use.
    view: OnceLock<Arc<SessionView>>,
    /// Per run, the nominal machine's axis Jacobian at every sample, when they fit
    /// [`AXIS_JACOBIAN_CACHE_BYTES`] (decided on first use); shared by the studies rebuilt with
    /// the same reduced model.
    axis_jacobians: Arc<OnceLock<Option<Vec<Vec<f64>>>>>,
    /// The location errors an effect can act on ([`Study::locations`]), decided on first use.
    locations: OnceLock<Vec<(ParamName, usize)>>,
    /// Per run, their columns at every sample ([`Study::location_jacobian`]), kept as the axis
    /// Jacobians are.
    location_jacobians: Arc<OnceLock<Option<Vec<Vec<f64>>>>>,
    /// The inputs and lag series of the session's runs, shared by the studies rebuilt from
    /// this one (they depend on the runs alone).
    series: Arc<SeriesCache>,
}

/// What a rebuilt study takes from the one it is rebuilt from, unchanged.
struct Shared {
    session: Arc<Session>,
    machine: Arc<LoadedMachine>,
    setups: Arc<Vec<SetupSlot>>,
    runs: Arc<Vec<RunSlot>>,
    inputs: Arc<Inputs>,
}

/// What a session's studies share besides its set-ups and runs: `[identify]` as parsed and
/// checked, and the text of the parameter file its `start` names (parsed again for a model
/// whose orders a search raised, never read again).
#[derive(Debug)]
struct Inputs {
    options: StudyOptions,
    start: Option<(PathBuf, String)>,
    held_prior: f64,
}

/// The nominal axis Jacobians of every sample are kept when they take at most this (a session
/// of about 70,000 samples on a five-axis machine: every example and test session): computed
/// once per study rather than once per pass over the data, which makes a physics search on
/// such a session about a quarter faster. A larger session computes each when it is needed,
/// so that its memory does not grow by 48 bytes per axis and sample (README, "Scale").
pub const AXIS_JACOBIAN_CACHE_BYTES: usize = 16 << 20;

/// How one sample's nominal Jacobian columns are computed ([`Study::axis_jacobian`]'s,
/// [`Study::location_jacobian`]'s).
type PerSample = fn(&Study, usize, usize, &mut AxisJacobianScratch, &mut [f64]);

/// Per-sample values kept for every sample, or computed when asked.
struct KeptPerSample<'s> {
    study: &'s Study,
    kept: Option<&'s Vec<Vec<f64>>>,
    compute: PerSample,
}

impl KeptPerSample<'_> {
    /// Sample `i` of run `r`'s values into `out`.
    fn fill(&self, r: usize, i: usize, scratch: &mut AxisJacobianScratch, out: &mut [f64]) {
        match self.kept {
            Some(all) => out.copy_from_slice(&all[r][i * out.len()..(i + 1) * out.len()]),
            None => (self.compute)(self.study, r, i, scratch, out),
        }
    }
}

/// Scratch for [`Study::axis_jacobian`] (one per thread): the nominal machine's workspace,
/// its zero coefficients and one sample's positions.
#[derive(Debug)]
pub struct AxisJacobianScratch {
    ws: mtcal_kinematics::Workspace,
    zeros: Vec<f64>,
    q: Vec<f64>,
    /// The full model's, for the location errors' columns (made on first use).
    full: Option<FullScratch>,
}

/// The full model's workspace, zero coefficients and coefficient Jacobian.
#[derive(Debug)]
struct FullScratch {
    ws: mtcal_kinematics::Workspace,
    zeros: Vec<f64>,
    jac: Vec<f64>,
}

/// Samples of one set-up looked at by `Study::field_like_nuisance` (an even stride through
/// more).
const FIELD_LIKE_SAMPLES: usize = 4000;

/// How a rebuilt study differs from the session as written: what the physics search adds.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Parameters of the error model to estimate besides `[identify] parameters`.
    pub estimate: Vec<ParamName>,
    /// Component errors whose basis gets more orders (Legendre degree or Fourier harmonics).
    pub raise: Vec<(ParamName, usize)>,
    /// Effects fitted along with the machine (their parameters come last in `x`).
    pub effects: Vec<Arc<dyn Effect>>,
    /// Parameters the runs cannot determine ([`crate::base`]), by name (`EXX.P3`,
    /// `bar.tool_length`): a set-up parameter is held at its start value; a machine
    /// coefficient stays in the fit with a prior of [`Study::held_prior`] about its start,
    /// so that it neither takes arbitrary values nor leaves its effect to the others (which
    /// would bias every prediction that sees it differently), and predictions carry its
    /// uncertainty.
    pub hold: Vec<String>,
    /// The noise the recordings carry, when it is not the stated white noise
    /// ([`crate::noise`]): every channel's σ scaled and its rows prewhitened.
    pub noise: Option<Arc<crate::whiten::NoiseModel>>,
}

impl Study {
    /// The shared set-ups of the manifest that no run uses, by name.
    pub fn unused_setups(&self) -> Vec<&str> {
        self.session
            .setups
            .keys()
            .filter(|name| !self.setups.iter().any(|s| &s.name == *name))
            .map(String::as_str)
            .collect()
    }

    /// Loads `dir` (a session folder or its manifest): machine, set-ups and every run file.
    pub fn load(dir: &Path) -> Result<Study, IdentifyError> {
        let session = load_session(dir)?;
        let machine = load_session_machine(&session)?;
        Self::assemble(session, machine, RunSource::Files, Changes::default())?
            .with_configured_effects()
    }

    /// A study of a session held in memory: `session` (its manifest as parsed), its machine
    /// and one table per run in the manifest's order, in file units as [`read_run`] gives a
    /// run file (simulated sessions: `mtcal_simulate::SimulatedSession::into_parts`). Reads no
    /// file, except the parameter file an `[identify] start` names. [`Study::load`] is the
    /// same with the tables read from the run files: the same tables give the same study.
    pub fn from_parts(
        session: Session,
        machine: LoadedMachine,
        tables: Vec<RunTable>,
    ) -> Result<Study, IdentifyError> {
        if tables.len() != session.runs.len() {
            return Err(IdentifyError::RunData {
                at: session.manifest.display().to_string(),
                message: format!(
                    "{} run tables for the manifest's {} runs: one per run, in its order",
                    tables.len(),
                    session.runs.len()
                ),
            });
        }
        let runs = RunSource::Tables(tables.into_iter());
        Self::assemble(session, machine, runs, Changes::default())?.with_configured_effects()
    }

    /// This study with the effects `[[identify.effect]]` configures, if any.
    fn with_configured_effects(self) -> Result<Study, IdentifyError> {
        let effects = self.configured_effects()?;
        if effects.is_empty() {
            return Ok(self);
        }
        self.rebuild(Changes {
            effects,
            ..Changes::default()
        })
    }

    /// The effects `[[identify.effect]]` puts in the model from the start (the baseline a
    /// physics search adds to: source 003's temperature polynomial, say). Their parameter
    /// values are starting values.
    fn configured_effects(&self) -> Result<Vec<Arc<dyn Effect>>, IdentifyError> {
        let Some(list) = &self.inputs.options.effect else {
            return Ok(Vec::new());
        };
        let bad = |m: String| identify_key(&self.session, "effect", &m);
        let mut effects: Vec<Arc<dyn Effect>> = Vec::new();
        for (k, table) in list.iter().enumerate() {
            let (e, _) = mtcal_effects::configure(table, self.view())
                .map_err(|m| bad(format!("effect {}: {m}", k + 1)))?;
            effects.push(crate::relabel::unique(&e, &effects));
        }
        Ok(effects)
    }

    /// The same session with `changes` (from the study as loaded, not from this one's
    /// changes): nothing is read or loaded again. The set-ups, runs and `[identify]` are
    /// shared; the model is built again only when the changes raise other orders, the reduced
    /// model only when they estimate other parameters.
    pub fn rebuild(&self, changes: Changes) -> Result<Study, IdentifyError> {
        let same_model =
            changes.estimate == self.changes.estimate && changes.raise == self.changes.raise;
        let model = if changes.raise == self.changes.raise {
            Some((Arc::clone(&self.model), self.base_coeffs.clone()))
        } else {
            None
        };
        let fit_model = same_model.then(|| Arc::clone(&self.fit_model));
        let mut study = Self::derive(
            Shared {
                session: Arc::clone(&self.session),
                machine: Arc::clone(&self.machine),
                setups: Arc::clone(&self.setups),
                runs: Arc::clone(&self.runs),
                inputs: Arc::clone(&self.inputs),
            },
            changes,
            model,
            fit_model,
        )?;
        // The same reduced model has the same axis Jacobians (a search refits many effects
        // on one model); the inputs and lag series depend on the runs alone.
        if same_model {
            study.axis_jacobians = Arc::clone(&self.axis_jacobians);
            study.location_jacobians = Arc::clone(&self.location_jacobians);
        }
        study.series = Arc::clone(&self.series);
        Ok(study)
    }

    /// The study as [`Study::load`] gave it (the configured effects, nothing a search
    /// changed), without reading anything again.
    pub fn as_loaded(&self) -> Result<Study, IdentifyError> {
        self.rebuild(Changes::default())?.with_configured_effects()
    }

    /// What this study changes from the session as written.
    pub fn changes(&self) -> &Changes {
        &self.changes
    }

    /// Reads `[identify]` and the start file, loads every set-up once and every run's samples
    /// from `source`, then derives the study of `changes`.
    fn assemble(
        session: Session,
        machine: LoadedMachine,
        mut source: RunSource,
        changes: Changes,
    ) -> Result<Study, IdentifyError> {
        let options = StudyOptions::read(&session)?;
        let held_prior = match options.held_prior {
            None => DEFAULT_HELD_PRIOR,
            Some(n) if n.value > 0.0 && n.value.is_finite() => n.value,
            Some(n) => {
                return Err(identify_key(
                    &session,
                    "held_prior",
                    &format!("expected a positive number (µm or µrad), found {n}"),
                ));
            }
        } * 1e-6;
        let start = match &options.start {
            None => None,
            Some(f) => {
                let path = session.dir.join(f);
                let text = std::fs::read_to_string(&path).map_err(|cause| {
                    IdentifyError::Params(params::ParamsError::Read {
                        path: path.clone(),
                        cause,
                    })
                })?;
                Some((path, text))
            }
        };
        // The runs' positions in SI need the machine's axes only (no raised order changes
        // them).
        let nominal = MachineModel::new(machine.machine.clone(), &machine.config).map_err(|e| {
            IdentifyError::Model {
                source_name: machine.config_source.clone(),
                message: e.to_string(),
            }
        })?;
        let mut setups: Vec<SetupSlot> = Vec::new();
        let mut by_name: BTreeMap<String, usize> = BTreeMap::new();
        let mut runs = Vec::with_capacity(session.runs.len());
        for spec in &session.runs {
            let setup_index = Self::setup_of(&session, &machine, spec, &mut setups, &mut by_name)?;
            let fit = spec.use_ == RunUse::Fit;
            let run = source.next_run(spec, &nominal, &*setups[setup_index].setup, fit)?;
            runs.push(RunSlot {
                name: spec.name.clone(),
                fit,
                setup: setup_index,
                file: run.file,
                t: run.t,
                q: run.q,
                readings: run.readings,
                context: run.context,
                labels: run.labels,
                position_blocks: run.position_blocks,
            });
        }
        if !runs.iter().any(|r| r.fit) {
            return Err(IdentifyError::NothingToFit {
                manifest: session.manifest.clone(),
            });
        }
        let shared = Shared {
            session: Arc::new(session),
            machine: Arc::new(machine),
            setups: Arc::new(setups),
            runs: Arc::new(runs),
            inputs: Arc::new(Inputs {
                options,
                start,
                held_prior,
            }),
        };
        Self::derive(shared, changes, None, None)
    }

    /// The index of `spec`'s set-up in `setups`, loading it the first time a run names it.
    fn setup_of(
        session: &Session,
        machine: &LoadedMachine,
        spec: &RunSpec,
        setups: &mut Vec<SetupSlot>,
        by_name: &mut BTreeMap<String, usize>,
    ) -> Result<usize, IdentifyError> {
        let plugin = mtcal_plugins::find(&spec.instrument).ok_or_else(|| {
            IdentifyError::UnknownInstrument {
                at: spec.location.to_string(),
                run: spec.name.clone(),
                name: spec.instrument.clone(),
                known: mtcal_plugins::plugins()
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            }
        })?;
        let setup_name = match &spec.setup {
            SetupRef::Shared(n) => n.clone(),
            SetupRef::Own(_) => spec.name.clone(),
        };
        if let Some(&i) = by_name.get(&setup_name) {
            if setups[i].plugin.name != plugin.name {
                return Err(IdentifyError::SetupShared {
                    at: spec.location.to_string(),
                    setup: setup_name,
                    first: setups[i].plugin.name.to_string(),
                    second: plugin.name.to_string(),
                });
            }
            return Ok(i);
        }
        let table = session.setup_of(spec).clone();
        let ctx = SetupContext {
            machine: &machine.machine,
        };
        // A set-up's error points at its key when the set-up is shared (its own table), else
        // at the run.
        let setup = (plugin.load_setup)(&table, &ctx).map_err(|e| IdentifyError::Setup {
            at: session
                .setup_location(&setup_name, &e.key)
                .unwrap_or(&spec.location)
                .to_string(),
            setup: setup_name.clone(),
            cause: e,
        })?;
        setups.push(SetupSlot {
            name: setup_name.clone(),
            plugin,
            setup,
            table,
        });
        by_name.insert(setup_name, setups.len() - 1);
        Ok(setups.len() - 1)
    }

    /// The study of `changes` on what is loaded: the model with the raised orders (`model`
    /// with its start values when they are the ones already built), the estimated
    /// coefficients, the reduced model (`fit_model` when it is the one already built), the
    /// free set-up parameters and the parameter layout.
    fn derive(
        shared: Shared,
        changes: Changes,
        model: Option<(Arc<MachineModel>, Vec<f64>)>,
        fit_model: Option<Arc<MachineModel>>,
    ) -> Result<Study, IdentifyError> {
        let Shared {
            session,
            machine,
            setups,
            runs,
            inputs,
        } = shared;
        let model_error =
            |machine: &LoadedMachine, e: &dyn std::fmt::Display| IdentifyError::Model {
                source_name: machine.config_source.clone(),
                message: e.to_string(),
            };
        // The study keeps the session's machine as loaded (a rebuild applies its raises again,
        // to that); its model has the raises.
        let mut config = machine.config.clone();
        for (name, extra) in &changes.raise {
            raise_order(&mut config, name, *extra).map_err(|m| model_error(&machine, &m))?;
        }
        let (model, base_coeffs) = match model {
            Some(built) => built,
            None => {
                let model = MachineModel::new(machine.machine.clone(), &config)
                    .map_err(|e| model_error(&machine, &e))?;
                let base = match &inputs.start {
                    None => vec![0.0; model.n_coeffs()],
                    Some((path, text)) => params::parse_params(text, path, model.errors())?,
                };
                (Arc::new(model), base)
            }
        };
        let coeff_labels = model.errors().coefficient_labels();
        let mut estimated =
            estimated_coefficients(&session, inputs.options.parameters.as_deref(), &model)?;
        for name in &changes.estimate {
            let p = model.errors().find(name).ok_or_else(|| {
                model_error(
                    &machine,
                    &format!("{name} is not in this machine's error model"),
                )
            })?;
            estimated.extend(p.offset..p.offset + p.len);
        }
        estimated.sort_unstable();
        estimated.dedup();
        let (fit_model, fit_coeffs) = match fit_model {
            Some(reduced) => (reduced, kept_coefficients(&model, &estimated, &base_coeffs)),
            None => {
                let (reduced, kept) =
                    reduced_model(&machine, &config, &model, &estimated, &base_coeffs)?;
                (Arc::new(reduced), kept)
            }
        };
        let free_nuisance: Vec<Vec<usize>> = setups
            .iter()
            .map(|slot| {
                slot.setup
                    .nuisance()
                    .iter()
                    .enumerate()
                    .filter(|(_, n)| {
                        n.free && !changes.hold.contains(&format!("{}.{}", slot.name, n.name))
                    })
                    .map(|(i, _)| i)
                    .collect()
            })
            .collect();
        let layout = ParamLayout::new(
            estimated,
            fit_coeffs,
            free_nuisance,
            &changes
                .effects
                .iter()
                .map(|e| e.params().len())
                .collect::<Vec<_>>(),
        );
        Ok(Study {
            held_prior: inputs.held_prior,
            session,
            machine,
            model,
            base_coeffs,
            fit_model,
            coeff_labels,
            setups,
            runs,
            inputs,
            layout,
            changes,
            view: OnceLock::new(),
            axis_jacobians: Arc::new(OnceLock::new()),
            locations: OnceLock::new(),
            location_jacobians: Arc::new(OnceLock::new()),
            series: Arc::default(),
        })
    }

    /// Where every parameter sits in the parameter vector `x`.
    pub fn layout(&self) -> &ParamLayout {
        &self.layout
    }

    /// The machine coefficient vector (SI) for parameter vector `x`.
    pub fn coeffs_from(&self, x: &[f64]) -> Vec<f64> {
        let mut c = self.base_coeffs.clone();
        for (i, &k) in self.layout.estimated().iter().enumerate() {
            c[k] = x[i];
        }
        c
    }

    /// The coefficient vector of [`Self::fit_model`] (SI) for parameter vector `x`.
    pub fn fit_coeffs_from(&self, x: &[f64]) -> Vec<f64> {
        let full = self.coeffs_from(x);
        self.layout.fit_coeffs().iter().map(|&k| full[k]).collect()
    }

    /// Set-up `s`'s full nuisance vector (SI; held ones at zero) for parameter vector `x`.
    pub fn nuisance_from(&self, s: usize, x: &[f64]) -> Vec<f64> {
        let mut n = vec![0.0; self.setups[s].setup.nuisance().len()];
        for (&i, j) in self.layout.free(s).iter().zip(self.layout.setup_range(s)) {
            n[i] = x[j];
        }
        n
    }

    /// The starting parameter vector.
    pub fn initial_x(&self) -> Vec<f64> {
        let mut x = vec![0.0; self.layout.n_x()];
        for (i, &k) in self.layout.estimated().iter().enumerate() {
            x[i] = self.base_coeffs[k];
        }
        let mut o = self.layout.effect_offset();
        for e in self.effects() {
            for p in e.params() {
                x[o] = p.initial;
                o += 1;
            }
        }
        x
    }

    /// The effects fitted along with the machine.
    pub fn effects(&self) -> &[Arc<dyn Effect>] {
        &self.changes.effects
    }

    /// The effects' parameters in `x`.
    pub fn effect_params<'x>(&self, x: &'x [f64]) -> &'x [f64] {
        &x[self.layout.effects()]
    }

    /// The effect parameter's definition, for parameter `i` of the parameter vector (`None` for
    /// machine and set-up parameters).
    pub fn effect_param(&self, i: usize) -> Option<&mtcal_effects::ParamDef> {
        self.effect_at(i).map(|(_, def)| def)
    }

    /// The effect parameter `i` of the parameter vector belongs to (`None` for machine and
    /// set-up parameters).
    pub fn effect_of_param(&self, i: usize) -> Option<&Arc<dyn Effect>> {
        self.effect_at(i).map(|(e, _)| e)
    }

    /// The effect and its parameter that parameter `i` of the vector is, if it is an
    /// effect's.
    fn effect_at(&self, i: usize) -> Option<(&Arc<dyn Effect>, &mtcal_effects::ParamDef)> {
        if !self.layout.effects().contains(&i) {
            return None;
        }
        match self.layout.slot(i) {
            ParamSlot::Effect { effect, param, .. } => {
                let e = &self.effects()[effect];
                Some((e, &e.params()[param]))
            }
            _ => None,
        }
    }

    /// Scratch for [`Self::axis_jacobian`].
    pub fn axis_jacobian_scratch(&self) -> AxisJacobianScratch {
        let model = &self.fit_model;
        AxisJacobianScratch {
            ws: model.workspace(),
            zeros: vec![0.0; model.n_coeffs()],
            q: vec![0.0; model.machine().n_axes()],
            full: None,
        }
    }

    /// The location errors (rotary axes' lines, linear axes' squareness) this study estimates,
    /// one coefficient each, with their coefficient in the full model: what an effect's
    /// [`mtcal_effects::Target::Location`] can act on, in slot order.
    pub fn locations(&self) -> &[(ParamName, usize)] {
        self.locations.get_or_init(|| {
            let estimated: std::collections::BTreeSet<usize> =
                self.layout.estimated().iter().copied().collect();
            self.model
                .errors()
                .params()
                .iter()
                .filter(|p| {
                    matches!(p.name, ParamName::Location { .. })
                        && p.len == 1
                        && estimated.contains(&p.offset)
                })
                .map(|p| (p.name, p.offset))
                .collect()
        })
    }

    /// `∂pose/∂L` of the nominal machine at sample `i` of run `r` into `out` (6 × the
    /// [`Self::locations`], column-major, as [`Self::axis_jacobian`]'s): how an effect that
    /// changes a location error moves the tool. Kept for every sample as the axis Jacobians
    /// are, computed on first use (only a search that proposes such a change needs them).
    pub fn location_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let width = 6 * self.locations().len();
        self.kept_per_sample(
            &self.location_jacobians,
            width,
            Self::nominal_location_jacobian,
        )
        .fill(r, i, scratch, out);
    }

    /// [`Self::location_jacobian`], computed: the full model's coefficient Jacobian at the
    /// nominal machine, the locations' columns.
    fn nominal_location_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let model = &self.model;
        let full = scratch.full.get_or_insert_with(|| FullScratch {
            ws: model.workspace(),
            zeros: vec![0.0; model.n_coeffs()],
            jac: vec![0.0; 6 * model.n_coeffs()],
        });
        self.runs[r].q.row_into(i, &mut scratch.q);
        model.tool_pose_jacobian(&scratch.q, &full.zeros, &mut full.ws, &mut full.jac);
        for (col, &(_, k)) in out.chunks_exact_mut(6).zip(self.locations()) {
            col.copy_from_slice(&full.jac[6 * k..6 * k + 6]);
        }
    }

    /// `∂pose/∂q` of the nominal machine at sample `i` of run `r` into `out` (6 × axis slots,
    /// column-major: the axes, then the tool side shifting along and turning about the
    /// machine's X, Y and Z, [`mtcal_effects::axis_slots`]): how an effect that displaces an axis moves the tool. The commanded
    /// positions are fixed: a small session keeps every sample's, a large one computes it at
    /// every call ([`AXIS_JACOBIAN_CACHE_BYTES`]; the same numbers either way).
    pub fn axis_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        let width = 6 * mtcal_effects::axis_slots(self.fit_model.machine().n_axes());
        self.kept_per_sample(&self.axis_jacobians, width, Self::nominal_axis_jacobian)
            .fill(r, i, scratch, out);
    }

    /// Every sample's `width` values from `compute`, per run, kept in `cell` on first use if
    /// they fit [`AXIS_JACOBIAN_CACHE_BYTES`] (otherwise each is computed when asked).
    fn kept_per_sample<'s>(
        &'s self,
        cell: &'s OnceLock<Option<Vec<Vec<f64>>>>,
        width: usize,
        compute: PerSample,
    ) -> KeptPerSample<'s> {
        let kept = cell.get_or_init(|| {
            let samples: usize = self.runs.iter().map(RunSlot::len).sum();
            if width == 0
                || samples * width * std::mem::size_of::<f64>() > AXIS_JACOBIAN_CACHE_BYTES
            {
                return None;
            }
            let mut scratch = self.axis_jacobian_scratch();
            let all = (0..self.runs.len())
                .map(|r| {
                    let mut out = vec![0.0; self.runs[r].len() * width];
                    for (i, values) in out.chunks_exact_mut(width).enumerate() {
                        compute(self, r, i, &mut scratch, values);
                    }
                    out
                })
                .collect();
            Some(all)
        });
        KeptPerSample {
            study: self,
            kept: kept.as_ref(),
            compute,
        }
    }

    /// [`Self::axis_jacobian`], computed.
    fn nominal_axis_jacobian(
        &self,
        r: usize,
        i: usize,
        scratch: &mut AxisJacobianScratch,
        out: &mut [f64],
    ) {
        self.runs[r].q.row_into(i, &mut scratch.q);
        let (axes, turns) = out.split_at_mut(6 * scratch.q.len());
        self.fit_model
            .tool_jacobian(&scratch.q, &scratch.zeros, &mut scratch.ws, axes);
        self.fit_model.tool_motion_columns(&scratch.ws, turns);
    }

    /// The session as the effects see it (built once).
    pub fn view(&self) -> &Arc<SessionView> {
        self.view.get_or_init(|| Arc::new(self.build_view()))
    }

    /// Per run, the fitted run it continues, if any: one recording cut into files (the
    /// cycles of a thermal test at one position written one file each) is one recording —
    /// the same set-up, no axis moving in either, and the run starting within
    /// [`CONTINUES_INTERVALS`] sample intervals of where the other ended. The noise filter
    /// runs on across such a boundary and the search divides the recording into blocks of
    /// its own, so a user's choice of file boundaries decides nothing.
    pub fn continues(&self) -> Vec<Option<usize>> {
        let view = self.view();
        let gap = CONTINUES_INTERVALS * view.median_interval();
        let held = |r: usize| (0..view.axes.len()).all(|a| !view.motion(r, a).moves);
        let mut out = vec![None; self.runs.len()];
        let mut previous: Option<usize> = None;
        for &r in view.runs_in_time_order() {
            if !self.runs[r].fit || self.runs[r].is_empty() {
                continue;
            }
            if let Some(p) = previous
                && view.runs[p].setup == view.runs[r].setup
                && held(p)
                && held(r)
                && let (Some(end), Some(start)) =
                    (view.runs[p].last_time(), view.runs[r].first_time())
                && start > end
                && start - end <= gap
            {
                out[r] = Some(p);
            }
            previous = Some(r);
        }
        out
    }

    /// Drops the series the view keeps over the whole timeline ([`SessionView::clear_caches`]),
    /// if it was built: a study kept for later need not hold them meanwhile.
    pub fn clear_view_caches(&self) {
        if let Some(view) = self.view.get() {
            view.clear_caches();
        }
    }

    /// `f` on run `r` as its instrument's own evaluations see it (whole vectors, expanded for
    /// this run only); `None` for a run without readings.
    pub fn with_evaluation<T>(
        &self,
        r: usize,
        f: impl FnOnce(&mtcal_instrument::Evaluation<'_>) -> T,
    ) -> Option<T> {
        let run = &self.runs[r];
        let readings = run.readings.as_ref()?;
        Some(f(&mtcal_instrument::Evaluation {
            machine: self.model.machine(),
            setup: &self.setups[run.setup].table,
            q: &run.q.to_row_major(),
            readings: &readings.to_row_major(),
            t: &run.t.to_vec(),
            labels: &run.labels,
        }))
    }

    fn build_view(&self) -> SessionView {
        let (lo, hi) = self.tool_travel_m();
        let machine = self.model.machine();
        let axes = AxisView::of_machine(machine);
        let field_like = self.field_like_nuisance();
        let setups = self
            .setups
            .iter()
            .zip(field_like)
            .map(|(s, field_like)| SetupView {
                field_like,
                ..SetupView::of(&s.name, s.plugin.name, s.setup.as_ref())
            })
            .collect();
        // The study's columns, shared (not copied): the positions convert to SI as they are
        // read, bit for bit what the fit reads.
        let runs = self
            .runs
            .iter()
            .map(|r| RunView {
                name: r.name.clone(),
                setup: r.setup,
                fit: r.fit,
                t: r.t.clone(),
                q: r.q.clone(),
                context: r.context.clone(),
            })
            .collect();
        let mut is_estimated = vec![false; self.model.n_coeffs()];
        for &k in self.layout.estimated() {
            is_estimated[k] = true;
        }
        let model = self
            .model
            .errors()
            .params()
            .iter()
            .map(|p| ModelParamView {
                name: p.name,
                estimated: (p.offset..p.offset + p.len).any(|k| is_estimated[k]),
                held: (p.offset..p.offset + p.len)
                    .any(|k| self.changes.hold.contains(&self.coeff_labels[k])),
                order: match &p.role {
                    mtcal_kinematics::model::Role::Component { basis, .. } => match basis {
                        Basis::Legendre { max_degree, .. } => BasisOrder::Legendre(*max_degree),
                        Basis::Fourier { max_harmonic, .. } => BasisOrder::Fourier(*max_harmonic),
                        _ => BasisOrder::Other,
                    },
                    _ => BasisOrder::Other,
                },
            })
            .collect();
        SessionView::new(axes, setups, runs, model)
            .with_locations(self.locations().iter().map(|&(n, _)| n).collect())
            .with_series_cache(Arc::clone(&self.series))
            .with_current(self.effects().iter().map(|e| e.info().clone()).collect())
            .with_tool_travel(lo, hi)
    }

    /// Per set-up and nuisance parameter: whether, at every fitted sample of the set-up, the
    /// parameter moves the readings as one fixed shift of the tool in the machine frame does —
    /// the least-squares fit of its derivative columns by the three machine-frame shift columns
    /// ([`mtcal_kinematics::MachineModel::tool_motion_columns`]) leaves nothing. A ball visited
    /// at one place, or whose height only a table turning about Z carries elsewhere: its drift
    /// there and the machine's own field move the readings alike
    /// ([`mtcal_effects::SetupView::field_like`]). A set-up without analytic derivatives says
    /// no for every parameter.
    fn field_like_nuisance(&self) -> Vec<Vec<bool>> {
        let x = self.initial_x();
        let coeffs = self.fit_coeffs_from(&x);
        let model = &self.fit_model;
        let na = model.machine().n_axes();
        let mut ws = model.workspace();
        let mut scratch = self.axis_jacobian_scratch();
        let mut jac = vec![0.0; 6 * mtcal_effects::axis_slots(na)];
        let mut q = vec![0.0; na];
        (0..self.setups.len())
            .map(|s| {
                let setup = self.setups[s].setup.as_ref();
                let (nn, nch) = (setup.nuisance().len(), setup.channels().len());
                let nuis = self.nuisance_from(s, &x);
                let (mut d_pose, mut d_nuis) = (vec![0.0; 6 * nch], vec![0.0; nch * nn]);
                let runs: Vec<usize> = (0..self.runs.len())
                    .filter(|&r| self.runs[r].setup == s && self.runs[r].fit)
                    .collect();
                let total: usize = runs.iter().map(|&r| self.runs[r].len()).sum();
                if nn == 0 || total == 0 {
                    return vec![false; nn];
                }
                // Normal equations of each parameter's column on the three shift columns.
                let mut ata = nalgebra::Matrix3::<f64>::zeros();
                let mut atb = vec![nalgebra::Vector3::<f64>::zeros(); nn];
                let mut btb = vec![0.0; nn];
                let stride = total.div_ceil(FIELD_LIKE_SAMPLES).max(1);
                let mut k = 0usize;
                for &r in &runs {
                    let run = &self.runs[r];
                    for i in 0..run.len() {
                        k += 1;
                        if k % stride != 0 {
                            continue;
                        }
                        run.q.row_into(i, &mut q);
                        let pose = model.tool_pose(&q, &coeffs, &mut ws);
                        let at = At {
                            q: &q,
                            t: run.t.get(i),
                            w_t_t: &pose,
                            label: run.label(i),
                        };
                        if !setup.derivatives(&at, &nuis, &mut d_pose, &mut d_nuis) {
                            return vec![false; nn];
                        }
                        self.axis_jacobian(r, i, &mut scratch, &mut jac);
                        let shifts = &jac[6 * na..6 * na + 18];
                        for (c, dp) in d_pose.chunks_exact(6).enumerate() {
                            let a = nalgebra::Vector3::from_fn(|m, _| {
                                (0..6).map(|p| dp[p] * shifts[6 * m + p]).sum::<f64>()
                            });
                            ata += a * a.transpose();
                            for j in 0..nn {
                                let b = d_nuis[c * nn + j];
                                atb[j] += a * b;
                                btb[j] += b * b;
                            }
                        }
                    }
                }
                let pinv = ata
                    .pseudo_inverse(1e-12 * ata.norm().max(f64::MIN_POSITIVE))
                    .unwrap_or_else(|_| nalgebra::Matrix3::zeros());
                (0..nn)
                    .map(|j| btb[j] - atb[j].dot(&(pinv * atb[j])) <= 1e-8 * btb[j])
                    .collect()
            })
            .collect()
    }

    /// The least and greatest coordinates of the nominal tool point in the machine frame over
    /// the fitted samples (m).
    fn tool_travel_m(&self) -> ([f64; 3], [f64; 3]) {
        let model = &self.model;
        let zeros = vec![0.0; model.n_coeffs()];
        let mut ws = model.workspace();
        let mut q = vec![0.0; model.machine().n_axes()];
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for run in self.runs.iter().filter(|r| r.fit) {
            for i in 0..run.len() {
                run.q.row_into(i, &mut q);
                model.tool_pose(&q, &zeros, &mut ws);
                let p = model.machine_tool_point(&ws);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        (lo, hi)
    }

    /// Name, unit and prior σ (SI) of parameter `i` of the parameter vector.
    pub fn param_info(&self, i: usize) -> ParamInfo {
        match self.layout.slot(i) {
            ParamSlot::Machine { coeff } => {
                let label = &self.coeff_labels[coeff];
                let base = label.split('.').next().unwrap_or(label);
                let unit = base
                    .parse::<ParamName>()
                    .map(|n| n.unit())
                    .unwrap_or("um")
                    .to_string();
                ParamInfo {
                    name: label.clone(),
                    unit,
                    per_si: 1e6,
                    prior_sigma: None,
                    machine: true,
                }
            }
            ParamSlot::Effect { .. } => {
                let (effect, def) = self.effect_at(i).expect("an effect's parameter");
                ParamInfo {
                    name: format!("{}.{}", effect.info().label, def.name),
                    unit: def.unit.clone(),
                    per_si: def.per_si,
                    prior_sigma: None,
                    machine: false,
                }
            }
            ParamSlot::Nuisance { setup, nuisance } => {
                let slot = &self.setups[setup];
                let nuis = &slot.setup.nuisance()[nuisance];
                ParamInfo {
                    name: format!("{}.{}", slot.name, nuis.name),
                    unit: nuis.unit.as_str().to_string(),
                    per_si: nuis.unit.per_si(),
                    prior_sigma: nuis.prior_sigma,
                    machine: false,
                }
            }
        }
    }

    /// The group parameter `i` belongs to, as the report names it: `machine`, `effect`, or the
    /// name of its set-up.
    pub fn param_group(&self, i: usize) -> String {
        match self.layout.slot(i) {
            ParamSlot::Machine { .. } => "machine".to_string(),
            ParamSlot::Effect { .. } => "effect".to_string(),
            ParamSlot::Nuisance { setup, .. } => self.setups[setup].name.clone(),
        }
    }

    /// The channels of run `r`.
    pub fn channels(&self, r: usize) -> &[Channel] {
        self.setups[self.runs[r].setup].setup.channels()
    }

    /// The noise of channel `c` of run `r` the fit assumes: the stated σ and white, unless
    /// [`Changes::noise`] says otherwise.
    pub fn noise(&self, r: usize, c: usize) -> crate::whiten::ChannelNoise {
        self.changes
            .noise
            .as_ref()
            .map_or(crate::whiten::ChannelNoise::STATED, |n| {
                n.of(self.runs[r].setup, c)
            })
    }

    /// σ of channel `c` of run `r` (SI): the stated one times the noise model's scale.
    pub fn sigma(&self, r: usize, c: usize) -> f64 {
        self.channels(r)[c].sigma * self.noise(r, c).scale
    }
}

/// What a parameter of the parameter vector is.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamInfo {
    pub name: String,
    /// The unit it is reported in (`um`, `urad`, `ppm`, an effect's `s`, `um/K`…).
    pub unit: String,
    /// Factor from SI to `unit`.
    pub per_si: f64,
    pub prior_sigma: Option<f64>,
    /// A machine error coefficient (not a set-up nuisance parameter).
    pub machine: bool,
}

fn load_session_machine(session: &Session) -> Result<LoadedMachine, IdentifyError> {
    let arg: PathBuf = match &session.machine_path {
        Some(p) => p.clone(),
        None => PathBuf::from(&session.machine),
    };
    load_machine(&arg.to_string_lossy(), Reading::default()).map_err(|e| IdentifyError::Machine {
        at: session.machine_at.to_string(),
        message: e.to_string(),
    })
}

/// Raises the order of component error `name` in `config` by `extra` (Legendre degree or
/// Fourier harmonics).
pub(crate) fn raise_order(
    config: &mut [mtcal_kinematics::ParamConfig],
    name: &ParamName,
    extra: usize,
) -> Result<(), String> {
    let entry = config
        .iter_mut()
        .find(|c| &c.name == name)
        .ok_or_else(|| format!("{name} is not in the error model: its order cannot be raised"))?;
    entry.basis = match entry.basis.take() {
        Some(Basis::Legendre {
            lo,
            hi,
            min_degree,
            max_degree,
        }) => Some(
            Basis::legendre(lo, hi, min_degree, max_degree + extra).map_err(|e| e.to_string())?,
        ),
        Some(Basis::Fourier {
            min_harmonic,
            max_harmonic,
        }) => Some(Basis::fourier(min_harmonic, max_harmonic + extra).map_err(|e| e.to_string())?),
        other => {
            entry.basis = other;
            return Err(format!(
                "{name}: only Legendre and Fourier bases have an order to raise"
            ));
        }
    };
    Ok(())
}

/// The model restricted to the parameters that are estimated or have a nonzero base value, and
/// per coefficient of it the index in the full model. The kept parameters keep their bases, so
/// the restricted model gives the same poses for the same values.
fn reduced_model(
    machine: &LoadedMachine,
    config: &[mtcal_kinematics::ParamConfig],
    model: &MachineModel,
    estimated: &[usize],
    base: &[f64],
) -> Result<(MachineModel, Vec<usize>), IdentifyError> {
    let kept_params = kept_params(model, estimated, base);
    // `ErrorModel::new` lays the parameters out in configuration order.
    let kept: Vec<_> = config
        .iter()
        .zip(&kept_params)
        .filter(|(_, k)| **k)
        .map(|(entry, _)| entry.clone())
        .collect();
    let index = kept_coefficients(model, estimated, base);
    let reduced =
        MachineModel::new(machine.machine.clone(), &kept).map_err(|e| IdentifyError::Model {
            source_name: machine.config_source.clone(),
            message: e.to_string(),
        })?;
    debug_assert_eq!(reduced.n_coeffs(), index.len());
    Ok((reduced, index))
}

/// Per parameter of `model`, whether the reduced model keeps it: estimated, or with a
/// nonzero base value.
fn kept_params(model: &MachineModel, estimated: &[usize], base: &[f64]) -> Vec<bool> {
    let mut used = vec![false; model.n_coeffs()];
    for &k in estimated {
        used[k] = true;
    }
    model
        .errors()
        .params()
        .iter()
        .map(|p| (p.offset..p.offset + p.len).any(|k| used[k] || base[k] != 0.0))
        .collect()
}

/// The coefficients of `model` the reduced model keeps, in order ([`kept_params`]).
fn kept_coefficients(model: &MachineModel, estimated: &[usize], base: &[f64]) -> Vec<usize> {
    let kept = kept_params(model, estimated, base);
    model
        .errors()
        .params()
        .iter()
        .zip(kept)
        .filter(|(_, k)| *k)
        .flat_map(|(p, _)| p.offset..p.offset + p.len)
        .collect()
}

/// `[identify] parameters = ["EC0Y", …]`: the machine parameters to estimate (all of a
/// component error's coefficients); default: every parameter of the error model.
fn estimated_coefficients(
    session: &Session,
    names: Option<&[String]>,
    model: &MachineModel,
) -> Result<Vec<usize>, IdentifyError> {
    let Some(names) = names else {
        return Ok((0..model.n_coeffs()).collect());
    };
    let bad = |m: String| identify_key(session, "parameters", &m);
    let mut out = Vec::new();
    for s in names {
        let name: ParamName = s
            .parse()
            .map_err(|e| bad(format!("`{s}` is not an ISO 230-1 parameter name: {e}")))?;
        let p = model.errors().find(&name).ok_or_else(|| {
            bad(format!(
                "`{s}` is not in this machine's error model ({} parameters; see its .errors.toml)",
                model.errors().params().len()
            ))
        })?;
        out.extend(p.offset..p.offset + p.len);
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// Run `spec`'s file, read with the columns its set-up and the machine give.
fn read_run_file(
    spec: &RunSpec,
    model: &MachineModel,
    setup: &dyn Setup,
    fit: bool,
) -> Result<RunTable, IdentifyError> {
    let channels: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
    let letters: Vec<char> = model
        .machine()
        .axes()
        .iter()
        .map(|a| a.letter().as_char())
        .collect();
    let columns = RunColumns {
        axes: &letters,
        readings: &channels,
        readings_optional: !fit,
        labels: setup.label_columns(),
    };
    Ok(read_run(&spec.file, &columns)?)
}

/// A run file's table → the run as the study keeps it (checked first): times, positions,
/// readings and context in compact columns ([`mtcal_session::Column`]: bit for bit the values
/// read) that convert positions to SI as they are read, readings prepared by the set-up, labels
/// resolved to numbers (a fitted run's label texts dropped), the positions' summary for the
/// mismatch analysis.
fn load_run(
    model: &MachineModel,
    setup: &dyn Setup,
    mut table: RunTable,
    fit: bool,
) -> Result<LoadedRun, IdentifyError> {
    crate::checks::check_run(model, setup, &table)?;
    let labels = run_labels(setup, &table)?;
    let position_blocks = crate::blocks::PositionBlocks::of(&table);
    let scales: Vec<Scale> = model
        .machine()
        .axes()
        .iter()
        .map(|a| match a.kind() {
            // What `v * 1e-3` and `v.to_radians()` compute.
            AxisKind::Linear => Scale::Mul(1e-3),
            AxisKind::Rotary => Scale::Mul(std::f64::consts::PI / 180.0),
        })
        .collect();
    let q = Columns::from_row_major(&table.positions, &scales);
    let t = Column::new(&table.t);
    let context: Vec<(String, Column)> = table
        .context
        .iter()
        .map(|(n, v)| (n.clone(), Column::new(v)))
        .collect();
    let readings = match table.values.take() {
        Some(raw) => {
            let q_si = positions_si(model, std::mem::take(&mut table.positions));
            Some(prepared_readings(setup, &table, &q_si, raw)?)
        }
        None => None,
    };
    if fit {
        for (_, column) in &mut table.labels {
            *column = Vec::new();
        }
    }
    let file = RunFile {
        path: table.path,
        columns: table.columns,
        axes: table.axes,
        readings: table.readings,
        labels: table.labels,
    };
    Ok(LoadedRun {
        file,
        t,
        q,
        readings,
        context,
        labels,
        position_blocks,
    })
}

/// Commanded positions in SI, converted in place: mm → m on linear axes, degrees → rad on
/// rotary ones.
fn positions_si(model: &MachineModel, mut positions: Vec<f64>) -> Vec<f64> {
    let kinds: Vec<AxisKind> = model.machine().axes().iter().map(|a| a.kind()).collect();
    for row in positions.chunks_exact_mut(kinds.len()) {
        for (v, k) in row.iter_mut().zip(&kinds) {
            *v = k.from_file(*v);
        }
    }
    positions
}

/// Every sample's label number, or an error naming the cell that does not resolve.
fn run_labels(setup: &dyn Setup, table: &RunTable) -> Result<Vec<u32>, IdentifyError> {
    if setup.label_columns().is_empty() {
        return Ok(Vec::new());
    }
    (0..table.len())
        .map(|i| {
            setup.resolve_label(&table.label_row(i)).map_err(|e| {
                let first = &table.labels[0].0;
                IdentifyError::RunData {
                    at: cell(table, i, first),
                    message: format!("column \"{first}\": {e}"),
                }
            })
        })
        .collect()
}

/// The run's readings in SI, prepared by the set-up (environmental compensation), or an error
/// naming the cell at fault. A channel the set-up leaves as it is (the file's value divided by
/// its unit) is kept as the file's numbers with that division; one it changes, as computed.
fn prepared_readings(
    setup: &dyn Setup,
    table: &RunTable,
    q: &[f64],
    raw: Vec<f64>,
) -> Result<Columns, IdentifyError> {
    let ch = setup.channels();
    let scales: Vec<Scale> = ch.iter().map(|c| Scale::Div(c.unit.per_si())).collect();
    // The file's numbers, read as `value / unit` (µm → m); the vector is then reused for the
    // set-up's preparation, which starts from exactly these values.
    let as_read = Columns::from_row_major(&raw, &scales);
    let mut readings = raw;
    for (i, row) in readings.chunks_exact_mut(ch.len()).enumerate() {
        as_read.row_into(i, row);
    }
    let data = mtcal_instrument::RunData {
        q,
        t: &table.t,
        context: &table.context,
    };
    setup
        .prepare_readings(&data, &mut readings)
        .map_err(|e| IdentifyError::RunData {
            at: match e.row {
                Some(i) => cell(table, i, &e.column),
                None => table.path.display().to_string(),
            },
            message: e.to_string(),
        })?;
    if let Some(k) = readings.iter().position(|x| !x.is_finite()) {
        let c = &ch[k % ch.len()].name;
        return Err(IdentifyError::RunData {
            at: cell(table, k / ch.len(), c),
            message: format!("column \"{c}\": the prepared reading is not a finite number"),
        });
    }
    let nch = ch.len();
    let mut column = Vec::new();
    let columns = (0..nch)
        .map(|c| {
            let prepared = readings.iter().skip(c).step_by(nch);
            let as_read_c = as_read.column(c);
            if prepared
                .clone()
                .enumerate()
                .all(|(i, p)| as_read_c.get(i).to_bits() == p.to_bits())
            {
                as_read_c.clone()
            } else {
                column.clear();
                column.extend(prepared);
                Column::new(&column)
            }
        })
        .collect();
    Ok(Columns::from_columns(columns))
}
