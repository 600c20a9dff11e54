//! mtcal's errors as Python exceptions: `MtcalError` and one subclass per kind of input, each
//! carrying `message`, `file`, `line` and `column` (`None` where the error has no place).
//!
//! The place comes from the error's own `Location` where its type exposes one
//! (`SessionError::location`, `ParamsError::position`), else from its message, which by
//! mtcal's rule (ARCHITECTURE.md, "Bad input is located") starts with `file:line:column:` or
//! `file:`.

use mtcal_identify::IdentifyError as RsIdentifyError;
use mtcal_located::Location;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use std::path::Path;

pyo3::create_exception!(
    _mtcal,
    MtcalError,
    PyException,
    "An mtcal error: bad input (located by `file`, `line`, `column`) or a failed computation."
);
pyo3::create_exception!(
    _mtcal,
    MachineError,
    MtcalError,
    "A machine (URDF, topology code, error model) or parameter file that cannot be used."
);
pyo3::create_exception!(
    _mtcal,
    SessionError,
    MtcalError,
    "A session (session.toml, run files, in-memory tables) that cannot be used."
);
pyo3::create_exception!(
    _mtcal,
    IdentifyError,
    MtcalError,
    "An identification that could not run (or a tolerance file that cannot be used)."
);
pyo3::create_exception!(
    _mtcal,
    SimulateError,
    MtcalError,
    "A test plan that cannot be simulated."
);

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MtcalError", py.get_type::<MtcalError>())?;
    m.add("MachineError", py.get_type::<MachineError>())?;
    m.add("SessionError", py.get_type::<SessionError>())?;
    m.add("IdentifyError", py.get_type::<IdentifyError>())?;
    m.add("SimulateError", py.get_type::<SimulateError>())?;
    // Class defaults: an exception raised from Python (or without a place) has them too.
    let base = py.get_type::<MtcalError>();
    for name in ["file", "line", "column"] {
        base.setattr(name, py.None())?;
    }
    Ok(())
}

/// Which exception class.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Kind {
    Mtcal,
    Machine,
    Session,
    Identify,
    Simulate,
}

/// An exception of `kind` with `message` and its place: `at` when the error gave one, else
/// the place its message starts with.
pub(crate) fn raise(kind: Kind, message: String, at: Option<&Location>) -> PyErr {
    let (file, line, column) = match at {
        Some(at) => (
            Some(at.file.display().to_string()),
            Some(at.line),
            Some(at.column),
        ),
        None => place_of(&message),
    };
    let err = match kind {
        Kind::Mtcal => MtcalError::new_err(message.clone()),
        Kind::Machine => MachineError::new_err(message.clone()),
        Kind::Session => SessionError::new_err(message.clone()),
        Kind::Identify => IdentifyError::new_err(message.clone()),
        Kind::Simulate => SimulateError::new_err(message.clone()),
    };
    Python::attach(|py| {
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail short of memory.
        let _ = value.setattr("message", message);
        let _ = value.setattr("file", file);
        let _ = value.setattr("line", line);
        let _ = value.setattr("column", column);
    });
    err
}

/// An error of the identification: its session's or parameter file's own location where the
/// type has one.
pub(crate) fn identify_error(e: RsIdentifyError) -> PyErr {
    let at = match &e {
        RsIdentifyError::Session(s) => s.location().cloned(),
        RsIdentifyError::Params(p) => p.position().cloned(),
        _ => None,
    };
    let kind = match &e {
        RsIdentifyError::Session(_) | RsIdentifyError::RunData { .. } => Kind::Session,
        RsIdentifyError::Machine { .. } | RsIdentifyError::Model { .. } => Kind::Machine,
        RsIdentifyError::UnknownInstrument { .. }
        | RsIdentifyError::Setup { .. }
        | RsIdentifyError::SetupShared { .. }
        | RsIdentifyError::NothingToFit { .. } => Kind::Session,
        _ => Kind::Identify,
    };
    raise(kind, e.to_string(), at.as_ref())
}

/// Any other error of `kind`, located by its message.
pub(crate) fn other(kind: Kind, e: impl std::fmt::Display) -> PyErr {
    raise(kind, e.to_string(), None)
}

/// `(file, line, column)` of a message that starts with `file:line:column: ` (the first such
/// prefix of its first line), or `(file, None, None)` when it starts with `file: ` and that
/// names a path (it exists, or has no spaces and a folder or an extension).
pub(crate) fn place_of(message: &str) -> (Option<String>, Option<usize>, Option<usize>) {
    let first = message.lines().next().unwrap_or("");
    let ends: Vec<usize> = first.match_indices(": ").map(|(i, _)| i).collect();
    for &end in &ends {
        let prefix = &first[..end];
        let mut parts = prefix.rsplitn(3, ':');
        let (col, line, file) = (parts.next(), parts.next(), parts.next());
        if let (Some(col), Some(line), Some(file)) = (col, line, file) {
            if let (Ok(line), Ok(col)) = (line.parse::<usize>(), col.parse::<usize>()) {
                if !file.is_empty() {
                    return (Some(file.to_string()), Some(line), Some(col));
                }
            }
        }
    }
    if let Some(&end) = ends.first() {
        let prefix = &first[..end];
        let looks_like_path = !prefix.contains(' ')
            && (prefix.contains('/') || prefix.contains('\\') || prefix.contains('.'));
        if Path::new(prefix).exists() || looks_like_path {
            return (Some(prefix.to_string()), None, None);
        }
    }
    (None, None, None)
}
