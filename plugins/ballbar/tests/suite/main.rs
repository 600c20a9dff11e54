//! mtcal-ballbar's integration tests, gathered into one binary (one link instead of one per file);
//! each module is one subject. Run one with `cargo test -p mtcal-ballbar --test suite <module>::`.

mod conformance;
mod iso230_4;
mod model;
mod paths;
