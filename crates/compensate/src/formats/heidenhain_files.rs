//! What the two Heidenhain formats share: the files a writer wrote beside the first, each said.

use std::path::{Path, PathBuf};

/// The files a Heidenhain writer wrote besides `path`, each said: a table or the card.
pub(super) fn beside(path: &Path, files: Vec<PathBuf>) -> Vec<(PathBuf, &'static str)> {
    let card = crate::card_path(path);
    files
        .into_iter()
        .filter(|f| f != path)
        .map(|f| {
            let what = if f == card {
                "the convention card: Heidenhain tables take no comments"
            } else {
                "a table the first file names"
            };
            (f, what)
        })
        .collect()
}
