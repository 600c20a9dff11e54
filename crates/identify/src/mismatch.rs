//! Where the identified model and the recordings disagree: every fitted run's whitened
//! residuals at the solution, ordered by time, by each axis position and by each context column
//! (`T_*`, `S`, `F`), and split by each axis' direction of motion, through [`mtcal_mismatch`].
//!
//! The whole call is one family for Holm's correction ([`Family::All`]), so a session of white
//! noise raises a false alarm with probability at most α = 5 %, however many runs it has.

use crate::blocks::{Norm, block_sums};
use crate::study::Study;
use mtcal_mismatch::{Analysis, Family, MismatchError, Options, RunResiduals};

/// Fewer samples than this give the structure tests nothing to work with: such runs are left
/// out (their χ² is in the run fits).
const MIN_SAMPLES: usize = 20;

/// Channels whose whitened residuals are smaller than this (RMS, in units of the stated noise)
/// are left out: a fit that good (simulated, noise-free data) leaves only rounding, whose
/// ordering the scale-free structure tests would read as structure.
const MIN_RMS: f64 = 1e-3;

/// One run's residuals and context, owned (the analysis borrows them).
pub(crate) struct RunData {
    name: String,
    channels: Vec<(String, Vec<f64>)>,
    context: Vec<(String, Vec<f64>)>,
    splits: Vec<(String, Vec<i32>)>,
    /// Per channel: `Σ rᵢ² − n` over the samples, the χ² beyond the noise.
    excess: Vec<(String, f64)>,
}

/// The mismatch analysis of the fitted runs; `predictions[r]` are run `r`'s predicted readings
/// (SI, `samples × channels`) at the solution, `None` for runs without readings.
pub fn analyse(study: &Study, predictions: &[Option<Vec<f64>>]) -> Result<Analysis, MismatchError> {
    let data = (0..study.runs.len())
        .filter_map(|r| run_summary(study, r, predictions[r].as_ref()?))
        .collect();
    analyse_summaries(data)
}

/// What the analysis keeps of run `r` given its predictions (`None` for a run it leaves out):
/// at most [`MAX_SAMPLES`](crate::blocks::MAX_SAMPLES) block sums per channel and context variable, so that the caller
/// can drop the predictions before predicting the next run.
pub(crate) fn run_summary(study: &Study, r: usize, pred: &[f64]) -> Option<RunData> {
    let run = &study.runs[r];
    if !run.fit || run.len() < MIN_SAMPLES {
        return None;
    }
    Some(run_data(study, r, pred)).filter(|d| !d.channels.is_empty())
}

/// [`analyse`] from the runs' summaries ([`run_summary`], in run order).
pub(crate) fn analyse_summaries(data: Vec<RunData>) -> Result<Analysis, MismatchError> {
    let runs: Vec<RunResiduals<'_>> = data
        .iter()
        .map(|d| {
            let mut rr = RunResiduals::new(&d.name);
            for (name, values) in &d.channels {
                rr = rr.channel(name, values);
            }
            for (name, values) in &d.context {
                rr = rr.context(name, values);
            }
            for (name, labels) in &d.splits {
                rr = rr.split(name, labels);
            }
            rr
        })
        .collect();
    let options = Options {
        family: Family::All,
        ..Options::default()
    };
    let mut analysis = mtcal_mismatch::locate(&runs, &options)?;
    // Largest first: run-channels by their excess χ² (beyond the noise); within one, the
    // analysis' own order (strongest evidence first) stays. Adjusted p-values cannot order
    // strong effects across runs (they underflow to zero), and a large effect in one run biases
    // the fitted parameters, which leaves smaller structure in the others.
    let excess = |run: &str, channel: &str| {
        data.iter()
            .filter(|d| d.name == run)
            .flat_map(|d| &d.excess)
            .find(|(c, _)| c == channel)
            .map_or(0.0, |(_, e)| *e)
    };
    analysis.mismatch.locations.sort_by(|a, b| {
        let ea = excess(&a.run, &a.channel);
        let eb = excess(&b.run, &b.channel);
        eb.total_cmp(&ea)
    });
    Ok(analysis)
}

fn run_data(study: &Study, r: usize, pred: &[f64]) -> RunData {
    let run = &study.runs[r];
    let readings = run.readings.as_ref().expect("fitted runs have readings");
    let channels = study.channels(r);
    let (n, nch) = (run.len(), channels.len());
    let sum_over = |f: &dyn Fn(usize) -> f64, normalise: Norm| block_sums(n, f, normalise);
    let mut channels_out = Vec::new();
    let mut excess = Vec::new();
    for (c, ch) in channels.iter().enumerate() {
        // In units of the noise the fit assumes, prewhitened as the fit's rows are: coloured
        // noise is not structure.
        let sigma = study.sigma(r, c);
        let raw: Vec<f64> = (0..n)
            .map(|i| (pred[i * nch + c] - readings.get(i, c)) / sigma)
            .collect();
        let white = crate::whiten::prewhiten(&raw, study.noise(r, c).phi);
        let w = |i: usize| white[i];
        let chi2: f64 = (0..n).map(|i| w(i) * w(i)).sum();
        if (chi2 / n as f64).sqrt() >= MIN_RMS {
            channels_out.push((ch.name.clone(), sum_over(&w, Norm::Residual)));
            excess.push((ch.name.clone(), chi2 - n as f64));
        }
    }
    let mut context = vec![("t".to_string(), sum_over(&|i| run.t.get(i), Norm::Mean))];
    context.extend(run.position_blocks.means.iter().cloned());
    for (name, values) in &run.context {
        context.push((name.clone(), sum_over(&|i| values.get(i), Norm::Mean)));
    }
    let splits = run.position_blocks.splits.clone();
    RunData {
        name: run.name.clone(),
        channels: channels_out,
        context,
        splits,
        excess,
    }
}
