//! Measurement planning: for a machine, choose the R-test ball and ball-bar pivot positions
//! (any instrument whose set-up has a position key) that tell most about the parameters the
//! user wants, check every planned pose for collisions of instrument and fixture with the
//! machine's URDF collision geometry, and write the test plan and the NC programs.
//!
//! Source 000 (§3.2, Ch. 6.3.4) chose its R-test ball positions by hand: far from the C axis,
//! high above the table, as the fixtures allow. Here the choice is made on the information of
//! the runs themselves ([`info`]): each candidate position's runs are simulated noise-free and
//! linearised through the identification's own fit problem, their set-up parameters
//! eliminated, and a greedy D-optimal selection with exchanges picks `choose` positions per
//! group. Positions whose runs collide ([`scene`]) or leave the axis limits are never chosen;
//! the report says which were given up and what that cost in interval width (the choice made
//! again as if they were free).
//!
//! # Planning file (`planning.toml`)
//! ```toml
//! machine = "../../machines/mcu630-cafyxz.urdf"  # relative to this file
//! wanted = ["EX0C", "EY0C", "EA0C", "EB0C"]      # or "all": every estimated parameter
//! tool_length_mm = 120.0   # gauge point → spindle ball / probe centre (default 100)
//! clearance_mm = 1.0       # bodies closer than this collide (default 1)
//! move_step = 5.0          # check the moves between poses every 5 mm / 5° (0: poses only)
//! feed_mm_min = 1000.0     # feed of the NC programs (default 1000)
//! compare = "plan.toml"    # a hand-written test plan to compare with (optional)
//! random_trials = 20       # random selections of the same sizes to compare with
//! seed = 1
//!
//! [identify]               # copied into the plan; `parameters` default: the wanted list
//! parameters = ["EX0C", "EY0C", "EA0C", "EB0C", "EC0Y"]
//!
//! [geometry]               # instrument and fixture sizes, mm (sizes::GeometryConfig)
//! rtest_head_diameter_mm = 70.0
//!
//! [setup.bar]              # set-ups of the fixed runs, as in a test plan
//! pivot = [0.0, 0.0, 150.0]
//! length = 100.0
//!
//! [[run]]                  # runs planned anyway (a test plan's [[run]]: checked, kept)
//! name = "ballbar-xy"
//! instrument = "ballbar"
//! setup = "bar"
//! path = { kind = "circle", plane = "XY", samples = 181 }
//!
//! [[candidates]]           # positions to choose from
//! name = "rtest"           # the chosen positions become set-ups `rtest-03`…
//! instrument = "rtest"
//! choose = 2               # how many positions
//! position = "ball"        # the set-up key that takes the position (default: the plugin's)
//! setup = { head = "ideal", mount = "ball-on-table" }   # the set-up's other keys
//! grid = { x = [0.0, 100.0, 200.0], y = [0.0], z = [150.0, 250.0] }  # or points = [[x,y,z]..]
//! max_radius_mm = 280.0    # fixture limits: within this radius of the workpiece origin,
//! height_mm = [50.0, 300.0]    # and this high above the table top
//! runs = [
//!   { name = "xyc", path = { kind = "xyc", samples = 37 } },
//!   { name = "yza", path = { kind = "yza", samples = 31 } },
//! ]
//! ```
//! Positions are mm in the workpiece frame (an artefact's `origin`: axis coordinates, as its
//! plugin reads it). Every key is checked; an error names the file, line and column.
//!
//! # Tool length
//! The shipped machines' tool point is the spindle gauge point. The plan's machine is that
//! machine with the tool point moved `tool_length_mm` down the tool axis (written as
//! `machine.urdf` beside the plan, with its `.errors.toml`), so the paths keep the ball (not
//! the gauge point) on the head, and the holder and stem have room.
//!
//! # Collision geometry
//! Machine: every link's `<collision>` boxes, cylinders, spheres and capsules, placed by the
//! nominal forward kinematics; meshes are reported as not checked. Instruments: each plugin's
//! own bodies ([`mtcal_instrument::collision`]: the R-test's ball, head and post on its
//! `mount`, which the plan writes into every planned R-test set-up; the ball-bar's balls, post
//! and bar; an artefact's plate per placement), with their sizes from `[geometry]` (the
//! plugin's keys) and the shared tool side (a holder up to the gauge point, a stem below it)
//! and table top ([`sizes`]). An instrument without bodies is checked for nothing but the
//! machine, and the report says so. Checked pairs: machine bodies of different branches that
//! are not carried one by the other; tool-side bodies against every machine body but the one
//! carrying the tool link (the holder sits in the spindle by design); table-side bodies
//! against every machine body but the one carrying the workpiece link (the posts stand on
//! it); a bar against everything; tool side against table side except the pairs the
//! instrument says touch by design (a ball in its head, a probe on its plate). A pair closer
//! than `clearance_mm` collides. Every pose of every run is checked, and with `move_step` the
//! straight axis moves between them.
//!
//! # Outputs ([`Planned::write`])
//! `plan.toml` (a test plan `simulate` accepts), `machine.urdf` (+ `machine.errors.toml`),
//! `programs/<run>.nc`, `report.json` (schema `mtcal.plan/1`) and `report.txt`.

pub mod geometry;
pub mod info;
pub mod scene;
pub mod sizes;
pub mod spec;

mod planner;
mod run_keys;
mod tooled;

pub use planner::{
    CandidateReport, Criteria, FixedReport, IntervalRow, Planned, PlannedRun, Report, RunCheck,
    plan, plan_source,
};

use std::path::PathBuf;

/// Why a plan could not be made. Messages name the file (and line and column where the
/// planning file is at fault) and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("{at}: {message}")]
    Spec {
        at: mtcal_located::Location,
        message: String,
    },
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{}: collision geometry: {message}", file.display())]
    Geometry { file: PathBuf, message: String },
    #[error("information of the planned runs: {0}")]
    Information(String),
    /// The plan's files could not all be written; none was.
    #[error(transparent)]
    Output(#[from] mtcal_located::OutputError),
}
