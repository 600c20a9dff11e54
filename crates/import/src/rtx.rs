//! `renishaw-rtx` (placeholder until its reader lands).
use std::path::Path;

use crate::ImportError;
use crate::recording::Recording;

/// Reads an Renishaw `.rtx` file.
pub fn read_rtx(path: &Path) -> Result<Recording, ImportError> {
    Err(ImportError::Options(format!(
        "{}: renishaw-rtx is not read yet",
        path.display()
    )))
}
