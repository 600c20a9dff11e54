//! What the tests of several mtcal crates share, so that a fixture is written once: where the
//! repository, its shipped files and the shared real recordings are ([`repo`],
//! [`machine_file`], [`shared_data`]), the five-axis example's
//! eleven errors and its truth ([`params`]), the simulation plans several identification tests
//! fit ([`plans`]), seeded generators that need no crate ([`random`]), the command line run
//! in the repository ([`cli`]), and a session put as a user has it with work run on a few
//! threads ([`sessions`]).
//!
//! Only text, paths and numbers: the kit depends on no mtcal crate, so any crate's tests can use
//! it, and it is only ever a dev-dependency (`tests/architecture.rs` checks both).

pub mod cli;
pub mod params;
pub mod plans;
pub mod random;
pub mod sessions;

use std::path::{Path, PathBuf};

pub use params::{ELEVEN, FIVE_AXIS_TRUTH};

/// The repository's root folder (canonical: symbolic links resolved).
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the repository root exists")
}

/// `path` inside the shared recordings, `../shared/data/<path>` beside the repository (or
/// under `MTCAL_SHARED_DATA`), when it exists. In CI (`.ci/run` sets
/// `MTCAL_REQUIRE_SHARED_DATA`) a missing one panics: a test on real recordings fails there
/// instead of skipping.
pub fn shared_data(path: &str) -> Option<PathBuf> {
    let base = std::env::var_os("MTCAL_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("../shared/data"));
    let found = base.join(path);
    if !found.exists() && std::env::var_os("MTCAL_REQUIRE_SHARED_DATA").is_some() {
        panic!("{} not found: CI requires ../shared/data", found.display());
    }
    found.exists().then_some(found)
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
