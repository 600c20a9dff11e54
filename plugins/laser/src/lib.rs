//! Laser interferometer: linear (ISO 230-2 positioning), straightness, angular (pitch / yaw),
//! diagonal and step-diagonal (ISO 230-6) runs, with environmental compensation of the
//! readings and the ISO 230-2 evaluation of bidirectional positioning runs.
//!
//! # Measurement model
//! Notation (workpiece frame, SI): the actual tool pose `w_T_t = (R, t)` the core hands in, the
//! nominal pose at the commanded `q`, `(R₀, t₀) = Machine::tool_in_workpiece(q)` (the set-up
//! keeps a clone of the nominal machine; the nominal pose is stack-only, nothing allocates);
//! the optic offset `a` (tool frame, key `optic_offset`); the moving optic's actual and nominal
//! positions `p = t + R a`, `p₀ = t₀ + R₀ a`.
//!
//! Readings are **deviations**: what the instrument measured minus the commanded motion,
//! relative to the run's datum (where the instrument was zeroed). The datum's own error is a
//! constant of the run: the free zero offset `o` (nuisance `zero`) absorbs it, so a run's
//! readings need not start at 0. On the nominal machine every reading is exactly 0.
//!
//! **Length modes** (`linear`, `diagonal`, `step-diagonal`) and **straightness** share one
//! form. With `m₀` the nominal measuring direction (the beam `n` for length modes, the
//! straightness `sense` `s` for straightness) and `m` the actual one, tilted by small nuisance
//! angles,
//!
//! ```text
//! d = u · (p − p₀) + (m − m₀) · (p₀ − b) + o
//! u = m                   optic = "tool"  (the beam is fixed in the workpiece frame)
//! u = R R₀ᵀ m             optic = "table" (the beam turns with the tool)
//! ```
//!
//! The first term is the optic's deviation from its nominal position along the measuring
//! direction: at first order `u·δt + (R a × u)·δθ`, the second part the **Abbe error** (an
//! angular error δθ of the tool acting through the optic's lever `R a`; e.g. a pitch `EBX` with
//! the optic `h` above the tool point reads `h·EBX` in a linear X run). The second term is the
//! tilt of the measuring direction about `b`, a point on the beam (key `origin`; default the
//! workpiece origin), acting on the commanded travel. Give `origin` on the path's line (where
//! the beam was aligned): the tilt then shifts no reading at first order on a straight path,
//! and the run's zero is determined on its own; about a far point a tilt adds the constant
//! `tilt × distance`, which zero and tilt share (zero then comes out with the tilt prior's
//! interval times that lever).
//!
//! - *Length modes*: `m = (n + α e₁ + β e₂)/√(1 + α² + β²)`, `α, β` the beam tilt (nuisance
//!   `tilt_1`, `tilt_2`, µrad) towards `e₁`, `e₂` ([`perpendicular_basis`]: `e₁` is the
//!   workpiece axis least aligned with `n`, made perpendicular to it; `e₂ = n × e₁`). The model
//!   is exact in the tilt, so the conformance Jacobian check holds at any tilt. How it enters:
//!   along the travel `s = n·(p₀ − b)`,
//!   `(m − n)·(p₀ − b) = (1/k − 1) s + (α e₁ + β e₂)·(p₀ − b)/k`: the
//!   **cosine error** `−(α² + β²)/2 · s` is second order and is confounded with the axis'
//!   linear positioning slope (the `EXX` slope); the first-order part `α e₁·p₀` is a constant
//!   on a straight path (absorbed by `o`) and varies only on paths that move across the beam
//!   (step-diagonal, where it is what ISO 230-6 looks for). So the tilts carry a **prior**
//!   (`tilt_prior_urad`, default 100 µrad — a laser aligned to ~0.1 mm over 1 m) and the prior
//!   decides between tilt and slope: with the default a cosine error of at most
//!   `(10⁻⁴)²/2 = 5·10⁻⁹` (0.005 µm/m), far below any positioning slope of interest.
//! - *Straightness*: `m = (s − γ n)/√(1 + γ²)`: the reference line of the straightness optics
//!   leans by `γ` (nuisance `slope`, µrad, free, no prior) towards `+s`, so a perfect axis reads
//!   `−γ·(n·p₀)` (+ const). This is the slope a straightness evaluation removes: a
//!   straightness run does not measure squareness (the set-up's alignment takes it).
//! - *Neglected* (optic = "table"): the turning beam's cosine error over the distance between
//!   the optics, `L·(1 − cos θ)` with `θ` the tool's angular error (`L = 1 m`, `θ = 20 µrad`:
//!   0.0002 µm).
//!
//! **Angular** mode: `d = w · log(R R₀ᵀ) + o`, `w` the unit axis `about`: the tool's rotation
//! relative to nominal about `w` (µrad). Which side carries the moving optic does not matter
//! (the relative rotation is read); the beam direction only checks the path.
//!
//! # Derivatives (analytic)
//! With the left pose perturbation (`t ← t + δt`, `R ← exp([δθ]×) R`):
//! - length / straightness: `∂d/∂δt = u`, `∂d/∂δθ = (R a) × u` (+ `u × (p − p₀)` when the beam
//!   turns with the tool, `δu = δθ × u`); `∂d/∂o = 1`;
//!   `∂d/∂α = ∂u/∂α · (p − p₀) + ∂m/∂α · (p₀ − b)` with `∂m/∂α = (e₁ − α m)/k` (`k = √(1+α²+β²)`;
//!   `∂u/∂α = R R₀ᵀ ∂m/∂α` for the table optic), likewise `β`, `γ` (with `e₁ = −n`).
//! - angular: `∂d/∂δθ = J_l(φ)⁻ᵀ w` with `φ = log(R R₀ᵀ)` (`log(exp(δθ) exp(φ)) = φ +
//!   J_l(φ)⁻¹ δθ + …`), `∂d/∂δt = 0`, `∂d/∂o = 1`.
//!
//! # Set-up keys (`[run.setup]` or `[setup.<name>]`)
//! | key | default | meaning |
//! |---|---|---|
//! | `mode` | required | `linear`, `straightness`, `angular`, `diagonal`, `step-diagonal` |
//! | `direction` | required | the beam (= travel) direction, workpiece frame: an axis letter `"X"`, `"-Y"` or a vector `[x, y, z]` (normalised) |
//! | `sense` | straightness: required | the direction the straightness deviation is read in (letter or vector), perpendicular to `direction` (`|cos| ≤ 1e-6`; orthogonalised) |
//! | `about` | angular: required | the axis of the rotation read (pitch or yaw), letter or vector, perpendicular to `direction` |
//! | `optic` | `"tool"` | `"tool"`: moving optic on the spindle side, laser and fixed optic on the table; `"table"`: moving optic on the table, laser on the tool side (the beam turns with the tool) |
//! | `origin` | `[0, 0, 0]` | mm, a point on the beam (where it was aligned), workpiece frame: the point the beam tilts about |
//! | `optic_offset` | `[0, 0, 0]` | mm, where the moving optic (or, for `"table"`, the tool-side optic) sits relative to the tool point, tool frame: the Abbe offset |
//! | `sigma_um` | 0.5 | µm, standard deviation of one length / straightness reading |
//! | `sigma_urad` | 1.0 | µrad, standard deviation of one angular reading |
//! | `offset_free` | `true` | fit the zero offset (nuisance `zero`, µm or µrad); `false` holds it at 0 |
//! | `tilt_free` | `true` | length modes: fit the beam tilts `tilt_1`, `tilt_2` (µrad) under their prior |
//! | `tilt_prior_urad` | 100 | length modes: standard deviation of the tilts' prior, µrad |
//! | `slope_free` | `true` | straightness: fit the reference slope `slope` (µrad, no prior) |
//! | `wavelength_compensated` | `true` | length modes: `false` = the readings were made with `assumed_index` and are corrected here for the air (below) |
//! | `assumed_index` | 1.0 | the refractive index the instrument assumed (1.0: it counted vacuum wavelengths) |
//! | `wavelength_nm` | 632.991 | vacuum wavelength of the laser, nm |
//! | `air_temperature_c`, `air_pressure_hpa`, `air_humidity_pct` | none | fixed air values used when the run has no `T_air` (°C), `P_air` (hPa), `H_air` (% RH) column |
//! | `expansion_ppm_per_k` | none | length modes: expansion coefficient of the machine's scale / material, ppm/K: normalise to 20 °C |
//! | `material_temperature_c` | none | fixed material temperature, °C, when the run has no `T_material` column |
//!
//! Unknown keys, keys of another mode (`sense` in a linear set-up, the air keys without
//! `wavelength_compensated = false`), malformed and out-of-range values are rejected with a
//! [`SetupError`](mtcal_instrument::SetupError) naming the key. One channel `d` (µm; µrad in
//! angular mode). Nuisance parameters, in order: `zero`, then `tilt_1`, `tilt_2` (length modes)
//! or `slope` (straightness). Runs that share a named set-up share them, so give each run its
//! own set-up unless they share the datum.
//!
//! ```toml
//! [setup.x-linear]
//! mode = "linear"
//! direction = "X"
//! optic_offset = [0.0, 0.0, 80.0]
//! wavelength_compensated = false
//! expansion_ppm_per_k = 11.5
//! ```
//!
//! # Environmental compensation ([`SetupFormat::prepare_readings`](mtcal_instrument::SetupFormat::prepare_readings))
//! Length modes only, before the fit. The instrument reports, at sample `k`, the deviation
//! `d_k = L_k − c_k`, with `c_k = n·(p₀(q_k) − p₀(q_0))` the commanded travel along the beam
//! from the datum, which is the run's **first sample** (the instrument zeroed there), and
//! `L_k` the length it measured. The true length at 20 °C material temperature is `κ_k L_k`:
//!
//! ```text
//! κ_k = n_assumed / n_air(T_air, P_air, H_air, λ)  ·  1 / (1 + α (T_material − 20 °C))
//! d'_k = κ_k L_k − c_k = κ_k d_k + (κ_k − 1) c_k
//! ```
//!
//! (the first factor only with `wavelength_compensated = false`, the second only with
//! `expansion_ppm_per_k`). `n_air` is the revised Edlén equation of Birch & Downs (Metrologia
//! 30 (1993) 155, corrected in Metrologia 31 (1994) 315; [`edlen_index`]), with the water
//! vapour pressure from the relative humidity and the IAPWS saturation pressure
//! ([`saturation_vapour_pressure`]). Material normalisation: a scale (or workpiece) at
//! `T > 20 °C` is longer by `α (T − 20)`; the reading is scaled as if it were at 20 °C
//! (ISO 230-2 §5.3). Values come from the run's context columns `T_air`, `P_air`, `H_air`,
//! `T_material` when present (every row checked: an error names the column and row), or from
//! the set-up's fixed values; neither is an error naming the column. A datum elsewhere than the
//! first sample changes `d'` by `(κ − 1)·Δc`: for `κ − 1 ≈ 10⁻⁵` and 1 mm, 0.01 µm, constant
//! while the air is.
//!
//! # Path keys (test plans)
//! Along one axis (`linear`, `straightness`, `angular`):
//! `path = { axis = "X", from = -300.0, to = 300.0, points = 11, cycles = 5, overrun = 5.0,
//! hold = { Y = 0.0, Z = -200.0 } }`
//! - `axis`: the moving linear axis (default: the set-up's `direction` when it is a letter);
//! - targets: `targets = [mm, …]`, or `from`/`to` (mm, default the axis limits) with `step`
//!   (mm) or `points` (default 11); sorted ascending;
//! - `cycles` (default 1) ISO 230-2 cycles: each approaches the targets ascending (↑) then,
//!   with `bidirectional = true` (default), descending (↓);
//! - `overrun` (mm, default 0): each pass starts `overrun` beyond its first target (a recorded
//!   sample there), so every target is approached from the right side; without it the
//!   reversal point is recorded twice (last ↑ reading, first ↓ reading);
//! - `hold`: the other axes' positions (mm / degrees, default 0).
//!
//! Diagonals (`diagonal`, `step-diagonal`): `path = { from = { X = -200.0, Y = -150.0,
//! Z = -400.0 }, to = { X = 200.0, Y = 150.0, Z = -100.0 }, points = 11, cycles = 1 }`: the
//! targets evenly spaced from `from` to `to`; step-diagonal moves one axis at a time between
//! targets (machine axis order), recording after every step. The path checks that the nominal
//! tool point travels along the set-up's `direction` (within [`ALIGN_TOL`] rad; the error gives
//! the vector to write) and the axis limits.
//!
//! # Evaluation (ISO 230-2:2014)
//! For `linear` and `diagonal` runs, [`evaluate()`] reports the axis values of
//! [`iso230_2()`] (`A↑ (ISO 230-2)`, `A↓`, `A`, `E↑`, `E↓`, `E`, `M`, `R↑`, `R↓`, `R`, `B`,
//! `B̄`; µm). A linear run moving one axis is evaluated along that axis (targets = its
//! commanded positions, ↑ = its positive direction, `x = P_measured − P_target` along it: the
//! reading, negated when the beam points against the axis' motion); a diagonal along the beam
//! (↑ = the travel increasing along `direction`). Approach directions come from the motion
//! ([`approach_directions`]), whatever any label says; targets are the positions approached at
//! least twice from each side ([`approach_table`]). [`approach_table`] and [`iso230_2()`] are
//! public for any bidirectional target/cycle table. Each value carries its expanded
//! uncertainty `U` (k = 2; [`Iso230_2::uncertainty`]: the repeatability of each mean, never
//! below the set-up's reading noise `sigma_um`, propagated through the range or maximum that
//! defines the value; what it leaves out is in docs/ACCEPTANCE.md), and a run evaluated along
//! an axis names it (the metric's `subject`), so acceptance can check it against that axis'
//! tolerances.
//!
//! A `straightness` run reports `straightness deviation (ISO 230-1)`: the range of its
//! readings about their least-squares line over the travel ([`straightness()`], µm); an
//! `angular` run `angular deviation (ISO 230-1)`: the range of its readings (µrad).

