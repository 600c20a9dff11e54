//! A command's outputs written as one transaction.
//!
//! A command that writes several files (a JSON result, one prediction per run, a report
//! folder) must not leave some of them behind when a later one fails: the user would take the
//! half-written set for a result. [`Outputs`] collects every file first, checks every path
//! before anything is written (a folder where a file is expected, a file where a folder is, a
//! name too long for the file system, the same file twice), writes each to a temporary sibling,
//! and renames them all at the end. On any error none of the new files remains, the old ones
//! are back, and the folders it created are gone.
//!
//! What is at an output path decides how it is written: a regular file (or nothing) is
//! replaced by a rename; a symbolic link is followed and its target written (the link stays); a
//! device or a FIFO is written through, last, after every regular file is in place — never
//! renamed over (run as root, renaming onto `/dev/null` would replace the device for every
//! program on the machine). A socket is refused.

use std::collections::HashSet;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The longest file name (bytes) the common file systems take (ext4, XFS, APFS, NTFS).
pub const NAME_MAX: usize = 255;

/// Why the outputs were not written. Nothing of them remains.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A path refused before anything was written.
    #[error("{}: {why}", path.display())]
    Refused { path: PathBuf, why: String },
    /// The file system refused a write; everything written was undone.
    #[error("cannot write {}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
}

/// What is at an output path when the transaction starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    /// Nothing: created by a rename.
    Absent,
    /// A regular file: replaced by a rename, the old one kept under a second name until the end.
    Regular,
    /// A device or FIFO: written through.
    Special,
}

/// A file to write.
#[derive(Debug)]
struct Staged {
    /// The path the user gave (for messages and the list of files written).
    given: PathBuf,
    bytes: Vec<u8>,
}

/// A file of the plan: where its bytes go (symbolic links followed) and what is there.
struct Resolved<'a> {
    given: &'a Path,
    path: PathBuf,
    target: Target,
    bytes: &'a [u8],
}

/// The files one command writes, written together or not at all (module doc).
#[derive(Debug, Default)]
pub struct Outputs {
    files: Vec<Staged>,
    folders: Vec<PathBuf>,
}

impl Outputs {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the file `path` with `bytes` (written at [`Self::commit`]).
    pub fn file(&mut self, path: impl Into<PathBuf>, bytes: impl Into<Vec<u8>>) {
        self.files.push(Staged {
            given: path.into(),
            bytes: bytes.into(),
        });
    }

    /// Adds the folder `path`, created at [`Self::commit`] if missing (its files are added with
    /// [`Self::file`]); a file there is refused.
    pub fn folder(&mut self, path: impl Into<PathBuf>) {
        self.folders.push(path.into());
    }

    /// Adds every file under `staging` (a private folder a writer filled, [`staged`]) as the
    /// same file under `target`.
    pub fn files_of(&mut self, staging: &Path, target: &Path) -> Result<(), OutputError> {
        let mut stack = vec![staging.to_path_buf()];
        while let Some(dir) = stack.pop() {
            let mut entries: Vec<PathBuf> = fs::read_dir(&dir)
                .map_err(io(&dir))?
                .map(|e| e.map(|e| e.path()))
                .collect::<Result<_, _>>()
                .map_err(io(&dir))?;
            entries.sort();
            for p in entries {
                let rel = p.strip_prefix(staging).expect("under the staging folder");
                if p.is_dir() {
                    self.folder(target.join(rel));
                    stack.push(p);
                } else {
                    let bytes = fs::read(&p).map_err(io(&p))?;
                    self.file(target.join(rel), bytes);
                }
            }
        }
        Ok(())
    }

