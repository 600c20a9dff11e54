//! The result of an identification as users read it: parameters with 95 % intervals, named
//! unidentifiable combinations (never numbers), fit statistics per run and channel, validation
//! predictions; the FORMATS.md `mtcal.identify/1` JSON and a plain-text summary.

use crate::base::{BaseModel, ConditionalCovariance, HeldWhy, expression};
use crate::study::Study;
use mtcal_kinematics::model::Role;
use mtcal_solve::Solution;
use serde::Serialize;
use std::fmt::Write as _;

pub use crate::K95;

/// Samples per component-error curve in the JSON.
const CURVE_SAMPLES: usize = 11;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParameterValue {
    pub name: String,
    /// In `unit` (µm, µrad, ppm).
    pub value: f64,
    pub unit: String,
    pub u95: f64,
    /// The 95 % interval if the parameters the runs cannot determine ([`crate::base`]) were
    /// exactly at their start values: what the runs alone say. `u95` also holds their prior
    /// uncertainty. Only when some are held.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u95_given_held: Option<f64>,
    /// `machine` or the set-up it belongs to.
    pub kind: String,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ComponentCurve {
    pub name: String,
    /// `[position mm|deg, value um|urad, u95]`.
    pub samples: Vec<[f64; 3]>,
}

/// What the runs determine of parameters they cannot separate: the taken parameter's estimate
/// stands for `name + Σ coefficient·term` ([`crate::base`]).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CombinationValue {
    /// Readable form, e.g. `EC0Y − 0.5·EXX.P1`.
    pub expression: String,
    /// The parameter that carries the number (coefficient 1).
    pub name: String,
    pub terms: Vec<crate::base::Term>,
    pub value: f64,
    pub unit: String,
    pub u95: f64,
    /// As [`ParameterValue::u95_given_held`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u95_given_held: Option<f64>,
    pub kind: String,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Unidentifiable {
    pub parameters: Vec<String>,
    pub why: String,
}

/// Identified parameters the runs barely determine: numbers are given, but their intervals are
/// beyond what a machine plausibly has (the runs hardly see the parameter), or their estimates
/// correlate so strongly that each interval is mostly the others' uncertainty.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct WeaklyDetermined {
    pub parameters: Vec<String>,
    pub why: String,
}

/// Two identified parameters whose estimates correlate beyond this are reported as weakly
/// determined (each interval is then at least 70 × what it would be with the other known).
pub const WEAK_CORRELATION: f64 = 0.9999;

/// A parameter whose 95 % interval exceeds this share of its plausible range (the solver's
/// `ParamSpec::scale`: a millimetre or milliradian for machine and set-up parameters) is
/// reported as weakly determined.
pub const WEAK_SHARE_OF_RANGE: f64 = 0.1;

