//! The double ball-bar: ISO 230-4 circular tests and the five-axis rotary-axis tests.
//!
//! # Measurement model
//! One ball sits on the table (the *pivot*, nominally at `pivot` in the workpiece frame), the
//! other in the spindle at the machine's tool point; a bar of calibrated length joins them. With
//! the actual tool pose `w_T_t = (R, t)` and the nuisance parameters (deviations from nominal,
//! SI, starting at 0):
//!
//! ```text
//! ball_tool = t − δℓ·R·ẑ                      (a tool longer by δℓ; ẑ = tool axis into the spindle)
//! dr        = |ball_tool − (pivot + δp)| − (length + δL)
//! ```
//!
//! The single reading channel `dr` (µm in files) is the bar length minus its nominal `length`.
//! A reading beyond ±1000 µm, the measuring range of the usual telescopic bars (QC20-W), is
//! rejected when the run is loaded (`SetupFormat::reading_range`).
//! The readings depend on the tool position and, through the tool-length offset, on its
//! orientation; [`Setup::derivatives`] is analytic.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `pivot` | required | `[x, y, z]` mm, nominal table-side ball centre, workpiece frame |
//! | `length` | required | mm, nominal (calibrated) bar length, > 0 |
//! | `sigma_um` | `1.0` | µm, standard deviation of one `dr` reading |
//! | `pivot_free` | `true` | fit the pivot position (nuisance `pivot_x`, `pivot_y`, `pivot_z`, µm) |
//! | `length_free` | `false` | fit the bar-length error (nuisance `length`, µm); `false` holds it at 0 (calibrated bar) |
//! | `length_u_um` | none | µm, prior standard deviation of the bar-length error; needs `length_free = true` |
//! | `tool_length_free` | `true` | fit the tool-length error of the spindle ball (nuisance `tool_length`, µm, positive = longer tool) |
//!
//! Unknown keys are rejected with a [`SetupError`] naming them.
//! The nuisance parameters are always declared in the order `pivot_x, pivot_y, pivot_z, length,
//! tool_length`; the flags only say which are free.
//!
//! # Path keys (test plans)
//! `kind = "circle"` — the ISO 230-4 circular test: the tool ball moves on the circle of radius
//! `length` about the pivot in a coordinate plane of the workpiece frame; the linear axes follow
//! it ([`mtcal_kinematics::ik::follow_point`]) and the rotary axes are held.
//! - `plane`: `"XY"`, `"YZ"` or `"ZX"` (required). Angles run from the first letter's axis
//!   towards the second's.
//! - `direction`: `"ccw"` (default) or `"cw"`, seen looking down the plane's normal (+Z, +X, +Y
//!   respectively): counter-clockwise is positive rotation about the normal.
//! - `start_deg = 0`, `sweep_deg = 360` (> 0), `overshoot_deg = 0`: the arc measured, and the
//!   arcs before and after it that ISO 230-4 recommends for feed-in and feed-out. Samples in the
//!   overshoot arcs are measured and fitted like any other; the evaluation leaves them out.
//! - `samples = 361`: evenly spaced over the whole commanded arc, overshoot included.
//! - `hold = { A = 0.0 }`: rotary axis positions in degrees; unnamed rotary axes are held at 0.
//!
//! `kind = "rotary"` — a five-axis test: one rotary axis sweeps while the tool ball stays at a
//! point fixed in the workpiece frame, `pivot + length·u`; the linear axes follow it. Errors in
//! the rotary axis' location (ISO 230-1 `EX0C`, `EA0C`…) and its error motions show up as bar
//! length changes.
//! - `sweep = { C = [0.0, 360.0] }`: the swept axis and its range in degrees (required).
//! - `bar`: the direction `u`, relative to the swept axis at the start pose (linear axes placed
//!   so that the tool point is at the pivot): `"radial"` (from the axis line through the pivot,
//!   so the pivot must not lie on the line), `"axial"` (along the axis, in the sense in which a
//!   positive command turns the tool relative to the workpiece), `"tangential"` (axial ×
//!   radial), or an explicit vector `[x, y, z]` in the workpiece frame (normalised).
//! - `samples = 361`, `hold` as above (the swept axis cannot be held).
//!
//! Any sample outside an axis' limits is rejected with a `SetupError` naming the axis and the
//! sample. Machines whose linear axes cannot put the ball where the path needs it are rejected
//! too. Machines with three linear axes use `follow_point`; others a least-squares solve that
//! must be exact.
//!
//! # Evaluation
//! [`evaluate()`] recognises circle runs from their commanded positions and reports the ISO
//! 230-4 circular deviation G after least-squares centre removal
//! ([`circular_deviation`]), with the fitted centre offsets and radius offset, all about the
//! circle's plane (the metric's `subject`, `XY`), and G's expanded uncertainty (k = 2) from the
//! reading noise `sigma_um` ([`circular_deviation_uncertainty`]). Rotary runs get
//! no evaluation. [`bidirectional_circular_deviation`] gives G(b) from a ccw and a cw run.
//! [`polar_view()`] gives the report a circle run's plane, radius and commanded angles, so it
//! draws the run as a polar plot.
//!
//! # Diagnostics
//! [`diagnose()`] pairs each counter-clockwise circle with a clockwise one of the same set-up,
//! plane and held axes and gives what ball-bar users read — backlash, lateral play, reversal
//! spikes, cyclic error, servo mismatch, squareness, straightness, scale mismatch — with their
//! uncertainties and contributions to circularity (the module's docs give each shape).

