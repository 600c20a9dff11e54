//! mtcal-indsim's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-indsim --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod agreement;
mod campaign;
mod effects_campaigns;
mod volumetric;
