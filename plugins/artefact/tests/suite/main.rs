//! mtcal-artefact's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-artefact --test suite <module>::`.

mod conformance;
mod evaluate;
mod model;