pub mod collision;
mod diagnose;
mod evaluate;
mod fixture;
mod path;
mod setup;

pub use diagnose::diagnose;
pub use evaluate::{
    Bidirectional, CircleRun, CircularDeviation, bidirectional_circular_deviation,
    circular_deviation, circular_deviation_uncertainty, evaluate, polar_view, recognise_circle,
};
pub use fixture::fixture;
pub use path::{
    Bar, DEFAULT_SAMPLES, PlaceError, Plane, axis_line, circle_angles, path, place_tool,
};
pub use setup::{BallbarConfig, BallbarSetup, SETUP_KEYS, nuis};

use mtcal_instrument::{InstrumentPlugin, Setup, SetupContext, SetupError};

/// The plugin's `load_setup`: a [`BallbarSetup`] from a manifest table.
pub fn load_setup(
    table: &toml::Table,
    _ctx: &SetupContext<'_>,
) -> Result<Box<dyn Setup>, SetupError> {
    Ok(Box::new(BallbarSetup::new(BallbarConfig::from_table(
        table,
    )?)))
}

inventory::submit! {
    InstrumentPlugin {
        name: "ballbar",
        about: "double ball-bar: bar length changes on ISO 230-4 circles and five-axis rotary tests",
        load_setup,
        fixture,
        path,
        path_labels: None,
        evaluate: Some(evaluate),
        polar_view: Some(polar_view),
        diagnose: Some(diagnose),
        planning: Some(collision::PLANNING),
    }
}

inventory::submit! {
    mtcal_instrument::capability::CircleRuns {
        instrument: "ballbar",
        reading: setup::READING,
        range_um: setup::RANGE_M * 1e6,
        setup: circle_setup,
    }
}

inventory::submit! {
    mtcal_instrument::capability::PolarSection {
        instrument: "ballbar",
        heading: "Ball-bar circles",
        none: "No ball-bar circle runs in this session.",
    }
}

/// The set-up of a circle of radius `radius_mm` about `pivot_mm` (mm, workpiece frame): the
/// pivot there and a bar as long as the radius (what the importers of ball-bar exports write).
pub fn circle_setup(pivot_mm: [f64; 3], radius_mm: f64) -> toml::Table {
    let mut setup = toml::Table::new();
    setup.insert(
        "pivot".into(),
        toml::Value::Array(pivot_mm.iter().map(|&v| v.into()).collect()),
    );
    setup.insert("length".into(), radius_mm.into());
    setup
}
