//! Artefact plates (ball plates, hole plates) probed by the machine: calibrated feature
//! positions, measured feature centres, the plate placed on the table at one or more placements
//! (the classic reversal: turned, moved, flipped) so that the fit separates the plate's own
//! errors from the machine's.
//!
//! Also two public toolboxes that need no session: [`plate`] (2-D similarity / affine /
//! quadrupole fits of measured against nominal positions, with uncertainties from the residual
//! scatter, and a reader for CMM hole-plate reports) and [`rotary_axis`] (a rotary axis' line
//! from points measured on arcs: plane + circle fits, the maths of the location errors `EX0C`,
//! `EY0C`, `EA0C`, `EB0C`).
//!
//! # Measurement model
//! The machine probes feature `k` of placement `j`. The run file has the axis positions `X, Y,
//! Z` where it was probed (commanded, or the position the probing cycle reports), the measured
//! feature centre `x, y, z` (mm, **machine coordinates**, i.e. the axis positions at which the
//! machine's scales say the centre is) and the label column `feature`.
//!
//! With `m` the measured centre and `q` the probed axis positions, the modelled reading is
//! `d = m − q` ([`SetupFormat::prepare_readings`](mtcal_instrument::SetupFormat::prepare_readings) forms it
//! from the file). The machine reports `m = q*`, the axis positions at which its *actual* tool
//! point sits on the feature's true centre `f_w`: `p_act(q*) = f_w`. With nominal kinematics
//! `p_nom(q) = q + c` (on every machine the plugin accepts, the linear axes X, Y, Z move the
//! nominal tool point along the workpiece frame's axes; `c` is the nominal tool point at q = 0)
//! and `p_act = p_nom + e(q)` (`e` the machine's error field):
//!
//! ```text
//! d = q* − q = f_w − p_act(q) − [e(q*) − e(q)]      exact
//! d ≈ f_w − p_act(q)                                  the model
//! f_w = c + o_j + δt_j + Rn_j · R0_j · (F_k + Δf_k)
//! ```
//! where `o_j` is the placement's origin (axis coordinates), `R0_j = Rz(rotation_deg)·Flip`
//! (Flip = diag(1, −1, −1) when `flipped`: turned over about the plate's X axis), `F_k` the
//! calibrated feature position (plate frame), and the nuisance parameters: `δt_j` and
//! `Rn_j = Rz(rz)·Ry(ry)·Rx(rx)` the placement's deviation from its nominal pose, `Δf_k` the
//! plate's own feature error. **Approximation**: the dropped term `e(q*) − e(q)` is the change of
//! the machine's error over `q* − q`: gradient (≈ 10⁻⁵) × distance (the probed position's
//! offset from the true centre, ≈ 10 µm when `q` is commanded to the nominal centre) ≈ 10⁻⁴ µm;
//! when `q` is the probing cycle's reported centre it is exactly zero. The placement's rotation
//! is exact (not linearised). On the nominal machine with nominal placement and plate, probing
//! at `q = o_j + R0_j·F_k` reads `d = 0`: what the conformance harness checks.
//!
//! **Analytic derivatives.** `∂d/∂δt_tool = −I`, no dependence on the tool's orientation (the
//! probed point is the tool point); `∂d/∂δt_j = I`; `∂d/∂(rx, ry, rz) = ∂Rn/∂(·)·R0·(F + Δf)`;
//! `∂d/∂Δf_k = Rn·R0`.
//!
//! **Simulated sessions.** `simulate` writes the model's reading `d` into the `x, y, z`
//! columns (it has no hook to turn a modelled reading back into a recorded one), while
//! `identify` reads them as measured centres and subtracts `q`. Until the core gains that hook,
//! a simulated artefact run must get `q` added to `x, y, z` before it is identified (the planted
//! truth test does this).
//!
//! # Placements: what separates the plate from the machine
//! Per placement: translation `dx, dy` and rotation `rz` (2-D plate), or `dx, dy, dz, rx, ry,
//! rz` (3-D plate); per feature the error `ex, ey` (2-D) or `ex, ey, ez` (3-D), **shared by all
//! placements** (the same plate). A single placement cannot tell a feature's error from the
//! machine's error at that point: every machine error an XY plate sees is then unidentifiable
//! (unless the plate is calibrated: `feature_sigma_um` puts a prior on `Δf` — then the
//! calibration is the reference). Several placements see the same plate errors at different
//! machine positions (for the XY plane, with the field `e = (EXX(x) + EXY(y) − EC0Y·y,
//! EYY(y) + EYX(x))`):
//! - **moved** along X (or Y): the difference of the field at `p` and `p + a` for every feature
//!   — the shape (curvature) of `EXX`, `EYX` (moves along X) and of `EYY`, `EXY` (along Y);
//! - **turned by 90°**: the plate's X and Y scales swap axes — the difference of the X and Y
//!   scale errors (EXX slope − EYY slope) and the squareness `EC0Y` (its symmetric shear
//!   changes sign under a 90° turn, the plate's does not);
//! - **flipped** (turned over about its X axis): mirrors the plate — also separates the
//!   squareness (a shear changes sign under the mirror) but not the difference of scales;
//! - never: the **common scale** of X and Y (EXX slope + EYY slope) against the plate's own
//!   scale — a uniform scale commutes with every turn and move. Only a calibrated plate
//!   (`feature_sigma_um`) fixes it; otherwise it is reported unidentifiable.
//!
//! Without a prior the plate's rigid motion is the same as moving every placement; the plugin
//! fixes the plate's own frame by holding a few feature error components at zero (its datum,
//! [`ArtefactSetup::datum_held`]): the feature errors are then relative to that datum.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `features` | required | table name → `[x, y]` (2-D plate) or `[x, y, z]` mm, calibrated positions in the plate's own frame; names: ASCII letters, digits, `_ - .` |
//! | `placements` | one placement `p1` from the keys below | table name → `{ origin, rotation_deg, flipped, free }` |
//! | `origin` | `[0, 0, 0]` | mm, where the plate's origin sits, machine (axis) coordinates |
//! | `rotation_deg` | `0` | the plate turned about +Z |
//! | `flipped` | `false` | the plate turned over about its own X axis |
//! | `free` (in a placement) | `true` | estimate the placement's deviation from nominal |
//! | `sigma_um` | `1.0` | µm, standard deviation of one measured coordinate |
//! | `feature_sigma_um` | none | µm, the plate's calibration uncertainty: a prior on each feature error; without it the feature errors are free (an uncalibrated plate) |
//! | `feature_errors` | `true` | model the plate's feature errors; `false` holds them at zero (a perfect plate) |
//!
//! The top-level `origin`, `rotation_deg`, `flipped` and `placements` exclude each other;
//! `to_toml` always writes `placements`.
//!
//! **Channels** `x, y` (2-D) or `x, y, z` (3-D), unit mm (file values are positions). **Label
//! column** `feature`: the feature name, or `placement/feature` when there is more than one
//! placement (`p2/h07`). **Nuisance** `<placement>_dx … _rz` (µm, µrad) in placement name order,
//! then `<feature>_ex, _ey(, _ez)` (µm) in feature name order.
//!
//! # Machines
//! The set-up loads on a machine with linear X, Y, Z axes that move the nominal tool point along
//! the workpiece frame's X, Y, Z (checked when loading, with every other axis at 0): all shipped
//! machines. Rotary axes are held at 0 (a plate on a rotary table is probed at C = 0).
//!
//! # Path keys (test plans)
//! `path = { placements = ["p1", "p2"], repeat = 1 }`: visits every feature (name order) of each
//! named placement (default: all, name order) at its nominal position; other axes at 0. A plan's
//! `noise` is in the channels' unit, **mm** (`noise = 0.0005` for 0.5 µm).
//!
//! # A plate the machine drilled, measured elsewhere
//! When the machine *made* the features (drilled a hole plate) and a CMM measured them, the
//! roles swap: the machine put each hole at its actual tool position `nom + e(nom)` and the CMM,
//! the reference, reports that. Give the CMM's measured centres as `features` (the "calibrated"
//! plate, with `feature_errors = false`), and the nominal (drilled) positions as both the axis
//! columns and the readings: the fit then finds `e` with the machine's own sign. The real-data
//! test `crates/identify/tests/suite/real_hole_plate.rs` does this, and [`plate`] fits the same
//! terms without a session.
//!
//! # Evaluation
//! [`evaluate()`] reports, per placement, what a plate report states: the similarity fit's RMS
//! and largest deviation of the measured centres from the calibrated ones, its scale, and the
//! affine fit's apparent X/Y scale difference and squareness (machine and plate errors
//! together; the identification separates them across placements).
//!
//! # Example
//! ```toml
//! [setup.plate]
//! sigma_um = 0.5
//! [setup.plate.features]
//! h00 = [0.0, 0.0]
//! h01 = [0.0, 100.0]
//! h10 = [100.0, 0.0]
//! [setup.plate.placements]
//! p1 = { origin = [-50.0, -50.0, -300.0] }
//! p2 = { origin = [50.0, -50.0, -300.0], rotation_deg = 90.0 }
//! ```

pub mod collision;
mod evaluate;
mod path;
pub mod plate;
pub mod rotary_axis;
mod setup;

pub use evaluate::evaluate;
pub use path::{PATH_KEYS, fixture, path, path_labels};
pub use setup::{
    ArtefactSetup, DEFAULT_PLACEMENT, DEFAULT_SIGMA_UM, PLACEMENT_KEYS, Placement, SETUP_KEYS,
    frame_of, load, load_setup, valid_name,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "artefact",
        about: "ball or hole plate probed at one or more placements (reversal); readings x,y,z (mm, measured feature centres), label column feature",
        load_setup,
        fixture,
        path,
        path_labels: Some(path_labels),
        evaluate: Some(evaluate),
        polar_view: None,
        diagnose: None,
        planning: Some(collision::PLANNING),
    }
}
