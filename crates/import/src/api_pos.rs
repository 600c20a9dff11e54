//! `api-pos` (placeholder until its reader lands).
use std::path::Path;

use crate::ImportError;
use crate::recording::Recording;

/// Reads an API XD `.pos` file.
pub fn read_pos(path: &Path) -> Result<Recording, ImportError> {
    Err(ImportError::Options(format!(
        "{}: api-pos is not read yet",
        path.display()
    )))
}
