//! mtcal-trend's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-trend --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod analyse;
mod compare;
mod drift;
mod props;
mod simulated_campaigns;
mod step;
mod thermal;
mod tolerance;
