//! An independent simulator of measurement sessions, for testing mtcal against physics it did
//! not write itself.
//!
//! mtcal's own `cargo xtask simulate` plants errors with the same kinematics its fit then
//! uses, so a recovery test on such a session proves arithmetic, not physics. This crate
//! writes sessions from its own formulation and shares **no code** with mtcal: it depends on
//! no `mtcal-*` crate (only its tests do, to compare). What it deliberately shares with mtcal
//! is the contract: the file formats of `/work/shared/FORMATS.md` (session folder, run CSVs,
//! units, ISO 230-1 names), the error-model conventions of ARCHITECTURE.md ("Conventions"),
//! the parameter-file and error-model-configuration formats, and each instrument plugin's
//! documented set-up keys and measurement physics.
//!
//! # What it models
//! - [`Machine`]: a URDF parsed with `urdf-rs`; the root link is the machine frame, one branch
//!   ends in the link `workpiece`, the other in `tool`; fixed joints stay constant transforms
//!   in their place; moving joints (named by axis letter) in the order X Y Z U V W A B C.
//!   Poses are plain `nalgebra::Matrix4<f64>` products, joint by joint.
//! - [`Truth`]: the geometric errors, by ISO 230-1 name, SI inside. Conventions (second order
//!   exact, since the agreement with mtcal is checked to 1e-9 µm):
//!   - component errors `E = (exp([ε]×), δ)`: three translations and a rotation vector, in
//!     machine directions at the zero pose (turned into the joint frame by the inverse of the
//!     joint frame's zero-pose orientation), the rotation about the joint frame's origin;
//!     `exp` is the exact rotation (Rodrigues). A linear axis moves `Trans(q·a)·E` (the error
//!     follows the carriage), a rotary axis `E·L·Rot(a, q)·L⁻¹` (the error motion does not
//!     turn). Errors are the tool's motion relative to the workpiece, so a workpiece-side axis
//!     moves its body by `E⁻¹`;
//!   - location errors `L = (exp([lw]×), lt)` of a rotary axis: where its line passes and how
//!     it tilts, across its own direction; its own-direction location errors are constants of
//!     its own-direction component errors;
//!   - squareness `EC0Y`, `EB0Z`, `EA0Z`: the tilt `R_L` of Y's or Z's direction of motion
//!     about +Z, +Y, +X: the axis moves along `R_L·a`. `EC0Y > 0` makes the angle between +X
//!     and +Y larger than 90°: moving Y by y moves the tool by −EC0Y·y along X;
//!   - set-up: `TOOL_DX..DZ` the tool point's offset in the tool frame, `WP_DX..WP_DC` the
//!     actual workpiece frame in the nominal one (translation, then rotation vector);
//!   - component errors as functions: Legendre P0..P3 over the stroke on linear axes
//!     (positioning from P1, straightness from P2, angular from P0) and Fourier harmonics 1..2
//!     on rotary axes — the terms mtcal's default full model keeps.
//! - [`Instrument`]s by their physics: the R-test in both mountings ([`Mount`]), the ball bar,
//!   the laser interferometer, the laser tracer (station on the table, reflector on the tool),
//!   fixed displacement sensors and artefact plates. Laser and tracer readings are zeroed at the
//!   run's first sample, as the instruments are.
//!   - `laser` ([`Instrument::Laser`], [`LaserMode`]): beam and fixed optic on the table
//!     (directions fixed in the workpiece frame), moving optic on the tool side at
//!     `optic_offset` in the tool frame (the plugin's `optic = "tool"`, not written).
//!     `linear`, `diagonal`, `step-diagonal`: the moving optic's deviation from its nominal
//!     position along the beam `direction` (Abbe errors through the offset); a diagonal is a
//!     beam through the work volume with the linear axes moving together, a step diagonal the
//!     same beam with one axis moving at a time between its targets (ISO 230-6; the optic then
//!     also moves across the beam). `straightness`: the same deviation across the beam, along
//!     `sense`. `angular` (pitch / yaw optics): the tool's rotation relative to the workpiece
//!     beyond the commanded one, about `about` across the beam — the component of the rotation
//!     vector of `R R₀ᵀ` (actual times nominal orientation transposed, workpiece frame), read in
//!     µrad (the one reading in µrad; its stated σ is `sigma_urad`, and [`Realism`]'s µm
//!     figures are taken as µrad for it, i.e. per metre); the optic's place on the tool does not
//!     enter (`optic_offset` not written). The beam is aligned: no tilt, no cosine error.
//!   - `displacement` ([`Instrument::Displacement`], ISO 230-3 thermal tests): sensors in a
//!     fixture on the table (directions fixed in the workpiece frame: an axis letter, a vector,
//!     or none), a mandrel on the tool point, touched at the tool point or `at` an offset in
//!     the tool frame. A sensor reads, along its direction, how far the touched point is from
//!     where the sensor was zeroed: the nominal mandrel at `setup.position`, oriented as the
//!     nominal tool at the run's first sample, moved with the fixture's misplacement. A sensor
//!     without a direction reads 0. Columns `d_<sensor>` in the order given.
//!   - `artefact` ([`Instrument::Artefact`]): a 2-D (`[x, y]`) or 3-D plate at one or more
//!     placements (origin in axis coordinates — where the nominal tool point is with X, Y, Z
//!     there and the other axes at zero —, turned about +Z, flipped about its own X). Each
//!     sample probes one feature, named by its label (`feature`, or `placement/feature` with
//!     several placements; [`RunPlan::labels`]); the reading `x, y(, z)` (mm, the only
//!     readings not in µm) is the axis position at which the machine's actual tool point sits
//!     on the feature's true centre (Newton on the actual chain; a 2-D plate solves X, Y and
//!     keeps Z). The axis columns are the commanded positions ([`Probed::Commanded`]) or the
//!     probing cycle's reported centre ([`Probed::Reported`]). The label column is written
//!     after the readings.
//! - [`Effect`]s a geometric model leaves out, by their physics ([`effects`] has each one's
//!   formula and sign), acting along the session's timeline (runs in plan order, state
//!   carried from run to run, validation runs alike; [`Plan::effects`], empty by default):
//!   - on an axis' actual position (the written commands stay the commands): lost motion
//!     ([`Effect::Backlash`], a dead band along the commanded sequence; [`Effect::LostMotion`],
//!     its width varying along the stroke and its state at a run's start carried or random,
//!     [`Approach`]), a periodic screw error ([`Effect::ScrewError`]), scale expansion about a
//!     reference with its temperature ([`Effect::ThermalScale`]), a position loop trailing its
//!     command ([`Effect::ServoLag`]), a time-based spike at reversals
//!     ([`Effect::ReversalSpike`]), a travel-based stick-slip after them ([`Effect::StickSlip`]);
//!   - as a translation of the tool point relative to the workpiece in machine directions,
//!     `w_T_t = f_T_w(a)⁻¹ · Trans(d) · f_T_t(a)` at the actual axis positions `a`: the
//!     spindle head's thermal growth from first-order nodes integrated exactly
//!     ([`Effect::Thermal`], [`HeatSource`], [`Programme`]), a table twist `k·x·y` along Z
//!     ([`Effect::Twist`]), a sag `k·q²` ([`Effect::Sag`]), a carriage rocking across its
//!     guideway clearance with the direction of motion ([`Effect::LateralPlay`]), a local dent
//!     of a guideway ([`Effect::GuidewayBump`]), the structure following a step of the room
//!     temperature through a node, the same everywhere ([`Effect::AmbientStep`]);
//!   - as a turn of the tool branch about a fixed line parallel to X, pre-multiplied after
//!     the translation (`f_T_w(a)⁻¹ · H(θ) · Trans(d) · f_T_t(a)`): a cross-beam twisting with
//!     a drive's temperature, `θ = g·(T(t) − T(0))` ([`Effect::HeadRotationX`]: the tool point
//!     moves by `(Rot_x(θ) − I)(p − c)`, a lever arm that differs between points);
//!   - as a translation in the tool frame (post-multiplied on the tool branch): the spindle's
//!     growth along its own axis ([`Effect::SpindleGrowth`]), turning with a tilting head;
//!   - on the instrument alone: the ball bar's own expansion ([`Effect::BallBarThermal`]), a
//!     set-up's fixed element settling after it was mounted ([`Effect::SetupCreep`]).
//!
//!   Every instrument reads the same actual pose. Context columns (after the readings and
//!   labels): a scale's temperature `T_<name>` (°C) in every run, the bar's in its set-up's
//!   runs, a head rotation's drive temperature and an ambient step's air temperature when
//!   they name a column, a logging sensor's ([`Effect::TemperatureSensor`]), the spindle speed
//!   `S` (rpm, [`Effect::SpindleSpeed`], which heat sources may follow) in every run;
//!   temperatures as a sensor reads them ([`Realism`]).
//! - [`paths`]: R-test follow-the-ball sweeps, ball-bar circles, laser lines, ISO 230-2
//!   bidirectional runs ([`paths::bidirectional`]), diagonals and step diagonals of the work
//!   volume ([`paths::diagonal`]), tracer grids; the linear axes come from this crate's own
//!   nominal inverse (Newton on the nominal chain) where a path follows a point.
//! - [`write_session`]: `session.toml` (machine path relative to the folder, shared
//!   `[setup.<name>]` tables, `use = "validate"` runs), one CSV per run (`t`, axis columns in
//!   mm / degrees, readings in µm — mm for the artefact, µrad for angular laser optics —,
//!   label columns, context columns), and the sidecar `truth/`: `params.toml` (the truth,
//!   `mtcal.params/1`), `errors.toml` (the model it lives in, `mtcal.errors/1`),
//!   `setups.toml` (real set-up offsets, the noise used), `<run>.csv` (noise-free readings,
//!   true context values) and, when effects are planted, `effects.toml` (each with its
//!   parameters, in µm / µrad / mm / s / K).
//! - [`Realism`]: sample-time jitter, quantised readings, AR(1)-coloured noise, a stated σ
//!   that differs from the one used, positions rounded as a controller writes them, real
//!   set-ups off the stated ones (ball / nest / pivot / station position, tool length; a normal
//!   draw, plus a bounded uniform one for a set-up placed by eye, e.g. up to 0.2 mm),
//!   temperature sensors' noise and resolution (a random stream of their own: with or without
//!   effects, every other draw is the same).
//!
//! # R-test mount key
//! FORMATS.md v1.1 has `setup.mount` (`"ball-on-table"`, the default, or `"ball-in-spindle"`).
//! [`Instrument::RTest::write_mount_key`] says whether the key is written; a file without it
//! means ball-on-table, so a ball-in-spindle set-up must write it.
//!
//! # Campaigns
//! [`Campaign::trunnion_rtest_ballbar`] and [`Campaign::three_axis_ballbar`] write the
//! sessions the identification tests use; [`Campaign::trunnion_rtest_ballbar_effects`] (the
//! trunnion's runs with effects, timed to half an hour) and
//! [`Campaign::three_axis_laser_tracer`] (ISO 230-2 laser runs, straightness, a laser-tracer
//! grid from four stations, validation runs; half an hour) plant effects.
//! [`Campaign::five_axis_check`] gives the half-hour R-test and ball-bar session of each
//! shipped five-axis layout ([`FiveAxisLayout`]: the trunnion's
//! [`Campaign::trunnion_thermal_check`], [`Campaign::table_table_check`],
//! [`Campaign::head_head_check`], [`Campaign::mixed_check`]);
//! [`Campaign::three_axis_ballbar_planes`] is a ball-bar-only session in three planes at two
//! feeds, its sample times following the feed ([`RunPlan::interval_s`]).
//!
//! # The volumetric thermal test
//! [`Campaign::volumetric_trunnion`] and [`Campaign::volumetric_three_axis`] write source
//! 000's volumetric thermal test (docs/VOLUMETRIC.md): an R-test head in the spindle visits 15
//! points in cycles of about 4.3 min at 2000 mm/min (2 s dwell on each ball) with 10 min load
//! phases between them — on the trunnion five balls of an artefact at C = 0, 120 and 240°, on
//! the three-axis machine 15 balls on a frame —, under spindle load (a uniform growth along
//! −Z, a little Z-screw growth) or Y-drive load (the head turning about X and the Y scale
//! growing with the drive's temperature), optionally with a step of the room temperature
//! ([`VolumetricSpec`], [`VolumetricLoad`], [`AmbientChange`]; [`Campaign::volumetric_plan`]
//! gives the machine, plan and effects). [`write_volumetric`] writes any [`VolumetricPlan`]
//! ([`volumetric`] gives the timing, the stream's samples, the noise and every file):
//! - the per-visit session: one set-up per ball, one run `<ball>` per ball (a row per visit:
//!   `t,<axes>,dx,dy,dz[,S][,T_<name>…]`), the withheld cycle as `<ball>-c<k>` runs with
//!   `use = "validate"`;
//! - `stream/`: `stream.csv` (`t,dx,dy,dz`, 500 Hz in the dwells, the end stop — the range in
//!   every column or empty cells, [`OffBall`] — off the balls, optionally the plunges' ramps),
//!   `cycle.nc` (the G-code of one cycle: `G90`, `G1 … F2000`, `G4 P<s>`) and `log.csv`
//!   (`t[,S][,T_<name>…]` every 10 s). A visit's reading is the mean of the stream over its
//!   dwell's middle half and its time the dwell's midpoint, its context the log interpolated
//!   there: what importing the stream gives;
//! - `truth/`: as [`write_session`]'s, plus `deformation.csv`
//!   (`t,point,ball,cycle,dx_um,dy_um,dz_um`: every visit's true deformation
//!   `d_j(t) = −(r_j(t) − r_j(t₀))` from the noise-free readings, µm, machine directions, `t₀`
//!   the point's first visit), `field.csv` (the same columns: every point at each cycle's
//!   midpoint, the field at one instant) and `volumetric.toml` (schedule and points).

pub mod campaign;
pub mod effects;
pub mod error;
pub mod instruments;
pub mod machine;
pub mod paths;
pub mod session;
pub mod truth;
pub mod volumetric;

use std::path::{Path, PathBuf};

pub use campaign::{
    AmbientChange, Campaign, FiveAxisLayout, VolumetricLoad, VolumetricMachine, VolumetricSpec,
};
pub use effects::{Approach, Effect, HeatSource, Programme, TemperatureProgramme};
pub use instruments::{
    DisplacementSensor, Instrument, LaserMode, Mount, PlatePlacement, Probed, SensorDirection,
    SetupOffsets,
};
pub use machine::{JointKind, Machine, MachineError, Side};
pub use session::{
    Plan, Realism, RunPlan, SetupPlan, SimError, Written, WrittenRun, write_session,
};
pub use truth::{AxisTruth, Truth};
pub use volumetric::{
    FieldValue, OffBall, Schedule, StreamOptions, Visit, VolumetricBall, VolumetricPlan,
    VolumetricPoint, VolumetricWritten, write_volumetric,
};

/// A shipped machine of the workspace's `machines/` folder, by file name.
pub fn shipped_machine(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../machines")
        .join(file)
}

#[cfg(test)]
mod tests;