/// A parameter whose standard uncertainty is more than this share of its prior's was not
/// narrowed by the runs (they take less than 10 % off its prior's width): its interval is the
/// prior's, and it is reported as weakly determined whatever the prior's width.
pub const PRIOR_ONLY: f64 = 0.9;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ChannelFit {
    pub name: String,
    pub unit: String,
    pub rms: f64,
    /// Σ (residual/σ)².
    pub chi2: f64,
    pub samples: usize,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RunFit {
    pub name: String,
    pub instrument: String,
    /// RMS over the run's channels, in µm (or the channels' unit).
    pub rms_um: f64,
    pub channels: Vec<ChannelFit>,
    /// The instrument's own evaluation of the measured readings (e.g. ISO 230-4).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub metrics: Vec<MetricValue>,
}

#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct MetricValue {
    pub name: String,
    pub value: f64,
    pub unit: String,
    /// The instrument's expanded uncertainty of `value` (k = 2, in `unit`), if it gives one;
    /// not in the JSON's run metrics (acceptance shows it with its verdicts).
    #[serde(skip)]
    pub u95: Option<f64>,
    /// What the value is about (an axis letter, a plane; `mtcal_instrument::Metric::subject`);
    /// not in the JSON.
    #[serde(skip)]
    pub subject: Option<String>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Fit {
    pub rms_um: f64,
    pub chi2_reduced: f64,
    pub chi2: f64,
    pub dof: usize,
    pub runs: Vec<RunFit>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SolverReport {
    pub iterations: usize,
    /// Passes over the data (evaluations at trial points and the start).
    pub passes: usize,
    /// Passes that built a factor; the others only checked a point (gradient-only).
    pub factorizations: usize,
    pub converged: bool,
    pub termination: mtcal_solve::Termination,
    pub rank: usize,
    pub parameters: usize,
    pub condition_number: f64,
}

/// Everything `identify` reports.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Identification {
    pub schema: &'static str,
    /// What a person reads first when the fit is not a calibration ([`Self::verdict`]): it
    /// did not converge, or the model does not explain the recordings. In the JSON only then.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<String>,
    pub parameters: Vec<ParameterValue>,
    pub component_errors: Vec<ComponentCurve>,
    /// Combinations of parameters the runs determine although they cannot separate them
    /// ([`crate::base`]); in the JSON only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub combinations: Vec<CombinationValue>,
    pub unidentifiable: Vec<Unidentifiable>,
    /// Parameters the runs do not determine, held near their start
    /// ([`crate::base`]); in the JSON only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<crate::base::Held>,
    /// Validation runs that depend on held parameters the fitted runs do not determine
    /// ([`crate::base::BaseModel::validation`]); in the JSON only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub undetermined_validation: Vec<(String, Vec<crate::base::Term>)>,
    /// Identified parameters the runs barely determine ([`WeaklyDetermined`]); in the JSON
    /// only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub weakly_determined: Vec<WeaklyDetermined>,
    pub fit: Fit,
    /// The noise the fit assumed where it is not the stated white noise ([`crate::noise`]),
    /// one sentence per set-up; in the JSON only when there is one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub noise: Vec<String>,
    /// Validation runs: not fitted; how well the identified model predicts them.
    pub validation: Vec<RunFit>,
    /// The instruments' own diagnostics in their users' terms (a ball-bar's circle pairs),
    /// with the model's value and what stands behind it ([`crate::diagnostics`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub diagnostics: Vec<crate::diagnostics::DiagnosisReport>,
    /// The location errors cycle by cycle where the runs overlap in time (R-test sets
    /// repeated between load cycles), each cycle's own value beside the model's
    /// ([`crate::series`]); in the JSON only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub location_series: Vec<crate::series::LocationSeries>,
    /// Where the fitted runs' residuals depart from their noise (FORMATS.md `mismatch`).
    pub mismatch: mtcal_mismatch::Mismatch,
    /// Every structure test behind `mismatch`, one sentence each for the rejected ones; in the
    /// JSON as `mismatch_tests`.
    #[serde(rename = "mismatch_tests")]
    pub mismatch_detail: Vec<String>,
    /// Every structure test behind `mismatch` (for the physics search's sentences).
    #[serde(skip)]
    pub tests: Vec<mtcal_mismatch::TestRecord>,
    /// What the physics search added, in the order it added them (FORMATS.md `discoveries`);
    /// empty without `--search`.
    pub discoveries: Vec<crate::findings::Discovery>,
    /// How the search went: candidates, every trial and why it was kept or not, effects the
    /// data cannot tell from the fitted parameters. Only with `--search`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search: Option<crate::findings::SearchReport>,
    pub solver: SolverReport,
    /// Which instrument and run constrain each identified machine parameter, and what
    /// repeating a run would do ([`crate::information`]); in the JSON when computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub information: Option<crate::information::InformationAccount>,
    /// What the parameters' numbers mean: errors, ISO 230-1 signs, the squareness definition,
    /// rotary direction, units ([`mtcal_machine::card::ConventionCard::mtcal_parameters`]).
    pub conventions: mtcal_machine::card::ConventionCard,
    /// The verdicts against a tolerance file (`identify --acceptance FILE`,
    /// [`mtcal_acceptance`]); in the JSON, last, only then.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub acceptance: Option<mtcal_acceptance::Acceptance>,
    /// The solution vector (SI), for predictions; not written to the JSON.
    #[serde(skip)]
    pub x: Vec<f64>,
}

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

    fn build(
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
        let mut id = Identification {
            schema: "mtcal.identify/1",
            verdict: None,
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
            mismatch: analysis.mismatch.clone(),
            mismatch_detail: analysis.describe(),
            tests: analysis.tests.clone(),
            discoveries: Vec::new(),
            search: None,
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
            information: None,
            conventions: mtcal_machine::card::ConventionCard::mtcal_parameters(
                study.model.machine(),
            ),
            acceptance: None,
            x,
        };
        id.verdict = id.verdict();
        Ok(id)
    }

    /// The FORMATS.md JSON (`mtcal.identify/1`, with mtcal's additional keys).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the report serialises") + "\n"
    }

    /// The verdict a person reads first: did the fit converge, and does the model explain the
    /// recordings? `None` when both hold.
    pub fn verdict(&self) -> Option<String> {
        if !self.solver.converged {
            return Some(format!(
                "NOT CONVERGED ({:?}) after {} iterations: the numbers below are the last iterate, \
                 not a calibration",
                self.solver.termination, self.solver.iterations
            ));
        }
        if !self.model_explains_recordings() {
            let worst = self
                .fit
                .runs
                .iter()
                .flat_map(|r| r.channels.iter().map(move |c| (r, c)))
                .max_by(|a, b| a.1.chi2.total_cmp(&b.1.chi2));
            let total: f64 = self
                .fit
                .runs
                .iter()
                .flat_map(|r| &r.channels)
                .map(|c| c.chi2)
                .sum();
            let at = worst.map_or(String::new(), |(r, c)| {
                format!(
                    "; most of it in run `{}`, channel {} (rms {:.3} {}, {:.0} % of the χ²)",
                    r.name,
                    c.name,
                    c.rms,
                    c.unit,
                    100.0 * c.chi2 / total.max(f64::MIN_POSITIVE)
                )
            });
            return Some(format!(
                "THE MODEL DOES NOT EXPLAIN THE RECORDINGS: chi2/dof {:.2} where the noise alone \
                 gives {:.2} ± {:.2}{at}. The parameters below are not a calibration: check the \
                 set-up (R-test `mount`, units, axis signs) or look for what the model leaves \
                 out (--search)",
                self.fit.chi2_reduced,
                1.0,
                chi2_spread(self.fit.dof)
            ));
        }
        None
    }

    /// Whether χ²/dof lies within what noise of the stated σ could give: below twice, and
    /// below 1 + 5 standard deviations of χ²/dof. A σ stated 20 % off or mildly coloured noise
    /// stays inside; readings in the wrong frame (χ²/dof of 50) do not.
    pub fn model_explains_recordings(&self) -> bool {
        chi2_within_noise(self.fit.chi2_reduced, self.fit.dof)
    }

    /// A plain-text summary for the terminal (a long parameter table summarised).
    pub fn summary(&self) -> String {
        self.summary_with(false)
    }

    /// [`Self::summary`], every parameter and combination on its own line when `verbose`.
    pub fn summary_with(&self, verbose: bool) -> String {
        let mut s = String::new();
        if let Some(v) = self.verdict() {
            let _ = writeln!(s, "{v}\n");
        }
        let _ = writeln!(
            s,
            "fit: rms {:.3} um, chi2/dof {:.3} ({} dof), {} iterations{}, rank {}/{}, condition {:.3e}",
            self.fit.rms_um,
            self.fit.chi2_reduced,
            self.fit.dof,
            self.solver.iterations,
            if self.solver.converged {
                ""
            } else {
                " (NOT converged)"
            },
            self.solver.rank,
            self.solver.parameters,
            self.solver.condition_number
        );
        for line in &self.noise {
            let _ = writeln!(
                s,
                "noise (from the residuals; the fit weighs by it): {line}"
            );
        }
        let _ = if self.solver.converged && self.model_explains_recordings() {
            writeln!(s, "\nidentified parameters (95 % intervals):")
        } else {
            writeln!(
                s,
                "\nfitted values (NOT a calibration: see the first line; 95 % intervals):"
            )
        };
        // A long table (a rich model) is summarised on the screen: single-valued errors in
        // full, a component error's coefficients on one line, set-up parameters counted; every
        // number is in the JSON and with `--verbose`.
        let concise =
            !verbose && self.parameters.len() + self.combinations.len() > SCREEN_PARAMETERS;
        let mut components: Vec<(String, Vec<&ParameterValue>)> = Vec::new();
        let mut setup = 0;
        for p in &self.parameters {
            if concise && p.kind != "machine" && p.kind != "effect" {
                setup += 1;
                continue;
            }
            if concise && let Some((component, _)) = p.name.split_once('.') {
                match components.iter_mut().find(|(c, _)| c == component) {
                    Some((_, list)) => list.push(p),
                    None => components.push((component.to_string(), vec![p])),
                }
                continue;
            }
            let _ = writeln!(
                s,
                "  {:<24} {:>12.4} ± {:<10.4} {:<5} {}{}",
                p.name,
                unsigned_zero(p.value, 4),
                p.u95,
                p.unit,
                if p.kind == "machine" { "" } else { &p.kind },
                given_held(p.u95_given_held, p.u95)
            );
        }
        for (component, list) in &components {
            if list.len() > SCREEN_TERMS {
                // A joint model's gains: dozens, each meaningful only with the others.
                let _ = writeln!(
                    s,
                    "  {component:<6} {} coefficients (in the JSON, or --verbose)",
                    list.len()
                );
                continue;
            }
            let terms: Vec<String> = list
                .iter()
                .map(|p| {
                    let term = p.name.split_once('.').map_or("", |(_, t)| t);
                    format!("{term} {:.2} ± {:.2}", unsigned_zero(p.value, 2), p.u95)
                })
                .collect();
            let _ = writeln!(s, "  {component:<6} {} {}", terms.join(", "), list[0].unit);
        }
        if setup > 0 {
            let _ = writeln!(
                s,
                "  and {setup} set-up parameters (ball, pivot, tool…; in the JSON, or --verbose)"
            );
        }
        if !self.combinations.is_empty() {
            let _ = writeln!(
                s,
                "\nidentified combinations (these runs cannot separate their members; 95 % intervals):"
            );
            let mut hidden = 0;
            for c in &self.combinations {
                if concise && (c.name.contains('.') || c.kind != "machine") {
                    hidden += 1;
                    continue;
                }
                // The four largest terms on the screen; all of them in the JSON.
                let shown = crate::base::expression(&c.name, &c.terms[..c.terms.len().min(4)]);
                let more = if c.terms.len() > 4 { " + …" } else { "" };
                let _ = writeln!(
                    s,
                    "  {:<40} {:>12.4} ± {:<10.4} {}{}",
                    format!("{shown}{more}"),
                    unsigned_zero(c.value, 4),
                    c.u95,
                    c.unit,
                    given_held(c.u95_given_held, c.u95)
                );
            }
            if hidden > 0 {
                let _ = writeln!(
                    s,
                    "  and {hidden} of component coefficients and set-up parameters (in the JSON, \
                     or --verbose)"
                );
            }
        }
        self.write_unidentifiable(&mut s);
        if !self.weakly_determined.is_empty() {
            let _ = writeln!(
                s,
                "\nweakly determined by these runs (the numbers above are given, but mean little):"
            );
            for w in &self.weakly_determined {
                let _ = writeln!(s, "  {}: {}", w.parameters.join(", "), w.why);
            }
        }
        if let Some(acceptance) = &self.acceptance {
            s.push_str(&acceptance.summary());
        }
        if self.mismatch.detected {
            let _ = writeln!(
                s,
                "\nmismatch: the residuals are not noise (family-wise α = 5 %):"
            );
            // Where the excess lies on the screen; every test with its p-value in the JSON
            // (`mismatch_tests`).
            let located: Vec<&String> = self
                .mismatch_detail
                .iter()
                .filter(|l| l.contains("of the excess"))
                .collect();
            let shown: Vec<&String> = if located.is_empty() {
                self.mismatch_detail.iter().take(SCREEN_MISMATCH).collect()
            } else {
                located.into_iter().take(SCREEN_MISMATCH).collect()
            };
            for line in &shown {
                let _ = writeln!(s, "  {line}");
            }
            let rejected = self
                .mismatch_detail
                .iter()
                .filter(|l| !l.contains("of the excess"))
                .count();
            let _ = writeln!(
                s,
                "  ({rejected} structure tests reject the noise; each with its p-value in the JSON, \
                 `mismatch_tests`)"
            );
        } else {
            let _ = writeln!(
                s,
                "\nmismatch: none found (every fitted run's residuals pass the structure tests, \
                 family-wise α = 5 %)"
            );
        }
        let _ = writeln!(s, "\nruns:");
        for r in self.fit.runs.iter().chain(&self.validation) {
            let role = if self.validation.contains(r) {
                "validate"
            } else {
                "fit"
            };
            let chans: Vec<String> = r
                .channels
                .iter()
                .map(|c| format!("{} {:.3}", c.name, c.rms))
                .collect();
            let _ = writeln!(
                s,
                "  {:<22} {:<8} {:<8} rms {:.3} um  ({})",
                r.name,
                r.instrument,
                role,
                r.rms_um,
                chans.join(", ")
            );
            for m in &r.metrics {
                let value = unsigned_zero(m.value, 3);
                let _ = writeln!(s, "  {:<22}   {}: {value:.3} {}", "", m.name, m.unit);
            }
        }
        if !self.diagnostics.is_empty() {
            let _ = writeln!(
                s,
                "\ndiagnostics in the instruments' terms (ranked by their contribution; 95 % intervals):"
            );
            for d in &self.diagnostics {
                s.push_str(&d.summary(verbose));
            }
        }
        if !self.location_series.is_empty() {
            s.push_str(&crate::series::summary(&self.location_series, verbose));
        }
        for (run, terms) in &self.undetermined_validation {
            let named: Vec<String> = terms
                .iter()
                .map(|t| format!("{} ({:.2} per unit)", t.name, t.coefficient))
                .collect();
            let _ = writeln!(
                s,
                "  {run}: its prediction depends on what the fitted runs do not determine: {}; \
                 a fitted run that moves them (another angle or position) would",
                named.join(", ")
            );
        }
        s
    }
}

