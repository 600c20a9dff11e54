//! mtcal-history's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-history --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod identify_json;
mod independent_campaigns;
mod store;
mod views;
