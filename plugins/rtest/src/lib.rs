//! The R-test: a precision ball and a three-sensor nest ("head"), one on the table, the other
//! in the spindle.
//!
//! In the "follow the ball" tests the linear axes keep the nominal tool point on the nominal
//! ball centre while the rotary axes sweep, and the nest reports the ball centre minus its
//! own centre along its own axes (source 000 §3.2, §3.7: MT-Check, XYC / YZA / XYZAC
//! trajectories). Which part sits where is the set-up key `mount` (FORMATS.md v1.1):
//!
//! - `"ball-on-table"` (**the default**): the ball is fixed to the table at `ball` and turns
//!   and tilts with it; the nest is in the spindle on the tool point, its axes the tool
//!   frame's (the machine X/Y/Z wherever the spindle does not tilt). This is source 000's
//!   MT-Check set-up and what FORMATS.md v1 always meant by `dx, dy, dz`, so a file without
//!   `mount` must keep meaning it.
//! - `"ball-in-spindle"`: the ball rides on the tool point; the nest is fixed to the table,
//!   centred at `ball`, its axes the workpiece axes, turning with the table (the IBS R-test,
//!   Weikert's R-test).
//!
//! The same machine error reads differently in the two: with the nest on the table a C-axis
//! location error `EX0C` reads (+10, +10, 0) µm at C = 90° where the spindle nest reads
//! (+10, −10, 0) µm (FORMATS.md, "Worked examples"; `tests/suite/worked_examples.rs`).
//!
//! # Measurement model
//! With the actual tool pose `w_T_t = (R, t)` (workpiece frame), `ẑ` the tool axis (into the
//! spindle), and the nuisance parameters (deviations from nominal, SI, starting at 0):
//! `δb = (ball_x, ball_y, ball_z)`, where the table-side part really is, and `δℓ =
//! tool_length`, a tool longer by δℓ (the spindle-side part sits δℓ further down the tool axis):
//!
//! ```text
//! ball-on-table:    B = ball_nominal + δb     ball, on the table
//!                   n = t − δℓ·R·ẑ            nest centre, in the spindle
//!                   d = Rᵀ·(B − n) = Rᵀ·(B − t) + δℓ·ẑ        along the nest (= tool) axes
//! ball-in-spindle:  b = t − δℓ·R·ẑ            ball, on the tool point
//!                   h = ball_nominal + δb     nest centre, on the table
//!                   d = b − h                 along the nest (= workpiece) axes
//! ideal head:         (dx, dy, dz) = d
//! three-sensor head:  (dx, dy, dz) = N_nom⁻¹ · diag(1 + gᵢ) · N_act · d
//! ```
//!
//! The readings `dx, dy, dz` (µm in files) are the ball centre minus the nest centre along the
//! nest's axes. They depend on the tool position and orientation (on the ball-on-table mount
//! through the nest's axes, on the ball-in-spindle mount through the tool-length offset that
//! turns with the tool); [`Setup::derivatives`](mtcal_instrument::Setup) is analytic. Under
//! the left perturbation `t ← t + δt`, `R ← exp([δθ]×)·R`:
//!
//! ```text
//! ball-on-table:    ∂d/∂δt = −Rᵀ   ∂d/∂δθ = Rᵀ·[B − t]×   ∂d/∂δb = Rᵀ   ∂d/∂δℓ = ẑ
//! ball-in-spindle:  ∂d/∂δt = I     ∂d/∂δθ = δℓ·[R·ẑ]×     ∂d/∂δb = −I   ∂d/∂δℓ = −R·ẑ
//! ```
//!
//! **Three-sensor head.** Sensor i sits at azimuth 0°, 120°, 240° about the nest's z axis and
//! elevation `e` away from the ball's equator; its axis points at the ball centre. A nest on
//! the table (`ball-in-spindle`) holds its sensors below the equator,
//! `nᵢ = (−cos e·cos φᵢ, −cos e·sin φᵢ, sin e)`; a nest hanging from the spindle
//! (`ball-on-table`) above it, pointing down: the same mirrored in z,
//! `nᵢ = (−cos e·cos φᵢ, −cos e·sin φᵢ, −sin e)`. Its flat contact makes it read
//! `mᵢ = nᵢ·d` exactly (positive when the ball centre moves away from the sensor along its
//! axis), whatever the ball's radius: the ball diameter does not enter flat-contact readings
//! (it would for spherical contacts, whose contact point moves on the ball). The head converts
//! its three readings with the **nominal** directions, `N_nom⁻¹·m` (rows of `N_nom` are the
//! `nᵢ`), so with zero geometry errors it reads exactly what the ideal head reads. Geometry
//! errors per sensor: a gain error `gᵢ` and a direction error, `nᵢ' = (nᵢ + aᵢ·uᵢ + bᵢ·vᵢ) /
//! √(1 + aᵢ² + bᵢ²)` with `uᵢ = ∂nᵢ/∂φᵢ` (unit, towards increasing azimuth) and
//! `vᵢ = ∂nᵢ/∂e` (towards increasing elevation, i.e. away from the equator; mirrored in z
//! with `nᵢ`). At the default elevation `asin(1/√3)` ≈ 35.26° the three directions are
//! orthogonal.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `ball` | required | `[x, y, z]` mm, nominal centre of the table-side part (the ball, or the nest on `ball-in-spindle`; nominally the ball and nest centres coincide), workpiece frame |
//! | `mount` | `"ball-on-table"` | which part sits where: `"ball-on-table"` (ball on the table, nest in the spindle) or `"ball-in-spindle"` (ball on the tool point, nest on the table) |
//! | `head` | `"ideal"` | head model: `"ideal"` or `"three-sensor"` |
//! | `sigma_um` | `0.5` | µm, standard deviation of one reading (each of `dx, dy, dz`), > 0 |
//! | `range_um` | `2000` | µm, the measuring range of each reading (±): a run file with a reading beyond it is refused, naming the cell, > 0 |
//! | `ball_free` | `true` | fit where the table-side part really is (nuisance `ball_x`, `ball_y`, `ball_z`, µm, workpiece frame) |
//! | `tool_length_free` | `true` | fit the tool-length error (nuisance `tool_length`, µm, positive = longer tool: the spindle-side part — ball or nest — moves by −δℓ along the tool axis) |
//! | `ball_diameter_mm` | `22.0` | three-sensor only: ball diameter, mm (documentation; flat contacts do not see it) |
//! | `sensor_elevation_deg` | `35.264…` | three-sensor only: sensor elevation away from the ball's equator (below it on a table nest, above it on a spindle nest), strictly between 0 and 90° |
//! | `sensor_geometry_free` | `false` | three-sensor only: fit the sensor gain and direction errors |
//! | `sensor_gain_u_ppm` | none | three-sensor, geometry free only: prior standard deviation of the gain errors, ppm |
//! | `sensor_angle_u_urad` | none | three-sensor, geometry free only: prior standard deviation of the direction errors, µrad |
//!
//! Unknown keys, unknown `mount` or `head` values, and three-sensor keys on the ideal head, are
//! rejected with a
//! [`SetupError`](mtcal_instrument::SetupError) naming them.
//!
//! Nuisance parameters, always in this order (the flags only say which are free):
//! `ball_x, ball_y, ball_z, tool_length` (µm); for the three-sensor head also, for sensor
//! i = 1, 2, 3, `sensor<i>_gain` (ppm), `sensor<i>_azimuth`, `sensor<i>_elevation` (µrad).
//!
//! # Path keys (test plans)
//! Any machine with three linear axes and one or two rotary axes. The rotary axes are swept
//! (linearly interpolated from `from` to `to`) or held; at every sample the linear axes put the
//! nominal tool point on the ball ([`mtcal_kinematics::ik::follow_point`]). A sample with any
//! axis outside its limits is rejected with a `SetupError` naming the axis and the sample (key
//! `ball` for a linear axis, `sweep`/`hold` for a rotary one); nothing is clipped.
//! - `kind`: `"xyc"` — C from 0 to 360°; `"yza"` — A over its limits clipped to [−30°, 90°];
//!   `"zxb"` — the same for B; `"xyzac"` — A from −θ to +θ (θ = 30°, less if A's limits say
//!   so) and C from 0 to 360° together; `"rotary"` (the default) — the axes of `sweep`. The
//!   presets fail on machines without the axes they sweep.
//! - `sweep = { C = [0.0, 360.0] }`: one or two rotary axes and their ranges in degrees,
//!   swept simultaneously; required for `rotary`, replaces a preset's sweep when given.
//! - `hold = { A = -30.0 }`: positions of rotary axes that are not swept, degrees; unnamed
//!   ones are held at 0.
//! - `samples = 73`: samples from `from` to `to` (at least 2).
//! - `back = false`: `true` goes and comes back (2·samples − 1 poses), to see both directions.
//!
//! [`nc_program`] writes the poses as a G-code program.

