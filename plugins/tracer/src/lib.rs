//! The laser tracer (tracking interferometer, e.g. LaserTRACER): sequential multilateration
//! with self-calibrated stations and dead paths.
//!
//! A tracer stands on the table (the workpiece side, so its station is fixed in the workpiece
//! frame) and follows a cat's-eye reflector in the spindle with its laser beam; its
//! interferometer measures how the station-to-reflector distance changes as the machine moves
//! through a path. The same path is measured from several stations (one set-up each), and with
//! several reflector offsets (a longer tool, a lateral offset); the identification fits the
//! machine's errors, every station's position and every dead path at once (*self-calibration*:
//! nothing but the approximate station positions needs to be known).
//!
//! # Measurement model
//! Let `(R, t)` be the actual tool pose `w_T_t` (workpiece frame), `(R₀(q), t₀(q))` the nominal
//! one at the sample's commanded positions `q` (`Machine::tool_in_workpiece`; the set-up keeps
//! a copy of the machine), `r` the reflector offset (tool frame, from the tool point), `s₀` the
//! set-up's approximate station and the nuisance parameters (SI deviations, starting at 0)
//! `δs` (station correction, 3) and `δL` (dead path / distance datum, 1):
//!
//! ```text
//! x   = t + R·r                 actual reflector centre
//! x₀  = t₀(q) + R₀(q)·r         nominal reflector centre
//! s   = s₀ + δs                 actual station (tracer pivot)
//! a   = x − s,  b = x₀ − s₀     actual and nominal lines of sight
//! d   = |a| − |b| + δL          the reading: measured distance minus nominal distance
//! ```
//!
//! `d` (µm in files) is a *deviation*, small on a good machine: the tracer's distance change
//! since its datum, minus the change the nominal machine would give, with the unknown distance
//! at the datum (dead path, the datum's own offset) in `δL`. To turn a recording into `d`,
//! subtract `|x₀(q) − s₀|` (computed from the commanded positions, the reflector offset and the
//! approximate station) from the recorded distance in any consistent datum: whatever constant
//! remains is `δL`'s. A wrong approximate station is the fit's business: `δs` refines it (the
//! model is exact in `δs`, not linearised, so an approximate station a few millimetres off
//! converges in a few Gauss–Newton iterations).
//!
//! `|a| − |b|` is evaluated as `(a − b)·(a + b)/(|a| + |b|)` with
//! `a − b = (t − t₀) + (R·r − R₀·r) − δs` formed from the small differences, so a reading keeps
//! its digits although both distances are about a metre.
//!
//! **Derivatives** (analytic, [`Setup::derivatives`](mtcal_instrument::Setup::derivatives)):
//! with the unit line of sight `u = a/|a|` and the left pose perturbation
//! (`t ← t + δt`, `R ← exp([δθ]×)·R`; the reflector moves by `δt + δθ × (R·r)`),
//!
//! ```text
//! ∂d/∂δt = uᵀ            ∂d/∂δθ = ((R·r) × u)ᵀ
//! ∂d/∂δs = −uᵀ           ∂d/∂δL = 1
//! ```
//!
//! The nominal term `|b|` depends on `q` only, not on the pose or the nuisance. A reflector at
//! the tool point (`r = 0`) does not see the tool's orientation
//! ([`Touches::orientation`](mtcal_instrument::Touches) is then `false`).
//!
//! **Noise.** The LaserTRACER's length measurement uncertainty is `U(k = 2) = 0.2 µm + 0.3 µm/m`
//! (source 000, §3.1). The trait gives one σ per channel, so the length-proportional part is
//! evaluated at the set-up's *typical distance*: from `s₀` to the nominal reflector with the
//! linear axes mid-stroke (rotary axes at 0, clamped into their limits):
//! `σ = sigma_um + sigma_um_per_m · D_mid`. The defaults are the k = 1 values, 0.1 µm and
//! 0.15 µm/m. Over a typical path the distance varies by a few hundred millimetres, so the
//! length-proportional part of σ is off by a few hundredths of a micrometre at most.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `station` | required | `[x, y, z]` mm, approximate station (tracer pivot, the centre of its reference sphere), workpiece frame; refined by the fit |
//! | `reflector` | `[0, 0, 0]` | `[x, y, z]` mm, reflector centre from the tool point in the tool frame (`[0, 0, 150]`: a 150 mm longer tool; a lateral part puts it off the spindle axis) |
//! | `sigma_um` | `0.1` | µm, length-independent standard deviation of one reading, > 0 |
//! | `sigma_um_per_m` | `0.15` | µm per m of station-to-reflector distance, ≥ 0 (see *Noise*) |
//! | `station_free` | `true` | fit the station correction (nuisance `station_x`, `station_y`, `station_z`, µm) |
//! | `station_u_mm` | none | mm, standard deviation of a prior on each station coordinate; needs `station_free = true` |
//! | `dead_path_free` | `true` | fit the dead path (nuisance `dead_path`, µm) |
//!
//! The nuisance parameters are always declared in the order `station_x, station_y, station_z,
//! dead_path`; the flags say which are free. Unknown keys are rejected with a
//! [`SetupError`](mtcal_instrument::SetupError) naming them, so is every malformed value.
//!
//! **No station prior by default.** A prior is a pseudo-measurement: it would make every
//! direction of the parameter space "identified" (with an enormous interval) and hide what a
//! layout cannot separate. Self-calibration does not need it; give `station_u_mm` only when
//! the stations are known independently.
//!
//! # Path keys (test plans)
//! The path moves the linear axes X, Y, Z over the centred `fraction` of their strokes; every
//! other axis is held (`hold`). The commanded path does not depend on the station or the
//! reflector, so every set-up of a campaign can run the same program.
//! - `kind = "grid"` (default): a 3-D grid, `counts = [nx, ny, nz]` points per axis (default
//!   `[4, 4, 4]`, each ≥ 1), visited in serpentine order.
//! - `kind = "lines"`: the 12 edges and 4 body diagonals of the box (ISO 230-6 diagonals),
//!   `samples` points per line (default 11, ≥ 2), corners included on every line.
//! - `fraction = 0.8`: the share of each stroke, in (0, 1].
//! - `hold = { A = 0.0, C = 0.0 }`: positions of the other axes (degrees for rotary, mm for
//!   linear axes); unnamed ones at 0.
//!
//! A campaign in a test plan (one set-up per station and reflector offset, all running the
//! same path; `[nuisance.<set-up>]` gives a simulation's true station correction and dead
//! path, µm):
//!
//! ```toml
//! [setup.s0-long]
//! station = [420.0, 320.0, 0.0]
//! reflector = [0.0, 0.0, 200.0]
//! [nuisance.s0-long]
//! station_x = 1500.0
//! dead_path = 25.0
//! [[run]]
//! name = "s0-long"
//! instrument = "tracer"
//! setup = "s0-long"
//! path = { kind = "grid", counts = [4, 4, 4] }
//! ```
//!
//! Samples outside the axis limits are rejected, and so is a station the reflector comes within
//! [`MIN_DISTANCE_MM`] of. Machines without linear X, Y and Z axes with limits get no path.
//!
//! # Campaign layout: what a tracer identifies
//! The readings see the reflector positions `x(q)` only through distances from stations whose
//! positions and dead paths are all free; one set-up per station and reflector offset. So a
//! rigid motion of what one reflector's set-ups see is invisible (their stations move along).
//! For a three-axis machine (the 21 errors: 18 component errors and `EC0Y`, `EB0Z`, `EA0Z`),
//! as worked out in `crates/identify/tests/suite/tracer_campaign.rs` on the shipped `ZFYX`
//! (`mcv754-zfyx`: X and Y carry the table, Z the spindle):
//!
//! - **The constant terms of the angular errors (`P0` of `EAX … ECZ`) are invisible to any
//!   layout**: nine null directions. X's three turn the workpiece (the set-up's `WP_DA…`);
//!   Z's three turn the tool, which moves each set-up's reflector by a constant its station
//!   absorbs (`TOOL_D…`); Y's three turn the workpiece and shear the X motion, which the
//!   squareness errors carry. A tracer campaign's error model should leave them out
//!   (`[component.EAX] min_degree = 1`, and so on for the nine): then the squareness errors
//!   carry Y's. Everything else — every varying term of the 18 component errors and the three
//!   squareness errors — a good layout identifies.
//! - **Recommended layout**: the same grid (`counts = [4, 4, 4]`, 80 % of the strokes) from
//!   four stations around and below the volume at different heights, with three reflector
//!   offsets: at the tool point, along the tool (a 200 mm longer tool) and lateral
//!   (`[150, 100, 100]`): twelve set-ups. Noise-free it recovers all 21 errors exactly (1e-6
//!   µm/µrad, Legendre degree 2); with σ ≈ 0.2 µm the 95 % intervals are about 0.4 µm/µrad on
//!   average and cover the truth at the stated rate (0.96 over 528 intervals). The ISO-style
//!   `lines` path (edges and body diagonals, 6 samples a line) separates the same errors.
//! - **No reflector offset**: the angular errors of the tool-side axis (Z) act through the
//!   fixed lever from its guideway to the tool point, exactly like Z's straightness and
//!   positioning: three combinations of `EAZ`, `EBZ`, `ECZ` with `EXZ`, `EYZ`, `EZZ`, `EA0Z`,
//!   `EB0Z` are lost. The angular errors of X and Y still show through levers that change with
//!   the other axes' positions.
//! - **Offsets along the tool only**: at the nominal machine one combination of the rolls
//!   (`ECY`, `ECZ` linear terms with `EXY`, `EYZ`, `EZZ`, `EB0Z`) is lost: a roll shows only
//!   through a lateral offset. (With errors present, second-order terms make it look barely
//!   identified, condition ~1e8: use a lateral offset.)
//! - **Stations**: three stations, or four in one plane (the same height), still separate
//!   everything, because the model has far fewer unknowns than the path has points and the
//!   reflector stays well off the stations' plane; three widen the intervals by about 40 %,
//!   coplanar ones hardly at all. Two stations leave the problem nearly singular (intervals a
//!   hundred times wider), one loses most of the errors. Four (or more, for redundancy), at
//!   different heights, is the layout to use.
//!
//! The identifier reports every combination a layout cannot separate in `unidentifiable`,
//! without a number.
//!
//! # Evaluation
//! None of its own: a tracer run means nothing alone. [`nc_program`] writes a path as G-code.

mod fixture;
mod path;
mod setup;

pub use fixture::fixture;
pub use mtcal_instrument::program::nc_program;
pub use path::{
    DEFAULT_COUNTS, DEFAULT_FRACTION, DEFAULT_LINE_SAMPLES, MIN_DISTANCE_MM, PATH_KEYS,
    linear_axes, path,
};
pub use setup::{
    DEFAULT_SIGMA_UM, DEFAULT_SIGMA_UM_PER_M, SETUP_KEYS, TracerConfig, TracerSetup, load,
    load_setup, middle_of_strokes, nuis,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "tracer",
        about: "laser tracer (tracking interferometer): station-to-reflector distance changes from several stations, stations and dead paths self-calibrated; reading d (um)",
        load_setup,
        fixture,
        path,
        path_labels: None,
        evaluate: None,
        polar_view: None,
        diagnose: None,
        planning: None,
    }
}
