//! The instruments' own diagnoses of their runs in their users' terms (a ball-bar's backlash,
//! squareness, servo mismatch… per circle pair, [`mtcal_instrument::InstrumentPlugin::diagnose`]),
//! each value set beside what the identified model predicts for it and which of the model's
//! parameters and effects that prediction comes from.
//!
//! A diagnosis is linear in the readings (its estimator), and the fit's rows say how much of
//! every reading each parameter predicts (`∂prediction/∂x_k · x_k`); the estimator applied to
//! one parameter's share gives that parameter's share of the diagnostic. Parameters are
//! gathered as people name them: a component error's coefficients as the error, an effect's
//! parameters as the effect, a set-up's nuisance as the set-up. No instrument is named here.

use crate::study::Study;
use crate::{ParamSlot, fit::prediction_jacobian};
use serde::Serialize;

/// One diagnosed group of runs (a ball-bar's circle pair in one plane).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiagnosisReport {
    pub instrument: String,
    /// What the group is about, e.g. the plane `XY`.
    pub subject: String,
    pub runs: Vec<String>,
    /// The peak-to-valley the items are ranked against (a ball-bar's circularity), µm.
    pub circularity_um: f64,
    /// Ranked: the determined items by their contribution, largest first, then the others.
    pub items: Vec<DiagnosticValue>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// One diagnostic of a [`DiagnosisReport`], in the unit its users read.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiagnosticValue {
    pub name: String,
    pub about: String,
    pub value: f64,
    pub unit: String,
    /// Expanded uncertainty (about 95 %), same unit.
    pub u95: f64,
    /// Out of the noise with family-wise confidence over the group's items; a value that is
    /// not is reported, never claimed or ranked.
    pub determined: bool,
    /// 1 = the largest contribution to circularity among the determined items.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rank: Option<usize>,
    /// The peak-to-valley this item alone draws, µm, and its share of the circularity.
    pub contribution_um: f64,
    pub share_of_circularity: f64,
    /// What the identified model (parameters and effects as fitted) predicts for this value.
    pub model: f64,
    /// The parameters and effects that prediction comes from (the largest shares).
    pub behind: Vec<Behind>,
    /// `value − model`: what the model leaves of it.
    pub unexplained: f64,
}

/// A parameter (or effect, or set-up) behind a diagnostic's model value.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Behind {
    pub name: String,
    /// Its part of the model value, same unit.
    pub value: f64,
    /// That part over the model value.
    pub share: f64,
}

/// A contributor is named when its part is at least this share of the parts' absolute sum.
const BEHIND_SHARE: f64 = 0.1;
/// At most this many contributors are named.
const BEHIND_MAX: usize = 3;

/// The diagnoses of every instrument that has one, at the parameters `x`.
pub fn diagnose(study: &Study, x: &[f64]) -> Vec<DiagnosisReport> {
    let mut out = Vec::new();
    let mut plugins: Vec<&'static mtcal_instrument::InstrumentPlugin> = Vec::new();
    for slot in study.setups.iter() {
        if slot.plugin.diagnose.is_some() && !plugins.iter().any(|p| p.name == slot.plugin.name) {
            plugins.push(slot.plugin);
        }
    }
    let groups = parameter_groups(study);
    for plugin in plugins {
        let Some(diagnose) = plugin.diagnose else {
            continue;
        };
        let runs: Vec<usize> = (0..study.runs.len())
            .filter(|&r| {
                study.runs[r].readings.is_some()
                    && study.setups[study.runs[r].setup].plugin.name == plugin.name
            })
            .collect();
        let diagnoses = with_evaluations(study, &runs, diagnose);
        for d in diagnoses {
            out.push(report(study, x, &groups, plugin.name, &runs, &d));
        }
    }
    out
}

