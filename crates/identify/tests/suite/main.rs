//! mtcal-identify's integration tests, gathered into one binary (one link instead of thirty):
//! each module is one subject, its doc says what it shows. Run one with
//! `cargo test -p mtcal-identify --test suite <module>::`.
//!
//! Four stay binaries of their own because they cannot share a process: `search.rs` and
//! `stub_instrument.rs` register a plugin and an effect family that every search in the same
//! binary would see; `scale_memory.rs` installs a counting global allocator; `real_thermal.rs`
//! times its searches and must not share the cores with other tests.

#[path = "../common/mod.rs"]
mod common;

mod artefact_planted;
mod ballbar_diagnostics;
mod ballbar_scale;
mod compact_runs;
mod coverage;
mod coverage_ballbar;
mod edge_cases;
mod effect_jacobian;
mod every_five_axis_machine;
mod examples;
mod heldout;
mod independent;
mod joint;
mod laser_planted;
mod mismatch;
mod mixed_instruments;
mod negative_control;
mod no_panic;
mod outcome;
mod param_ids;
mod physics_search;
mod planted_truth;
mod real_hole_plate;
mod real_iso230_2;
mod real_positioner;
mod real_rotary_axis;
mod reduced_model;
mod rtest_mounts;
mod search_honesty;
mod search_independent;
mod search_real_shapes;
mod search_spans;
mod three_axis_example;
mod tracer_campaign;
