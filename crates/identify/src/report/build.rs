//! Building an `Identification` from a fit: values and intervals, combinations the data
//! cannot separate, weakly determined directions, fit per run and channel, component curves,
//! the parameters a session's base model holds.

use super::*;

impl Identification {
    /// Builds the report of `solution` for `study`.
    pub fn new(
        study: &Study,
        solution: &Solution,
    ) -> Result<Identification, mtcal_mismatch::MismatchError> {
        Self::build(study, solution, true)
    }

    /// The report without its mismatch analysis (the costly part: a periodogram per channel
    /// and variable), for a state of which only the fit and the validation are read.
    pub(crate) fn without_mismatch(
        study: &Study,
        solution: &Solution,
    ) -> Result<Identification, mtcal_mismatch::MismatchError> {
        Self::build(study, solution, false)
    }

    pub(super) fn build(
        study: &Study,
        solution: &Solution,
        analysed: bool,
    ) -> Result<Identification, mtcal_mismatch::MismatchError> {
        let x = solution.x.clone();
        let mut parameters = Vec::new();
        for (i, &xi) in x.iter().enumerate() {
            if !solution.identified[i] {
                continue;
            }
            let Some(sigma) = solution.sigma[i] else {
                continue;
            };
            let info = study.param_info(i);
            parameters.push(ParameterValue {
                name: info.name,
                value: xi * info.per_si,
                unit: info.unit,
                u95: K95 * sigma * info.per_si,
                u95_given_held: None,
                kind: study.param_group(i),
            });
        }
        let unidentifiable = solution
            .combinations
            .iter()
            .map(|c| Unidentifiable {
                parameters: c.params.iter().map(|&i| study.param_info(i).name).collect(),
                why: c.why.clone(),
            })
            .collect();
        let weakly_determined = weakly_determined(study, solution);
        let component_errors = component_curves(study, solution);
        let mut runs = Vec::new();
        let mut validation = Vec::new();
        // One run's predictions at a time: the run fits and the mismatch analysis' block sums
        // are all that is kept of them.
        let prepared = crate::fit::prepared_effects(study, &x);
        let mut summaries = Vec::new();
        let mut stated = study
            .changes()
            .noise
            .as_ref()
            .map(|_| AgainstStated::default());
        for r in 0..study.runs.len() {
            if study.runs[r].readings.is_none() {
                continue;
            }
            let pred = crate::fit::predict_run_with(study, r, &x, prepared.clone());
            if analysed {
                summaries.extend(crate::mismatch::run_summary(study, r, &pred));
            }
            let fit = run_fit(study, r, &pred);
            if study.runs[r].fit {
                if let Some(stated) = stated.as_mut() {
                    stated.add(study, r, &fit);
                }
                runs.push(fit);
            } else {
                validation.push(fit);
            }
        }
        let analysis = crate::mismatch::analyse_summaries(summaries)?;
        let n: usize = runs
            .iter()
            .flat_map(|r| &r.channels)
            .map(|c| c.samples)
            .sum();
        let ss: f64 = runs
            .iter()
            .flat_map(|r| &r.channels)
            .map(|c| c.rms * c.rms * c.samples as f64)
            .sum();
        Ok(Identification {
            parameters,
            component_errors,
            combinations: Vec::new(),
            unidentifiable,
            held: Vec::new(),
            undetermined_validation: Vec::new(),
            weakly_determined,
            fit: Fit {
                rms_um: if n > 0 { (ss / n as f64).sqrt() } else { 0.0 },
                chi2_reduced: solution.chi2_reduced,
                chi2: solution.chi2,
                dof: solution.dof,
                runs,
            },
            noise: study
                .changes()
                .noise
                .as_ref()
                .map_or_else(Vec::new, |n| n.describe(study)),
            validation,
            diagnostics: if analysed {
                crate::diagnostics::diagnose(study, &x)
            } else {
                Vec::new()
            },
            location_series: if analysed {
                crate::series::location_series(study, &x)
            } else {
                Vec::new()
            },
            against_stated: stated,
            mismatch: analysis.mismatch.clone(),
            mismatch_detail: analysis.describe(),
            tests: analysis.tests.clone(),
            solver: SolverReport {
                iterations: solution.iterations,
                passes: solution.evaluations,
                factorizations: solution.factorizations,
                converged: solution.converged,
                termination: solution.termination,
                rank: solution.rank,
                parameters: solution.x.len(),
                condition_number: solution.condition_number,
            },
            conventions: mtcal_machine::card::ConventionCard::mtcal_parameters(
                study.model.machine(),
            ),
        })
    }
}