/// `f` over the evaluations of `runs` (owned buffers held while it runs).
fn with_evaluations<T>(
    study: &Study,
    runs: &[usize],
    f: impl FnOnce(&[mtcal_instrument::Evaluation<'_>]) -> T,
) -> T {
    let buffers: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = runs
        .iter()
        .map(|&r| {
            let run = &study.runs[r];
            let readings = run.readings.as_ref().expect("runs with readings only");
            (
                run.q.to_row_major(),
                readings.to_row_major(),
                run.t.to_vec(),
            )
        })
        .collect();
    let evs: Vec<mtcal_instrument::Evaluation<'_>> = runs
        .iter()
        .zip(&buffers)
        .map(|(&r, (q, readings, t))| {
            let run = &study.runs[r];
            mtcal_instrument::Evaluation {
                machine: study.model.machine(),
                setup: study.setups[run.setup].setup.as_ref(),
                q,
                readings,
                t,
                labels: &run.labels,
            }
        })
        .collect();
    f(&evs)
}

/// The name people know each parameter by: its group, one per parameter (index of `names`).
fn parameter_groups(study: &Study) -> (Vec<String>, Vec<usize>) {
    let mut names: Vec<String> = Vec::new();
    let mut of = Vec::with_capacity(study.layout().n_x());
    for i in 0..study.layout().n_x() {
        let full = study.param_info(i).name;
        let name = match study.layout().slot(i) {
            ParamSlot::Machine { .. } => full.split('.').next().unwrap_or(&full).to_string(),
            ParamSlot::Effect { .. } => full
                .rsplit_once('.')
                .map_or(full.as_str(), |(e, _)| e)
                .to_string(),
            ParamSlot::Nuisance { .. } => format!("set-up {}", study.param_group(i)),
        };
        let k = names.iter().position(|n| *n == name).unwrap_or_else(|| {
            names.push(name);
            names.len() - 1
        });
        of.push(k);
    }
    (names, of)
}

fn report(
    study: &Study,
    x: &[f64],
    (names, of): &(Vec<String>, Vec<usize>),
    instrument: &str,
    runs: &[usize],
    d: &mtcal_instrument::Diagnosis,
) -> DiagnosisReport {
    let n_items = d.items.len();
    // parts[item][group]: the diagnostic value each group's predicted readings give, SI.
    let mut parts = vec![vec![0.0; names.len()]; n_items];
    let cols: Vec<usize> = (0..x.len()).collect();
    for (k, &local) in d.runs.iter().enumerate() {
        let r = runs[local];
        let estimator = &d.estimator[k];
        if estimator.is_empty() {
            continue;
        }
        let n = study.runs[r].len();
        let nch = study.channels(r).len();
        let m = n * nch;
        let jac = prediction_jacobian(study, r, x, &cols);
        for (col, &xk) in x.iter().enumerate() {
            if xk == 0.0 {
                continue;
            }
            let g = &jac[col * m..(col + 1) * m];
            for (item, part) in parts.iter_mut().enumerate() {
                let e = &estimator[item * n..(item + 1) * n];
                let v: f64 = (0..n).map(|i| e[i] * g[i * nch + d.channel]).sum();
                part[of[col]] += v * xk;
            }
        }
    }
    let mut items: Vec<DiagnosticValue> = d
        .items
        .iter()
        .zip(&parts)
        .map(|(item, part)| {
            let model: f64 = part.iter().sum();
            let total_abs: f64 = part.iter().map(|v| v.abs()).sum();
            let mut behind: Vec<(usize, f64)> = part
                .iter()
                .copied()
                .enumerate()
                .filter(|&(_, v)| total_abs > 0.0 && v.abs() >= BEHIND_SHARE * total_abs)
                .collect();
            behind.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            behind.truncate(BEHIND_MAX);
            let per = item.per_si;
            DiagnosticValue {
                name: item.name.clone(),
                about: item.about.clone(),
                value: item.value * per,
                unit: item.unit.to_string(),
                u95: item.u95 * per,
                determined: item.determined,
                rank: None,
                contribution_um: item.contribution * 1e6,
                share_of_circularity: if d.circularity > 0.0 {
                    item.contribution / d.circularity
                } else {
                    0.0
                },
                model: model * per,
                behind: behind
                    .into_iter()
                    .map(|(g, v)| Behind {
                        name: names[g].clone(),
                        value: v * per,
                        share: if model != 0.0 { v / model } else { 0.0 },
                    })
                    .collect(),
                unexplained: (item.value - model) * per,
            }
        })
        .collect();
    // Determined items first, by contribution; then the rest by contribution.
    items.sort_by(|a, b| {
        b.determined
            .cmp(&a.determined)
            .then(b.contribution_um.total_cmp(&a.contribution_um))
    });
    for (k, item) in items.iter_mut().filter(|i| i.determined).enumerate() {
        item.rank = Some(k + 1);
    }
    DiagnosisReport {
        instrument: instrument.to_string(),
        subject: d.subject.clone(),
        runs: d
            .runs
            .iter()
            .map(|&k| study.runs[runs[k]].name.clone())
            .collect(),
        circularity_um: d.circularity * 1e6,
        items,
        notes: d.notes.clone(),
    }
}

impl DiagnosisReport {
    /// The group on the terminal: the determined items ranked, each with what the model says
    /// of it; the others named on one line (every value with `verbose`).
    pub fn summary(&self, verbose: bool) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "  {} {} ({}): circularity {:.2} um",
            self.instrument,
            self.subject,
            self.runs.join(" + "),
            self.circularity_um
        );
        for item in &self.items {
            if !item.determined && !verbose {
                continue;
            }
            let rank = item.rank.map_or("  -".to_string(), |r| format!("{r:>3}"));
            let behind: Vec<String> = item
                .behind
                .iter()
                .map(|b| format!("{} {:.0} %", b.name, 100.0 * b.share))
                .collect();
            let model = if behind.is_empty() {
                "not in the model".to_string()
            } else {
                format!("model {:.2} ({})", item.model, behind.join(", "))
            };
            let left = if item.determined && item.unexplained.abs() > item.u95 {
                format!(
                    "; the model leaves {:.2} {} of it",
                    item.unexplained, item.unit
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "  {rank} {:<26} {:>8.2} ± {:<6.2} {:<5} {:>3.0} % of circularity  {model}{left}",
                item.name,
                item.value,
                item.u95,
                item.unit,
                100.0 * item.share_of_circularity,
            );
        }
        if !verbose {
            let quiet: Vec<&str> = self
                .items
                .iter()
                .filter(|i| !i.determined)
                .map(|i| i.name.as_str())
                .collect();
            if !quiet.is_empty() {
                let _ = writeln!(
                    s,
                    "      within the noise: {} (values in the JSON, or --verbose)",
                    quiet.join(", ")
                );
            }
        }
        for note in &self.notes {
            let _ = writeln!(s, "      not evaluated: {note}");
        }
        s
    }
}