    /// Whether nothing was added.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty() && self.folders.is_empty()
    }

    /// Checks every path as [`Self::commit`] would, writing nothing: to refuse before a long
    /// computation whose results could not be written.
    pub fn check(&self) -> Result<(), OutputError> {
        self.resolved().map(|_| ())
    }

    /// Writes every file (module doc) and returns the paths written, as given, in the order
    /// added. On an error nothing new remains and the old files are back.
    pub fn commit(self) -> Result<Vec<PathBuf>, OutputError> {
        self.commit_failing_at(None)
    }

    /// [`Self::commit`], with the rename of file `fail_at` made to fail (to test the undo).
    fn commit_failing_at(self, fail_at: Option<usize>) -> Result<Vec<PathBuf>, OutputError> {
        let plan = self.resolved()?;
        let mut tx = Transaction {
            fail_at,
            ..Transaction::default()
        };
        match tx.run(&plan) {
            Ok(()) => {
                tx.finish();
                Ok(plan.files.iter().map(|f| f.given.to_path_buf()).collect())
            }
            Err(e) => {
                tx.undo();
                Err(e)
            }
        }
    }

    /// Every path checked and symbolic links followed: the plan [`Self::commit`] carries out.
    fn resolved(&self) -> Result<Plan<'_>, OutputError> {
        for folder in &self.folders {
            check_folder(folder)?;
        }
        let mut seen = HashSet::new();
        let mut files = Vec::with_capacity(self.files.len());
        for f in &self.files {
            let (path, target) = resolve(&f.given)?;
            if !seen.insert(path.clone()) {
                return Err(refused(
                    &f.given,
                    "this file would be written twice (two outputs share its name)",
                ));
            }
            files.push(Resolved {
                given: &f.given,
                path,
                target,
                bytes: &f.bytes,
            });
        }
        Ok(Plan {
            files,
            folders: &self.folders,
        })
    }
}

/// Runs `write` on a private temporary folder — for a writer that puts its files straight on
/// disk — and returns its result with the folder, whose files [`Outputs::files_of`] then adds
/// under the real target. The folder goes when the returned guard drops.
pub fn staged<T, E>(
    write: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<Result<(T, tempfile::TempDir), E>, OutputError> {
    let dir = tempfile::Builder::new()
        .prefix(".mtcal-staging-")
        .tempdir()
        .map_err(io(Path::new("a temporary folder")))?;
    Ok(write(dir.path()).map(|t| (t, dir)))
}

/// What [`Outputs::commit`] does, every path resolved.
struct Plan<'a> {
    files: Vec<Resolved<'a>>,
    folders: &'a [PathBuf],
}

fn refused(path: &Path, why: impl Into<String>) -> OutputError {
    OutputError::Refused {
        path: path.to_path_buf(),
        why: why.into(),
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |cause| OutputError::Io {
        path: path.to_path_buf(),
        cause,
    }
}

/// Every component of `path` short enough for the file system, and the nearest existing
/// ancestor a folder.
fn check_names_and_parents(path: &Path) -> Result<(), OutputError> {
    for c in path.components() {
        if c.as_os_str().len() > NAME_MAX {
            return Err(refused(
                path,
                format!(
                    "a name of {} bytes, longer than the file system's {NAME_MAX}",
                    c.as_os_str().len()
                ),
            ));
        }
    }
    let mut ancestor = path.parent();
    while let Some(a) = ancestor.filter(|a| !a.as_os_str().is_empty()) {
        match fs::metadata(a) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                return Err(refused(
                    path,
                    format!("{} is a file, not a folder", a.display()),
                ));
            }
            Err(_) => ancestor = a.parent(),
        }
    }
    Ok(())
}

fn check_folder(folder: &Path) -> Result<(), OutputError> {
    check_names_and_parents(folder)?;
    match fs::metadata(folder) {
        Ok(m) if !m.is_dir() => Err(refused(
            folder,
            "a file is there, where a folder is to be written",
        )),
        _ => Ok(()),
    }
}

