//! [`SessionError`]: every way a session folder, its manifest or a run file can be wrong.

use std::io;
use std::path::{Path, PathBuf};

pub use mtcal_located::Location;

/// Why a session or run could not be loaded or written.
///
/// Where a position in a file applies, the message starts with `path:line:column:` (1-based),
/// then says what was expected and what was found.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The file could not be read at all (missing, unreadable).
    #[error("{}: cannot read: {cause}", path.display())]
    Read { path: PathBuf, cause: io::Error },
    /// The file could not be written.
    #[error("{}: cannot write: {cause}", path.display())]
    Write { path: PathBuf, cause: io::Error },
    /// The contents are wrong at `at`; `message` says what was expected and what was found.
    #[error("{at}: {message}")]
    Invalid { at: Location, message: String },
    /// Nothing was written because the result would not load back; `message` says why.
    #[error("{}: not written: {message}", path.display())]
    NotWritten { path: PathBuf, message: String },
}

impl SessionError {
    /// Where in which file the problem is; `None` for I/O failures and refused writes.
    pub fn location(&self) -> Option<&Location> {
        match self {
            SessionError::Invalid { at, .. } => Some(at),
            _ => None,
        }
    }

    pub(crate) fn invalid(at: Location, message: impl Into<String>) -> Self {
        SessionError::Invalid {
            at,
            message: message.into(),
        }
    }

    pub(crate) fn read(path: &Path, source: io::Error) -> Self {
        SessionError::Read {
            path: path.to_path_buf(),
            cause: source,
        }
    }
}

/// The location of byte `offset` of `text`, the contents of `file`.
pub(crate) fn locate(file: &Path, text: &str, offset: usize) -> Location {
    Location::of_offset(file, text, offset)
}

/// A location given directly by line and column.
pub(crate) fn at(file: &Path, line: usize, column: usize) -> Location {
    Location::at(file, line, column)
}
