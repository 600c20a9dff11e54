//! A loaded session ready to identify: the machine model, which coefficients are estimated,
//! every distinct set-up with its nuisance parameters, and every run's samples in SI units.

use crate::IdentifyError;
use crate::checks::cell;
use crate::ids::{CoeffId, EffectId, ParamId, SetupId};
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
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

mod jacobians;
mod model;
mod runs;
mod view;

pub use jacobians::{AXIS_JACOBIAN_CACHE_BYTES, AxisJacobianScratch};
pub(crate) use model::raise_order;
use model::*;
use runs::*;
pub use runs::{ExpandedRun, RunFile, RunSlot};

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
    /// A label per machine coefficient (`EX0C`, `EXX.P2`), for people.
    pub coeff_labels: Vec<String>,
    /// What each machine coefficient is ([`Study::param_id`]).
    coeff_ids: Vec<CoeffId>,
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

/// How a rebuilt study differs from the session as written: what the physics search adds.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Parameters of the error model to estimate besides `[identify] parameters`.
    pub estimate: Vec<ParamName>,
    /// Component errors whose basis gets more orders (Legendre degree or Fourier harmonics).
    pub raise: Vec<(ParamName, usize)>,
    /// Effects fitted along with the machine (their parameters come last in `x`).
    pub effects: Vec<Arc<dyn Effect>>,
    /// Parameters the runs cannot determine ([`crate::base`]; `EXX.P3`, `bar.tool_length`): a
    /// set-up parameter is held at its start value; a machine
    /// coefficient stays in the fit with a prior of [`Study::held_prior`] about its start,
    /// so that it neither takes arbitrary values nor leaves its effect to the others (which
    /// would bias every prediction that sees it differently), and predictions carry its
    /// uncertainty.
    pub hold: Vec<ParamId>,
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
        let coeff_ids = model
            .errors()
            .coefficient_terms()
            .into_iter()
            .map(|(param, term)| CoeffId { param, term })
            .collect();
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
            .enumerate()
            .map(|(s, slot)| {
                slot.setup
                    .nuisance()
                    .iter()
                    .enumerate()
                    .filter(|&(nuisance, n)| {
                        let id = ParamId::Nuisance {
                            setup: SetupId(s),
                            nuisance,
                        };
                        n.free && !changes.hold.contains(&id)
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
            coeff_ids,
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

    /// What parameter `i` of the parameter vector is: the same id in every study rebuilt from
    /// this session, wherever the parameter sits.
    pub fn param_id(&self, i: usize) -> ParamId {
        match self.layout.slot(i) {
            ParamSlot::Machine { coeff } => ParamId::Machine(self.coeff_ids[coeff]),
            ParamSlot::Nuisance { setup, nuisance } => ParamId::Nuisance {
                setup: SetupId(setup),
                nuisance,
            },
            ParamSlot::Effect { effect, param, .. } => ParamId::Effect {
                effect: EffectId(Arc::from(self.effects()[effect].info().label.as_str())),
                param,
            },
        }
    }

    /// Whether machine coefficient `coeff` (of the full model) is held ([`Changes::hold`]).
    pub fn is_held(&self, coeff: usize) -> bool {
        let id = ParamId::Machine(self.coeff_ids[coeff]);
        self.changes.hold.contains(&id)
    }

    /// Every parameter's place in the parameter vector, by id.
    pub fn param_indices(&self) -> HashMap<ParamId, usize> {
        (0..self.layout.n_x())
            .map(|i| (self.param_id(i), i))
            .collect()
    }

    /// Name, unit and prior σ (SI) of parameter `i` of the parameter vector.
    pub fn param_info(&self, i: usize) -> ParamInfo {
        match self.layout.slot(i) {
            ParamSlot::Machine { coeff } => ParamInfo {
                name: self.coeff_labels[coeff].clone(),
                unit: self.coeff_ids[coeff].param.unit().to_string(),
                per_si: 1e6,
                prior_sigma: None,
                machine: true,
            },
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
