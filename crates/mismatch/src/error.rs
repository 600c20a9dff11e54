//! Why `locate` refused its input.

/// Bad input to [`locate`](crate::locate). Each variant names the run, channel and variable it
/// concerns and says what to fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MismatchError {
    /// A context variable or split does not have one value per sample.
    #[error(
        "run `{run}`, channel `{channel}`: `{variable}` has {found} values but the channel has \
         {expected} residuals; every context variable and split needs one value per sample"
    )]
    LengthMismatch {
        /// Run name.
        run: String,
        /// Channel name.
        channel: String,
        /// Variable or split name.
        variable: String,
        /// Number of residuals.
        expected: usize,
        /// Number of values of the variable.
        found: usize,
    },
    /// A residual is NaN or infinite.
    #[error(
        "run `{run}`, channel `{channel}`: residual {index} is {value}; residuals must be \
         finite (drop or repair that sample)"
    )]
    NonFiniteResidual {
        /// Run name.
        run: String,
        /// Channel name.
        channel: String,
        /// Sample index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A context value is NaN or infinite.
    #[error(
        "run `{run}`: context variable `{variable}` value {index} is {value}; context values \
         must be finite"
    )]
    NonFiniteContext {
        /// Run name.
        run: String,
        /// Variable name.
        variable: String,
        /// Sample index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A channel has too few samples for the tests to mean anything.
    #[error(
        "run `{run}`, channel `{channel}`: {found} samples, at least {min} are needed \
         (lower Options::min_samples or merge runs)"
    )]
    TooFewSamples {
        /// Run name.
        run: String,
        /// Channel name.
        channel: String,
        /// Samples given.
        found: usize,
        /// Samples needed.
        min: usize,
    },
    /// Two runs, two channels of a run, or two variables/splits of a run share a name.
    #[error("run `{run}`: the {what} name `{name}` is used twice; names must be unique")]
    DuplicateName {
        /// Run name.
        run: String,
        /// The repeated name.
        name: String,
        /// What kind of name.
        what: &'static str,
    },
    /// An option is out of range.
    #[error("invalid option `{option}`: {why}")]
    InvalidOption {
        /// Option name.
        option: &'static str,
        /// What is wrong.
        why: String,
    },
}
