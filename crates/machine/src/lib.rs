//! Machine descriptions for mtcal: standard URDF files, topology codes such as `wCAFYXZt`, the
//! error-model configuration that lives beside a URDF, and parameter-value files.
//!
//! This crate turns files into `mtcal-kinematics` types; it holds no kinematics of its own.
//! Beside the files: axis positions and map grids as the command line writes them
//! ([`axis_text`]) and a machine described for a reader ([`describe()`]).

pub mod axis_text;
pub mod card;
pub mod config;
mod describe;
pub mod from_identify;
pub mod params;
pub mod topology;
pub mod urdf;

pub use describe::describe;

use mtcal_kinematics::{Machine, ParamConfig};
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

/// Located reading and atomic writing (`mtcal-located`), which every file of a machine goes
/// through.
pub use mtcal_located::{Location, OutputError, Outputs, write_atomically};
