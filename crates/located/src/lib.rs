//! Located reading and writing for mtcal's files.
//!
//! Every file mtcal reads is a user's file, and a problem in it is reported where it is:
//! `file:line:column: what was expected, what was found`. This crate is the one place that
//! turns a byte offset into that [`Location`], reads a file as text ([`Source`]), reads TOML
//! into typed structs through serde with located messages ([`toml`]), and writes files so that
//! an interrupted run never leaves half of one ([`write_atomically`]).
//!
//! Layer 0: it knows nothing of machines or instruments.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

pub mod outputs;
pub mod toml;
pub use outputs::{OutputError, Outputs, staged};

/// A position in a text file, 1-based, for error messages. The column counts characters, not
/// bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    pub file: PathBuf,
    pub line: usize,
    pub column: usize,
}

impl Location {
    /// The location of byte `offset` of `text`, the contents of `file` (an offset inside a
    /// character counts as that character; one past the end as the end).
    pub fn of_offset(file: &Path, text: &str, offset: usize) -> Self {
        let mut end = offset.min(text.len());
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let before = &text[..end];
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        Location {
            file: file.to_path_buf(),
            line: before.matches('\n').count() + 1,
            column: before[line_start..].chars().count() + 1,
        }
    }

    /// A location given directly by line and column.
    pub fn at(file: &Path, line: usize, column: usize) -> Self {
        Location {
            file: file.to_path_buf(),
            line,
            column,
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// Something wrong at a place in a file: `at: message`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{at}: {message}")]
pub struct Located {
    pub at: Location,
    pub message: String,
}

/// Why a file could not be read as text.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// Missing or unreadable.
    #[error("{}: cannot read: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// Not UTF-8 text; located at the first byte that is not.
    #[error(transparent)]
    NotText(Located),
}

/// A text file as read: its path (as given, for messages) and its contents without a
/// byte-order mark.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Source {
    pub path: PathBuf,
    pub text: String,
}

/// The message for bytes that are not UTF-8.
pub const NOT_UTF8: &str =
    "expected UTF-8 text, found a byte that is not UTF-8 (save the file as UTF-8)";

impl Source {
    /// Reads `path` as UTF-8 text; a leading byte-order mark is dropped (editors on Windows
    /// write one, and the formats accept it).
    pub fn read(path: &Path) -> Result<Source, ReadError> {
        let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
            path: path.to_path_buf(),
            cause: source,
        })?;
        Source::from_bytes(path, bytes)
    }

    /// Text from bytes read elsewhere; `path` names them in messages.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Source, ReadError> {
        match String::from_utf8(bytes) {
            Ok(text) => Ok(Source::new(path, text)),
            Err(e) => {
                let valid = e.utf8_error().valid_up_to();
                let bytes = e.into_bytes();
                let prefix = String::from_utf8_lossy(&bytes[..valid]);
                Err(ReadError::NotText(Located {
                    at: Location::of_offset(path, &prefix, valid),
                    message: NOT_UTF8.to_string(),
                }))
            }
        }
    }

    /// Text given in memory; a leading byte-order mark is dropped.
    pub fn new(path: &Path, mut text: String) -> Source {
        if text.starts_with('\u{feff}') {
            text.drain(..'\u{feff}'.len_utf8());
        }
        Source {
            path: path.to_path_buf(),
            text,
        }
    }

    /// The location of byte `offset`.
    pub fn locate(&self, offset: usize) -> Location {
        Location::of_offset(&self.path, &self.text, offset)
    }

    /// `message` located at the start of `span`.
    pub fn at(&self, span: Range<usize>, message: impl Into<String>) -> Located {
        Located {
            at: self.locate(span.start),
            message: message.into(),
        }
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// an interrupted run leaves either the old file or the new one, never half of one: an
/// [`Outputs`] of one file (a symbolic link followed, a device or FIFO written through, a
/// folder refused). The file's data reach the disk before the rename and the folder's entry
/// after it. A missing folder is created. A run killed during the write may leave its temporary
/// file `.mtcal-PID-K.tmp` beside `path` (`path` itself is whole); the next write into that
/// folder removes those whose process is gone (on Linux, where `/proc` tells).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut out = Outputs::new();
    out.file(path, bytes);
    out.commit().map(|_| ()).map_err(|e| match e {
        OutputError::Io { cause, .. } => cause,
        refused => std::io::Error::other(refused.to_string()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_become_lines_and_character_columns() {
        let f = Path::new("f.toml");
        let text = "a = 1\nbé = 2\n";
        assert_eq!(Location::of_offset(f, text, 0).to_string(), "f.toml:1:1");
        assert_eq!(Location::of_offset(f, text, 6).to_string(), "f.toml:2:1");
        // `=` after the two-byte é is the fourth character of line 2.
        let eq = text.find("= 2").unwrap();
        assert_eq!(Location::of_offset(f, text, eq).to_string(), "f.toml:2:4");
        // Inside é, and past the end.
        assert_eq!(Location::of_offset(f, text, 8).column, 2);
        assert_eq!(Location::of_offset(f, text, 999).line, 3);
    }

    #[test]
    fn sources_drop_a_byte_order_mark_and_locate_bytes_that_are_not_utf8() {
        let f = Path::new("s.toml");
        let s = Source::from_bytes(f, b"\xef\xbb\xbfa = 1".to_vec()).unwrap();
        assert_eq!(s.text, "a = 1");
        let e = Source::from_bytes(f, b"a = 1\nb = \"\xff\"".to_vec()).unwrap_err();
        assert_eq!(e.to_string(), format!("s.toml:2:6: {NOT_UTF8}"));
        let e = Source::read(Path::new("/nonexistent/x.toml")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("/nonexistent/x.toml: cannot read: "),
            "{e}"
        );
    }

    #[test]
    fn atomic_write_replaces_whole_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.txt");
        write_atomically(&p, b"old").unwrap();
        write_atomically(&p, b"new contents").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new contents");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "no temporary file left behind");
        write_atomically(&dir.path().join("missing/deeper/x.txt"), b"x").unwrap();
        assert_eq!(
            std::fs::read(dir.path().join("missing/deeper/x.txt")).unwrap(),
            b"x"
        );
    }

    #[test]
    #[cfg(unix)]
    fn the_temporaries_of_killed_writes_are_removed_by_the_next_write() {
        if !Path::new("/proc/self").exists() {
            eprintln!("skipped: no /proc to tell whether a process is alive");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        // A process id that is not running (beyond the kernel's pid_max), and a live one (the
        // process that started this test).
        let dead = dir.path().join(".mtcal-4294967295-0.tmp");
        let live = dir.path().join(format!(
            ".mtcal-{}-0.tmp",
            std::os::unix::process::parent_id()
        ));
        // A dead process' second name of an old file (never its only copy): removed too.
        let old = dir.path().join(".mtcal-4294967295-1.old.tmp");
        // Not a temporary of mtcal's: left alone.
        let other = dir.path().join(".other-4294967295-1.tmp");
        for f in [&dead, &live, &old, &other] {
            std::fs::write(f, b"half").unwrap();
        }
        write_atomically(&p, b"whole").unwrap();
        assert!(!dead.exists(), "a dead process' temporary is removed");
        assert!(live.exists(), "a running process' temporary is left alone");
        assert!(!old.exists(), "a dead process' old version is removed");
        assert!(other.exists(), "another program's file is left alone");
        assert_eq!(std::fs::read(&p).unwrap(), b"whole");
    }
}