/// Identified machine and set-up parameters whose 95 % interval exceeds [`WEAK_SHARE_OF_RANGE`]
/// of their plausible range (unless a prior the user set within that range is what bounds
/// it), one entry each; then groups of identified parameters whose estimates correlate beyond
/// [`WEAK_CORRELATION`] (linked pairwise), in parameter order.
pub(super) fn weakly_determined(study: &Study, solution: &Solution) -> Vec<WeaklyDetermined> {
    let n = solution.x.len();
    let ids: Vec<usize> = (0..n)
        .filter(|&i| solution.identified[i] && solution.sigma[i].is_some_and(|s| s > 0.0))
        .collect();
    let specs = crate::param_specs_from(study, &solution.x);
    let mut out: Vec<WeaklyDetermined> = Vec::new();
    // Machine and set-up parameters (an effect's shape is judged by the search).
    for &i in ids.iter().filter(|&&i| i < study.layout().effect_offset()) {
        let (Some(sigma), Some(scale)) = (solution.sigma[i], specs[i].scale) else {
            continue;
        };
        let u95 = K95 * sigma;
        let info = study.param_info(i);
        let prior = specs[i].prior.map(|(_, s)| s);
        // Held machine parameters have their own section ([`crate::base`]).
        let held = info.machine && study.changes().hold.contains(&study.param_id(i));
        if let Some(p) = prior
            && sigma > PRIOR_ONLY * p
            && !held
        {
            // Whatever the prior's width, the runs did not narrow it: the value is the
            // prior's centre and the interval its width, not an identification. One entry per
            // prior width, so six beam tilts make one line.
            let why = format!(
                "their 95 % intervals are their prior's (±{:.4} {unit}): these runs do not see \
                 them",
                K95 * p * info.per_si,
                unit = info.unit,
            );
            match out.iter_mut().find(|w| w.why == why) {
                Some(w) => w.parameters.push(info.name),
                None => out.push(WeaklyDetermined {
                    parameters: vec![info.name],
                    why,
                }),
            }
            continue;
        }
        if u95 <= WEAK_SHARE_OF_RANGE * scale {
            continue;
        }
        let why = match prior {
            // The user's own prior within the plausible range: the interval is what they said.
            Some(p) if K95 * p <= scale => continue,
            Some(p) if sigma > 0.5 * p => format!(
                "its 95 % interval, ±{:.4} {unit}, is its prior's (±{:.4} {unit}): these runs \
                 hardly see it, and the prior is wider than any machine plausibly has",
                u95 * info.per_si,
                K95 * p * info.per_si,
                unit = info.unit,
            ),
            _ => format!(
                "its 95 % interval, ±{:.4} {unit}, is more than {:.0} % of its plausible range \
                 ({:.4} {unit}): these runs hardly see it; a run where it acts more (another \
                 position, axis angle or set-up) would determine it",
                u95 * info.per_si,
                WEAK_SHARE_OF_RANGE * 100.0,
                scale * info.per_si,
                unit = info.unit,
            ),
        };
        out.push(WeaklyDetermined {
            parameters: vec![info.name],
            why,
        });
    }
    // Union–find over strongly correlated pairs.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut largest = vec![0.0_f64; n];
    for (a, &i) in ids.iter().enumerate() {
        for &j in &ids[a + 1..] {
            let Some(rho) = solution.correlation(i, j) else {
                continue;
            };
            if rho.is_finite() && rho.abs() > WEAK_CORRELATION {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri.max(rj)] = ri.min(rj);
                largest[i] = largest[i].max(rho.abs());
                largest[j] = largest[j].max(rho.abs());
            }
        }
    }
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for &i in &ids {
        if largest[i] == 0.0 {
            continue;
        }
        let r = root(&mut parent, i);
        match groups.iter_mut().find(|(g, _)| *g == r) {
            Some((_, members)) => members.push(i),
            None => groups.push((r, vec![i])),
        }
    }
    out.extend(groups.into_iter().map(|(_, members)| {
        let rho = members.iter().map(|&i| largest[i]).fold(0.0, f64::max);
        WeaklyDetermined {
            parameters: members.iter().map(|&i| study.param_info(i).name).collect(),
            why: format!(
                "their estimates correlate up to |ρ| = {rho:.6}: the runs barely tell them apart, \
                 so each interval is mostly the others' uncertainty; a run that moves them \
                 differently would separate them"
            ),
        }
    }));
    out
}

