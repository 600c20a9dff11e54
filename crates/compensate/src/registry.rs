//! The control formats mtcal writes, registered with `inventory` ([`ControlFormat`],
//! [`Registered`]): each says its name as the user types it, what it writes, which `--axis`
//! it takes, its own options, how it writes and how its file is read back and checked. The
//! command line and [`crate::write_compensation`] find formats here by name and nowhere else,
//! so a format is its own module and one `inventory::submit!` line
//! (`tests/stub_format.rs` registers one of its own).

use crate::CompensateError;
use crate::exported::{Checked, Exported};
use crate::settings::Settings;
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

/// A format's own setting: its key in `--control-option KEY=VALUE` and what it sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlOption {
    pub key: &'static str,
    /// One line for `--help`: what it sets, its unit and its default.
    pub about: &'static str,
}

/// A control format: one registered descriptor of a kind of compensation file.
pub trait ControlFormat: Sync {
    /// Its name as the user types it (`--format fanuc`): lower case, words joined by `-`.
    fn name(&self) -> &'static str;

    /// One line for `--help`: what it writes, with `--axis` and without.
    fn about(&self) -> &'static str;

    /// Its own settings (`--control-option KEY=VALUE`); none by default. A key the format does
    /// not declare is refused before anything is written.
    fn options(&self) -> &'static [ControlOption] {
        &[]
    }

    /// Refuses an `--axis` use the format does not take (a whole-machine file given an axis, a
    /// per-axis file given none), saying what to do instead; every use by default.
    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        let _ = axis;
        Ok(())
    }

    /// Whether the file asked for with `asked` (its `--axis`) holds a reversal of linear axis
    /// `axis` (a bidirectional table of it); none by default.
    fn holds_reversal_of(&self, asked: Option<char>, axis: char) -> bool {
        let _ = (asked, axis);
        false
    }

    /// Writes the file (and those beside it) of `model` with coefficients `coeffs` to `path`,
    /// its convention card in it or beside it; says what it wrote.
    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError>;

    /// Reads `path` back as this format's file of `machine` and checks it against the
    /// control's limits in `settings`; by default the format has no reader.
    fn check(
        &self,
        machine: &Machine,
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Checked, CompensateError> {
        let _ = (machine, path, axis, settings);
        Err(CompensateError::NoReader {
            format: self.name(),
        })
    }
}

/// A format's registration: `inventory::submit!(mtcal_compensate::Registered(&MyFormat));`.
pub struct Registered(pub &'static dyn ControlFormat);

impl std::fmt::Debug for Registered {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Registered").field(&self.0.name()).finish()
    }
}

inventory::collect!(Registered);

/// Every registered format, sorted by name.
pub fn control_formats() -> Vec<&'static dyn ControlFormat> {
    let mut all: Vec<&'static dyn ControlFormat> = inventory::iter::<Registered>
        .into_iter()
        .map(|r| r.0)
        .collect();
    all.sort_by_key(|f| f.name());
    all
}

/// The format registered as `name`; an unknown name is refused with every registered one.
pub fn find_format(name: &str) -> Result<&'static dyn ControlFormat, CompensateError> {
    inventory::iter::<Registered>
        .into_iter()
        .map(|r| r.0)
        .find(|f| f.name() == name)
        .ok_or_else(|| CompensateError::UnknownFormat {
            name: name.to_string(),
            expected: one_of(&control_formats()),
        })
}

/// `a, b or c`: the formats' names.
fn one_of(formats: &[&dyn ControlFormat]) -> String {
    let names: Vec<&str> = formats.iter().map(|f| f.name()).collect();
    match names.split_last() {
        None => "no format (none is registered)".to_string(),
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
    }
}

/// One file of a registered format, as `--format` and `--axis` ask for it.
#[derive(Clone, Copy)]
pub struct Request {
    pub format: &'static dyn ControlFormat,
    /// `--axis`: which axis (or input axis) the file is of, where the format takes one.
    pub axis: Option<char>,
}

impl std::fmt::Debug for Request {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Request")
            .field("format", &self.format.name())
            .field("axis", &self.axis)
            .finish()
    }
}

impl Request {
    /// The file of format `name` with `axis`: an unknown format or an `--axis` use the format
    /// does not take is refused.
    pub fn new(name: &str, axis: Option<char>) -> Result<Self, CompensateError> {
        Self::of(find_format(name)?, axis)
    }

    /// The file of `format` with `axis`: an `--axis` use the format does not take is refused.
    pub fn of(
        format: &'static dyn ControlFormat,
        axis: Option<char>,
    ) -> Result<Self, CompensateError> {
        format.accepts_axis(axis)?;
        Ok(Request { format, axis })
    }

    /// Whether the file holds a reversal of linear axis `axis` (a bidirectional table of it).
    pub fn holds_reversal_of(&self, axis: char) -> bool {
        self.format.holds_reversal_of(self.axis, axis)
    }

    /// Writes the file of `model` with coefficients `coeffs` to `path` (atomically), its
    /// convention card in it or beside it; says what it wrote. Options the format does not
    /// take are refused first.
    pub fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        self.check_options(settings)?;
        self.format.write(model, coeffs, path, self.axis, settings)
    }

    /// Reads `path` as this file of `machine` and checks it with the limits in `settings`.
    /// Every error names the file (and line and column where the fault is on one line).
    pub fn check(
        &self,
        machine: &Machine,
        path: &Path,
        settings: &Settings,
    ) -> Result<Checked, CompensateError> {
        self.check_options(settings)?;
        let checked = self.format.check(machine, path, self.axis, settings);
        // A limit error does not name the file: it is said here, once for every format.
        checked.map_err(|e| match e {
            CompensateError::Fanuc(_)
            | CompensateError::Heidenhain(_)
            | CompensateError::Siemens(_)
            | CompensateError::Carr(_)
            | CompensateError::TooManyNodes { .. } => CompensateError::Invalid {
                file: path.to_path_buf(),
                cause: Box::new(e),
            },
            located => located,
        })
    }

    /// Refuses an option key the format does not declare.
    fn check_options(&self, settings: &Settings) -> Result<(), CompensateError> {
        let declared = self.format.options();
        let unknown = settings
            .control_options
            .keys()
            .find(|k| !declared.iter().any(|o| o.key == *k));
        match unknown {
            None => Ok(()),
            Some(key) => Err(CompensateError::UnknownOption {
                format: self.format.name(),
                key: key.to_string(),
                takes: if declared.is_empty() {
                    "none".to_string()
                } else {
                    declared
                        .iter()
                        .map(|o| o.key)
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            }),
        }
    }
}
