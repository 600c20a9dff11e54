//! The readings: every planned run measured on the true machine (planted effects and plants
//! included, noise added), then written down as the instrument and the controller write them.

use crate::SimulateError;
use crate::effects::{Planted, effect_scratch};
use crate::plan::{Plan, Settings};
use crate::plant::{Plant, PlantSample};
use crate::record::Record;
use crate::runs::{PlannedRun, PlannedSetup};
use crate::session::SimulatedRun;
use mtcal_effects::SampleEffects;
use mtcal_instrument::At;
use mtcal_kinematics::{MachineModel, Rigid, Workspace};
use mtcal_session::RunTable;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::Path;

/// What the readings come from: the true machine, the plan's planted effects and the
/// caller's plants.
pub(crate) struct Truth<'a> {
    pub model: &'a MachineModel,
    pub coeffs: &'a [f64],
    pub effects: Option<&'a Planted>,
    pub plants: &'a [&'a dyn Plant],
}

/// Every run measured, in plan order, its table in the session folder `dir`.
pub(crate) fn measure(
    plan: &Plan,
    settings: &Settings,
    truth: &Truth<'_>,
    setups: &[PlannedSetup],
    runs: Vec<PlannedRun>,
    dir: &Path,
) -> Result<Vec<SimulatedRun>, SimulateError> {
    runs.into_iter()
        .enumerate()
        .map(|(ri, run)| {
            measure_run(ri, run, settings, truth, setups, dir)
                .map_err(|(name, message)| plan.run_error(&name, message))
        })
        .collect()
}

/// Run `ri` measured; or its name and what went wrong.
fn measure_run(
    ri: usize,
    run: PlannedRun,
    settings: &Settings,
    truth: &Truth<'_>,
    setups: &[PlannedSetup],
    dir: &Path,
) -> Result<SimulatedRun, (String, String)> {
    let setup = &setups[run.setup];
    let mut values = true_readings(ri, &run, setup, setups, truth);
    add_noise(&mut values, &run.noise, settings.seed, ri);
    let poses: Vec<f64> = run.poses.concat();
    // The instrument's own form of the readings (an artefact's measured centres, a laser's
    // uncompensated lengths), then file units.
    let data = mtcal_instrument::RunData {
        q: &poses,
        t: &run.t,
        context: &run.context,
    };
    if let Err(e) = setup.setup.record_readings(&data, &mut values) {
        return Err((run.name, format!("recording the readings: {e}")));
    }
    let channels = setup.setup.channels();
    for row in values.chunks_exact_mut(channels.len()) {
        for (v, ch) in row.iter_mut().zip(channels) {
            *v = Record::round(*v * ch.unit.per_si(), settings.record.readings);
        }
    }
    let table = run_table(&run, setup, truth.model, &settings.record, values, dir);
    Ok(SimulatedRun {
        name: run.name,
        instrument: run.instrument,
        use_: run.use_,
        setup: run.setup_ref,
        table,
        poses,
        feed_mm_min: run.feed,
    })
}

/// Every sample's readings of `run` on the true machine (SI, before noise), row-major.
fn true_readings(
    ri: usize,
    run: &PlannedRun,
    setup: &PlannedSetup,
    setups: &[PlannedSetup],
    truth: &Truth<'_>,
) -> Vec<f64> {
    let nch = setup.setup.channels().len();
    let mut sampler = Sampler::new(truth, setup, setups);
    let mut values = Vec::with_capacity(run.poses.len() * nch);
    for i in 0..run.poses.len() {
        values.extend_from_slice(sampler.sample(ri, run, i));
    }
    values
}

/// Gaussian noise of σ `noise[c]` added to channel `c` of every row: a ChaCha8 generator
/// seeded from the plan's seed and the run's index, so a plan gives the same session on every
/// machine.
fn add_noise(values: &mut [f64], noise: &[f64], seed: u64, ri: usize) {
    if noise.is_empty() {
        return;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1_000_003) + ri as u64);
    for row in values.chunks_exact_mut(noise.len()) {
        for (v, &sigma) in row.iter_mut().zip(noise) {
            let e = if sigma > 0.0 {
                Normal::new(0.0, sigma)
                    .expect("finite positive σ")
                    .sample(&mut rng)
            } else {
                0.0
            };
            // Added even when zero: a noise-free −0 reading is written as 0, as always.
            *v += e;
        }
    }
}