/// Residual statistics of run `r` (which has readings) from its predictions `pred`.
pub(super) fn run_fit(study: &Study, r: usize, pred: &[f64]) -> RunFit {
    let run = &study.runs[r];
    let readings = run
        .readings
        .as_ref()
        .expect("only runs with readings are fitted");
    let channels = study.channels(r);
    let nch = channels.len();
    let n = run.len();
    let mut fits = Vec::with_capacity(nch);
    let mut ss_all = 0.0;
    for (c, ch) in channels.iter().enumerate() {
        let mut ss = 0.0;
        for i in 0..n {
            let d = pred[i * nch + c] - readings.get(i, c);
            ss += d * d;
        }
        ss_all += ss;
        fits.push(ChannelFit {
            name: ch.name.clone(),
            unit: ch.unit.as_str().to_string(),
            rms: (ss / n as f64).sqrt() * ch.unit.per_si(),
            chi2: ss / (study.sigma(r, c).powi(2)),
            samples: n,
        });
    }
    let slot = &study.setups[run.setup];
    let metrics = slot
        .plugin
        .evaluate
        .and_then(|f| study.with_evaluation(r, f))
        .unwrap_or_default()
        .into_iter()
        .map(|m| MetricValue {
            name: m.name,
            value: m.value * m.unit.per_si(),
            unit: m.unit.as_str().to_string(),
            u95: m.u95.map(|u| u * m.unit.per_si()),
            subject: m.subject,
        })
        .collect();
    RunFit {
        name: run.name.clone(),
        instrument: slot.plugin.name.to_string(),
        rms_um: (ss_all / (n * nch) as f64).sqrt() * 1e6,
        channels: fits,
        metrics,
    }
}

/// Curves of the estimated multi-coefficient component errors whose coefficients are all
/// identified, with 95 % bands from the covariance, at [`CURVE_SAMPLES`] positions.
pub(super) fn component_curves(study: &Study, solution: &Solution) -> Vec<ComponentCurve> {
    component_curves_sampled(study, solution, CURVE_SAMPLES)
}

/// [`component_curves`] at `samples` (≥ 2) positions evenly over each stroke, its ends
/// included.
pub(crate) fn component_curves_sampled(
    study: &Study,
    solution: &Solution,
    samples: usize,
) -> Vec<ComponentCurve> {
    let model = &study.model;
    let pos: Vec<Option<usize>> = {
        let mut p = vec![None; model.n_coeffs()];
        for (i, &k) in study.layout().estimated().iter().enumerate() {
            p[k] = Some(i);
        }
        p
    };
    let coeffs = study.coeffs_from(&solution.x);
    let mut out = Vec::new();
    for param in model.errors().params() {
        let Role::Component { axis, basis, .. } = &param.role else {
            continue;
        };
        let idx: Option<Vec<usize>> = (param.offset..param.offset + param.len)
            .map(|k| pos[k].filter(|&i| solution.identified[i]))
            .collect();
        let Some(idx) = idx else { continue };
        let (lo, hi) = basis
            .stroke()
            .unwrap_or_else(|| mtcal_kinematics::model::default_stroke(model.machine(), *axis));
        let rotary = model.machine().axes()[*axis].kind() == mtcal_kinematics::AxisKind::Rotary;
        let mut phi = vec![0.0; param.len];
        let mut points = Vec::with_capacity(samples);
        for s in 0..samples {
            let q = lo + (hi - lo) * s as f64 / (samples - 1) as f64;
            basis.eval(q, &mut phi);
            let value: f64 = phi
                .iter()
                .zip(&coeffs[param.offset..param.offset + param.len])
                .map(|(a, b)| a * b)
                .sum();
            let mut var = 0.0;
            for (a, &i) in idx.iter().enumerate() {
                for (b, &j) in idx.iter().enumerate() {
                    var += phi[a] * phi[b] * solution.cov(i, j);
                }
            }
            let position = if rotary { q.to_degrees() } else { q * 1e3 };
            points.push([position, value * 1e6, K95 * var.max(0.0).sqrt() * 1e6]);
        }
        out.push(ComponentCurve {
            name: param.name.to_string(),
            samples: points,
        });
    }
    out
}

