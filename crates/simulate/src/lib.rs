//! Simulated sessions: a machine, a truth parameter file and a test plan → a session folder
//! that `identify` reads like a real one, or the same session held in memory.
//!
//! # Test plan (`plan.toml`)
//! ```toml
//! machine = "../machines/mcu630-cafyxz.urdf"  # relative to the plan, or a topology code
//! truth = "truth.params.toml"                 # optional (mtcal.params/1); default all zero
//! seed = 7                                    # noise seed (default 0)
//! interval_s = 0.5                            # time between samples (default 0.5 s)
//!
//! [identify]                                  # copied into the session manifest
//! parameters = ["EC0Y", "EB0Z", "EA0Z"]
//!
//! [setup.ball1]                               # shared set-ups, as in session.toml: the
//! ball = [150.0, 0.0, 100.0]                  # plugin's keys, written into the session as
//! mount = "ball-on-table"                     # given (R-test: or "ball-in-spindle"; default
//!                                             # "ball-on-table", plugins/rtest)
//!
//! [nuisance.ball1]                            # true nuisance values (their units, e.g. um)
//! ball_x = 3.0
//!
//! [[run]]
//! name = "xyc-a0"
//! instrument = "rtest"
//! setup = "ball1"                             # or an own [run.setup] table
//! use = "fit"                                 # or "validate"
//! path = { kind = "xyc", samples = 73 }       # the plugin's path keys
//! noise = 0.5                                 # σ of the reading noise (channel units);
//!                                             # default: the channel's σ; 0: noise-free
//! readings = true                             # false: a validation run without readings
//! feed_mm_min = 1000.0                        # feed written into the run's NC program
//! ```
//! Besides the session, every run's commanded path is written as a G-code program,
//! `programs/<run>.nc` (mm / degrees, `G90 G01`, the linear axes keeping the tool point where
//! the instrument needs it), for running the same test on the real machine.
//! Noise is Gaussian, from a ChaCha8 generator seeded with `seed` and the run's index, so a
//! plan gives byte-identical sessions on every machine.
//!
//! # More plan keys
//! ```toml
//! truth_errors = "rich.errors.toml"  # error model of the truth only (a higher order than the
//!                                    # session's model: a planted `component-order` effect)
//! pause_s = 10.0                     # time between runs (default 10 s)
//!
//! [record]                           # optional: the files hold rounded numbers, as a controller
//! positions = 4                      # and an instrument write them: decimals of mm and degrees
//! readings = 4                       # (the machine moves to exactly the written positions),
//! time = 3                           # of each reading channel's unit, of seconds and of the
//! context = 3                        # context columns; default: every digit of the f64
//!
//! [context]                          # context columns written into every run, by session time
//! S = [[0.0, 0.0], [150.0, 4000.0]]  # spindle speed, rpm: steps (held until the next point)
//! T_bed = [[0.0, 20.5], [600.0, 21.5]]  # temperatures, °C: linear between points
//! P_air = [[0.0, 1013.0], [600.0, 1011.0]]  # air pressure, hPa, and H_<name> humidity, %:
//!                                    # linear between points
//!
//! [[effect]]                         # a planted effect (any number)
//! effect = "thermal-drift"           # a registered family (crates/effects)
//! axis = "Z"                         # its target: axis, channel (+ instrument) or setup + nuisance
//! amplitude_um = 3.0                 # every parameter, named with its unit
//! tau_s = 400.0
//! below_noise = 0.5                  # optional: scale the amplitudes so that the effect's
//!                                    # largest change of any reading is 0.5 × its noise
//! ```
//!
//! # Planting effects
//! A plan's `[[effect]]` tables are evaluated on the whole planned session (thermal states run
//! over all runs in time order) and applied exactly: an effect on an axis displaces the axis in
//! the truth model (the fit carries it through the axis Jacobian), one on a set-up parameter
//! moves the parameter, one on a reading (or its gain) changes the reading. Each family's keys:
//! `crates/effects/src/families/`.
//!
//! Concealing an effect: `below_noise` puts it under the single-sample noise; the rest is a
//! matter of the plan: a
//! timing that hides it in the fitted parameters (a drift with τ shorter than the first run
//! rises while C turns once and looks like C's location errors; a temperature that changes
//! during one XYC run); a larger effect of another class planted beside it. The planted-effect
//! tests (`crates/identify/tests/suite/physics_search.rs`) do all three for every family.
//!
//! [`simulate_with`] also takes [`Plant`]s: each sees every sample (run, time, axis positions,
//! tool pose) and adds to the readings, for effects no family describes.
//!
//! # Steps
//! [`simulate_with`] is three steps, each usable on its own: [`Plan::read`] reads the plan (a
//! TOML error located by line and column) and [`Plan::machine`] loads the machine it names;
//! [`simulate_session`] builds every run in memory (a [`SimulatedSession`]: the manifest and each
//! run's table exactly as reading the written file gives it back); [`SimulatedSession::write`]
//! writes the folder (every file atomically). The planner (`mtcal-plan`) builds its plans with
//! [`Plan::from_table`] and [`PlanMachine::from_urdf`] and hands the session to
//! `mtcal_identify::Study::from_parts`: nothing touches the disk.

