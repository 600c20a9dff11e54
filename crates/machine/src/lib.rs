//! Machine descriptions for mtcal: standard URDF files, topology codes such as `wCAFYXZt`, the
//! error-model configuration that lives beside a URDF, and parameter-value files.
//!
//! This crate turns files into `mtcal-kinematics` types; it holds no kinematics of its own.
//! Beside the files: axis positions and map grids as the command line writes them
//! ([`axis_text`]) and a machine described for a reader ([`describe()`]).

pub mod axis_text;
pub mod config;
mod describe;
pub mod params;
pub mod topology;
pub mod urdf;

pub use describe::describe;

use mtcal_kinematics::{Machine, ParamConfig};
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A machine and the error model configured for it.
#[derive(Debug, Clone)]
pub struct LoadedMachine {
    pub machine: Machine,
    pub config: Vec<ParamConfig>,
    /// Where the machine came from: a file path or `topology code …`.
    pub source: String,
    /// Where the error model came from: the `.errors.toml` path or the default.
    pub config_source: String,
}

/// Why a machine could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Urdf(#[from] urdf::UrdfError),
    #[error(transparent)]
    Topology(#[from] topology::TopologyError),
    #[error(transparent)]
    Config(#[from] config::ConfigError),
    #[error("{path}: no such file, and `{arg}` is not a topology code either ({why})")]
    NotFound {
        path: PathBuf,
        arg: String,
        why: topology::TopologyError,
    },
}

/// Loads a machine from a URDF path or a topology code, with its error model: the
/// `<stem>.errors.toml` beside a URDF if there is one, else the full ISO model
/// ([`config::default_config`]).
pub fn load_machine(arg: &str, reading: topology::Reading) -> Result<LoadedMachine, LoadError> {
    let path = Path::new(arg);
    if path.is_file() || arg.ends_with(".urdf") {
        if !path.is_file() {
            let why = match topology::parse_code(arg, reading) {
                Err(e) => e,
                Ok(_) => unreachable!("a path ending in .urdf is no topology code"),
            };
            return Err(LoadError::NotFound {
                path: path.to_path_buf(),
                arg: arg.to_string(),
                why,
            });
        }
        let machine = urdf::load_urdf_file(path)?;
        let cfg_path = config::config_path_for(path);
        let (config, config_source) = if cfg_path.is_file() {
            (
                config::load_config(&cfg_path, &machine)?,
                cfg_path.display().to_string(),
            )
        } else {
            (
                config::default_config(&machine),
                "full ISO model: no .errors.toml beside the URDF".to_string(),
            )
        };
        return Ok(LoadedMachine {
            machine,
            config,
            source: path.display().to_string(),
            config_source,
        });
    }
    let code = topology::parse_code(arg, reading)?;
    let machine = topology::nominal_machine(&code, arg)?;
    Ok(LoadedMachine {
        config: config::default_config(&machine),
        source: format!("topology code {code}"),
        config_source: "full ISO model".to_string(),
        machine,
    })
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// an interrupted run leaves either the old file or the new one, never half of one. The file's
/// data reach the disk before the rename and the folder's entry after it. A missing folder is
/// created. A run killed during the write may leave its temporary file `.NAME.PID.tmp` beside
/// `path` (`path` itself is whole); the next write of `path` removes those whose process is
/// gone (on Linux, where `/proc` tells).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)?;
        // The rename itself to disk (a folder opens for reading on Unix; elsewhere skip).
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    } else {
        remove_stale_temporaries(dir, &name);
    }
    result
}

/// Removes `.NAME.PID.tmp` files in `dir` left by killed writes of `NAME` (their process no
/// longer exists). Where processes cannot be looked up, nothing is removed.
fn remove_stale_temporaries(dir: &Path, name: &str) {
    let proc = Path::new("/proc/self");
    if !proc.exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(pid) = file
            .to_str()
            .and_then(|f| f.strip_prefix(&prefix))
            .and_then(|rest| rest.strip_suffix(".tmp"))
            .filter(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
        else {
            continue;
        };
        if !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// A position in a text file, 1-based, for error messages.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    pub file: PathBuf,
    pub line: usize,
    pub column: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let dead = dir.path().join(".out.json.4294967295.tmp");
        let live = dir.path().join(format!(
            ".out.json.{}.tmp",
            std::os::unix::process::parent_id()
        ));
        let other = dir.path().join(".other.json.4294967295.tmp");
        for f in [&dead, &live, &other] {
            std::fs::write(f, b"half").unwrap();
        }
        write_atomically(&p, b"whole").unwrap();
        assert!(!dead.exists(), "a dead process' temporary is removed");
        assert!(live.exists(), "a running process' temporary is left alone");
        assert!(other.exists(), "another file's temporary is left alone");
        assert_eq!(std::fs::read(&p).unwrap(), b"whole");
    }
}
