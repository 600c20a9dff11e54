//! Prediction bands of validation runs: how far the identified model's prediction of a run it
//! did not fit may be from the truth, from the covariance of the fitted parameters.
//!
//! The prediction of a reading is `f(x)`; with the fitted parameters' covariance `C`, its
//! variance is `g·C·gᵀ` with `g = ∂f/∂x` (first order, the same linearisation as the
//! intervals). `g` is the fit's own Jacobian row of each reading, before the noise filter and
//! the weights (analytic where the set-up and the effects give derivatives, central
//! differences where a plugin has none): one pass over the run (central differences of the
//! whole prediction, two per parameter, took 7 s of a 60 s search on a joint thermal model of
//! 445 parameters). The band is
//! `1.96·√(k·g·C·gᵀ)` (`k`: [`noise_inflation`], what the residuals say of the noise the
//! stated σ does not: a σ stated too small, coloured noise): where the truth (noise-free readings) should lie in 95 % of the samples.
//! It does not contain the reading noise (a measured reading scatters around the truth by σ
//! more), nor what held parameters ([`crate::base`]) would add: a run that depends on those
//! is named by [`crate::base`], not covered by a wider band.

use crate::K95;
use crate::fit::{predict_run, prediction_jacobian};
use crate::study::Study;
use mtcal_solve::Solution;
use nalgebra::DMatrix;

/// How much larger the parameters' covariance is than the stated noise makes it: the residual
/// scatter over the stated σ (`χ²/dof`, when above 1: a σ stated too small) times the variance
/// inflation of AR(1)-coloured noise, `(1 + φ)/(1 − φ)` with `φ` the lag-1 autocorrelation of
/// the whitened residuals pooled over the fitted runs' channels (when positive: neighbouring
/// samples that share their error carry less information than independent ones). Both are
/// 1 for white noise of the stated σ.
pub fn noise_inflation(study: &Study, solution: &Solution) -> f64 {
    let (mut lag0, mut lag1) = (0.0, 0.0);
    for (r, run) in study.runs.iter().enumerate() {
        let (true, Some(readings)) = (run.fit, run.readings.as_ref()) else {
            continue;
        };
        let channels = study.channels(r);
        let nch = channels.len();
        let pred = predict_run(study, r, &solution.x);
        for c in 0..channels.len() {
            // In units of the noise the fit assumed, prewhitened as its rows were: what is
            // left beyond that model inflates the band.
            let sigma = study.sigma(r, c);
            let raw: Vec<f64> = (0..run.len())
                .map(|i| (readings.get(i, c) - pred[i * nch + c]) / sigma)
                .collect();
            let white = crate::whiten::prewhiten(&raw, study.noise(r, c).phi);
            let mut prev = None;
            for &e in &white {
                lag0 += e * e;
                if let Some(p) = prev {
                    lag1 += e * p;
                }
                prev = Some(e);
            }
        }
    }
    let phi = if lag0 > 0.0 {
        (lag1 / lag0).clamp(0.0, 0.95)
    } else {
        0.0
    };
    solution.chi2_reduced.max(1.0) * (1.0 + phi) / (1.0 - phi)
}

/// 95 % prediction band of run `r` (one entry per sample and channel, row-major, SI), for the
/// parameters of `solution`, with their covariance scaled by [`noise_inflation`].
pub fn prediction_u95(study: &Study, solution: &Solution, r: usize) -> Vec<f64> {
    prediction_u95_inflated(study, solution, r, noise_inflation(study, solution))
}

/// [`prediction_u95`] with the covariance scaled by `inflation` (computed once per fit).
fn prediction_u95_inflated(
    study: &Study,
    solution: &Solution,
    r: usize,
    inflation: f64,
) -> Vec<f64> {
    let n = solution.x.len();
    let free: Vec<usize> = (0..n)
        .filter(|&i| solution.sigma[i].is_some_and(|s| s > 0.0))
        .collect();
    let m = study.runs[r].len() * study.channels(r).len();
    // G (readings × parameters): ∂prediction/∂x, the fit's own rows.
    let g = DMatrix::from_vec(
        m,
        free.len(),
        prediction_jacobian(study, r, &solution.x, &free),
    );
    let c = DMatrix::from_fn(free.len(), free.len(), |a, b| {
        solution.cov(free[a], free[b])
    });
    // diag(G C Gᵀ), row by row.
    let gc = &g * c;
    (0..m)
        .map(|s| {
            let var = gc.row(s).dot(&g.row(s));
            K95 * (var * inflation).max(0.0).sqrt()
        })
        .collect()
}

impl crate::report::Identification {
    /// The report with every validation run's mean 95 % prediction band and, where it has
    /// readings, its RMS prediction error in units of the stated noise (1 = predicted to the
    /// noise).
    pub fn with_prediction_bands(mut self, study: &Study, solution: &Solution) -> Self {
        let inflation = noise_inflation(study, solution);
        for (r, run) in study.runs.iter().enumerate() {
            if run.fit {
                continue;
            }
            let Some(fit) = self.validation.iter_mut().find(|v| v.name == run.name) else {
                continue;
            };
            let channels = study.channels(r);
            let band = prediction_u95_inflated(study, solution, r, inflation);
            if band.is_empty() {
                continue;
            }
            let per_si = channels[0].unit.per_si();
            let mean = band.iter().sum::<f64>() / band.len() as f64;
            fit.metrics.push(crate::report::MetricValue {
                name: "95 % prediction band (mean, model uncertainty)".into(),
                value: mean * per_si,
                unit: channels[0].unit.as_str().to_string(),
                ..Default::default()
            });
            if run.readings.is_some() {
                // RMS of (measured − predicted)/σ over every channel.
                let ratio = (fit
                    .channels
                    .iter()
                    .zip(channels)
                    .map(|(c, ch)| {
                        let rel = c.rms / (ch.sigma * ch.unit.per_si());
                        rel * rel * c.samples as f64
                    })
                    .sum::<f64>()
                    / fit.channels.iter().map(|c| c.samples).sum::<usize>().max(1) as f64)
                    .sqrt();
                fit.metrics.push(crate::report::MetricValue {
                    name: "prediction error over the stated noise (rms)".into(),
                    value: ratio,
                    unit: "".into(),
                    ..Default::default()
                });
            }
        }
        self
    }
}