/// `(± u if the undetermined are at their start)` where that interval is clearly narrower than
/// the full one: the runs alone say more than the held parameters' prior lets them.
fn given_held(u95: Option<f64>, full: f64) -> String {
    match u95 {
        Some(u) if u < 0.8 * full => format!("  (± {u:.4} if the undetermined are zero)"),
        _ => String::new(),
    }
}

/// Whether χ²/dof (against the stated σ) lies within what noise could give, a σ stated 20 %
/// off or mildly coloured included: below twice, and below 1 + 5 standard deviations of χ²/dof
/// ([`Identification::model_explains_recordings`]).
pub fn chi2_within_noise(chi2_reduced: f64, dof: usize) -> bool {
    chi2_reduced <= (1.0 + 5.0 * chi2_spread(dof)).max(2.0)
}

/// One standard deviation of χ²/dof for pure noise: `√(2/dof)`.
fn chi2_spread(dof: usize) -> f64 {
    (2.0 / dof.max(1) as f64).sqrt()
}

/// Parameters and combinations beyond this make the screen summary concise.
const SCREEN_PARAMETERS: usize = 30;

/// Coefficients of one component or effect shown on one line of the concise table; more are
/// counted.
const SCREEN_TERMS: usize = 8;

/// At most this many lines of where the residuals are not noise on the screen.
const SCREEN_MISMATCH: usize = 6;

