//! mtcal-displacement's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-displacement --test suite <module>::`.

mod conformance;
mod evaluate;
mod loader;
mod model;
mod paths;