/// Where `path`'s bytes go (symbolic links followed) and what is there.
fn resolve(path: &Path) -> Result<(PathBuf, Target), OutputError> {
    check_names_and_parents(path)?;
    let mut at = path.to_path_buf();
    // A chain of links, followed as the system would (bounded: a loop is refused).
    for _ in 0..40 {
        let meta = match fs::symlink_metadata(&at) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if at != path {
                    check_names_and_parents(&at)?;
                }
                return Ok((at, Target::Absent));
            }
            Err(e) => return Err(io(path)(e)),
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let link = fs::read_link(&at).map_err(io(path))?;
            at = match at.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            continue;
        }
        if kind.is_dir() {
            return Err(refused(
                path,
                "a folder is there, where a file is to be written",
            ));
        }
        if kind.is_file() {
            return Ok((at, Target::Regular));
        }
        if is_socket(&kind) {
            return Err(refused(path, "a socket is there: mtcal writes files"));
        }
        return Ok((at, Target::Special));
    }
    Err(refused(path, "too many levels of symbolic links"))
}

#[cfg(unix)]
fn is_socket(kind: &fs::FileType) -> bool {
    use std::os::unix::fs::FileTypeExt;
    kind.is_socket()
}

#[cfg(not(unix))]
fn is_socket(_: &fs::FileType) -> bool {
    false
}

/// What a commit has done so far, to finish or undo.
#[derive(Default)]
struct Transaction {
    /// Folders created, outermost first.
    created: Vec<PathBuf>,
    /// Temporary files written and not yet renamed.
    temporaries: Vec<PathBuf>,
    /// Files renamed into place, with where their old version waits (`None`: there was none).
    placed: Vec<(PathBuf, Option<PathBuf>)>,
    /// A rename made to fail (tests of the undo).
    fail_at: Option<usize>,
}

/// A temporary sibling of `path` (short: a long output name leaves no room for a suffix).
fn sibling(path: &Path, k: usize, what: &str) -> PathBuf {
    let name = format!(".mtcal-{}-{k}.{what}", std::process::id());
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) => dir.join(name),
        None => PathBuf::from(name),
    }
}

impl Transaction {
    fn run(&mut self, plan: &Plan) -> Result<(), OutputError> {
        for folder in plan.folders {
            self.create_folder(folder)?;
        }
        for f in &plan.files {
            if let Some(dir) = f.path.parent().filter(|d| !d.as_os_str().is_empty()) {
                self.create_folder(dir)?;
            }
        }
        // Every regular file to a temporary sibling, on disk before any rename.
        let regular = || {
            plan.files
                .iter()
                .enumerate()
                .filter(|(_, f)| f.target != Target::Special)
        };
        for (k, f) in regular() {
            let tmp = sibling(&f.path, k, "tmp");
            self.temporaries.push(tmp.clone());
            let mut file = fs::File::create(&tmp).map_err(io(f.given))?;
            file.write_all(f.bytes).map_err(io(f.given))?;
            file.sync_all().map_err(io(f.given))?;
        }
        for (k, f) in regular() {
            // The old version kept under a second name (a hard link, or a copy where the file
            // system has none) while the new one is renamed over it: the path always holds a
            // whole file, old or new, even if the process is killed here.
            let old = match f.target {
                Target::Regular => {
                    let old = sibling(&f.path, k, "old.tmp");
                    if fs::hard_link(&f.path, &old).is_err() {
                        fs::copy(&f.path, &old).map_err(io(f.given))?;
                    }
                    Some(old)
                }
                _ => None,
            };
            self.placed.push((f.path.clone(), old));
            if self.fail_at == Some(k) {
                return Err(io(f.given)(std::io::Error::other("failure injected")));
            }
            let tmp = sibling(&f.path, k, "tmp");
            fs::rename(&tmp, &f.path).map_err(io(f.given))?;
            self.temporaries.retain(|t| *t != tmp);
        }
        // Devices and FIFOs last: a write through cannot be taken back.
        for f in plan.files.iter().filter(|f| f.target == Target::Special) {
            let mut file = fs::OpenOptions::new()
                .write(true)
                .open(&f.path)
                .map_err(io(f.given))?;
            file.write_all(f.bytes).map_err(io(f.given))?;
        }
        Ok(())
    }

