//! The identification as `mtcal identify` runs it, from the session folder to everything the
//! command prints and writes: the parameters the runs cannot determine held ([`crate::base`]),
//! the fit or the physics search ([`crate::search`]), prediction bands, the information account
//! ([`crate::information`]); the verdicts against a tolerance file when one is given
//! ([`crate::acceptance`]); then, on request, what another session's runs would add, the
//! suggested error model, the JSON, the validation runs' predictions and the HTML report
//! ([`crate::html_report`]).
//!
//! Two steps, so that a command line can say what it loaded before a long fit:
//! [`Prepared::load`], then [`Prepared::run`] to an [`Outcome`].

use crate::IdentifyError;
use crate::base::{BaseModel, identifiable_study, suggested_model};
use crate::report::{Identification, IdentifyJson};
use crate::search::{SearchOptions, Searched};
use crate::study::Study;
use mtcal_solve::{Observer, Options, Solution};
use std::fmt;
use std::path::{Path, PathBuf};

/// Lines of the information account on the screen without `verbose` (all in the JSON).
const ACCOUNT_LINES: usize = 12;

/// What [`identify`] returns: the study fitted (the parameters the runs cannot determine
/// held), its solution, the report with [`BaseModel`] applied, and the model (`None` when the
/// session names its parameters).
#[derive(Debug)]
pub struct Identified {
    pub study: Study,
    pub solution: Solution,
    pub identification: Identification,
    pub base: Option<BaseModel>,
}