pub mod collision;
mod fixture;
mod path;
mod setup;

pub use fixture::{axis_line, fixture, fixture_mount, fixture_with_mount};
pub use mtcal_instrument::program::nc_program;
pub use path::{
    DEFAULT_SAMPLES, Kind, PATH_KEYS, Plan, TILT_RANGE_DEG, XYZAC_TILT_DEG, check_machine, path,
    plan, poses,
};
pub use setup::{
    DEFAULT_BALL_DIAMETER_MM, DEFAULT_SIGMA_UM, HeadKind, Mount, RTest, SENSOR_AZIMUTHS_DEG,
    SETUP_KEYS, ThreeSensor, default_sensor_elevation_deg, load, load_setup, sensor_directions,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "rtest",
        about: "R-test: ball and three-sensor nest (ball on the table by default, or in the spindle); readings dx, dy, dz (um)",
        load_setup,
        fixture,
        path,
        path_labels: None,
        evaluate: None,
        polar_view: None,
        diagnose: None,
        planning: Some(collision::PLANNING),
    }
}

inventory::submit! {
    mtcal_instrument::capability::PointVisits {
        instrument: "rtest",
        readings: setup::READINGS,
        point_key: "ball",
        range_key: "range_um",
        default_range_um: setup::DEFAULT_RANGE_UM,
        machine_axes: mtcal_instrument::capability::MachineAxes {
            key: "mount",
            value: Mount::BallOnTable.as_str(),
            words: "the nest in the spindle",
        },
    }
}
