//! `cargo xtask identify`: a session's errors identified ([`mtcal_identify::pipeline`]) and
//! printed, with the files asked for; with `--acceptance FILE`, checked against a tolerance
//! file ([`mtcal_acceptance`]).

use anyhow::Result;
use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use mtcal_located::Outputs;
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `identify`.
#[derive(clap::Args)]
pub(crate) struct IdentifyArgs {
    /// The session folder (or its session.toml).
    session: PathBuf,
    /// Write the result as JSON (schema mtcal.identify/1) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write every validation run's predicted readings to DIR/<run>.csv.
    #[arg(long)]
    predict: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Everything on the screen (the whole information account; otherwise its first
    /// lines, and all of it in the JSON).
    #[arg(long)]
    verbose: bool,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Run the physics search: find the effects the model left out (thermal drift,
    /// backlash, cyclic errors, omitted parameters…), add those that improve held-out
    /// prediction, and report them as discoveries.
    #[arg(long)]
    search: bool,
    /// Another session (planned, moved or extra runs, e.g. from `simulate`): print what
    /// adding its runs would do to every interval, without refitting.
    #[arg(long, value_name = "SESSION")]
    what_if: Option<PathBuf>,
    /// Write an HTML report (DIR/index.html, self-contained, SVG plots): ball-bar polar
    /// plots, residuals along time and temperatures, component errors, volumetric map,
    /// parameters, what the data cannot separate, discoveries.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Write the error model these runs identify (an .errors.toml to keep beside the
    /// URDF): the parameters they determine, without those they cannot.
    #[arg(long, value_name = "FILE")]
    suggest_model: Option<PathBuf>,
    /// Check the result against a tolerance file (mtcal.acceptance/1, docs/ACCEPTANCE.md):
    /// ISO 230-2 values per axis, ISO 230-4 G per plane, identified parameters; each value
    /// ± U decided by ISO 14253-1 (pass, fail or cannot decide), on the screen, in the JSON
    /// (`acceptance`) and in the report.
    #[arg(long, value_name = "FILE")]
    acceptance: Option<PathBuf>,
    /// Write the identified values as a parameter file (TOML, `mtcal.params/1`) to edit by
    /// hand or give to `--params`: what the session determined, the rest zero, and a header
    /// saying what was left out. The identify JSON itself is read by `--params` as well.
    #[arg(long, value_name = "FILE")]
    params_out: Option<PathBuf>,
    /// Stop the fit after this many iterations (default: the solver's own limit); a fit
    /// stopped before it converges says so first and exits 1.
    #[arg(long, value_name = "N")]
    max_iterations: Option<usize>,
}

/// `identify`: what was loaded, then (after the fit or the search) the summary and the
/// information account, what another session would add, and the files asked for.
pub(crate) fn run(args: IdentifyArgs, out: &mut impl Write) -> Result<()> {
    check_outputs(&args, &[])?;
    // The tolerance file first: a mistake in it is told before the session is read.
    let acceptance = args
        .acceptance
        .as_deref()
        .map(mtcal_acceptance::Tolerances::read)
        .transpose()?;
    let options = PipelineOptions {
        solver: {
            let defaults = mtcal_solve::Options::default();
            mtcal_solve::Options {
                threads: args.threads,
                max_iterations: args.max_iterations.unwrap_or(defaults.max_iterations),
                ..defaults
            }
        },
        search: args.search,
        acceptance,
    };
    let prepared = Prepared::load(&args.session, options)?;
    if let Some(dir) = &args.predict {
        check_outputs(&args, &prepared.prediction_paths(dir))?;
    }
    write!(out, "{}", prepared.header())?;
    let mut progress = Progress::new(args.quiet);
    let outcome = prepared.run(&mut progress);
    progress.finish();
    let outcome = outcome?;
    write!(out, "{}", outcome.screen(args.verbose))?;
    if let Some(dir) = &args.what_if {
        write!(out, "\n{}", outcome.what_if(dir)?)?;
    }
    // Every output built first, then written together: an error in any leaves none behind.
    let mut files = Outputs::new();
    if let Some(path) = &args.suggest_model {
        files.file(path, outcome.suggested_model());
    }
    if let Some(path) = &args.json {
        files.file(path, outcome.to_json());
    }
    if let Some(path) = &args.params_out {
        files.file(path, params_file(&outcome, path)?);
    }
    if let Some(dir) = &args.predict {
        files.folder(dir);
        for (path, text) in outcome.prediction_files(dir)? {
            files.file(path, text);
        }
    }
    if let Some(dir) = &args.report {
        files.folder(dir);
        files.file(dir.join("index.html"), outcome.report_page()?);
    }
    crate::commit(out, files)?;
    checks_failed(&outcome)
}

/// Exit 1 ([`crate::ChecksFailed`]) when the work is done but something asked of it is not: the
/// fit did not converge or does not explain the recordings (the verdict), or the acceptance
/// failed or could not be decided.
fn checks_failed(outcome: &mtcal_identify::pipeline::Outcome) -> Result<()> {
    let mut why = Vec::new();
    if let Some(verdict) = outcome.identification.verdict() {
        let first = verdict.split([':', '\n']).next().unwrap_or(&verdict);
        why.push(format!("the fit: {first}"));
    }
    if let Some(a) = outcome
        .acceptance
        .as_ref()
        .filter(|a| a.verdict != mtcal_acceptance::Verdict::Pass)
    {
        why.push(format!(
            "the acceptance ({}): {}",
            a.file,
            a.verdict.as_str()
        ));
    }
    match why.is_empty() {
        true => Ok(()),
        false => Err(crate::ChecksFailed(why.join("; ")).into()),
    }
}

/// The identified values as a parameter file of the session's model, with what the JSON read
/// by `--params` would say as its header ([`mtcal_machine::from_identify`]): one reading of an
/// identification, whichever file carries it.
fn params_file(
    outcome: &mtcal_identify::pipeline::Outcome,
    path: &std::path::Path,
) -> Result<String> {
    let errors = outcome.study.model.errors();
    let from = mtcal_machine::from_identify::read_identify_json(&outcome.to_json(), path, errors)?;
    let mut text: String = from
        .account("")
        .iter()
        .map(|l| format!("# {l}\n"))
        .collect();
    text.push_str(&mtcal_machine::params::write_params(errors, &from.coeffs));
    Ok(text)
}

/// Every output path of `args` checked before the fit (`predictions`: the files `--predict`
/// will write, once the session is read): a folder where the JSON goes, a file where the
/// report folder goes, a run's name too long for a file name, are told at once.
fn check_outputs(args: &IdentifyArgs, predictions: &[PathBuf]) -> Result<()> {
    let mut files = Outputs::new();
    for path in [&args.suggest_model, &args.json, &args.params_out]
        .into_iter()
        .flatten()
    {
        files.file(path, Vec::new());
    }
    for dir in [&args.predict, &args.report].into_iter().flatten() {
        files.folder(dir);
    }
    if let Some(dir) = &args.report {
        files.file(dir.join("index.html"), Vec::new());
    }
    for path in predictions {
        files.file(path, Vec::new());
    }
    files.check()?;
    Ok(())
}

/// A progress bar on standard error for long fits (hidden when quiet or not a terminal).
struct Progress {
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = (!quiet).then(|| {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} iteration {prefix} [{bar:30}] {pos}/{len} blocks {msg}",
                )
                .expect("valid template"),
            );
            bar
        });
        Self { bar }
    }
    fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

impl mtcal_solve::Observer for Progress {
    fn iteration(&mut self, it: usize, cost: f64, _lambda: f64) {
        if let Some(bar) = &self.bar {
            bar.set_prefix(it.to_string());
            bar.set_message(format!("cost {cost:.4e}"));
        }
    }
    fn rows(&mut self, done: usize, total: usize) {
        if let Some(bar) = &self.bar {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
    }
}
