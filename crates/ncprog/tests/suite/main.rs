//! mtcal-ncprog's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-ncprog --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod cl;
mod correct;
mod zero_point;
