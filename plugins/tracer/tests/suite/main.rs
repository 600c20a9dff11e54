//! mtcal-tracer's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-tracer --test suite <module>::`.

mod conformance;
mod loader;
mod model;
mod paths;
