//! mtcal-laser's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-laser --test suite <module>::`.

mod conformance;
mod environment;
mod iso230_2;
mod model;
mod no_alloc;
