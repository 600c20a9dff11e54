//! What the physics search found and how it went (FORMATS.md `discoveries` and `search`):
//! data the outcome holds beside the fit ([`crate::pipeline::Outcome`]); [`crate::search`]
//! builds them.

use serde::Serialize;

/// Blocked cross-validation of a model on its fitted runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Heldout {
    /// Mean square of the whitened held-out residuals (1 for a model as good as the noise).
    pub mean_square: f64,
    /// RMS of the held-out residuals in the channels' units (µm).
    pub rms_um: f64,
    pub samples: usize,
    /// Per fold, the mean square of its whitened held-out residuals (the scatter a gain is
    /// judged against).
    #[serde(skip)]
    pub folds: Vec<f64>,
    /// Per forecasting fold (the model fitted on the earlier part of the session predicting
    /// the next stretch), the same.
    #[serde(skip)]
    pub forecast_folds: Vec<f64>,
    /// Mean square over the forecasting folds' samples; `None` for a session too short to cut.
    #[serde(skip)]
    pub forecast_mean_square: Option<f64>,
}

/// A parameter of a discovery.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiscoveryParameter {
    pub name: String,
    pub value: f64,
    pub unit: String,
    /// 95 % half-width; `null` when the data cannot separate it, or when it is held.
    pub u95: Option<f64>,
    /// A shape (τ, a pitch) the data do not determine, held where the fit left it: an
    /// assumption of the model, not a fitted number. In the JSON only when true.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub held: bool,
}

/// A span of one axis' positions a discovery's parameters are given over
/// ([`mtcal_effects::Effect::spans`]), in the axis' file unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiscoverySpan {
    pub axis: String,
    pub from: f64,
    pub to: f64,
    /// `mm`, or `deg` for a rotary axis.
    pub unit: String,
}

impl DiscoverySpan {
    pub fn of(span: &mtcal_effects::Span) -> Self {
        let (unit, per_si) = span.unit();
        DiscoverySpan {
            axis: span.letter.to_string(),
            from: span.lo * per_si,
            to: span.hi * per_si,
            unit: unit.to_string(),
        }
    }
}

/// A machine parameter an omitted effect had biased.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correction {
    pub name: String,
    pub unit: String,
    /// Before the effect was added.
    pub before: f64,
    /// With the effect (the final fit).
    pub after: f64,
    pub u95: f64,
}

/// One effect the search added (FORMATS.md `discoveries`, with mtcal's additions).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Discovery {
    pub effect: String,
    pub axis: Option<String>,
    pub component: Option<String>,
    pub driver: Option<String>,
    /// Its label (the prefix of its parameters' names).
    pub label: String,
    pub parameters: Vec<DiscoveryParameter>,
    /// The spans of axis positions its parameters are given over (a backlash along the
    /// stroke: at the middle of the positions the fitted runs cover and its change to their
    /// positive end); nothing is said beyond them. In the JSON only when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub spans: Vec<DiscoverySpan>,
    pub rms_before_um: f64,
    pub rms_after_um: f64,
    pub heldout_rms_before_um: f64,
    pub heldout_rms_after_um: f64,
    /// RMS over the validation runs (`use = "validate"`) with readings, before and after.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_rms_before_um: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_rms_after_um: Option<f64>,
    /// Share of the excess χ² (beyond the noise) it removed.
    pub share_of_excess: f64,
    /// The score test that proposed it.
    pub statistic: f64,
    pub adjusted_p: f64,
    /// Share of it the fitted parameters could imitate.
    pub absorbed: f64,
    /// Machine parameters that moved by more than two of their standard deviations when it
    /// was added.
    pub corrected: Vec<Correction>,
    /// Where the residuals showed it before it was added, if the structure tests saw it.
    #[serde(rename = "where", skip_serializing_if = "Option::is_none")]
    pub location: Option<mtcal_mismatch::Location>,
    /// Explanations the data cannot tell from this one (then the discovery names a class of
    /// explanations, not one: the model keeps the best for its predictions). In the JSON only
    /// when there are any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub alternatives: Vec<LookAlike>,
    /// The effect with its fitted values, in words.
    pub sentence: String,
    pub explanation: String,
}

/// A trial of one candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trial {
    pub candidate: String,
    pub effect: String,
    pub statistic: f64,
    pub adjusted_p: f64,
    pub absorbed: f64,
    pub accepted: bool,
    /// Why it was kept or not.
    pub why: String,
}

/// A candidate the data cannot tell from the fitted parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Concealed {
    pub candidate: String,
    pub effect: String,
    pub absorbed: f64,
    /// The fitted parameters that imitate it.
    pub hides_behind: Vec<String>,
    /// A measurement that would separate it from them.
    pub measurement: String,
}

/// What the physics search found: the effects it added, in the order it added them
/// (FORMATS.md `discoveries`), and how it went (`search`). Its words are
/// [`SearchFindings::summary_with`].
#[derive(Debug, Clone, PartialEq)]
pub struct SearchFindings {
    pub discoveries: Vec<Discovery>,
    pub report: SearchReport,
}

