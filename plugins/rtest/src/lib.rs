//! The R-test: a precision ball in the spindle, a three-sensor nest ("head") on the table.
//!
//! The ball rides on the machine's tool point; the head is fixed to the table (the workpiece
//! side, so it turns and tilts with the table), its axes aligned with the workpiece frame. In
//! the "follow the ball" tests the linear axes keep the nominal tool point on the head centre
//! while the rotary axes sweep, and the head reports where the ball centre really is
//! (source 000 §3.2, §3.7: MT-Check head, XYC / YZA / XYZAC trajectories).
//!
//! # Measurement model
//! With the actual tool pose `w_T_t = (R, t)` (workpiece frame) and the nuisance parameters
//! (deviations from nominal, SI, starting at 0):
//!
//! ```text
//! ball = t − δℓ·R·ẑ                  a tool longer by δℓ; ẑ = tool axis, into the spindle
//! head = ball_nominal + δh           δh = (ball_x, ball_y, ball_z)
//! d    = ball − head                 workpiece frame = the head's own axes
//! ideal head:         (dx, dy, dz) = d
//! three-sensor head:  (dx, dy, dz) = N_nom⁻¹ · diag(1 + gᵢ) · N_act · d
//! ```
//!
//! The readings `dx, dy, dz` (µm in files) are the ball centre minus the head centre along the
//! head's axes. They depend on the tool position and, through the tool-length offset that turns
//! with the tool, on its orientation; [`Setup::derivatives`](mtcal_instrument::Setup) is
//! analytic.
//!
//! **Three-sensor head.** Sensor i sits below the ball's equator at azimuth 0°, 120°, 240°
//! about the head's z axis and elevation `e`; its axis points at the ball centre:
//! `nᵢ = (−cos e·cos φᵢ, −cos e·sin φᵢ, sin e)`. Its flat contact makes it read
//! `mᵢ = nᵢ·d` exactly (positive when the ball centre moves away from the sensor along its
//! axis), whatever the ball's radius: the ball diameter does not enter flat-contact readings
//! (it would for spherical contacts, whose contact point moves on the ball). The head converts
//! its three readings with the **nominal** directions, `N_nom⁻¹·m` (rows of `N_nom` are the
//! `nᵢ`), so with zero geometry errors it reads exactly what the ideal head reads. Geometry
//! errors per sensor: a gain error `gᵢ` and a direction error, `nᵢ' = (nᵢ + aᵢ·uᵢ + bᵢ·vᵢ) /
//! √(1 + aᵢ² + bᵢ²)` with `uᵢ = ∂nᵢ/∂φᵢ` (unit, towards increasing azimuth) and
//! `vᵢ = ∂nᵢ/∂e` (towards increasing elevation). At the default elevation `asin(1/√3)` ≈
//! 35.26° the three directions are orthogonal.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `ball` | required | `[x, y, z]` mm, nominal ball (= head) centre, workpiece frame |
//! | `head` | `"ideal"` | head model: `"ideal"` or `"three-sensor"` |
//! | `sigma_um` | `0.5` | µm, standard deviation of one reading (each of `dx, dy, dz`), > 0 |
//! | `range_um` | `2000` | µm, the measuring range of each reading (±): a run file with a reading beyond it is refused, naming the cell, > 0 |
//! | `ball_free` | `true` | fit the head position offset (nuisance `ball_x`, `ball_y`, `ball_z`, µm) |
//! | `tool_length_free` | `true` | fit the tool-length error (nuisance `tool_length`, µm, positive = longer tool: the ball moves by −δℓ along the tool axis) |
//! | `ball_diameter_mm` | `22.0` | three-sensor only: ball diameter, mm (documentation; flat contacts do not see it) |
//! | `sensor_elevation_deg` | `35.264…` | three-sensor only: sensor elevation below the ball's equator, strictly between 0 and 90° |
//! | `sensor_geometry_free` | `false` | three-sensor only: fit the sensor gain and direction errors |
//! | `sensor_gain_u_ppm` | none | three-sensor, geometry free only: prior standard deviation of the gain errors, ppm |
//! | `sensor_angle_u_urad` | none | three-sensor, geometry free only: prior standard deviation of the direction errors, µrad |
//!
//! Unknown keys, and three-sensor keys on the ideal head, are rejected with a
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

mod fixture;
mod path;
mod setup;

pub use fixture::{axis_line, fixture};
pub use mtcal_instrument::program::nc_program;
pub use path::{
    DEFAULT_SAMPLES, Kind, PATH_KEYS, Plan, TILT_RANGE_DEG, XYZAC_TILT_DEG, check_machine, path,
    plan, poses,
};
pub use setup::{
    DEFAULT_BALL_DIAMETER_MM, DEFAULT_SIGMA_UM, HeadKind, RTest, SENSOR_AZIMUTHS_DEG, SETUP_KEYS,
    ThreeSensor, default_sensor_elevation_deg, load, load_setup, sensor_directions,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "rtest",
        about: "R-test: spindle ball, three-sensor nest on the table; readings dx, dy, dz (um)",
        load_setup,
        fixture,
        path,
        path_labels: None,
        evaluate: None,
    }
}