mod context;
mod effects;
mod keys;
mod plan;
mod plant;
mod readings;
mod record;
mod runs;
mod session;

pub use plan::{MachineFiles, Plan, PlanMachine};
pub use plant::{Plant, PlantSample};
pub use session::{SimulatedRun, SimulatedSession};

use std::path::{Path, PathBuf};

/// Why a plan could not be simulated; names the plan file and the key.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    #[error("{}: {message}", file.display())]
    Plan { file: PathBuf, message: String },
    #[error("{}: run `{run}`: {message}", file.display())]
    Run {
        file: PathBuf,
        run: String,
        message: String,
    },
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// The session's files could not all be written; none was.
    #[error(transparent)]
    Output(#[from] mtcal_machine::OutputError),
}

/// What a simulation wrote.
#[derive(Debug, Clone)]
pub struct Simulated {
    pub manifest: PathBuf,
    pub runs: usize,
    pub samples: usize,
}

/// Simulates `plan` into the folder `out` (created if needed).
pub fn simulate(plan: &Path, out: &Path) -> Result<Simulated, SimulateError> {
    simulate_with(plan, out, &[])
}

/// [`simulate`] with planted effects (besides the plan's own `[[effect]]` tables).
pub fn simulate_with(
    plan: &Path,
    out: &Path,
    plants: &[&dyn Plant],
) -> Result<Simulated, SimulateError> {
    let plan = Plan::read(plan)?;
    let machine = plan.machine()?;
    simulate_session(&plan, machine, plants, out)?.write()
}

/// The session `plan` describes on `machine`, in memory, for the folder `dir` (where its run
/// tables say they are and [`SimulatedSession::write`] puts them). `plan`'s own `machine` key
/// is not read: `machine` is the one simulated. The plan's truth files are read; nothing is
/// written.
pub fn simulate_session(
    plan: &Plan,
    machine: PlanMachine,
    plants: &[&dyn Plant],
    dir: &Path,
) -> Result<SimulatedSession, SimulateError> {
    let (model, truth) = plan.truth(&machine.loaded)?;
    let settings = plan.settings()?;
    let (runs, setups) = runs::plan_runs(plan, &settings, &model)?;
    // The planted effects see the whole planned session: thermal states run over every run.
    let effects = effects::planted_effects(plan, &model, &truth, &setups, &runs)?;
    let truth = readings::Truth {
        model: &model,
        coeffs: &truth,
        effects: effects.as_ref(),
        plants,
    };
    let simulated = readings::measure(plan, &settings, &truth, &setups, runs, dir)?;
    Ok(SimulatedSession::new(
        plan, &settings, machine, simulated, dir,
    ))
}
