//! mtcal-solve's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-solve --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod coverage;
mod errors;
mod identifiability;
mod linear;
mod nonlinear;
mod scale;
mod score;
mod streaming_props;
