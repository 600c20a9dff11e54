//! The plan's `[[effect]]` tables, prepared on the whole planned session (a thermal state runs
//! over every run in time order).

use crate::SimulateError;
use crate::plan::Plan;
use crate::runs::{PlannedRun, PlannedSetup};
use mtcal_effects::{
    AxisView, Effect, ParamKind, PreparedEffects, RunView, SampleEffects, SessionView, SetupView,
};
use mtcal_instrument::At;
use mtcal_kinematics::{MachineModel, Workspace};
use mtcal_session::RunUse;
use std::sync::Arc;

/// The planted effects and their parameter values.
pub(crate) type Planted = (PreparedEffects, Vec<f64>);

/// The plan's `[[effect]]` tables prepared on the planned session (`None` without any).
pub(crate) fn planted_effects(
    plan: &Plan,
    model: &MachineModel,
    truth: &[f64],
    setups: &[PlannedSetup],
    runs: &[PlannedRun],
) -> Result<Option<Planted>, SimulateError> {
    let Some(list) = plan.effects() else {
        return Ok(None);
    };
    let view = Arc::new(session_view(model, setups, runs));
    let mut effects: Vec<Arc<dyn Effect>> = Vec::new();
    let mut values = Vec::new();
    for (k, table) in list.iter().enumerate() {
        let (effect, v) = planted_effect(table.clone(), &view, model, truth, setups, runs)
            .map_err(|m| plan.error(format!("[[effect]] {}: {m}", k + 1)))?;
        effects.push(effect);
        values.extend(v);
    }
    Ok(Some((
        PreparedEffects::new(&effects, &view, &values),
        values,
    )))
}

/// One `[[effect]]` table's effect and parameter values, or what is wrong with it.
fn planted_effect(
    mut table: toml::Table,
    view: &Arc<SessionView>,
    model: &MachineModel,
    truth: &[f64],
    setups: &[PlannedSetup],
    runs: &[PlannedRun],
) -> Result<(Arc<dyn Effect>, Vec<f64>), mtcal_effects::PlantError> {
    let below = below_noise(&mut table)?;
    let (effect, mut v) = mtcal_effects::plant(&table, view)?;
    if let Some(fraction) = below {
        let single = PreparedEffects::new(std::slice::from_ref(&effect), view, &v);
        let largest = largest_change(model, truth, &single, &v, setups, runs);
        if largest.is_nan() || largest <= 0.0 {
            return Err("`below_noise`: the effect changes no reading of this plan".into());
        }
        for (x, p) in v.iter_mut().zip(effect.params()) {
            if p.kind == ParamKind::Amplitude {
                *x *= fraction / largest;
            }
        }
    }
    Ok((effect, v))
}

/// `below_noise = f` (taken out of `table`): the amplitudes are scaled so that the effect's
/// largest change of any reading is f times that reading's noise.
fn below_noise(table: &mut toml::Table) -> Result<Option<f64>, String> {
    let Some(v) = table.remove("below_noise") else {
        return Ok(None);
    };
    v.as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .filter(|f| f.is_finite() && *f > 0.0)
        .map(Some)
        .ok_or_else(|| format!("`below_noise` must be a positive number, found {v}"))
}

/// The planned session as the effect families see it.
fn session_view(model: &MachineModel, setups: &[PlannedSetup], runs: &[PlannedRun]) -> SessionView {
    let machine = model.machine();
    let axes = AxisView::of_machine(machine);
    let setups = setups
        .iter()
        .map(|s| SetupView::of(&s.name, &s.instrument, s.setup.as_ref()))
        .collect();
    let runs = runs
        .iter()
        .map(|r| {
            let q: Vec<f64> = r.poses.iter().flat_map(|q| q.iter().copied()).collect();
            RunView::from_vectors(
                r.name.clone(),
                r.setup,
                r.use_ == RunUse::Fit,
                &r.t,
                &q,
                &r.context,
            )
        })
        .collect();
    SessionView::new(axes, setups, runs, Vec::new())
}

/// Scratch for the effects of one sample of any of `setups`.
pub(crate) fn effect_scratch(
    effects: &PreparedEffects,
    model: &MachineModel,
    setups: &[PlannedSetup],
) -> SampleEffects {
    let max_nuis = setups.iter().map(|d| d.nuis.len()).max().unwrap_or(0);
    let max_ch = setups
        .iter()
        .map(|d| d.setup.channels().len())
        .max()
        .unwrap_or(0);
    effects.scratch(model.machine().n_axes(), max_nuis, max_ch)
}

/// The largest change an effect makes to any reading of the plan, in units of that reading's
/// noise (its channel's σ where the run is noise-free).
fn largest_change(
    model: &MachineModel,
    truth: &[f64],
    effect: &PreparedEffects,
    values: &[f64],
    setups: &[PlannedSetup],
    runs: &[PlannedRun],
) -> f64 {
    let mut out = effect_scratch(effect, model, setups);
    let mut ws = model.workspace();
    let mut largest: f64 = 0.0;
    for (r, run) in runs.iter().enumerate() {
        let mut change = ReadingChange::new(model, &setups[run.setup]);
        for i in 0..run.poses.len() {
            effect.sample(r, run.setup, i, values, &mut out);
            let sample = change.of_sample(model, truth, &out, run, i, &mut ws);
            largest = largest.max(sample);
        }
    }
    largest
}

/// Buffers for the readings of one set-up with and without an effect.
struct ReadingChange<'a> {
    setup: &'a PlannedSetup,
    plain: Vec<f64>,
    with: Vec<f64>,
    q: Vec<f64>,
    nuis: Vec<f64>,
}

impl<'a> ReadingChange<'a> {
    fn new(model: &MachineModel, setup: &'a PlannedSetup) -> Self {
        let n = setup.setup.channels().len();
        ReadingChange {
            setup,
            plain: vec![0.0; n],
            with: vec![0.0; n],
            q: vec![0.0; model.machine().n_axes()],
            nuis: setup.nuis.clone(),
        }
    }

    /// The largest change `effects` (one sample's) make to the readings of sample `i` of
    /// `run`, in units of the readings' noise.
    fn of_sample(
        &mut self,
        model: &MachineModel,
        truth: &[f64],
        effects: &SampleEffects,
        run: &PlannedRun,
        i: usize,
        ws: &mut Workspace,
    ) -> f64 {
        let PlannedSetup { setup, nuis, .. } = self.setup;
        let (q, t) = (&run.poses[i], run.t[i]);
        for ((s, &a), d) in self.q.iter_mut().zip(q).zip(&effects.dq) {
            *s = a + d;
        }
        for ((s, &a), d) in self.nuis.iter_mut().zip(nuis).zip(&effects.dn) {
            *s = a + d;
        }
        let at = |pose| At {
            q,
            t,
            w_t_t: pose,
            label: 0,
        };
        let pose = model.tool_pose(q, truth, ws);
        setup.predict(&at(&pose), nuis, &mut self.plain);
        let pose = model.tool_pose(&self.q, truth, ws);
        setup.predict(&at(&pose), &self.nuis, &mut self.with);
        let mut largest: f64 = 0.0;
        for (c, ch) in setup.channels().iter().enumerate() {
            let changed = self.with[c] * (1.0 + effects.gain[c]) + effects.dr[c];
            let sigma = if run.noise[c] > 0.0 {
                run.noise[c]
            } else {
                ch.sigma
            };
            largest = largest.max((changed - self.plain[c]).abs() / sigma);
        }
        largest
    }
}
