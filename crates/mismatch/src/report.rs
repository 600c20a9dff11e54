//! What [`locate`](crate::locate) returns: the FORMATS.md `mismatch` object and the account of
//! every test behind it.

use serde::{Deserialize, Serialize};

use crate::options::Options;

/// The `mismatch` object of the `identify` JSON (FORMATS.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mismatch {
    /// Whether any test rejected white noise of the stated σ after the multiple-testing
    /// correction.
    pub detected: bool,
    /// Where, strongest evidence first within each run and channel.
    #[serde(rename = "where")]
    pub locations: Vec<Location>,
}

/// One place that carries excess: a run, a channel, a variable and a span along it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Location {
    /// Run name.
    pub run: String,
    /// Channel name.
    pub channel: String,
    /// The context variable or split along which structure was found; `null` when only the
    /// χ² test fired (excess spread evenly: σ understated, or a cause no variable orders).
    pub along: Option<String>,
    /// Start of the span, in the variable's own units (a label for a split); `null` with `along`.
    pub from: Option<f64>,
    /// End of the span (inclusive); `null` with `along`.
    pub to: Option<f64>,
    /// Fraction of the run-channel's excess χ² (`Σ r² − n`) inside the span, in [0, 1].
    pub share: f64,
}

impl Location {
    /// One sentence for a report.
    pub fn describe(&self) -> String {
        let head = format!("run {}, channel {}", self.run, self.channel);
        match (&self.along, self.from, self.to) {
            (Some(along), Some(from), Some(to)) if from == to => format!(
                "{head}: structure along {along}; {:.0} % of the excess χ² lies at {along} = {from}",
                100.0 * self.share
            ),
            (Some(along), Some(from), Some(to)) => format!(
                "{head}: structure along {along}; {:.0} % of the excess χ² lies between \
                 {along} = {from} and {to}",
                100.0 * self.share
            ),
            _ => format!(
                "{head}: χ² exceeds the stated noise, evenly — no tested variable orders the \
                 excess (is σ too small?)"
            ),
        }
    }
}

/// The tests `locate` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TestKind {
    /// χ² goodness of fit, upper tail. Detail: reduced χ².
    ChiSquare,
    /// Wald–Wolfowitz runs test on signs, two-sided. Detail: z-score (negative: clustered).
    Runs,
    /// Ljung–Box portmanteau. Detail: lag-1 autocorrelation.
    LjungBox,
    /// CUSUM of the mean. Detail: the variable's value at the largest departure.
    Cusum,
    /// Lomb–Scargle peak. Detail: the peak's period in the variable's units.
    LombScargle,
    /// Welch's ANOVA on group means. Detail: largest difference of group means (σ).
    WelchMeans,
    /// Brown–Forsythe test of group spreads. Detail: largest/smallest group standard deviation.
    BrownForsythe,
}

impl TestKind {
    /// Name for a sentence.
    pub fn label(self) -> &'static str {
        match self {
            Self::ChiSquare => "χ² goodness of fit",
            Self::Runs => "runs test on signs",
            Self::LjungBox => "Ljung–Box",
            Self::Cusum => "CUSUM of the mean",
            Self::LombScargle => "Lomb–Scargle periodogram",
            Self::WelchMeans => "Welch test of group means",
            Self::BrownForsythe => "Brown–Forsythe test of group spreads",
        }
    }

    /// What `detail` means, for a sentence.
    fn detail_label(self) -> &'static str {
        match self {
            Self::ChiSquare => "reduced χ²",
            Self::Runs => "z",
            Self::LjungBox => "lag-1 autocorrelation",
            Self::Cusum => "largest departure at",
            Self::LombScargle => "period",
            Self::WelchMeans => "largest difference of means (σ)",
            Self::BrownForsythe => "ratio of standard deviations",
        }
    }
}

/// One test on one run and channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestRecord {
    /// Run name.
    pub run: String,
    /// Channel name.
    pub channel: String,
    /// Which test.
    pub test: TestKind,
    /// The variable or split the residuals were ordered or grouped by; `None` for χ².
    pub along: Option<String>,
    /// The test statistic.
    pub statistic: f64,
    /// Unadjusted p-value.
    pub p_value: f64,
    /// Holm-adjusted p-value within the test's family.
    pub adjusted_p: f64,
    /// Whether `adjusted_p ≤ α`.
    pub rejected: bool,
    /// One more number; its meaning depends on `test` (see [`TestKind`]).
    pub detail: f64,
}

impl TestRecord {
    /// One sentence for a report.
    pub fn describe(&self) -> String {
        let along = self
            .along
            .as_deref()
            .map_or_else(String::new, |a| format!(" along {a}"));
        let verdict = if self.rejected {
            "structure"
        } else {
            "consistent with noise"
        };
        format!(
            "run {}, channel {}: {}{along}: statistic {:.4}, {} {:.4}, p = {:.3e}, adjusted \
             p = {:.3e} — {verdict}",
            self.run,
            self.channel,
            self.test.label(),
            self.statistic,
            self.test.detail_label(),
            self.detail,
            self.p_value,
            self.adjusted_p,
        )
    }
}

/// A test that was not run, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Skipped {
    /// Run name.
    pub run: String,
    /// The variable or split.
    pub along: String,
    /// Why (e.g. "constant").
    pub why: String,
}

/// Everything `locate` found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Analysis {
    /// The FORMATS.md `mismatch` object.
    pub mismatch: Mismatch,
    /// Every test run, in input order (run, channel, χ², then variables, then splits).
    pub tests: Vec<TestRecord>,
    /// Variables and splits that could not be tested.
    pub skipped: Vec<Skipped>,
    /// The options used (α, family, grid).
    pub options: Options,
}

impl Analysis {
    /// The rejected tests, one sentence each, followed by the locations.
    pub fn describe(&self) -> Vec<String> {
        let tests = self
            .tests
            .iter()
            .filter(|t| t.rejected)
            .map(TestRecord::describe);
        tests
            .chain(self.mismatch.locations.iter().map(Location::describe))
            .collect()
    }
}
