//! mtcal-import's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-import --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod api_pos;
mod ecmc_dat;
mod renishaw_b5r;
mod renishaw_rtx;
mod rtest_stream;