mod env;
mod fixture;
mod iso230_2;
mod mode;
mod path;
mod setup;

pub use env::{
    COLUMN_AIR_H, COLUMN_AIR_P, COLUMN_AIR_T, COLUMN_MATERIAL_T, Environment, HENE_NM, REFERENCE_C,
    compensate, edlen_index, edlen_index_f, length_factor, saturation_vapour_pressure,
};
pub use fixture::fixture;
pub use iso230_2::{
    Approaches, COVERAGE, Iso230_2, Iso230_2Error, Iso230_2Uncertainty, TARGET_TOL, TargetStats,
    approach_directions, approach_table, evaluate, iso230_2, straightness,
};
pub use path::{ALIGN_TOL, AXIS_PATH_KEYS, DEFAULT_POINTS, DIAGONAL_PATH_KEYS, path};
pub use setup::{
    DEFAULT_SIGMA_UM, DEFAULT_SIGMA_URAD, DEFAULT_TILT_PRIOR_URAD, Direction, LaserSetup, Mode,
    Optic, PERPENDICULAR_TOL, SETUP_KEYS, load, load_setup, perpendicular_basis,
};

inventory::submit! {
    mtcal_instrument::InstrumentPlugin {
        name: "laser",
        about: "laser interferometer: linear, straightness, angular, diagonal and step-diagonal runs (ISO 230-2, ISO 230-6), air and material compensation; reading d (um, urad for angular)",
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

inventory::submit! {
    mtcal_instrument::capability::PositioningRuns {
        instrument: "laser",
        reading: "d",
        setup: positioning_setup,
    }
}

/// The set-up of a positioning run along the linear axis `axis`: linear mode, the beam along
/// the axis (what the importers of laser exports write).
pub fn positioning_setup(axis: char) -> toml::Table {
    let mut setup = toml::Table::new();
    setup.insert("mode".into(), Mode::Linear.as_str().into());
    setup.insert("direction".into(), axis.to_string().into());
    setup
}
