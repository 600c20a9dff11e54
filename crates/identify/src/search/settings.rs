//! The search's settings: [`SearchOptions`], the held-out check's division of the data
//! ([`CrossValidation`]), the look-alike threshold ([`LOOKALIKE_BIC`]) and the session's
//! `[identify] heldout`/`folds` applied to them. The lowest of the search's modules: every phase
//! reads these, and this module uses none of them.

use crate::IdentifyError;
use crate::options::SearchKeys;
use crate::study::Study;
use mtcal_solve::Options;

/// Settings of [`search`].
///
/// [`search`]: super::search
#[derive(Debug, Clone)]
pub struct SearchOptions {
    /// Family-wise level of the score tests (Holm).
    pub alpha: f64,
    /// Effects added at most.
    pub max_steps: usize,
    /// Significant candidates refitted per step, strongest first, before giving up.
    pub tries: usize,
    /// How the held-out check divides the fitted data.
    pub cross_validation: CrossValidation,
    /// Number of blocks (per run, or of the timeline).
    pub folds: usize,
    /// Relative drop of the held-out mean square a candidate must bring (0: any drop; the score
    /// test and the information criterion already ask for evidence).
    pub min_heldout_gain: f64,
    /// One-sided level of the signed-rank test a held-out gain must pass over the folds
    /// (the blocks of the cross-validation): the folds that predict better must outweigh
    /// those that predict worse beyond chance.
    pub gain_level: f64,
    /// Only candidates of these families (`None`: every registered family).
    pub families: Option<Vec<String>>,
    /// Solver settings of every fit.
    pub solver: Options,
    /// Memory for candidates' cached series (bytes) per scoring pass: more candidates are
    /// scored in several passes.
    pub cache_bytes: usize,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self {
            alpha: 0.05,
            max_steps: 10,
            tries: 8,
            folds: 8,
            cross_validation: CrossValidation::BlocksPerRun,
            min_heldout_gain: 0.0,
            gain_level: 0.2,
            families: None,
            solver: Options::default(),
            cache_bytes: 256 << 20,
        }
    }
}

/// How the held-out check divides the fitted data (`[identify] heldout` in a session).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CrossValidation {
    /// `"blocks"`: every fitted run cut into [`SearchOptions::folds`] contiguous blocks; fold
    /// `k` is the `k`-th block of every run (every set-up stays in every training set: right
    /// for sessions of different runs, each telling something of its own).
    BlocksPerRun,
    /// `"runs"`: one fitted run at a time (leave-one-run-out): when runs repeat one experiment
    /// and a model must carry over to a run it never saw.
    Runs,
    /// `"timeline"`: the fitted samples in time order cut into [`SearchOptions::folds`]
    /// contiguous blocks: a long recording (a thermal test) where a model must predict hours it
    /// did not see.
    Timeline,
}

/// Information criterion (in units of the noise estimate) within which another candidate is a
/// look-alike of the one added: below 10, the evidence for the one over the other is not
/// "very strong" (Kass & Raftery's scale for Bayes factors).
pub const LOOKALIKE_BIC: f64 = 10.0;

/// Whether the fitted runs (two or more) are one recording cut into files
/// ([`Study::continues`]): every fitted run after the first continues the one before it.
pub(super) fn one_recording(study: &Study) -> bool {
    let continues = study.continues();
    let fitted = study.runs.iter().filter(|r| r.fit && !r.is_empty()).count();
    fitted >= 2 && continues.iter().flatten().count() == fitted - 1
}

/// `options` with the session's `[identify] heldout` (`"blocks"`, the default, or
/// `"timeline"` for one recording cut into runs; `"runs"`; `"timeline"`) and `folds` (blocks: 8 per run, 16 of a timeline).
pub(super) fn with_session_options(
    study: &Study,
    options: &SearchOptions,
) -> Result<SearchOptions, IdentifyError> {
    let mut out = options.clone();
    // Candidates are judged by χ² differences of a unit or less: every fit runs to its
    // optimum, never stopping where a creep along a second-order direction still promises a
    // few units (which a candidate's refit would then "explain").
    out.solver.settle = false;
    let bad = |key: &str, m: String| IdentifyError::Options {
        at: study.session.identify_location(key),
        key: key.into(),
        message: m,
    };
    let keys = SearchKeys::read(&study.session)?;
    match keys.heldout.as_deref() {
        // A recording cut into files is judged as the recording: its blocks are the same
        // whatever the files (eight blocks of one run, or of four runs that continue one
        // another), so a user's choice of file boundaries does not decide what is found.
        None if one_recording(study) => out.cross_validation = CrossValidation::Timeline,
        None => {}
        Some("blocks") => out.cross_validation = CrossValidation::BlocksPerRun,
        Some("runs") => out.cross_validation = CrossValidation::Runs,
        Some("timeline") => {
            out.cross_validation = CrossValidation::Timeline;
            out.folds = 16;
        }
        Some(other) => {
            let found = toml::Value::from(other);
            return Err(bad(
                "heldout",
                format!("expected \"blocks\", \"runs\" or \"timeline\", found {found}"),
            ));
        }
    }
    match keys.folds {
        None => {}
        Some(k) if k >= 2 => out.folds = k as usize,
        Some(k) => {
            return Err(bad(
                "folds",
                format!("expected a whole number ≥ 2, found {k}"),
            ));
        }
    }
    if out.cross_validation == CrossValidation::Runs
        && study.runs.iter().filter(|r| r.fit).count() < 2
    {
        return Err(bad(
            "heldout",
            "leaving runs out needs two fitted runs at least".into(),
        ));
    }
    Ok(out)
}
