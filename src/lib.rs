//! mtcal: machine-tool metrology.
//!
//! This facade re-exports the library crates so that the workspace-level integration tests
//! (`tests/`) and benchmarks (`benches/`) have one package to depend on.
pub use mtcal_kinematics as kinematics;
pub use mtcal_machine as machine;