    /// Creates `dir` and its missing ancestors, remembering each.
    fn create_folder(&mut self, dir: &Path) -> Result<(), OutputError> {
        let mut missing = Vec::new();
        let mut at = Some(dir);
        while let Some(a) = at.filter(|a| !a.as_os_str().is_empty() && !a.exists()) {
            missing.push(a.to_path_buf());
            at = a.parent();
        }
        for m in missing.into_iter().rev() {
            fs::create_dir(&m).map_err(io(&m))?;
            self.created.push(m);
        }
        Ok(())
    }

    /// Everything in place: the old versions go, the folders' entries reach the disk, and the
    /// temporaries of killed writes in those folders are removed.
    fn finish(self) {
        let mut dirs = HashSet::new();
        for (path, old) in &self.placed {
            if let Some(old) = old {
                let _ = fs::remove_file(old);
            }
            let dir = path
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            if dirs.insert(dir.to_path_buf()) {
                if let Ok(d) = fs::File::open(dir) {
                    let _ = d.sync_all();
                }
                remove_stale_temporaries(dir);
            }
        }
    }

    /// Takes back every step: new files removed, old ones restored, created folders removed.
    fn undo(self) {
        for tmp in &self.temporaries {
            let _ = fs::remove_file(tmp);
        }
        for (path, old) in self.placed.iter().rev() {
            match old {
                Some(old) => {
                    // The new file may not be there yet (its rename failed): restore anyway. A
                    // rename between two names of one file does nothing; then the path holds
                    // the old contents already and the second name goes.
                    let _ = fs::rename(old, path);
                    if old.exists() && fs::read(old).ok() == fs::read(path).ok() {
                        let _ = fs::remove_file(old);
                    }
                }
                None => {
                    let _ = fs::remove_file(path);
                }
            }
        }
        for dir in self.created.iter().rev() {
            let _ = fs::remove_dir(dir);
        }
    }
}

