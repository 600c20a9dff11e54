//! What [`locate`](crate::locate) is given: per run, whitened residuals of each channel and the
//! context they were recorded in. Borrowed slices only, so callers need not copy their data.

use crate::MismatchError;

/// One channel's whitened residuals `rᵢ = (model − measured)/σ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Channel<'a> {
    /// Channel name as the instrument calls it (`dz`, `dr`, …).
    pub name: &'a str,
    /// One residual per sample, in sample order.
    pub residuals: &'a [f64],
}

/// A continuous context variable: one value per sample (`t`, an axis letter, `T_spindle`, `S`,
/// `F`, …). Units do not matter: every test is invariant to a positive rescaling and a shift.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable<'a> {
    /// Name that reports use as `along`.
    pub name: &'a str,
    /// One value per sample.
    pub values: &'a [f64],
}

/// A categorical split: one integer label per sample (direction of motion −1/+1, CW/CCW, an
/// index into the set-up names, …). Samples with the same label form a group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split<'a> {
    /// Name that reports use as `along` (`direction`, `setup`).
    pub name: &'a str,
    /// One label per sample; reports give a span of labels as `from`/`to`.
    pub labels: &'a [i32],
}

/// Everything recorded in one run. All channels, variables and splits have one entry per sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunResiduals<'a> {
    /// Run name (unique among the runs passed to `locate`).
    pub run: &'a str,
    /// The channels; names unique within the run.
    pub channels: Vec<Channel<'a>>,
    /// Continuous context variables; names unique within the run, shared with `splits`.
    pub context: Vec<Variable<'a>>,
    /// Categorical splits.
    pub splits: Vec<Split<'a>>,
}

impl<'a> RunResiduals<'a> {
    /// A run without channels or context yet.
    pub fn new(run: &'a str) -> Self {
        Self {
            run,
            ..Self::default()
        }
    }

    /// Adds a channel.
    #[must_use]
    pub fn channel(mut self, name: &'a str, residuals: &'a [f64]) -> Self {
        self.channels.push(Channel { name, residuals });
        self
    }

    /// Adds a continuous context variable.
    #[must_use]
    pub fn context(mut self, name: &'a str, values: &'a [f64]) -> Self {
        self.context.push(Variable { name, values });
        self
    }

    /// Adds a categorical split.
    #[must_use]
    pub fn split(mut self, name: &'a str, labels: &'a [i32]) -> Self {
        self.splits.push(Split { name, labels });
        self
    }

    /// Checks names, lengths and finiteness; the first problem found is the error.
    pub(crate) fn validate(&self, min_samples: usize) -> Result<(), MismatchError> {
        self.check_names()?;
        for variable in &self.context {
            if let Some((index, value)) = finite_check(variable.values).next() {
                return Err(MismatchError::NonFiniteContext {
                    run: self.run.to_owned(),
                    variable: variable.name.to_owned(),
                    index,
                    value,
                });
            }
        }
        for channel in &self.channels {
            self.check_channel(channel, min_samples)?;
        }
        Ok(())
    }

    fn check_channel(
        &self,
        channel: &Channel<'_>,
        min_samples: usize,
    ) -> Result<(), MismatchError> {
        let n = channel.residuals.len();
        let lengths = self.context.iter().map(|v| (v.name, v.values.len()));
        let lengths = lengths.chain(self.splits.iter().map(|s| (s.name, s.labels.len())));
        for (variable, found) in lengths {
            if found != n {
                return Err(MismatchError::LengthMismatch {
                    run: self.run.to_owned(),
                    channel: channel.name.to_owned(),
                    variable: variable.to_owned(),
                    expected: n,
                    found,
                });
            }
        }
        if let Some((index, value)) = finite_check(channel.residuals).next() {
            return Err(MismatchError::NonFiniteResidual {
                run: self.run.to_owned(),
                channel: channel.name.to_owned(),
                index,
                value,
            });
        }
        if n < min_samples {
            return Err(MismatchError::TooFewSamples {
                run: self.run.to_owned(),
                channel: channel.name.to_owned(),
                found: n,
                min: min_samples,
            });
        }
        Ok(())
    }

    fn check_names(&self) -> Result<(), MismatchError> {
        let channels = self.channels.iter().map(|c| c.name);
        if let Some(name) = first_duplicate(channels) {
            return Err(self.duplicate(name, "channel"));
        }
        let along = self
            .context
            .iter()
            .map(|v| v.name)
            .chain(self.splits.iter().map(|s| s.name));
        if let Some(name) = first_duplicate(along) {
            return Err(self.duplicate(name, "context variable or split"));
        }
        Ok(())
    }

    fn duplicate(&self, name: &str, what: &'static str) -> MismatchError {
        MismatchError::DuplicateName {
            run: self.run.to_owned(),
            name: name.to_owned(),
            what,
        }
    }
}

/// Indices and values of the non-finite entries.
fn finite_check(values: &[f64]) -> impl Iterator<Item = (usize, f64)> + '_ {
    values
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, v)| !v.is_finite())
}

/// The first name that occurs twice.
pub(crate) fn first_duplicate<'n>(names: impl Iterator<Item = &'n str>) -> Option<&'n str> {
    let mut seen = std::collections::BTreeSet::new();
    names.into_iter().find(|&name| !seen.insert(name))
}
