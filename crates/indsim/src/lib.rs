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
//! - [`paths`]: R-test follow-the-ball sweeps, ball-bar circles, laser lines, diagonals and
//!   step diagonals of the work volume ([`paths::diagonal`]), tracer grids; the linear axes
//!   come from this crate's own nominal inverse (Newton on the nominal chain) where a path
//!   follows a point.
//! - [`write_session`]: `session.toml` (machine path relative to the folder, shared
//!   `[setup.<name>]` tables, `use = "validate"` runs), one CSV per run (`t`, axis columns in
//!   mm / degrees, readings in µm — mm for the artefact, µrad for angular laser optics —,
//!   label columns), and the sidecar `truth/`: `params.toml` (the truth,
//!   `mtcal.params/1`), `errors.toml` (the model it lives in, `mtcal.errors/1`),
//!   `setups.toml` (real set-up offsets, the noise used) and `<run>.csv` (noise-free readings).
//! - [`Realism`]: sample-time jitter, quantised readings, AR(1)-coloured noise, a stated σ
//!   that differs from the one used, positions rounded as a controller writes them, real
//!   set-ups off the stated ones (ball / nest / pivot / station position, tool length).
//!
//! # R-test mount key
//! FORMATS.md v1.1 has `setup.mount` (`"ball-on-table"`, the default, or `"ball-in-spindle"`).
//! [`Instrument::RTest::write_mount_key`] says whether the key is written; a file without it
//! means ball-on-table, so a ball-in-spindle set-up must write it.
//!
//! # Campaigns
//! [`Campaign::trunnion_rtest_ballbar`] and [`Campaign::three_axis_ballbar`] write the
//! sessions the identification tests use.

pub mod instruments;
pub mod machine;
pub mod paths;
pub mod session;
pub mod truth;

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

pub use instruments::{
    DisplacementSensor, Instrument, LaserMode, Mount, PlatePlacement, Probed, SensorDirection,
    SetupOffsets,
};
pub use machine::{JointKind, Machine, MachineError, Side};
pub use session::{
    Plan, Realism, RunPlan, SetupPlan, SimError, Written, WrittenRun, write_session,
};
pub use truth::{AxisTruth, Truth};

/// A shipped machine of the workspace's `machines/` folder, by file name.
pub fn shipped_machine(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../machines")
        .join(file)
}

/// Ready-made sessions for the identification tests.
#[derive(Debug)]
pub struct Campaign;

