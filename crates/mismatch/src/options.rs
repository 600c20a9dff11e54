//! Settings of [`locate`](crate::locate).

use serde::{Deserialize, Serialize};

use crate::MismatchError;
use crate::periodogram::LombScargleOptions;

/// Over which tests the family-wise false-alarm rate is held at α.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// All tests of one run (every channel, variable and split): each run on its own has at most
    /// probability α of a false alarm.
    Run,
    /// All tests of all runs passed together: the whole call has at most probability α.
    All,
}

/// Settings of [`locate`](crate::locate).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Options {
    /// Family-wise false-alarm rate.
    pub alpha: f64,
    /// Which tests form one family for Holm's correction.
    pub family: Family,
    /// Fewest samples a channel may have.
    pub min_samples: usize,
    /// Lags of the Ljung–Box test (capped at a quarter of the samples).
    pub ljung_box_lags: usize,
    /// Frequency grid of the periodogram.
    pub lomb_scargle: LombScargleOptions,
    /// Groups of a split with fewer samples are left out of its tests.
    pub min_group_samples: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            alpha: 0.05,
            family: Family::Run,
            min_samples: 20,
            ljung_box_lags: 10,
            lomb_scargle: LombScargleOptions::default(),
            min_group_samples: 5,
        }
    }
}

impl Options {
    pub(crate) fn validate(&self) -> Result<(), MismatchError> {
        let bad = |option: &'static str, why: &str| {
            Err(MismatchError::InvalidOption {
                option,
                why: why.to_owned(),
            })
        };
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return bad("alpha", "must lie strictly between 0 and 1 (e.g. 0.05)");
        }
        if self.min_samples < 8 {
            return bad(
                "min_samples",
                "must be at least 8: the tests need some samples",
            );
        }
        if self.ljung_box_lags == 0 {
            return bad("ljung_box_lags", "must be at least 1");
        }
        let grid = &self.lomb_scargle;
        let oversampling_ok = grid.oversampling.is_finite() && grid.oversampling >= 1.0;
        if !oversampling_ok || grid.max_frequencies == 0 {
            return bad(
                "lomb_scargle",
                "oversampling must be ≥ 1 and max_frequencies ≥ 1",
            );
        }
        if self.min_group_samples < 2 {
            return bad(
                "min_group_samples",
                "must be at least 2 (a variance needs two samples)",
            );
        }
        Ok(())
    }
}