/// Removes the temporaries `.mtcal-PID-K.tmp` (a new file not yet renamed) and
/// `.mtcal-PID-K.old.tmp` (a second name of an old file, never its only copy) in `dir` left by
/// killed writes (their process no longer exists). Where processes cannot be looked up, nothing
/// is removed.
fn remove_stale_temporaries(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(pid) = file
            .to_str()
            .and_then(|f| f.strip_prefix(".mtcal-"))
            .and_then(|rest| rest.strip_suffix(".tmp"))
            .and_then(|rest| rest.split_once('-'))
            .map(|(pid, _)| pid)
            .filter(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
        else {
            continue;
        };
        if !Path::new("/proc").join(pid).exists() {
            let _ = fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut out = Vec::new();
        for e in walk(dir) {
            let rel = e.strip_prefix(dir).unwrap().display().to_string();
            let bytes = if e.is_file() {
                fs::read(&e).unwrap()
            } else {
                Vec::new()
            };
            out.push((rel, bytes));
        }
        out.sort();
        out
    }

    fn walk(dir: &Path) -> Vec<PathBuf> {
        let mut out = Vec::new();
        for e in fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            out.push(p.clone());
            if p.is_dir() && !p.is_symlink() {
                out.extend(walk(&p));
            }
        }
        out
    }

    #[test]
    fn every_file_is_written_and_no_temporary_remains() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        fs::write(d.join("o.json"), "old").unwrap();
        let mut out = Outputs::new();
        out.file(d.join("o.json"), "new");
        out.folder(d.join("rep"));
        out.file(d.join("rep/index.html"), "<html>");
        out.file(d.join("pred/a/b.csv"), "1,2");
        let written = out.commit().unwrap();
        assert_eq!(written.len(), 3);
        assert_eq!(
            listing(d),
            vec![
                ("o.json".into(), b"new".to_vec()),
                ("pred".into(), vec![]),
                ("pred/a".into(), vec![]),
                ("pred/a/b.csv".into(), b"1,2".to_vec()),
                ("rep".into(), vec![]),
                ("rep/index.html".into(), b"<html>".to_vec()),
            ]
        );
    }

    /// A report folder that is a file, a prediction name too long, a folder where the JSON
    /// goes, the same file twice: refused before anything is written.
    #[test]
    fn a_bad_path_anywhere_writes_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        fs::write(d.join("o.json"), "old").unwrap();
        fs::write(d.join("rep"), "a file").unwrap();
        fs::create_dir(d.join("dir.json")).unwrap();
        let before = listing(d);
        let long = "v".repeat(300);
        type Add<'a> = Box<dyn Fn(&mut Outputs) + 'a>;
        let cases: Vec<(Add, &str)> = vec![
            (
                Box::new(|o| {
                    o.folder(d.join("rep"));
                    o.file(d.join("rep/index.html"), "x");
                }),
                "a file is there",
            ),
            (
                Box::new(|o| o.file(d.join(format!("pred/{long}.csv")), "x")),
                "longer than the file system's 255",
            ),
            (
                Box::new(|o| o.file(d.join("dir.json"), "x")),
                "a folder is there",
            ),
            (
                Box::new(|o| {
                    o.file(d.join("p/a.csv"), "x");
                    o.file(d.join("p/a.csv"), "y");
                }),
                "written twice",
            ),
            (
                Box::new(|o| o.file(d.join("o.json/x"), "x")),
                "is a file, not a folder",
            ),
        ];
        for (add, why) in cases {
            let mut out = Outputs::new();
            out.file(d.join("o.json"), "new");
            out.file(d.join("fresh/f.txt"), "new");
            add(&mut out);
            let err = out.commit().unwrap_err().to_string();
            assert!(err.contains(why), "{err}");
            assert_eq!(listing(d), before, "{why}");
        }
    }

    /// A failure during the renames takes back the files already in place: the old ones
    /// return, the new ones and the created folders go, at whichever file it happens.
    #[test]
    fn a_failure_half_way_restores_the_old_files() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        fs::write(d.join("a.json"), "old a").unwrap();
        fs::create_dir(d.join("p")).unwrap();
        fs::write(d.join("p/c.csv"), "old c").unwrap();
        let before = listing(d);
        for k in 0..3 {
            let mut out = Outputs::new();
            out.file(d.join("a.json"), "new a");
            out.file(d.join("new/deeper/b.csv"), "b");
            out.file(d.join("p/c.csv"), "new c");
            let err = out.commit_failing_at(Some(k)).unwrap_err().to_string();
            assert!(err.contains("failure injected"), "{err}");
            assert_eq!(listing(d), before, "failing at file {k}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_followed_and_kept() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        fs::create_dir(d.join("real")).unwrap();
        fs::write(d.join("real/target.json"), "old").unwrap();
        std::os::unix::fs::symlink("real/target.json", d.join("link.json")).unwrap();
        std::os::unix::fs::symlink(d.join("real/absent.json"), d.join("dangling.json")).unwrap();
        let mut out = Outputs::new();
        out.file(d.join("link.json"), "new");
        out.file(d.join("dangling.json"), "made");
        out.commit().unwrap();
        assert!(
            fs::symlink_metadata(d.join("link.json"))
                .unwrap()
                .is_symlink()
        );
        assert_eq!(fs::read(d.join("real/target.json")).unwrap(), b"new");
        assert!(
            fs::symlink_metadata(d.join("dangling.json"))
                .unwrap()
                .is_symlink()
        );
        assert_eq!(fs::read(d.join("real/absent.json")).unwrap(), b"made");
    }
}