impl Campaign {
    /// The shipped five-axis trunnion `machines/mcu630-cafyxz.urdf` (A cradle carrying a C
    /// table, spindle on X Y Z), a random truth from `seed` ([`Truth::random`], scale 1), and
    /// into `dir`:
    /// - R-test, ball on the table (`mount = "ball-on-table"` written), one shared
    ///   set-up `ball1` at [150, 0, 200] mm: `rtest-xyc` (C 0→360°, 145 samples), the same at
    ///   A = ±30° (`rtest-xyc-a+30`, `rtest-xyc-a-30`), `rtest-xyzac` (A −30→30° with C
    ///   0→360°, 289), and set-up `ball2` on the C axis at [0, 0, 200] mm: `rtest-yza`
    ///   (A −30→90°, 97);
    /// - ball bar, set-up `bar1` (pivot [0, 0, 200] mm, 100 mm): `ballbar-xy-ccw`,
    ///   `ballbar-xy-cw` (XY circles at A = C = 0, 361 samples), `ballbar-xy-c90` (the same
    ///   circle with C held at 90°);
    /// - validation runs: `rtest-validate` (ball1, A 20→−20° with C 0→180°, 37 samples),
    ///   `ballbar-validate` (bar1, an XY circle with C held at 45°, 91), `rtest-validate-a15`
    ///   (ball1, XYC at A = 15°, 73) and `ballbar-validate-c180` (bar1, the XY circle clockwise
    ///   with C held at 180°, 91).
    pub fn trunnion_rtest_ballbar(
        dir: &Path,
        seed: u64,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf"))?;
        let truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0);
        Self::trunnion_rtest_ballbar_with(dir, &truth, realism)
    }

    /// [`Self::trunnion_rtest_ballbar`] with a given truth (e.g. a random draw with the rotary
    /// axes' component errors removed).
    pub fn trunnion_rtest_ballbar_with(
        dir: &Path,
        truth: &Truth,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine("mcu630-cafyxz.urdf");
        let machine = Machine::from_urdf_file(&urdf)?;
        let truth = truth.clone();
        let deg = f64::to_radians;
        let ball1 = [150.0, 0.0, 200.0];
        let ball2 = [0.0, 0.0, 200.0];
        let rtest = |ball_mm| Instrument::RTest {
            ball_mm,
            mount: Mount::BallOnTable,
            write_mount_key: true,
        };
        let at = |v: [f64; 3]| Vector3::new(v[0], v[1], v[2]) * 1e-3;
        let pivot = [0.0, 0.0, 200.0];
        let circle = |ccw, hold: &[(char, f64)], n| {
            paths::circle(&machine, at(pivot), 0.1, (0, 1), ccw, hold, n)
        };
        // Source 000's XYC: C turned once round with the cradle held at `a_deg`.
        let xyc = |a_deg: f64, n| {
            paths::follow_ball(
                &machine,
                at(ball1),
                &[('C', 0.0, deg(360.0))],
                &[('A', deg(a_deg))],
                n,
            )
        };
        let run = |name: &str, setup: &str, validate, poses| RunPlan {
            name: name.into(),
            setup: setup.into(),
            validate,
            poses,
            labels: Vec::new(),
        };
        let plan = Plan {
            machine_urdf: urdf.clone(),
            setups: vec![
                SetupPlan {
                    name: "ball1".into(),
                    instrument: rtest(ball1),
                },
                SetupPlan {
                    name: "ball2".into(),
                    instrument: rtest(ball2),
                },
                SetupPlan {
                    name: "bar1".into(),
                    instrument: Instrument::BallBar {
                        pivot_mm: pivot,
                        length_mm: 100.0,
                    },
                },
            ],
            runs: vec![
                run("rtest-xyc", "ball1", false, xyc(0.0, 145)?),
                run(
                    "rtest-yza",
                    "ball2",
                    false,
                    paths::follow_ball(
                        &machine,
                        at(ball2),
                        &[('A', deg(-30.0), deg(90.0))],
                        &[],
                        97,
                    )?,
                ),
                run(
                    "rtest-xyzac",
                    "ball1",
                    false,
                    paths::follow_ball(
                        &machine,
                        at(ball1),
                        &[('A', deg(-30.0), deg(30.0)), ('C', 0.0, deg(360.0))],
                        &[],
                        289,
                    )?,
                ),
                // The XYC at the cradle tilted both ways: the C axis' location relative to
                // the A axis, seen from three A angles.
                run("rtest-xyc-a+30", "ball1", false, xyc(30.0, 145)?),
                run("rtest-xyc-a-30", "ball1", false, xyc(-30.0, 145)?),
                run("ballbar-xy-ccw", "bar1", false, circle(true, &[], 361)?),
                run("ballbar-xy-cw", "bar1", false, circle(false, &[], 361)?),
                // The same circle with the table turned a quarter: the pivot's offset from
                // C's axis line separates from the line's own position.
                run(
                    "ballbar-xy-c90",
                    "bar1",
                    false,
                    circle(true, &[('C', deg(90.0))], 361)?,
                ),
                run(
                    "rtest-validate",
                    "ball1",
                    true,
                    paths::follow_ball(
                        &machine,
                        at(ball1),
                        &[('A', deg(20.0), deg(-20.0)), ('C', 0.0, deg(180.0))],
                        &[],
                        37,
                    )?,
                ),
                run(
                    "ballbar-validate",
                    "bar1",
                    true,
                    circle(true, &[('C', deg(45.0))], 91)?,
                ),
                // An XYC between the tilts measured (within what the fitted runs determine),
                // and the circle with the table turned half a revolution, clockwise (which,
                // like the one at 45°, also sees C's radial motion at that angle).
                run("rtest-validate-a15", "ball1", true, xyc(15.0, 73)?),
                run(
                    "ballbar-validate-c180",
                    "bar1",
                    true,
                    circle(false, &[('C', deg(180.0))], 91)?,
                ),
            ],
        };
        write_session(dir, &machine, &truth, &plan, realism)
    }

    /// The shipped three-axis `machines/mcv754-zfyx.urdf` (X and Y carry the table, Z the
    /// spindle), a random truth from `seed`, and into `dir` one ball bar (set-up `bar1`, pivot
    /// [0, 0, 100] mm, 150 mm) on an XY circle counter-clockwise (`ballbar-xy-ccw`) and
    /// clockwise (`ballbar-xy-cw`), 361 samples each.
    pub fn three_axis_ballbar(
        dir: &Path,
        seed: u64,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine("mcv754-zfyx.urdf");
        let machine = Machine::from_urdf_file(&urdf)?;
        let truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0);
        let pivot = [0.0, 0.0, 100.0];
        let centre = Vector3::new(pivot[0], pivot[1], pivot[2]) * 1e-3;
        let circle = |ccw| paths::circle(&machine, centre, 0.15, (0, 1), ccw, &[], 361);
        let plan = Plan {
            machine_urdf: urdf.clone(),
            setups: vec![SetupPlan {
                name: "bar1".into(),
                instrument: Instrument::BallBar {
                    pivot_mm: pivot,
                    length_mm: 150.0,
                },
            }],
            runs: vec![
                RunPlan {
                    name: "ballbar-xy-ccw".into(),
                    setup: "bar1".into(),
                    validate: false,
                    poses: circle(true)?,
                    labels: Vec::new(),
                },
                RunPlan {
                    name: "ballbar-xy-cw".into(),
                    setup: "bar1".into(),
                    validate: false,
                    poses: circle(false)?,
                    labels: Vec::new(),
                },
            ],
        };
        write_session(dir, &machine, &truth, &plan, realism)
    }
}

#[cfg(test)]
mod tests;
