//! Fixed displacement sensors (eddy-current or capacitive probes) against a test mandrel or
//! ball in the spindle, the machine held at one position: the set-up of ISO 230-3 thermal
//! tests (drift under spindle rotation, under axis motion elsewhere, under a changing room).
//!
//! The sensors sit in a fixture on the table (the workpiece side, so their directions are
//! fixed in the workpiece frame); the mandrel rides on the machine's tool point. Each sensor
//! reports how far the point of the mandrel it touches has moved along its measuring direction.
//!
//! # Measurement model
//! With the actual tool pose `w_T_t = (R, t)` (workpiece frame), sensor s with unit direction
//! `n_s` (workpiece frame) touching the mandrel at `a_s` (tool frame, from the tool point;
//! default 0) and its zero offset `o_s` (nuisance, SI, starting at 0):
//!
//! ```text
//! p_s         = t + R·a_s                  the touched point
//! p_s,nominal = position + a_s             where it is on the nominal machine
//! d_s         = n_s · (p_s − p_s,nominal) + o_s
//! ```
//!
//! A sensor without a direction reads `d_s = o_s`: it is *modelled on its own* (its reading
//! does not depend on the pose, [`Setup::reads_pose`](mtcal_instrument::Setup::reads_pose) is
//! `false` for it, and the physics search gives it effects of its own such as drift). The
//! derivatives are analytic: with the left pose perturbation `∂d_s/∂δt = n_s`,
//! `∂d_s/∂δθ = (R·a_s) × n_s` (the touched point moves by `δt + δθ × (R·a_s)`),
//! `∂d_s/∂o_s = 1`.
//!
//! `n_s` is the direction in which a displacement of the touched point reads **positive**. A
//! probe on the +X side of the mandrel whose reading grows with the gap reads positive when the
//! mandrel moves towards −X: its direction is `"-X"`.
//!
//! **Approximation.** The nominal touched point is `position + a_s`: the model takes the
//! nominal tool frame at the held position to be aligned with the workpiece frame (the tool
//! axis along the workpiece's +Z, as on a three-axis machine and on five-axis machines with the
//! rotary axes at zero), because a set-up sees the machine only through the actual pose. The
//! [`path`] function checks this against the machine's nominal geometry at the held axis
//! positions and rejects a path where it is off by more than [`POSITION_TOL_MM`] for a sensor
//! with an `at` offset (with the rotary axes tilted, an `at` offset must lie along the axis
//! the tool is turned about). It checks `position` against the nominal tool point there too.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `position` | `[0, 0, 0]` | `[x, y, z]` mm, the nominal tool point (mandrel or ball centre) where the sensors touch it, workpiece frame: the machine's nominal tool point at the held axis positions |
//! | `sigma_um` | `0.5` | µm, standard deviation of one reading, > 0; a sensor may give its own |
//! | `offset_free` | `true` | fit each sensor's zero offset (nuisance `<sensor>_offset`, µm); `false` holds them at 0 |
//! | `sensors` | required | table of sensors by name (at least one), below |
//!
//! Each entry of `sensors` (the name: ASCII letters, digits, `_`, `-`) is one of
//! - an axis letter `"X"`, `"Y"`, `"Z"`, optionally signed (`"-X"`, `"+Y"`): the direction is
//!   that axis of the workpiece frame;
//! - a vector `[x, y, z]` (workpiece frame; normalised when loaded, nonzero and finite);
//! - a table with the keys
//!
//!   | key | default | meaning |
//!   |---|---|---|
//!   | `direction` | none | a letter or a vector as above; without it the sensor is modelled on its own |
//!   | `sigma_um` | the set-up's | µm, this sensor's standard deviation of one reading, > 0 |
//!   | `at` | `[0, 0, 0]` | `[x, y, z]` mm, where the sensor touches the mandrel, from the tool point in the tool frame (`[0, 0, 50]`: 50 mm up the tool axis, so it also sees the tool's tilt); needs a `direction` |
//!
//!   `{}` is a sensor without a direction.
//!
//! ```toml
//! [setup.spindle-test]
//! position = [0.0, 0.0, 0.0]
//! sigma_um = 0.5
//! offset_free = true
//! [setup.spindle-test.sensors]
//! x1 = "X"
//! tilt = [0.0, 0.7071, 0.7071]
//! ch5 = {}
//! x2 = { direction = "X", sigma_um = 0.3, at = [0.0, 0.0, 50.0] }
//! ```
//!
//! Unknown keys, at the top or in a sensor's table, are rejected with a
//! [`SetupError`](mtcal_instrument::SetupError) naming them (`sensors.x2.sigma`); so is every
//! malformed value, naming its key.
//!
//! **Channel order.** The channels are `d_<sensor>` (µm), one per sensor, in **sorted
//! sensor-name order** (byte order: `ch5, tilt, x1, x2` above), and the nuisance parameters
//! `<sensor>_offset` (µm) follow the same order. The loader sorts explicitly: `toml` tables keep
//! sorted order in this workspace, but a cargo feature (`preserve_order`) that any crate in a
//! build may enable would switch them to file order. `to_toml` writes a sensor as its bare
//! direction when it has nothing else (a `"+"` sign is dropped, a vector is written as given),
//! `{}` or a table otherwise, and every top-level key with its default.
//!
//! # Path keys (test plans)
//! A displacement test holds the machine still: `path = { samples = 200, at = { X = 0.0,
//! Y = 0.0, Z = -250.0 } }`.
//! - `at`: axis positions by letter, mm for linear axes, degrees for rotary ones; axes not
//!   named are held at 0. An unknown letter, a non-number or a position outside the axis'
//!   limits is rejected naming `at.<letter>`.
//! - `samples = 100`: how many samples (at least 1); the plan's `interval_s` spaces them in time.
//!
//! The set-up must agree with the machine there (see *Approximation*): `position` within
//! [`POSITION_TOL_MM`] of the nominal tool point (the error says the value to write).
//!
//! # Evaluation
//! [`evaluate()`] reports, per sensor, `thermal drift d_<sensor> (ISO 230-3)`: the range
//! (max − min) of its reading over the run, µm.
//!
//! [`nc_program`] writes the held position as a G-code program.

mod evaluate;
mod fixture;
mod path;
mod setup;

pub use evaluate::{drift, evaluate};
pub use fixture::fixture;
pub use mtcal_instrument::program::nc_program;
pub use path::{DEFAULT_SAMPLES, PATH_KEYS, POSITION_TOL_MM, check_setup, held_position, path};
pub use setup::{
    DEFAULT_SIGMA_UM, DisplacementSetup, SENSOR_KEYS, SETUP_KEYS, Sensor, SensorDirection, load,
    load_setup,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "displacement",
        about: "displacement sensors against a spindle mandrel or ball at one position (ISO 230-3); readings d_<sensor> (um)",
        load_setup,
        fixture,
        path,
        path_labels: None,
        evaluate: Some(evaluate),
        polar_view: None,
        diagnose: None,
        planning: None,
    }
}
