//! The command line's integration tests, gathered into one binary (one link instead of one per
//! file); each module is one subject. Three stay binaries of their own because they time what
//! they run: `hostile_outputs.rs` and `reruns.rs` (a run killed part-way, an error within a
//! second) and `report.rs` (headless Chromium). Run one with
//! `cargo test -p mtcal-xtask --test suite <module>::`.

mod acceptance;
mod bad_input;
mod bare_urdf;
mod broken_pipe;
mod cl_data;
mod compensate;
mod edge_cases;
mod error_messages;
mod exit_codes;
mod history;
mod identify_to_act;
mod information;
mod linuxcnc;
mod map;
mod mutations;
mod nc_programs;
mod plan;
mod search;
mod tolerance;
mod volumetric;
