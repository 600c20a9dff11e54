//! What the tests of several mtcal crates share, so that a fixture is written once: where the
//! repository and its shipped files are ([`repo`], [`machine_file`]), the five-axis example's
//! eleven errors and its truth ([`params`]), the simulation plans several identification tests
//! fit ([`plans`]), seeded generators that need no crate ([`random`]) and the command line run
//! in the repository ([`cli`]).
//!
//! Only text, paths and numbers: the kit depends on no mtcal crate, so any crate's tests can use
//! it, and it is only ever a dev-dependency (`tests/architecture.rs` checks both).

pub mod cli;
pub mod params;
pub mod plans;
pub mod random;

use std::path::{Path, PathBuf};

pub use params::{ELEVEN, FIVE_AXIS_TRUTH};

/// The repository's root folder (canonical: symbolic links resolved).
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the repository root exists")
}

/// A shipped machine description, `machines/<name>` (`mcu630-cafyxz.urdf`).
pub fn machine_file(name: &str) -> PathBuf {
    repo().join("machines").join(name)
}

/// The five-axis trunnion every identification test of the eleven errors simulates.
pub const TRUNNION: &str = "mcu630-cafyxz.urdf";

/// The truth parameter file of the five-axis example (`examples/five-axis`).
pub fn five_axis_truth_file() -> PathBuf {
    repo().join("examples/five-axis/truth.params.toml")
}
