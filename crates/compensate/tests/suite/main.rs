//! mtcal-compensate's integration tests, gathered into one binary (one link instead of one per
//! file); each module is one format or subject. `stub_format.rs` stays a binary of its own: the
//! format it registers would be listed by every test here. Run one with
//! `cargo test -p mtcal-compensate --test suite <module>::`.

#[path = "../carr_control/mod.rs"]
mod carr_control;
#[path = "../common/mod.rs"]
mod common;
#[path = "../heidenhain_control/mod.rs"]
mod heidenhain_control;
#[path = "../trt_control/mod.rs"]
mod trt_control;

mod axis_use;
mod end_to_end;
mod fanuc;
mod heidenhain;
mod parameters;
mod roundtrip;
mod siemens;
mod siemens_carr;
mod trt;