/// [`identifiable_study`], then the fit on the noise the residuals show ([`fit_on_its_noise`]),
/// then the report with the model applied: what `mtcal identify` does before its extras.
pub fn identify(
    study: Study,
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<Identified, IdentifyError> {
    let (study, base) = identifiable_study(study, options)?;
    fit(study, base, options, observer)
}

/// The fit of `study` (already reduced to `base`) on the noise its residuals show
/// ([`fit_on_its_noise`]), the report with the model applied.
fn fit(
    study: Study,
    base: Option<BaseModel>,
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<Identified, IdentifyError> {
    let (study, solution) = fit_on_its_noise(study, options, observer)?;
    let mut identification = Identification::new(&study, &solution)?;
    if let Some(base) = &base {
        identification = identification.with_base(base, &study, &solution);
    }
    Ok(Identified {
        study,
        solution,
        identification,
        base,
    })
}

/// The fit of `study`, then — when its residuals show noise larger than the stated σ or
/// coloured ([`crate::noise`]), and the model explains the recordings within what such noise
/// gives — the fit again on that noise, from the first fit's solution.
///
/// The intervals of a fit are only as honest as the noise it assumes. Instruments' recordings
/// are rarely the white noise of the σ their files state: a filter or a wandering air path
/// makes neighbouring samples share their error. With AR(1) noise of φ = 0.6 and a σ stated
/// 20 % small, the stated-σ fit printed 95 % intervals that held the truth in 60 % of the
/// sessions (172 of 287, the worst 3.7 intervals off; the independent simulator,
/// `crates/history/tests/suite/independent_campaigns.rs`), and 97 % on this noise. The physics
/// search already fitted on it; the plain fit now does too, and says so (`noise` in the
/// summary and the JSON). A session whose recordings are what they state is fitted once,
/// exactly as before.
fn fit_on_its_noise(
    study: Study,
    options: &Options,
    observer: &mut dyn Observer,
) -> Result<(Study, Solution), IdentifyError> {
    let specs = crate::param_specs(&study);
    let solution = mtcal_solve::solve(&crate::FitProblem::new(&study), &specs, options, observer)?;
    // A model that does not explain the recordings keeps the stated σ, so that its verdict
    // stands: re-weighing by residuals that are structure would hide it.
    let explains = crate::report::chi2_within_noise(solution.chi2_reduced, solution.dof);
    if !explains {
        return Ok((study, solution));
    }
    let Some(study) = crate::noise::rebuilt_on_estimate(&study, &solution.x)? else {
        return Ok((study, solution));
    };
    let specs = crate::param_specs_from(&study, &solution.x);
    let solution = mtcal_solve::solve(&crate::FitProblem::new(&study), &specs, options, observer)?;
    Ok((study, solution))
}

/// The physics search from `study` (already reduced to `base`) with the model applied to its
/// result; also the fit it started from and what it found.
fn physics_search(
    study: Study,
    base: Option<BaseModel>,
    solver: &Options,
) -> Result<(Identified, Searched), IdentifyError> {
    let options = SearchOptions {
        solver: solver.clone(),
        ..Default::default()
    };
    let mut result = crate::search::search(study, &options)?;
    if let Some(base) = &base {
        result = result.with_base(base)?;
    }
    let identified = Identified {
        study: result.study,
        solution: result.solution,
        identification: result.identification,
        base,
    };
    let searched = Searched {
        before: result.initial,
        before_x: result.initial_solution.x,
        findings: result.findings,
    };
    Ok((identified, searched))
}

/// How [`Prepared::run`] identifies.
#[derive(Debug, Clone, Default)]
pub struct PipelineOptions {
    /// The solver's settings (worker threads).
    pub solver: Options,
    /// Run the physics search after the fit: the effects the model left out.
    pub search: bool,
    /// Check the result against these tolerances (`--acceptance FILE`): its `[parameters]`
    /// names are checked against the session's model at [`Prepared::load`], the verdicts
    /// computed at the end of [`Prepared::run`].
    pub acceptance: Option<mtcal_acceptance::Tolerances>,
}

/// A session loaded and reduced to the parameters its runs can determine (without
/// `[identify] parameters`), ready to [`run`](Prepared::run).
#[derive(Debug)]
pub struct Prepared {
    /// The session as the user named it (its folder or its `session.toml`).
    session: PathBuf,
    study: Study,
    base: Option<BaseModel>,
    options: PipelineOptions,
}

impl Prepared {
    /// Loads `session` and holds what its runs cannot determine ([`identifiable_study`]);
    /// the tolerances' parameter names must be the model's.
    pub fn load(session: &Path, options: PipelineOptions) -> Result<Self, IdentifyError> {
        Self::from_study(session, Study::load(session)?, options)
    }

    /// [`Self::load`] for a study already built (a session held in memory, as the Python
    /// package builds one from arrays); `session` names it in the outputs.
    pub fn from_study(
        session: &Path,
        study: Study,
        options: PipelineOptions,
    ) -> Result<Self, IdentifyError> {
        let (study, base) = identifiable_study(study, &options.solver)?;
        if let Some(tolerances) = &options.acceptance {
            let units = crate::acceptance::model_units(&study, base.as_ref());
            tolerances.check_parameters(&|name| units.get(name).cloned())?;
        }
        Ok(Self {
            session: session.to_path_buf(),
            study,
            base,
            options,
        })
    }

    /// What was loaded, the lines `mtcal identify` prints before the fit: the session, its
    /// machine and parameters; the parameters the runs cannot determine, if any were held.
    /// The files `--predict dir` will write: one per validation run
    /// ([`crate::prediction_path`]), to check before the fit.
    pub fn prediction_paths(&self, dir: &Path) -> Vec<PathBuf> {
        self.study
            .runs
            .iter()
            .filter(|run| !run.fit)
            .map(|run| crate::prediction_path(dir, &run.name))
            .collect()
    }

    pub fn header(&self) -> String {
        let study = &self.study;
        let samples: usize = study.runs.iter().map(|r| r.len()).sum();
        let mut s = format!(
            "session {}: {} runs, {} samples; machine {} ({}); {} parameters ({} machine \
             coefficients)\n",
            self.session.display(),
            study.runs.len(),
            samples,
            study.machine.machine.name(),
            study.machine.source,
            study.layout().n_x(),
            study.layout().n_machine()
        );
        for name in study.unused_setups() {
            s.push_str(&format!(
                "warning: {}: set-up `{name}` is used by no run (is a run's `setup` misspelt?)\n",
                study.session.manifest.display()
            ));
        }
        if let Some(base) = self.base.as_ref().filter(|b| !b.held.is_empty()) {
            s.push_str(&format!(
                "model: {} parameters the runs cannot determine get no values (no [identify] \
                 parameters given; see below)\n",
                base.held.len()
            ));
        }
        s
    }

    /// The fit (`observer` follows it; the physics search reports no progress) or the physics
    /// search, the prediction bands and the information account of what the runs determine.
    pub fn run(self, observer: &mut dyn Observer) -> Result<Outcome, IdentifyError> {
        let Prepared {
            session,
            study,
            base,
            options,
        } = self;
        let (identified, search) = if options.search {
            let (identified, searched) = physics_search(study, base, &options.solver)?;
            (identified, Some(searched))
        } else {
            (fit(study, base, &options.solver, observer)?, None)
        };
        let Identified {
            study,
            solution,
            identification,
            base,
        } = identified;
        let identification = identification.with_prediction_bands(&study, &solution);
        let mut information = crate::information::account(&study, &solution)?;
        // What the runs do not determine has no value in the report, nor a line in the account.
        if let Some(base) = &base {
            information
                .parameters
                .retain(|p| !base.held.iter().any(|h| h.name == p.name));
        }
        let acceptance = options.acceptance.as_ref().map(|tolerances| {
            let evidence = crate::acceptance::evidence(&study, &solution, &identification);
            mtcal_acceptance::evaluate(tolerances, &evidence)
        });
        Ok(Outcome {
            session,
            study,
            solution,
            base,
            identification,
            search,
            information,
            acceptance,
        })
    }
}

/// Everything `mtcal identify` prints and writes, computed: the report of the final fit and,
/// beside it, what the physics search found, the information account and the acceptance
/// verdicts. Each part is built once and not changed after; the JSON is a view of them all
/// ([`Outcome::json`]).
#[derive(Debug)]
pub struct Outcome {
    /// The session as the user named it.
    pub session: PathBuf,
    /// The study of the final model (with the effects the search kept).
    pub study: Study,
    pub solution: Solution,
    /// The parameters held because the runs cannot determine them (`None` when the session
    /// names its parameters).
    pub base: Option<BaseModel>,
    /// The report of the final fit, with the validation runs' prediction bands.
    pub identification: Identification,
    /// With `--search`: the fit before it and what it found.
    pub search: Option<Searched>,
    /// Which instrument and run constrain each identified machine parameter, and what
    /// repeating a run would do ([`crate::information`]).
    pub information: crate::information::InformationAccount,
    /// The verdicts against a tolerance file (`identify --acceptance FILE`).
    pub acceptance: Option<mtcal_acceptance::Acceptance>,
}

impl Outcome {
    /// What `mtcal identify` prints after the fit: the summary (with the search, the model
    /// before it, the search and the model after it) and the information account — its first
    /// lines unless `verbose`.
    pub fn screen(&self, verbose: bool) -> String {
        let after = self
            .identification
            .summary_beside(verbose, self.acceptance.as_ref());
        let mut s = match &self.search {
            Some(searched) => search_screen(searched, &self.identification, after, verbose),
            None => after,
        };
        s.push('\n');
        s.push_str(&screen_lines(
            &self.information.summary(),
            verbose,
            ACCOUNT_LINES,
        ));
        s
    }

    /// The JSON view of every part ([`IdentifyJson`]).
    pub fn json(&self) -> IdentifyJson<'_> {
        IdentifyJson::of(&self.identification)
            .search(self.search.as_ref().map(|s| &s.findings))
            .information(Some(&self.information))
            .acceptance(self.acceptance.as_ref())
    }

    /// The document `mtcal identify --json` writes (`mtcal.identify/1`).
    pub fn to_json(&self) -> String {
        self.json().to_json()
    }

    /// What adding the runs of the session `extra` would do to every interval, without
    /// refitting ([`crate::information::what_if`]).
    pub fn what_if(&self, extra: &Path) -> Result<WhatIf, IdentifyError> {
        let extra_study = Study::load(extra)?;
        let after = crate::information::what_if(&self.study, &self.solution, &extra_study)?;
        let rows = after
            .into_iter()
            .filter_map(|(name, after_u95)| {
                let now = self
                    .identification
                    .parameters
                    .iter()
                    .find(|p| p.name == name)?;
                Some(WhatIfRow {
                    now_u95: now.u95,
                    unit: now.unit.clone(),
                    name,
                    after_u95,
                })
            })
            .collect();
        Ok(WhatIf {
            session: extra.to_path_buf(),
            rows,
        })
    }

    /// The error model these runs identify, as an `.errors.toml` to keep beside the URDF
    /// ([`suggested_model`]).
    pub fn suggested_model(&self) -> String {
        suggested_model(&self.study, self.base.as_ref())
    }

    /// Every validation run's predicted readings as `dir/<run>.csv` would hold them
    /// ([`crate::prediction_files`]).
    pub fn prediction_files(&self, dir: &Path) -> Result<Vec<(PathBuf, String)>, IdentifyError> {
        crate::prediction_files(&self.study, &self.solution.x, dir)
    }

    /// The HTML report's model ([`crate::html_report::report`]).
    pub fn report(&self) -> Result<mtcal_report::Report, IdentifyError> {
        crate::html_report::report(
            &self.session,
            &self.study,
            &self.solution,
            &self.identification,
            self.search.as_ref(),
            self.acceptance.as_ref(),
        )
    }

    /// The HTML report's page (`index.html` of the report folder).
    pub fn report_page(&self) -> Result<String, IdentifyError> {
        mtcal_report::render(&self.report()?).map_err(IdentifyError::Report)
    }
}

/// The screen of the physics search: the model before it (its summary when `verbose`, else
/// the final verdict and one line), the search, the model after it (`after`: its summary).
fn search_screen(
    searched: &Searched,
    final_fit: &Identification,
    after: String,
    verbose: bool,
) -> String {
    let before = &searched.before;
    let mut s = String::new();
    if verbose {
        s.push_str("before the physics search:\n");
        s.push_str(&before.summary_with(true));
    } else {
        // The verdict on the final model first; the fit before the search in one line.
        if let Some(v) = final_fit.verdict() {
            s.push_str(&format!("{v}\n\n"));
        }
        s.push_str(&format!(
            "before the physics search: fit rms {:.3} um, chi2/dof {:.3}{}\n",
            before.fit.rms_um,
            before.fit.chi2_reduced,
            validation_rms(before).map_or(String::new(), |v| format!(", validation rms {v:.3} um"))
        ));
    }
    s.push('\n');
    s.push_str(&searched.findings.summary_with(verbose));
    s.push_str("\nafter the physics search:\n");
    s.push_str(&after);
    s
}

/// RMS over every validation run with readings (µm), if any.
fn validation_rms(id: &Identification) -> Option<f64> {
    let (mut ss, mut n) = (0.0, 0usize);
    for run in &id.validation {
        for c in &run.channels {
            ss += c.rms * c.rms * c.samples as f64;
            n += c.samples;
        }
    }
    (n > 0).then(|| (ss / n as f64).sqrt())
}

/// `text` cut to its first line and `keep` more unless `verbose`, with a line saying so.
fn screen_lines(text: &str, verbose: bool, keep: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    if verbose || lines.len() <= keep + 2 {
        return text.to_string();
    }
    let mut s = lines[..=keep].join("\n");
    s.push_str(&format!(
        "\n  … {} more (--verbose, or the JSON)\n",
        lines.len() - keep - 1
    ));
    s
}

/// What another session's runs would do to the 95 % intervals ([`Outcome::what_if`]); its
/// `Display` is the table `mtcal identify --what-if` prints.
#[derive(Debug, Clone, PartialEq)]
pub struct WhatIf {
    /// The other session as the user named it.
    pub session: PathBuf,
    /// Every reported parameter, in the order of the account.
    pub rows: Vec<WhatIfRow>,
}

/// One parameter's 95 % interval now and with the other session's runs added.
#[derive(Debug, Clone, PartialEq)]
pub struct WhatIfRow {
    pub name: String,
    /// Half-widths, in `unit`.
    pub now_u95: f64,
    pub after_u95: f64,
    pub unit: String,
}

impl fmt::Display for WhatIf {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "with the runs of {} added (95 % intervals now → after):",
            self.session.display()
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "  {:<24} ±{:<10.4} → ±{:<10.4} {}",
                r.name, r.now_u95, r.after_u95, r.unit
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_account_is_cut_to_its_first_lines_unless_verbose() {
        let text: String = (0..20).map(|i| format!("line {i}\n")).collect();
        let cut = screen_lines(&text, false, 12);
        assert_eq!(cut.lines().count(), 14, "{cut}");
        assert!(cut.starts_with("line 0\n"), "{cut}");
        assert!(
            cut.contains("line 12\n") && !cut.contains("line 13"),
            "{cut}"
        );
        assert!(
            cut.ends_with("\n  … 7 more (--verbose, or the JSON)\n"),
            "{cut}"
        );
        assert_eq!(screen_lines(&text, true, 12), text);
        // Cutting one line would cost a line to say so: all of it.
        let short: String = (0..14).map(|i| format!("line {i}\n")).collect();
        assert_eq!(screen_lines(&short, false, 12), short);
    }

    #[test]
    fn the_what_if_table_lines_up_its_columns() {
        let what_if = WhatIf {
            session: PathBuf::from("more/session"),
            rows: vec![
                WhatIfRow {
                    name: "EC0Y".into(),
                    now_u95: 12.345678,
                    after_u95: 3.2,
                    unit: "urad".into(),
                },
                WhatIfRow {
                    name: "ball_x (ball-low)".into(),
                    now_u95: 0.5,
                    after_u95: 0.5,
                    unit: "um".into(),
                },
            ],
        };
        assert_eq!(
            what_if.to_string(),
            "with the runs of more/session added (95 % intervals now → after):\n\
             \x20 EC0Y                     ±12.3457    → ±3.2000     urad\n\
             \x20 ball_x (ball-low)        ±0.5000     → ±0.5000     um\n"
        );
    }
}