/// Null-space directions longer than this are named by their largest members on the screen.
const SCREEN_MEMBERS: usize = 6;
/// At most this many null-space directions on the screen; all of them are in the JSON.
const SCREEN_DIRECTIONS: usize = 8;

impl Identification {
    /// What the runs cannot determine, readable on a screen: held parameters grouped by why,
    /// short null directions as they are, long ones by their size; the full list is in the
    /// JSON.
    fn write_unidentifiable(&self, s: &mut String) {
        let held_names: Vec<&str> = self.held.iter().map(|h| h.name.as_str()).collect();
        let directions: Vec<&Unidentifiable> = self
            .unidentifiable
            .iter()
            .filter(|u| {
                !(u.parameters.len() == 1 && held_names.contains(&u.parameters[0].as_str()))
            })
            .filter(|u| !self.combinations.iter().any(|c| c.name == u.parameters[0]))
            .collect();
        if directions.is_empty() && self.held.is_empty() {
            return;
        }
        let _ = writeln!(s, "\nnot identifiable from these runs (no values given):");
        for u in directions.iter().take(SCREEN_DIRECTIONS) {
            if u.parameters.len() <= SCREEN_MEMBERS {
                let _ = writeln!(s, "  {}: {}", u.parameters.join(", "), u.why);
            } else {
                let _ = writeln!(
                    s,
                    "  a combination of {} parameters ({}, …) is not observed",
                    u.parameters.len(),
                    u.parameters[..3].join(", ")
                );
            }
        }
        if directions.len() > SCREEN_DIRECTIONS {
            let _ = writeln!(
                s,
                "  … and {} more directions (all in the JSON, `unidentifiable`)",
                directions.len() - SCREEN_DIRECTIONS
            );
        }
        let group = |f: &dyn Fn(&crate::base::HeldWhy) -> bool| -> Vec<&str> {
            self.held
                .iter()
                .filter(|h| f(&h.why))
                .map(|h| h.name.as_str())
                .collect()
        };
        use crate::base::HeldWhy;
        for (names, what) in [
            (
                group(&|w| matches!(w, HeldWhy::Aliased)),
                "seen only within the combinations above",
            ),
            (
                group(&|w| matches!(w, HeldWhy::TooWeak { .. })),
                "seen too weakly to determine (intervals in the JSON)",
            ),
            (
                group(&|w| matches!(w, HeldWhy::NotObserved)),
                "not observed at all",
            ),
        ] {
            if names.is_empty() {
                continue;
            }
            let shown: Vec<&str> = names.iter().take(10).copied().collect();
            let more = if names.len() > shown.len() {
                format!(", … ({} in all)", names.len())
            } else {
                String::new()
            };
            let _ = writeln!(s, "  {what}: {}{more}", shown.join(", "));
        }
        if !self.held.is_empty() {
            let _ = writeln!(
                s,
                "  (these {} are not given values: set-up parameters are held at their start, \
                 machine coefficients kept near it by a prior; `--suggest-model FILE` writes the \
                 model these runs identify)",
                self.held.len()
            );
        }
    }
}