impl Identification {
    /// The report with what `base` says: a parameter that stands for a combination moves from
    /// `parameters` to `combinations` (FORMATS.md: what the data cannot separate never has a
    /// value of its own), and every held parameter is named in `unidentifiable`.
    pub fn with_base(
        mut self,
        base: &BaseModel,
        study: &Study,
        solution: &mtcal_solve::Solution,
    ) -> Self {
        let index: std::collections::HashMap<String, usize> = (0..study.layout().n_x())
            .map(|i| (study.param_info(i).name, i))
            .collect();
        let held: Vec<&str> = base.held.iter().map(|h| h.name.as_str()).collect();
        let given_held = ConditionalCovariance::new(study, solution, &held, &index);
        let mut kept = Vec::new();
        for p in std::mem::take(&mut self.parameters) {
            if held.contains(&p.name.as_str()) {
                continue;
            }
            let terms = base.aliases_of(&p.name);
            if terms.is_empty() {
                let mut p = p;
                let i = index[&p.name];
                p.u95_given_held = given_held.u95(&[(i, study.param_info(i).per_si)]);
                kept.push(p);
                continue;
            }
            // The combination's value and interval from the fit (file units): the held members
            // are in the fit too, near their start values.
            let mut weights = vec![(index[&p.name], study.param_info(index[&p.name]).per_si)];
            for t in terms {
                if let Some(&j) = index.get(&t.name) {
                    weights.push((j, t.coefficient * study.param_info(j).per_si));
                }
            }
            let value: f64 = weights.iter().map(|&(i, w)| w * solution.x[i]).sum();
            let var: f64 = weights
                .iter()
                .flat_map(|&(a, wa)| weights.iter().map(move |&(b, wb)| (a, wa, b, wb)))
                .map(|(a, wa, b, wb)| wa * wb * solution.cov(a, b))
                .sum();
            let u95 = crate::K95 * var.max(0.0).sqrt();
            let names: Vec<String> = std::iter::once(p.name.clone())
                .chain(terms.iter().map(|t| t.name.clone()))
                .collect();
            let expr = expression(&p.name, terms);
            self.unidentifiable.push(crate::report::Unidentifiable {
                parameters: names,
                why: format!(
                    "these runs see only their combination {expr} = {value:.4} ± {u95:.4} {}",
                    p.unit
                ),
            });
            self.combinations.push(crate::report::CombinationValue {
                expression: expr,
                name: p.name,
                terms: terms.to_vec(),
                value,
                unit: p.unit,
                u95,
                u95_given_held: given_held.u95(&weights),
                kind: p.kind,
            });
        }
        self.parameters = kept;
        for h in &base.held {
            let why = match &h.why {
                HeldWhy::NotObserved => "not observed by these runs".to_string(),
                HeldWhy::Aliased => "seen only within the combinations above".to_string(),
                HeldWhy::TooWeak { u95 } => format!(
                    "these runs see it too weakly to determine it (its 95 % interval would be \
                     ±{u95:.4} {}); kept near its start value",
                    h.unit
                ),
            };
            if matches!(h.why, HeldWhy::Aliased) {
                continue;
            }
            self.unidentifiable.push(crate::report::Unidentifiable {
                parameters: vec![h.name.clone()],
                why,
            });
        }
        self.held = base.held.clone();
        self.undetermined_validation = base.validation.clone();
        self
    }
}

impl AgainstStated {
    /// Adds the fitted run `r` (its fit `fit`, against the noise the study assumes).
    fn add(&mut self, study: &Study, r: usize, fit: &RunFit) {
        for (c, ch) in fit.channels.iter().enumerate() {
            let scale = study.noise(r, c).scale;
            // The channel's χ² with every residual weighed by the stated σ, not `scale` × it.
            let chi2 = ch.chi2 * scale * scale;
            self.chi2 += chi2;
            self.largest_scale = self.largest_scale.max(scale);
            if self.worst.as_ref().is_none_or(|w| chi2 > w.chi2) {
                self.worst = Some(WorstChannel {
                    run: fit.name.clone(),
                    channel: ch.name.clone(),
                    rms: ch.rms,
                    unit: ch.unit.clone(),
                    chi2,
                });
            }
        }
    }
}
