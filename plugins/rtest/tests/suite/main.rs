//! mtcal-rtest's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-rtest --test suite <module>::`.

mod conformance;
mod model;
mod paths;
mod worked_examples;