/// `x`, or +0 when it prints as zero with `decimals` decimals (no `-0.0000` in a summary).
fn unsigned_zero(x: f64, decimals: i32) -> f64 {
    if (x * 10f64.powi(decimals)).round() == 0.0 {
        0.0
    } else {
        x
    }
}

/// Identified machine and set-up parameters whose 95 % interval exceeds [`WEAK_SHARE_OF_RANGE`]
/// of their plausible range (unless a prior the user set within that range is what bounds
/// it), one entry each; then groups of identified parameters whose estimates correlate beyond
/// [`WEAK_CORRELATION`] (linked pairwise), in parameter order.
fn weakly_determined(study: &Study, solution: &Solution) -> Vec<WeaklyDetermined> {
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
        let held = info.machine && study.changes().hold.contains(&info.name);
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
fn run_fit(study: &Study, r: usize, pred: &[f64]) -> RunFit {
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
fn component_curves(study: &Study, solution: &Solution) -> Vec<ComponentCurve> {
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
    /// Reports what `base` says: a parameter that stands for a combination moves from
    /// `parameters` to `combinations` (FORMATS.md: what the data cannot separate never has a
    /// value of its own), and every held parameter is named in `unidentifiable`.
    pub fn apply_base(
        &mut self,
        base: &BaseModel,
        study: &Study,
        solution: &mtcal_solve::Solution,
    ) {
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
    }
}

#[cfg(test)]
mod tests {
    use super::unsigned_zero;

    #[test]
    fn a_value_that_prints_as_zero_prints_without_a_sign() {
        assert_eq!(format!("{:.4}", unsigned_zero(-0.00004, 4)), "0.0000");
        assert_eq!(format!("{:.4}", unsigned_zero(-0.0, 4)), "0.0000");
        assert_eq!(format!("{:.4}", unsigned_zero(-0.00006, 4)), "-0.0001");
        assert_eq!(format!("{:.3}", unsigned_zero(2.5, 3)), "2.500");
    }
}