/// How the search went.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SearchReport {
    /// Candidates scored at the first step.
    pub candidates: usize,
    /// Per step, every candidate refitted.
    pub steps: Vec<Vec<Trial>>,
    /// Why it stopped (in the JSON, the sentence).
    pub stopped: SearchStop,
    pub concealed: Vec<Concealed>,
    /// The final ranking's strongest candidates, one sentence each.
    pub ranking: Vec<String>,
    /// Effects a step added that the final model does not keep: a parameter the final fit
    /// does not determine, or the model predicting held-out data worse than the fit before the
    /// search. Not discoveries.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub withdrawn: Vec<Withdrawn>,
    /// Structure the final model leaves unexplained: where it is, its shape and the families
    /// that came closest. The search claims nothing for it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub remains: Vec<Remains>,
}

/// An effect a step added and the final model does not keep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Withdrawn {
    pub candidate: String,
    pub effect: String,
    pub why: String,
}

/// Structure the final model leaves in the residuals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Remains {
    /// Where it is, as in `mismatch.where`: run, channel, the variable it is ordered by (`t`,
    /// an axis position, `X direction`, a context column), the span and its share.
    #[serde(flatten)]
    pub location: mtcal_mismatch::Location,
    /// Its shape in words (a slow change in time, a local shape along X, periodic along Y
    /// with a period of 12 mm, flipping with the direction of X…).
    pub shape: String,
    /// The candidates that came closest, each with why it was not kept.
    pub closest: Vec<String>,
}

/// Why the search stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchStop {
    /// Nothing significant at the first step: the model explains the recordings.
    NothingSignificant,
    /// Nothing significant once the discoveries were in the model.
    NothingFurther,
    /// Significant candidates, but none improved both the held-out prediction and the
    /// information criterion.
    NoneImproved,
    /// As many effects added as allowed (`SearchOptions::max_steps`).
    MostAllowed { steps: usize },
    /// The fit before the search did not converge: nothing was searched.
    BaseNotConverged,
}

impl std::fmt::Display for SearchStop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SearchStop::NothingSignificant => {
                f.write_str("no candidate is significant: the model explains the recordings")
            }
            SearchStop::NothingFurther => f.write_str("no further candidate is significant"),
            SearchStop::NoneImproved => f.write_str(
                "no significant candidate improved the held-out prediction and the information \
                 criterion",
            ),
            SearchStop::MostAllowed { steps } => {
                write!(f, "{steps} effects added (the most allowed)")
            }
            SearchStop::BaseNotConverged => f.write_str(
                "the fit before the search did not converge, so nothing was searched or claimed \
                 on it: fit a model the runs determine (`[identify] parameters`), check the \
                 set-ups' starting values, or add runs that determine the weak parameters",
            ),
        }
    }
}

impl Serialize for SearchStop {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

/// Another explanation the data cannot tell from a discovery.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LookAlike {
    pub candidate: String,
    pub effect: String,
    pub label: String,
    /// Its χ² over the discovery's (noise units): what the data say for the one over the other.
    pub delta_chi2: f64,
    /// The same in the information criterion (its parameters counted).
    pub delta_bic: f64,
    /// A measurement that would tell them apart.
    pub measurement: String,
}

impl Discovery {
    /// The discovery in a few lines: what it is with its values; where it showed and what it
    /// changed; the parameters it had biased; what the data cannot tell it from.
    pub fn in_brief(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(s, "  + {}: {}", self.label, self.sentence);
        let mut evidence = Vec::new();
        if let Some(loc) = &self.location {
            evidence.push(match &loc.along {
                Some(along) => format!("seen in run {}'s {} along {along}", loc.run, loc.channel),
                None => format!("seen in run {}'s {}", loc.run, loc.channel),
            });
        }
        evidence.push(format!(
            "explains {:.0} % of the excess χ²",
            100.0 * self.share_of_excess
        ));
        evidence.push(format!(
            "held-out RMS {:.3} → {:.3} um",
            self.heldout_rms_before_um, self.heldout_rms_after_um
        ));
        if let (Some(a), Some(b)) = (self.validation_rms_before_um, self.validation_rms_after_um) {
            evidence.push(format!("validation RMS {a:.3} → {b:.3} um"));
        }
        let _ = writeln!(s, "      {}", evidence.join("; "));
        if !self.corrected.is_empty() {
            let list: Vec<String> = self
                .corrected
                .iter()
                .take(3)
                .map(|c| {
                    format!(
                        "{} by {:+.3} {} (now {:.3} ± {:.3})",
                        c.name,
                        c.before - c.after,
                        c.unit,
                        c.after,
                        c.u95
                    )
                })
                .collect();
            let more = self.corrected.len().saturating_sub(3);
            let _ = writeln!(
                s,
                "      it had biased {}{}",
                list.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            );
        }
        if let Some(first) = self.alternatives.first() {
            let names: Vec<&str> = self
                .alternatives
                .iter()
                .map(|a| a.candidate.as_str())
                .collect();
            let _ = writeln!(
                s,
                "      THESE DATA CANNOT TELL IT FROM {} — neither is the answer; to tell them apart: {}",
                names.join(" or "),
                first.measurement
            );
        }
        s
    }
}