/// The run's table as the file holds it and reading the file gives it back: positions in mm
/// and degrees, readings in the channels' units (`[record]` decimals), the reading columns
/// named even where a validation run has none.
fn run_table(
    run: &PlannedRun,
    setup: &PlannedSetup,
    model: &MachineModel,
    record: &Record,
    values: Vec<f64>,
    dir: &Path,
) -> RunTable {
    let axes = model.machine().axes();
    let mut positions = Vec::with_capacity(run.poses.len() * axes.len());
    for q in &run.poses {
        for (v, ax) in q.iter().zip(axes) {
            // The pose was rounded in file units already: this gives the same digits.
            positions.push(Record::round(ax.kind().to_file(*v), record.positions));
        }
    }
    let labels = setup
        .setup
        .label_columns()
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let column = run.labels.iter().map(|v| v[k].clone()).collect();
            (name.to_string(), column)
        })
        .collect();
    let mut table = RunTable {
        path: dir.join(format!("{}.csv", run.name)),
        columns: Vec::new(),
        t: run.t.clone(),
        axes: axes.iter().map(|a| a.letter().as_char()).collect(),
        positions,
        readings: setup
            .setup
            .channels()
            .iter()
            .map(|c| c.name.clone())
            .collect(),
        values: run.with_readings.then_some(values),
        context: run.context.clone(),
        labels,
    };
    table.columns = table.canonical_columns();
    table
}

/// Buffers for one run's samples: the true pose, the planted effects' shifts, the readings.
struct Sampler<'a> {
    truth: &'a Truth<'a>,
    setup: &'a PlannedSetup,
    ws: Workspace,
    /// The planted effects' scratch, with them.
    effects: Option<(&'a Planted, SampleEffects)>,
    shifted_q: Vec<f64>,
    shifted_nuis: Vec<f64>,
    pred: Vec<f64>,
}

impl<'a> Sampler<'a> {
    fn new(truth: &'a Truth<'a>, setup: &'a PlannedSetup, setups: &[PlannedSetup]) -> Self {
        let model = truth.model;
        Sampler {
            truth,
            setup,
            ws: model.workspace(),
            effects: truth
                .effects
                .map(|planted| (planted, effect_scratch(&planted.0, model, setups))),
            shifted_q: vec![0.0; model.machine().n_axes()],
            shifted_nuis: setup.nuis.clone(),
            pred: vec![0.0; setup.setup.channels().len()],
        }
    }

    /// Sample `i` of run `ri` (`run`): its noise-free readings, SI.
    fn sample(&mut self, ri: usize, run: &PlannedRun, i: usize) -> &[f64] {
        let (model, coeffs) = (self.truth.model, self.truth.coeffs);
        let PlannedSetup { setup, nuis, .. } = self.setup;
        let (q, t) = (&run.poses[i], run.t[i]);
        let mut pose = model.tool_pose(q, coeffs, &mut self.ws);
        let mut current_nuis: &[f64] = nuis;
        if let Some(((prepared, params), out)) = self.effects.as_mut() {
            // Planted effects act exactly: the axes really are elsewhere, the set-up's
            // parameters really have moved.
            prepared.sample(ri, run.setup, i, params, out);
            for ((s, &qi), d) in self.shifted_q.iter_mut().zip(q).zip(&out.dq) {
                *s = qi + d;
            }
            for ((s, &v), d) in self.shifted_nuis.iter_mut().zip(nuis).zip(&out.dn) {
                *s = v + d;
            }
            pose = model.tool_pose(&self.shifted_q, coeffs, &mut self.ws);
            current_nuis = &self.shifted_nuis;
        }
        let at = At {
            q,
            t,
            w_t_t: &pose,
            label: run.label_numbers.get(i).copied().unwrap_or(0),
        };
        setup.predict(&at, current_nuis, &mut self.pred);
        if let Some((_, out)) = self.effects.as_ref() {
            for (c, p) in self.pred.iter_mut().enumerate() {
                *p = *p * (1.0 + out.gain[c]) + out.dr[c];
            }
        }
        self.apply_plants(ri, run, i, &pose);
        &self.pred
    }

    /// The caller's plants' additions to the readings of sample `i`.
    fn apply_plants(&mut self, ri: usize, run: &PlannedRun, i: usize, pose: &Rigid) {
        let sample = PlantSample {
            run: &run.name,
            instrument: &run.instrument,
            run_index: ri,
            sample: i,
            t: run.t[i],
            q: &run.poses[i],
            w_t_t: pose,
        };
        for p in self.truth.plants {
            p.apply(&sample, &mut self.pred);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_free_channels_draw_nothing_and_write_minus_zero_as_zero() {
        let mut values = vec![-0.0, 1.0, -0.0, 2.0];
        add_noise(&mut values, &[0.0, 1e-6], 7, 0);
        assert_eq!(values[0].to_bits(), 0.0f64.to_bits());
        assert_eq!(values[2].to_bits(), 0.0f64.to_bits());
        // The noisy channel's draws do not depend on the noise-free one.
        let mut alone = vec![1.0, 2.0];
        add_noise(&mut alone, &[1e-6], 7, 0);
        assert_eq!([values[1], values[3]], [alone[0], alone[1]]);
        assert_ne!(alone, [1.0, 2.0]);
    }
}
