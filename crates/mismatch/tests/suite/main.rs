//! mtcal-mismatch's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-mismatch --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod calibration;
mod errors;
mod power;
mod props;
